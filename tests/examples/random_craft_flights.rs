//! One line per flight of a random-craft cell (`massid_tests::random_craft`): the craft, the
//! flight, the status and each scored term's error in sigma, to see which flights a cell's
//! figures come from:
//! `cargo run --release -p massid-tests --example random_craft_flights -- CLASS FLIGHTS SEED0
//! [detail|brief] [f64|f32|fixed|kernel-f64]` (CLASS: 3d-few, 3d-some, 3d-many, planar,
//! planar-mocap; `detail`: the estimate, truth and model of every flight, not only of those
//! not `ok`; the implementation, f64 when left out).
use massid_tests::identification_mc::{
    estimate_with, fly, scored_errors, Condition, Implementation, TERMS,
};
use massid_tests::random_craft::{draw, CraftClass};
use reference_f64::flight_id::Options;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let class = match args.get(1).map(String::as_str).unwrap_or("3d-some") {
        "3d-few" => CraftClass {
            planar: false,
            thrusters: (1, 4),
            mocap: false,
        },
        "3d-some" => CraftClass {
            planar: false,
            thrusters: (5, 8),
            mocap: false,
        },
        "3d-many" => CraftClass {
            planar: false,
            thrusters: (9, 16),
            mocap: false,
        },
        "planar" => CraftClass {
            planar: true,
            thrusters: (1, 16),
            mocap: false,
        },
        "planar-mocap" => CraftClass {
            planar: true,
            thrusters: (1, 16),
            mocap: true,
        },
        other => panic!("unknown class {other}"),
    };
    let flights: u64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(10);
    let seed0: u64 = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(60000);
    let detail = args.get(4).is_some_and(|a| a == "detail");
    let implementation = match args.get(5).map(String::as_str).unwrap_or("f64") {
        "f64" => Implementation::F64,
        "f32" => Implementation::F32,
        "fixed" => Implementation::Fixed,
        "kernel-f64" => Implementation::KernelF64,
        other => panic!("unknown implementation {other} (f64, f32, fixed, kernel-f64)"),
    };
    let cond = Condition::RandomCraft(class.clone());
    for seed in seed0..seed0 + flights {
        let d = draw(&class, seed);
        let sim = fly(&cond, seed);
        let est = estimate_with(implementation, &sim, &Options::default());
        let max_rate = (0..sim.flight.time_s.len())
            .map(|k| {
                let r = sim.flight.rate.at(k);
                r.iter()
                    .filter(|v| v.is_finite())
                    .map(|v| v * v)
                    .sum::<f64>()
                    .sqrt()
            })
            .fold(0.0, f64::max);
        let head = format!(
            "seed {seed}: {} thr, {} {} Hz, max rate {max_rate:.2} rad/s, noise {:.2e}, bw {:.0} Hz, sigma_f {}, {} samples",
            d.model.n_thrusters(),
            d.spec.maneuver.name(),
            d.spec.rate_hz,
            d.spec.sensors.gyro_noise_rad_s[0],
            d.spec.sensors.gyro_bandwidth_hz,
            !d.model.thrust_sigma_n.is_empty(),
            sim.flight.time_s.len()
        );
        match est {
            Err(e) => println!("{head}: error {e}"),
            Ok(e) => {
                let mut z = String::new();
                for (t, err, sigma) in scored_errors(&sim, &e) {
                    z.push_str(&format!(" {}={:+.1}", TERMS[t], err / sigma));
                }
                let tests: Vec<String> = e
                    .consistency
                    .iter()
                    .filter(|t| t.p_value < 0.05)
                    .map(|t| format!("{}:{:.0e}", t.name, t.p_value))
                    .collect();
                println!(
                    "{head}: {} unobs {:?}{z} | low p: {}",
                    e.status,
                    e.unobservable,
                    tests.join(" ")
                );
                if detail || e.status != "ok" {
                    println!(
                        "    inertia: estimate {:.4?} +- {:.2?}\n             truth    {:.4?}\n             model    {:.4?}\n    CoM - model's (mm): estimate {:.2?} +- {:.2?}, truth {:.2?}\n    samples used {}, noise {:?}",
                        e.inertia_kgm2,
                        e.inertia_stderr_kgm2,
                        &sim.truth[3..],
                        sim.model.inertia_kgm2,
                        e.com_offset_mm,
                        e.com_offset_stderr_mm,
                        &sim.truth[..3],
                        e.samples_used,
                        e.noise.iter().map(|n| n.as_ref().map(|n| format!("phi {:.3?} var {:.2e} ma {:.3}", n.phi, n.sigma2, n.ma))).collect::<Vec<_>>()
                    );
                }
            }
        }
    }
}
