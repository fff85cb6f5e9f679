//! The onboard output-error identification (`massid_kernel::flight_id`, through
//! `massid_kernel_host::flight_id`): calibrated on flights it was not developed on (seeds
//! 31000+; development used 700-719), each check shown failing on a planted fault, in f32
//! and in the fixed kernel's integer floating point.
use massid_sim::Maneuver;

use massid_tests::identification_mc::*;
use reference_f64::flight_id::Options;

fn cell(cond: &Condition, flights: u64, seed0: u64, sigma_factor: f64) -> Cell {
    cell_of(Implementation::F32, cond, flights, seed0, sigma_factor)
}

fn cell_of(
    imp: Implementation,
    cond: &Condition,
    flights: u64,
    seed0: u64,
    sigma_factor: f64,
) -> Cell {
    let mut c = Cell::default();
    for seed in seed0..seed0 + flights {
        let sim = fly(cond, seed);
        let est = estimate_with(imp, &sim, &Options::default()).map(|mut e| {
            e.inertia_stderr_kgm2
                .iter_mut()
                .for_each(|s| *s *= sigma_factor);
            e.com_offset_stderr_mm
                .iter_mut()
                .for_each(|s| *s *= sigma_factor);
            e
        });
        c.add(&sim, &est);
    }
    c
}

fn spheres(maneuver: Maneuver, rate_hz: f64) -> Condition {
    Condition::Spheres {
        maneuver,
        rate_hz,
        noise: 1.0,
    }
}

#[test]
fn f32_kernel_is_calibrated_on_rga12_and_combo() {
    for cond in [
        spheres(Maneuver::Rga12, 1000.0),
        spheres(Maneuver::Combo, 250.0),
    ] {
        let c = cell(&cond, 24, 31000, 1.0);
        assert_eq!(c.ok, c.flights, "{}: {:?}", cond.label(), c.statuses);
        small_sample_check(&c).unwrap_or_else(|e| panic!("{}: {e}", cond.label()));
    }
}

#[test]
fn calibration_check_fails_when_the_kernel_sigma_is_halved() {
    let c = cell(&spheres(Maneuver::Rga12, 1000.0), 24, 31000, 0.5);
    assert!(small_sample_check(&c).is_err());
}

/// Planar motion capture (rates differenced from attitude: moving-average noise of root
/// about 0.77 at 25 Hz): with the root found on each flight and taken out before the sums
/// (`massid_kernel::flight_id::ma_prefilter`), both kernels are calibrated and test their
/// consistency. Held out: the filter's design looked at seeds 66000-66099.
#[test]
fn both_kernels_are_calibrated_on_planar_motion_capture() {
    let cond = mocap_25hz();
    for imp in [Implementation::F32, Implementation::Fixed] {
        let c = cell_of(imp, &cond, 24, 31000, 1.0);
        assert_eq!(c.ok, c.flights, "{imp:?}: {:?}", c.statuses);
        small_sample_check(&c).unwrap_or_else(|e| panic!("{imp:?}: {e}"));
    }
}

fn mocap_25hz() -> Condition {
    Condition::PlanarMocap {
        step_ms: 40,
        control_ms: 80,
        closed_loop: true,
    }
}

/// Planted fault: the same flights with the root held at 0 (the AR(2) model alone, as before
/// the filter) give sigmas 2-3 times too large, and the calibration check says so.
#[test]
fn motion_capture_without_the_moving_average_filter_fails_the_calibration_check() {
    use massid_kernel_host::flight_id::{identify_with, MaRoot};
    use reference_f64::flight_id::fit::SensorResponse;
    let cond = mocap_25hz();
    let mut c = Cell::default();
    for seed in 31000..31024 {
        let sim = fly(&cond, seed);
        let est = identify_with::<f32>(
            &sim.flight,
            &sim.model,
            Some(SensorResponse::BackwardMean),
            0.0,
            MaRoot::Fixed(0.0, 1),
        )
        .map_err(|e| e.to_string());
        c.add(&sim, &est);
    }
    let err = small_sample_check(&c).expect_err("sigmas 2-3 times too large must fail");
    assert!(err.contains("RMS error/sigma"), "{err}");
}

/// The fixed kernel (integer floating point, `massid_kernel::IntFloat`) is calibrated on the
/// same held-out flights, and its rounding (its distance from the same algorithm in f64)
/// stays within [`ROUNDING_BUDGET_SIGMA`] on each.
#[test]
fn fixed_kernel_is_calibrated_and_within_its_rounding_budget() {
    for cond in [
        spheres(Maneuver::Rga12, 1000.0),
        spheres(Maneuver::Combo, 250.0),
    ] {
        let c = cell_of(Implementation::Fixed, &cond, 24, 31000, 1.0);
        assert_eq!(c.ok, c.flights, "{}: {:?}", cond.label(), c.statuses);
        small_sample_check(&c).unwrap_or_else(|e| panic!("{}: {e}", cond.label()));
        for seed in [31000, 31001, 31002] {
            let sim = fly(&cond, seed);
            let run = |imp| estimate_with(imp, &sim, &Options::default()).unwrap();
            let (fixed, f32k, exact) = (
                run(Implementation::Fixed),
                run(Implementation::F32),
                run(Implementation::KernelF64),
            );
            assert_eq!(fixed.status, exact.status);
            let (d_fixed, d_f32) = (
                worst_difference_in_sigma(&fixed, &exact),
                worst_difference_in_sigma(&f32k, &exact),
            );
            println!(
                "{} seed {seed}: rounding fixed {d_fixed:.4} f32 {d_f32:.4} sigma",
                cond.label()
            );
            assert!(
                d_fixed < ROUNDING_BUDGET_SIGMA,
                "{} seed {seed}: {d_fixed} sigma",
                cond.label()
            );
        }
    }
}

/// The largest difference between two estimates, in the second's sigma, over every term.
fn worst_difference_in_sigma(
    a: &reference_f64::flight_id::FlightEstimate,
    b: &reference_f64::flight_id::FlightEstimate,
) -> f64 {
    let inertia =
        (0..6).map(|m| (a.inertia_kgm2[m] - b.inertia_kgm2[m]).abs() / b.inertia_stderr_kgm2[m]);
    let com =
        (0..3).map(|m| (a.com_offset_mm[m] - b.com_offset_mm[m]).abs() / b.com_offset_stderr_mm[m]);
    inertia.chain(com).fold(0.0, f64::max)
}

/// The fixed kernel's rounding budget, in sigma of the estimate.
const ROUNDING_BUDGET_SIGMA: f64 = 0.1;

#[test]
fn the_rounding_check_catches_a_fifth_of_a_sigma() {
    let sim = fly(&spheres(Maneuver::Rga12, 1000.0), 31000);
    let f32k = estimate_with(Implementation::F32, &sim, &Options::default()).unwrap();
    let mut shifted = f32k.clone();
    shifted.inertia_kgm2[2] += 0.2 * f32k.inertia_stderr_kgm2[2];
    assert!(worst_difference_in_sigma(&shifted, &f32k) >= ROUNDING_BUDGET_SIGMA);
}

/// One SPH2 flight with `effects`, as the estimator reads it.
fn sph2_flight(
    maneuver: Maneuver,
    rate_hz: f64,
    seed: u64,
    effects: Vec<massid_sim::effects::Effect>,
) -> reference_f64::flight_id::flight::Flight {
    let sat = reference_f64::satellite::Satellite::builtin("sph2").expect("sph2");
    let mut spec = massid_sim::SimSpec::new(sat.clone(), effects, maneuver);
    spec.rate_hz = rate_hz;
    spec.seed = seed;
    let out = massid_sim::simulate(&spec).expect("simulation");
    reference_f64::flight_id::flight::Flight::from_v1(&out.recording, &sat)
}

fn kernel_status(flight: &reference_f64::flight_id::flight::Flight, latency_ms: f64) -> String {
    let sat = reference_f64::satellite::Satellite::builtin("sph2").expect("sph2");
    let e = massid_kernel_host::flight_id::identify::<f32>(flight, &sat, None, latency_ms)
        .expect("estimate");
    let tests: Vec<String> = e
        .consistency
        .iter()
        .map(|t| format!("{}={:.1}", t.name, t.statistic))
        .collect();
    format!("{} {}", e.status, tests.join(" "))
}

/// The largest thrust-symmetry statistic in a [`kernel_status`] line.
fn largest_symmetry(status: &str) -> f64 {
    status
        .split(' ')
        .filter_map(|t| t.strip_prefix("thrust_symmetry_"))
        .filter_map(|t| t.split('=').nth(1)?.parse::<f64>().ok())
        .fold(f64::NAN, f64::max)
}

/// The onboard consistency tests: an unmodelled 6 ms latency, a 10 ms thrust rise and one
/// thruster at 90 % make the status `inconsistent`; the same flights without them, and the
/// latency flight told its latency, stay `ok` (held-out seeds 31000+; development used
/// 3000-3004 and, for the thrust-symmetry test, 44000-44039 and 45000-45009). The weak
/// thruster is caught by the thrust-symmetry test: the flight fails without the
/// timing test's help, so the assertion fails if the symmetry test is taken out.
#[test]
fn kernel_consistency_catches_timing_faults_and_passes_controls() {
    use massid_sim::effects::{Effect, ThrustRise, ThrustScale, ThrusterLatency};
    let latency = || {
        vec![Effect::ThrusterLatency(ThrusterLatency {
            open_ms: 6.0,
            close_ms: 6.0,
        })]
    };
    let rise = || vec![Effect::ThrustRise(ThrustRise { tau_ms: 10.0 })];
    let weak = || {
        let mut scale = vec![1.0; 12];
        scale[massid_tests::planted_faults::WEAK] = 0.9;
        vec![Effect::ThrustScale(ThrustScale { scale })]
    };
    let threshold = f64::from(massid_kernel::flight_id::consistency::SYMMETRY_REJECT_ABOVE);
    for (maneuver, rate) in [(Maneuver::Rga12, 1000.0), (Maneuver::Combo, 250.0)] {
        for seed in [31000, 31001] {
            let control = kernel_status(&sph2_flight(maneuver, rate, seed, vec![]), 0.0);
            assert!(control.starts_with("ok"), "{maneuver:?} control: {control}");
            assert!(largest_symmetry(&control) < threshold, "{control}");
            let late = sph2_flight(maneuver, rate, seed, latency());
            let s = kernel_status(&late, 0.0);
            assert!(s.starts_with("inconsistent"), "{maneuver:?} latency: {s}");
            let told = kernel_status(&late, 6.0);
            assert!(told.starts_with("ok"), "{maneuver:?} latency told: {told}");
            let s = kernel_status(&sph2_flight(maneuver, rate, seed, rise()), 0.0);
            assert!(s.starts_with("inconsistent"), "{maneuver:?} rise: {s}");
            let s = kernel_status(&sph2_flight(maneuver, rate, seed, weak()), 0.0);
            assert!(
                s.starts_with("inconsistent"),
                "{maneuver:?} weak thruster: {s}"
            );
            assert!(
                largest_symmetry(&s) > threshold,
                "{maneuver:?} weak thruster: {s}"
            );
        }
    }
}

/// The largest `|error| / sigma` over the terms `e` identifies (the truth `truth`, NaN where
/// the craft cannot show a term).
fn worst_error_in_sigma(e: &reference_f64::flight_id::FlightEstimate, truth: &[f64; 9]) -> f64 {
    let com = (0..3).map(|a| (e.com_offset_mm[a] - truth[a]) / e.com_offset_stderr_mm[a]);
    let inertia = (0..6).map(|m| (e.inertia_kgm2[m] - truth[3 + m]) / e.inertia_stderr_kgm2[m]);
    com.chain(inertia)
        .filter(|z| z.is_finite())
        .fold(0.0, |m, z| m.max(z.abs()))
}

/// A fast spinner (a random 3-D craft with 5-8 thrusters turning at 5-8 rad/s, sampled at
/// 1 kHz; seed 70013, where the fixed kernel was `ok` 6.8 sigma off): the rate noise in
/// Euler's products of the measured rates, integrated over windows of 1.9 s, is a random walk
/// the noise model does not describe. With the windows ended at the coupled noise walk
/// (`massid_kernel::flight_id::window::MAX_WINDOW_WALK`) the kernel's algorithm, in f64 so
/// that no rounding enters, is within 2 sigma; with that limit taken out (the planted fault)
/// it is `ok` more than 3 sigma off, so the check fails without the limit. The f32 and
/// integer-float kernels are then `ok` within 3 sigma or flag the flight.
#[test]
fn a_fast_spinner_s_windows_end_at_the_coupled_noise_walk() {
    use massid_kernel_host::flight_id::{identify_adjusted, MaRoot};
    let class = massid_tests::random_craft::CraftClass {
        planar: false,
        thrusters: (5, 8),
        mocap: false,
    };
    let sim = fly(&Condition::RandomCraft(class), 70013);
    let response = reference_f64::flight_id::identify(&sim.flight, &sim.model, &Options::default())
        .expect("reference")
        .sensor;
    let run = |walk: Option<f64>| {
        identify_adjusted::<f64>(
            &sim.flight,
            &sim.model,
            Some(response),
            0.0,
            MaRoot::FromFlight,
            |cfg| {
                if let Some(w) = walk {
                    cfg.max_window_walk = w;
                }
            },
        )
        .expect("estimate")
    };
    let with = run(None);
    let worst = worst_error_in_sigma(&with, &sim.truth);
    assert!(worst < 2.0, "{} {worst:.2}", with.status);
    let without = run(Some(f64::INFINITY));
    let worst = worst_error_in_sigma(&without, &sim.truth);
    assert!(
        without.status == "ok" && worst > 3.0,
        "{} {worst:.2}",
        without.status
    );
    // The kernels themselves: no answer `ok` and more than 3 sigma off (the integer float
    // was `ok` 6.8 sigma off before the limit; f32 does not converge without it).
    for imp in [Implementation::F32, Implementation::Fixed] {
        if let Ok(e) = estimate_with(imp, &sim, &Options::default()) {
            let worst = worst_error_in_sigma(&e, &sim.truth);
            assert!(
                e.status != "ok" || worst < 3.0,
                "{imp:?}: {} {worst:.2}",
                e.status
            );
        }
    }
}
