//! The onboard kernel's consistency test (f32) on planted faults and their controls:
//! `cargo run --release -p massid-tests --example kernel_consistency -- SEED0 FLIGHTS`.
use massid_sim::{simulate, Maneuver, SimSpec};
use reference_f64::flight_id::flight::Flight;
use reference_f64::satellite::Satellite;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let seed0: u64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(3000);
    let flights: u64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(5);
    let sat = Satellite::builtin("sph2").expect("sph2");
    let mut faults: Vec<(&str, Vec<massid_sim::effects::Effect>)> = vec![("none", vec![])];
    faults.extend(massid_tests::planted_faults::planted_faults(12));
    for m in [Maneuver::Rga12, Maneuver::Combo, Maneuver::ClosedLoop] {
        for rate in [1000.0, 250.0] {
            for (name, effects) in &faults {
                let mut stats = Vec::new();
                let mut inconsistent = 0;
                for seed in seed0..seed0 + flights {
                    let mut spec = SimSpec::new(sat.clone(), effects.clone(), m);
                    spec.rate_hz = rate;
                    spec.seed = seed;
                    let out = simulate(&spec).expect("simulation");
                    let flight = Flight::from_v1(&out.recording, &sat);
                    match massid_kernel_host::flight_id::identify::<f32>(&flight, &sat, None, 0.0) {
                        Ok(e) => {
                            inconsistent += (e.status == "inconsistent") as u32;
                            if e.status != "inconsistent" && !effects.is_empty() {
                                println!("  seed {seed}: {}", e.status);
                            }
                            stats.push(e.consistency.first().map_or(f64::NAN, |t| t.statistic));
                        }
                        Err(e) => println!("  {e}"),
                    }
                }
                println!(
                    "| {} {} Hz | {name} | {inconsistent}/{flights} | {} |",
                    m.name(),
                    rate,
                    stats
                        .iter()
                        .map(|s| format!("{s:.1}"))
                        .collect::<Vec<_>>()
                        .join(" ")
                );
            }
        }
    }
}
