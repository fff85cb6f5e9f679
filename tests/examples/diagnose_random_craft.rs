//! The diagnosis on craft nobody developed on: a random craft (`massid_tests::random_craft`,
//! 3-D or planar, 1-16 thrusters, its own noise and gyro band) flies 40 s of random PWM at
//! 100 Hz with nothing wrong or with one planted effect, and `diagnose_rate_recording` is run
//! against the craft's own model. One line per flight, then per planted effect: flights,
//! named exactly (the planted effect, or an effect that lists it under `equivalent_to`),
//! nothing named, something else named, unexplained. Then how well the named parameters'
//! standard errors cover the truth, over the flights that named one effect with a truth,
//! the planted effect or its exact equal, listed or not (a uniform thrust scale named as an
//! inertia scored against the model's inertia over the scale, a delay named as a latency
//! against equal open and close latencies): z = (named - truth) / error per entry, its
//! mean, RMS and 1- and 2-sigma coverage.
//! `cargo run --release -p massid-tests --example diagnose_random_craft -- FLIGHTS SEED0
//! [3d|planar] [PLANT...]` (PLANT: none latency delay scale com disturbance pressure rise
//! damping inertia gyroscale uniformscale; the first five when left out). `DRC_HORIZON_S=5` runs the
//! diagnosis with `--horizon 5`. The disturbance and the pressure drop are sized to the craft
//! (5 % of its weakest thruster's torque at the craft's size on each turning axis; 10 % of
//! its weakest thrust per extra open valve), so that a large craft's are as visible as
//! SPHERES'.
use massid_diagnose::numfmt::unidentifiable;
use massid_diagnose::{diagnose_rate_recording, Settings};
use massid_sim::effects::{
    ComOffset, DisturbanceTorque, Effect, GyroScale, Inertia, MeasurementDelay, PressureDrop,
    RateDamping, ThrustRise, ThrustScale, ThrusterLatency,
};
use massid_sim::simulate::{simulate, Maneuver};
use massid_tests::random_craft::{draw, CraftClass};
use std::time::Instant;

/// What a named effect's parameter should be: (effect, parameter, true value per entry).
type Truth = Vec<(&'static str, &'static str, Vec<f64>)>;

/// The named parameters' truth for the planted `effects` on a craft whose model's inertia
/// is `inertia`.
fn truth_of(effects: &[Effect], inertia: [f64; 6]) -> Truth {
    effects
        .iter()
        .flat_map(|e| match e {
            Effect::ThrusterLatency(l) => vec![
                ("thruster_latency", "open_ms", vec![l.open_ms]),
                ("thruster_latency", "close_ms", vec![l.close_ms]),
            ],
            // a delay is on rates an equal latency on every edge
            Effect::MeasurementDelay(d) => vec![
                ("measurement_delay", "delay_ms", vec![d.delay_ms]),
                ("thruster_latency", "open_ms", vec![d.delay_ms]),
                ("thruster_latency", "close_ms", vec![d.delay_ms]),
            ],
            // a uniform scale is on rates an inertia divided by it
            Effect::ThrustScale(t) => {
                let mut truth = vec![("thrust_scale", "scale", t.scale.clone())];
                if t.scale.iter().all(|&v| v == t.scale[0]) {
                    let scaled = inertia.iter().map(|v| v / t.scale[0]).collect();
                    truth.push(("inertia", "inertia_kgm2", scaled));
                }
                truth
            }
            Effect::ComOffset(c) => vec![("com_offset", "offset_mm", c.offset_mm.to_vec())],
            Effect::DisturbanceTorque(d) => {
                vec![("disturbance_torque", "torque_nm", d.torque_nm.to_vec())]
            }
            Effect::PressureDrop(d) => vec![(
                "pressure_drop",
                "newton_per_extra_thruster",
                vec![d.newton_per_extra_thruster],
            )],
            Effect::ThrustRise(r) => vec![("thrust_rise", "tau_ms", vec![r.tau_ms])],
            Effect::RateDamping(d) => {
                vec![("rate_damping", "nms_per_rad", d.nms_per_rad.to_vec())]
            }
            Effect::Inertia(i) => vec![("inertia", "inertia_kgm2", i.inertia_kgm2.to_vec())],
            Effect::GyroScale(g) => vec![("gyro_scale", "scale", g.scale.to_vec())],
            _ => vec![],
        })
        .collect()
}

/// The effect planted by `plant` on a craft of `n` thrusters, size `size_m` and weakest
/// thrust `min_thrust_n`, and the names that count as found.
fn planted(
    plant: &str,
    n: usize,
    size_m: f64,
    min_thrust_n: f64,
    inertia: [f64; 6],
    planar: bool,
) -> (Vec<Effect>, Vec<&'static str>) {
    match plant {
        "none" => (vec![], vec![]),
        "latency" => (
            vec![Effect::ThrusterLatency(ThrusterLatency {
                open_ms: 40.0,
                close_ms: 20.0,
            })],
            vec!["thruster_latency"],
        ),
        "delay" => (
            vec![Effect::MeasurementDelay(MeasurementDelay {
                delay_ms: 100.0,
            })],
            vec!["measurement_delay"],
        ),
        "scale" => {
            let mut scale = vec![1.0; n];
            scale[0] = 0.8;
            (
                vec![Effect::ThrustScale(ThrustScale { scale })],
                vec!["thrust_scale"],
            )
        }
        // every thruster 10 % weak: on rates exactly the inertia 10 % up, products and all
        "uniformscale" => (
            vec![Effect::ThrustScale(ThrustScale {
                scale: vec![0.9; n],
            })],
            vec!["thrust_scale", "inertia"],
        ),
        "com" => {
            let d = 0.1 * size_m * 1e3;
            let offset_mm = if planar { [d, -d, 0.0] } else { [d, -d, d] };
            (
                vec![Effect::ComOffset(ComOffset { offset_mm })],
                vec!["com_offset"],
            )
        }
        "disturbance" => {
            let t = 0.05 * min_thrust_n * size_m;
            let torque_nm = if planar { [0.0, 0.0, t] } else { [t, -t, t] };
            (
                vec![Effect::DisturbanceTorque(DisturbanceTorque { torque_nm })],
                vec!["disturbance_torque"],
            )
        }
        "pressure" => (
            vec![Effect::PressureDrop(PressureDrop {
                newton_per_extra_thruster: 0.1 * min_thrust_n,
            })],
            vec!["pressure_drop"],
        ),
        "rise" => (
            vec![Effect::ThrustRise(ThrustRise { tau_ms: 20.0 })],
            vec!["thrust_rise"],
        ),
        // rates decaying with a 20 s time constant on each turning axis
        "damping" => {
            let d = |a: usize| {
                if planar && a < 2 {
                    0.0
                } else {
                    inertia[a] / 20.0
                }
            };
            (
                vec![Effect::RateDamping(RateDamping {
                    nms_per_rad: [d(0), d(1), d(2)],
                })],
                vec!["rate_damping"],
            )
        }
        // the turning axes' moments 10 % above the model's
        "inertia" => {
            let mut inertia_kgm2 = inertia;
            for (a, v) in inertia_kgm2.iter_mut().enumerate().take(3) {
                if !planar || a == 2 {
                    *v *= 1.1;
                }
            }
            (
                vec![Effect::Inertia(Inertia { inertia_kgm2 })],
                vec!["inertia"],
            )
        }
        "gyroscale" => (
            vec![Effect::GyroScale(GyroScale {
                scale: [1.03, 0.98, 1.03],
            })],
            vec!["gyro_scale"],
        ),
        other => panic!("unknown plant {other}"),
    }
}

/// `--horizon` from the environment (`DRC_HORIZON_S`): none by default, as a new user runs it.
fn horizon_s() -> Option<f64> {
    std::env::var("DRC_HORIZON_S")
        .ok()
        .and_then(|v| v.parse().ok())
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let flights: u64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(10);
    let seed0: u64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(74000);
    let planar = args.get(3).is_some_and(|s| s == "planar");
    let plants: Vec<String> = if args.len() > 4 {
        args[4..].to_vec()
    } else {
        ["none", "latency", "delay", "scale", "com"]
            .map(String::from)
            .to_vec()
    };
    let class = CraftClass {
        planar,
        thrusters: (1, 16),
        mocap: false,
    };
    let (mut table, mut calibration) = (Vec::new(), Vec::new());
    for plant in &plants {
        let (mut exact, mut nothing, mut other, mut unexplained) = (0, 0, 0, 0);
        // (named parameter - truth) / its standard error, over the flights that named the
        // planted effect or its exact equal, and how many such flights
        let (mut zs, mut scored): (Vec<f64>, usize) = (vec![], 0);
        for seed in seed0..seed0 + flights {
            let d = draw(&class, seed);
            let n = d.model.n_thrusters();
            let size = d
                .model
                .thruster_pos_m
                .iter()
                .map(|p| p.iter().map(|v| v * v).sum::<f64>().sqrt())
                .fold(0.0, f64::max);
            let min_thrust = d.model.thrust_n.iter().copied().fold(f64::MAX, f64::min);
            let (effects, want) = planted(plant, n, size, min_thrust, d.model.inertia_kgm2, planar);
            let truth = truth_of(&effects, d.model.inertia_kgm2);
            let mut spec = d.spec.clone();
            spec.effects = effects;
            spec.maneuver = Maneuver::RandomPwm;
            spec.seconds = Some(40.0);
            spec.rate_hz = 100.0;
            let start = Instant::now();
            let out = simulate(&spec).expect("simulate");
            let rec = out.rate_recording.expect("a v2 craft");
            let settings = Settings {
                horizon_s: horizon_s(),
                ..Settings::default()
            };
            let result = diagnose_rate_recording(&rec, &d.model, &settings);
            let secs = start.elapsed().as_secs_f64();
            let Ok(a) = result else {
                println!("seed {seed} {plant}: error {:?}", result.err());
                other += 1;
                continue;
            };
            if std::env::var_os("DRC_SUMMARY").is_some() {
                println!("{}", massid_diagnose::report::summary(&a));
            }
            let o = a.output;
            let names: Vec<String> = o.effects.iter().map(|e| e.effect.clone()).collect();
            let listed: Vec<String> = o
                .effects
                .iter()
                .flat_map(|e| e.equivalent_to.iter())
                .filter_map(|v| v["effect"].as_str().map(String::from))
                .collect();
            let found = if want.is_empty() {
                names.is_empty()
            } else {
                names.len() == 1
                    && (want.contains(&names[0].as_str())
                        || listed.iter().any(|l| want.contains(&l.as_str())))
            };
            let z = if names.len() == 1 {
                z_scores(&o.effects[0], &truth)
            } else {
                vec![]
            };
            if !z.is_empty() {
                scored += 1;
            }
            let worst_z = z.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            zs.extend(z);
            if found {
                exact += 1;
            } else if names.is_empty() {
                nothing += 1;
            } else {
                other += 1;
            }
            if o.unexplained.is_some() {
                unexplained += 1;
            }
            println!(
                "seed {seed} {plant}: {n} thr, noise {:.1e} through {:.0} Hz, named {names:?} (equivalent {listed:?}){}{}{} {secs:.1} s",
                spec.sensors.gyro_noise_rad_s[0],
                spec.sensors.gyro_bandwidth_hz,
                if worst_z > 0.0 { format!(", worst |z| {worst_z:.1}") } else { String::new() },
                if found { "" } else { "  MISS" },
                if o.unexplained.is_some() { ", unexplained" } else { "" },
            );
        }
        let craft = if planar { "planar" } else { "3-D" };
        table.push(format!(
            "| {craft} | {plant} | {flights} | {exact} | {nothing} | {other} | {unexplained} |"
        ));
        calibration.push(calibration_row(craft, plant, scored, &zs));
    }
    println!(
        "| craft | planted | flights | named exactly | nothing named | other named | unexplained |"
    );
    println!("|---|---|---|---|---|---|---|");
    for row in table {
        println!("{row}");
    }
    println!();
    println!("| craft | planted | flights scored | entries | mean z | RMS z | within 1 sigma | within 2 sigma | worst abs z |");
    println!("|---|---|---|---|---|---|---|---|---|");
    for row in calibration {
        println!("{row}");
    }
}

/// `(named - truth) / standard error` for each entry of the named effect's parameters that
/// has a truth and an error: not held at the model's, not unidentifiable (a planar craft's
/// x and y terms, a thruster that never fired).
fn z_scores(named: &massid_diagnose::output::EffectReport, truth: &Truth) -> Vec<f64> {
    let entries = |v: Option<&serde_json::Value>| -> Vec<Option<f64>> {
        match v {
            Some(serde_json::Value::Array(a)) => a.iter().map(|x| x.as_f64()).collect(),
            Some(x) => vec![x.as_f64()],
            None => vec![],
        }
    };
    truth
        .iter()
        .filter(|(effect, _, _)| *effect == named.effect)
        .flat_map(|(_, param, want)| {
            let got = entries(named.params.get(*param));
            let err = entries(named.stderr.get(*param));
            let held: Vec<usize> = named
                .held
                .get(*param)
                .and_then(|h| serde_json::from_value(h.clone()).ok())
                .unwrap_or_default();
            want.iter()
                .zip(got)
                .zip(err)
                .enumerate()
                .filter_map(|(j, ((w, g), e))| match (g, e) {
                    (Some(g), Some(e)) if e > 0.0 && !unidentifiable(e) && !held.contains(&j) => {
                        Some((g - w) / e)
                    }
                    _ => None,
                })
                .collect::<Vec<f64>>()
        })
        .collect()
}

/// One row of the calibration table: how the named parameters' errors cover the truth.
fn calibration_row(craft: &str, plant: &str, flights: usize, zs: &[f64]) -> String {
    if zs.is_empty() {
        return format!("| {craft} | {plant} | {flights} | 0 | | | | | |");
    }
    let n = zs.len() as f64;
    let mean = zs.iter().sum::<f64>() / n;
    let rms = (zs.iter().map(|z| z * z).sum::<f64>() / n).sqrt();
    let within = |k: f64| 100.0 * zs.iter().filter(|z| z.abs() <= k).count() as f64 / n;
    let worst = zs.iter().fold(0.0f64, |m, z| m.max(z.abs()));
    format!(
        "| {craft} | {plant} | {flights} | {} | {mean:+.2} | {rms:.2} | {:.0} % | {:.0} % | {worst:.1} |",
        zs.len(),
        within(1.0),
        within(2.0)
    )
}
