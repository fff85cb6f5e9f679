//! The diagnosis on differenced motion-capture rates (`massid_tests::mocap_flight`, the
//! air-bearing craft at 25 Hz; central differences, or with `backward` the difference with the
//! previous sample): per flight, nominal and with the true Izz 20 % above the
//! model's, what is named (the truth, or an effect that lists it under `equivalent_to`: on
//! yaw alone a gyro scale is an inertia) and whether anything is left unexplained; then the
//! counts.
//! `cargo run --release -p massid-tests --example diagnose_central_mc -- FLIGHTS SEED0
//! [central|backward] [DIR]`
//! (with DIR, each recording is also written there as `nominal_SEED.csv` and
//! `inertia_SEED.csv`, for `massid diagnose FILE --model examples/models/airbearing-mpc.toml`;
//! with `CLOSED_LOOP=1` in the environment the flights are closed loop).
use massid_diagnose::{diagnose_rate_recording, Settings};
use massid_tests::identification_mc::airbearing_model;
use massid_tests::mocap_flight::{differenced_csv, Difference};
use reference_f64::rate_recording::RateRecording;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let flights: u64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(10);
    let seed0: u64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(95200);
    let difference = match args.get(3).map(String::as_str) {
        Some("backward") => Difference::Backward,
        None | Some("central") => Difference::Central,
        Some(other) => {
            eprintln!("unknown difference {other:?}: central or backward");
            std::process::exit(2);
        }
    };
    let closed_loop = std::env::var_os("CLOSED_LOOP").is_some();
    let dir = args.get(4).map(std::path::PathBuf::from);
    let sat = airbearing_model();
    // (case, flights with the truth named (or an effect listing it as equivalent) and nothing
    // unexplained, named so but unexplained, something else named)
    let mut tally = [("nominal", 0, 0, 0), ("inertia", 0, 0, 0)];
    for seed in seed0..seed0 + flights {
        for (case, scale, want) in [(0, 1.0, vec![]), (1, 1.2, vec!["inertia"])] {
            let csv = differenced_csv(seed, scale, difference, closed_loop);
            if let Some(d) = &dir {
                let name = format!("{}_{seed}.csv", tally[case].0);
                std::fs::write(d.join(name), &csv).expect("write");
            }
            let rec = RateRecording::from_reader(csv.as_bytes(), "central.csv").expect("parse");
            let out = diagnose_rate_recording(&rec, &sat, &Settings::default())
                .expect("diagnosis")
                .output;
            let named: Vec<&str> = out.effects.iter().map(|e| e.effect.as_str()).collect();
            // the effects listed as giving the same rates (on yaw alone a gyro scale is an
            // inertia: named either way, with the other under `equivalent_to`)
            let equivalent: Vec<String> = out
                .effects
                .iter()
                .flat_map(|e| &e.equivalent_to)
                .filter_map(|v| v.get("effect")?.as_str().map(str::to_string))
                .collect();
            let exact = named == want
                || (named.len() == want.len()
                    && want.iter().all(|w| equivalent.iter().any(|e| e == w)));
            let noise = out.noise.as_ref().map_or("-".to_string(), |n| {
                format!("{} {:?}", n.kind.name(), n.difference_samples)
            });
            println!(
                "seed {seed} {}: noise {noise}, named {named:?} (equivalent {equivalent:?}), \
                 unexplained {}",
                tally[case].0,
                out.unexplained.is_some()
            );
            let t = &mut tally[case];
            if !exact {
                t.3 += 1;
            } else if out.unexplained.is_some() {
                t.2 += 1;
            } else {
                t.1 += 1;
            }
        }
    }
    for (case, right, unexplained, other) in tally {
        println!(
            "{case}: {right} of {flights} right, {unexplained} named right but unexplained, \
             {other} named otherwise"
        );
    }
}
