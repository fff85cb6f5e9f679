//! A small version of the identification Monte Carlo (`examples/identification_mc.rs`, the
//! README's table): on held-out seeds, four conditions the estimator was not tuned on (a
//! calibration maneuver at 100 Hz, short random pulses at 50 Hz with 4x the gyro noise, closed
//! loop at 250 Hz, and a planar craft with motion-capture rates in closed loop) give
//! unbiased errors whose spread matches the reported sigmas; planted faults (sigmas halved, a
//! bias of one sigma) fail the same check.
use massid_sim::Maneuver;
use massid_tests::identification_mc::{run_cell, run_cell_with, small_sample_check, Condition};
use reference_f64::flight_id::Options;

const FLIGHTS: u64 = 16;
const SEED0: u64 = 7000;

fn conditions() -> Vec<Condition> {
    vec![
        Condition::Spheres {
            maneuver: Maneuver::Rga12,
            rate_hz: 100.0,
            noise: 1.0,
        },
        Condition::Spheres {
            maneuver: Maneuver::Combo,
            rate_hz: 50.0,
            noise: 4.0,
        },
        Condition::Spheres {
            maneuver: Maneuver::ClosedLoop,
            rate_hz: 250.0,
            noise: 1.0,
        },
        Condition::PlanarMocap {
            step_ms: 40,
            control_ms: 80,
            closed_loop: true,
        },
    ]
}

#[test]
fn errors_match_the_reported_sigmas_on_held_out_conditions() {
    for cond in conditions() {
        let cell = run_cell(&cond, FLIGHTS, SEED0, &Options::default());
        eprintln!("{}: ok {} of {}", cond.label(), cell.ok, cell.flights);
        if let Err(why) = small_sample_check(&cell) {
            panic!("{}: {why}", cond.label());
        }
    }
}

#[test]
fn planted_faults_fail_the_check() {
    let cond = Condition::Spheres {
        maneuver: Maneuver::Rga12,
        rate_hz: 100.0,
        noise: 1.0,
    };
    let halved = run_cell_with(&cond, FLIGHTS, SEED0, &Options::default(), |e| {
        e.inertia_stderr_kgm2.iter_mut().for_each(|s| *s *= 0.5);
    });
    let why = small_sample_check(&halved).expect_err("sigmas halved must fail");
    assert!(why.contains("RMS"), "{why}");
    let biased = run_cell_with(&cond, FLIGHTS, SEED0, &Options::default(), |e| {
        e.com_offset_mm[1] += e.com_offset_stderr_mm[1];
    });
    // One sigma of bias leaves the RMS within its bar (about 1.4) but not the mean.
    let why = small_sample_check(&biased).expect_err("a 1-sigma bias must fail");
    assert!(why.contains("bias"), "{why}");
}
