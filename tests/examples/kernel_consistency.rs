//! The onboard kernel's consistency tests (f32) on planted faults and their controls:
//! `cargo run --release -p massid-tests --example kernel_consistency -- SEED0 FLIGHTS [craft]`.
//! Each flight prints `timing/symmetry`: the timing test's chi-square (1 dof, rejects above
//! 10.8) and the largest of the three thrust-symmetry tests' (each rejects above 12.9).
//! Without `craft`: SPH2 at rga12 / combo / closed loop, 1 kHz and 250 Hz. With `craft`: the
//! example craft (`examples/models/`: cubesat8, freeflyer16, airbearing-mpc) at combo and
//! random PWM, 1 kHz and 100 Hz, with each thruster in turn 10 % weak (one flight each).
use massid_sim::effects::{Effect, ThrustScale};
use massid_sim::{simulate, Maneuver, SimSpec};
use massid_tests::identification_mc::model_of;
use reference_f64::flight_id::flight::Flight;
use reference_f64::mass_id::{COM_TERMS, INERTIA_TERMS};
use reference_f64::satellite::Satellite;

/// One flight through the f32 kernel: its status, the timing statistic / the largest symmetry
/// statistic, and the largest error of a reported term in its sigmas.
fn fly(sat: &Satellite, effects: &[Effect], m: Maneuver, rate: f64, seed: u64) -> String {
    let mut spec = SimSpec::new(sat.clone(), effects.to_vec(), m);
    spec.rate_hz = rate;
    spec.seed = seed;
    let out = simulate(&spec).expect("simulation");
    let flight = match &out.rate_recording {
        Some(r) => Flight::from_v2(r),
        None => Flight::from_v1(&out.recording, sat),
    };
    match massid_kernel_host::flight_id::identify::<f32>(&flight, sat, None, 0.0) {
        Ok(e) => {
            let of = |prefix: &str| {
                e.consistency
                    .iter()
                    .filter(|t| t.name.starts_with(prefix))
                    .map(|t| t.statistic)
                    .fold(f64::NAN, f64::max)
            };
            // The largest error of a term the estimate reports, in its sigmas (the truth is
            // the model: the effects change no mass property).
            let truth = sat.inertia_kgm2;
            let inertia = (0..6)
                .filter(|&m| !e.unobservable.contains(&INERTIA_TERMS[m]))
                .map(|m| (e.inertia_kgm2[m] - truth[m]).abs() / e.inertia_stderr_kgm2[m]);
            let com = (0..3)
                .filter(|&a| !e.unobservable.contains(&COM_TERMS[a]))
                .map(|a| e.com_offset_mm[a].abs() / e.com_offset_stderr_mm[a]);
            let worst = inertia.chain(com).fold(0.0, f64::max);
            format!(
                "{} {:.1}/{:.1} worst error {worst:.1} sigma",
                e.status,
                of("valve_timing"),
                of("thrust_symmetry")
            )
        }
        Err(e) => format!("error {e}"),
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let seed0: u64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(3000);
    let flights: u64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(5);
    if args.get(3).map(String::as_str) == Some("craft") {
        craft(seed0, flights);
        return;
    }
    let sat = Satellite::builtin("sph2").expect("sph2");
    let mut faults: Vec<(&str, Vec<Effect>)> = vec![("none", vec![])];
    faults.extend(massid_tests::planted_faults::planted_faults(12));
    for m in [Maneuver::Rga12, Maneuver::Combo, Maneuver::ClosedLoop] {
        for rate in [1000.0, 250.0] {
            for (name, effects) in &faults {
                let runs: Vec<String> = (seed0..seed0 + flights)
                    .map(|seed| fly(&sat, effects, m, rate, seed))
                    .collect();
                let inconsistent = runs
                    .iter()
                    .filter(|r| r.starts_with("inconsistent "))
                    .count();
                let stats: Vec<&str> = runs
                    .iter()
                    .map(|r| r.split(' ').nth(1).unwrap_or(""))
                    .collect();
                println!(
                    "| {} {} Hz | {name} | {inconsistent}/{flights} | {} |",
                    m.name(),
                    rate,
                    stats.join(" ")
                );
                if !effects.is_empty() {
                    for (seed, r) in (seed0..).zip(&runs) {
                        if !r.starts_with("inconsistent ") {
                            println!("  seed {seed}: {r}");
                        }
                    }
                }
            }
        }
    }
}

/// The example craft, each thruster in turn 10 % weak, `flights` nominal controls per cell.
fn craft(seed0: u64, flights: u64) {
    for model in ["cubesat8", "freeflyer16", "airbearing-mpc"] {
        let sat = model_of(model);
        let n = sat.n_thrusters();
        for m in [Maneuver::Combo, Maneuver::RandomPwm] {
            for rate in [1000.0, 100.0] {
                let controls: Vec<String> = (seed0..seed0 + flights)
                    .map(|seed| fly(&sat, &[], m, rate, seed))
                    .collect();
                let weak: Vec<String> = (0..n)
                    .map(|k| {
                        let mut scale = vec![1.0; n];
                        scale[k] = 0.9;
                        let effect = Effect::ThrustScale(ThrustScale { scale });
                        fly(&sat, &[effect], m, rate, seed0 + k as u64)
                    })
                    .collect();
                let count =
                    |v: &[String]| v.iter().filter(|r| r.starts_with("inconsistent ")).count();
                println!(
                    "| {model} {} {rate} Hz | controls inconsistent {}/{} | one weak thruster inconsistent {}/{} |",
                    m.name(),
                    count(&controls),
                    controls.len(),
                    count(&weak),
                    weak.len()
                );
                for (k, r) in weak.iter().enumerate() {
                    println!("  thruster {} at 0.9: {r}", k + 1);
                }
                for (seed, r) in (seed0..).zip(&controls) {
                    if !r.starts_with("ok ") {
                        println!("  control seed {seed}: {r}");
                    }
                }
            }
        }
    }
}
