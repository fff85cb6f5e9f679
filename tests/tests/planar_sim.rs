//! Issue 15: our simulator flies a planar 8-thruster craft (the air-bearing model of
//! `examples/models/airbearing-mpc.toml`) with a known rate damping, thrust rise and yaw
//! inertia error, and the diagnosis, given only the recording (format v2, rates in rad/s,
//! z only) and the nominal model, recovers each within 10 % or 2 stderr and names nothing
//! else. The commands are held 60 ms steps like the real flight's controller; the rate is
//! sampled at 50 Hz (a rate the real flight does not have) with white noise.

use massid_diagnose::{diagnose_rate_recording, Settings};
use massid_sim::effects::{Effect, Inertia, RateDamping, ThrustRise};
use massid_sim::predict::{predict, PredictOptions};
use reference_f64::rate_recording::{Commands, RateRecording};
use reference_f64::recording::DataIssues;
use std::path::Path;

/// The authors' cube approximation, the model's Izz.
const NOMINAL_IZZ: f64 = 0.3237;
const IZZ: f64 = 0.42;
const DAMPING: f64 = 0.02;
const TAU_MS: f64 = 30.0;

/// A deterministic generator (no test depends on a crate's RNG stream).
fn lcg(x: &mut u64) -> f64 {
    *x = x
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    (*x >> 11) as f64 / (1u64 << 53) as f64
}

/// Box-Muller normal.
fn normal(x: &mut u64) -> f64 {
    let (u, v) = (lcg(x).max(1e-300), lcg(x));
    (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
}

/// The recording of a 50 Hz flight with 0.002 rad/s noise.
fn flight(
    effects: &[Effect],
    seconds: u64,
    seed: u64,
) -> (RateRecording, reference_f64::satellite::Satellite) {
    flight_sampled(effects, seconds, seed, 20, 0.002)
}

/// The recording of a flight sampled every `step_ms` with white noise `noise` rad/s.
fn flight_sampled(
    effects: &[Effect],
    seconds: u64,
    seed: u64,
    step_ms: usize,
    noise: f64,
) -> (RateRecording, reference_f64::satellite::Satellite) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("workspace");
    let sat =
        massid_sim::model_file::ModelFile::read(&root.join("examples/models/airbearing-mpc.toml"))
            .expect("model")
            .satellite;
    let mut x = seed;
    // 1 ms command grid: each thruster on with probability 0.25 for each 60 ms step
    let n_ms = seconds * 1000;
    let mut word = 0u16;
    let words_ms: Vec<u16> = (0..n_ms)
        .map(|t| {
            if t % 60 == 0 {
                word = (0..8)
                    .filter(|_| lcg(&mut x) < 0.25)
                    .fold(0u16, |w, i| w | (1 << i));
            }
            word
        })
        .collect();
    let t_ms: Vec<u64> = (0..n_ms).collect();
    let p = predict(
        &sat,
        effects,
        &t_ms,
        &words_ms,
        [0.0, 0.0, 0.1],
        PredictOptions::default(),
    );
    // the word of a sample is the one commanded at its time
    let keep: Vec<usize> = (0..n_ms as usize).step_by(step_ms).collect();
    let rate = keep
        .iter()
        .map(|&k| {
            [
                f64::NAN,
                f64::NAN,
                p.gyro_rad_s[k][2] + noise * normal(&mut x),
            ]
        })
        .collect();
    let rec = RateRecording {
        source: format!("planar-sim-{seed}.csv"),
        metadata: vec![("satellite".into(), sat.name.clone())],
        axes: [false, false, true],
        time_ms: keep.iter().map(|&k| k as u64).collect(),
        rate,
        commands: Commands::Thrusters {
            n: 8,
            words: keep.iter().map(|&k| words_ms[k]).collect(),
        },
        issues: DataIssues::default(),
    };
    (rec, sat)
}

fn truth() -> Vec<Effect> {
    vec![
        Effect::Inertia(Inertia {
            inertia_kgm2: [NOMINAL_IZZ, NOMINAL_IZZ, IZZ, 0.0, 0.0, 0.0],
        }),
        Effect::RateDamping(RateDamping {
            nms_per_rad: [0.0, 0.0, DAMPING],
        }),
        Effect::ThrustRise(ThrustRise { tau_ms: TAU_MS }),
    ]
}

fn within(name: &str, got: f64, se: f64, want: f64) {
    assert!(
        (got - want).abs() <= (0.1 * want.abs()).max(2.0 * se),
        "{name}: {got} +- {se}, truth {want}"
    );
}

/// A thrust rise alone is recovered and nothing else is named.
#[test]
fn thrust_rise_is_recovered_on_a_planar_craft_and_nothing_else_is_named() {
    let rise = truth().pop().expect("rise");
    let (rec, sat) = flight(&[rise], 90, 22);
    let settings = Settings {
        horizon_s: Some(10.0),
        ..Settings::default()
    };
    let out = diagnose_rate_recording(&rec, &sat, &settings)
        .expect("diagnosis")
        .output;
    let named: Vec<&str> = out.effects.iter().map(|e| e.effect.as_str()).collect();
    assert_eq!(named, vec!["thrust_rise"]);
    let e = &out.effects[0];
    within(
        "rise",
        e.params["tau_ms"].as_f64().unwrap(),
        e.stderr["tau_ms"].as_f64().unwrap(),
        TAU_MS,
    );
}

/// The planted fault the check must catch: the same craft without any effect names nothing.
#[test]
fn nominal_planar_flight_names_nothing() {
    let (rec, sat) = flight(&[], 60, 16);
    let settings = Settings {
        horizon_s: Some(10.0),
        ..Settings::default()
    };
    let out = diagnose_rate_recording(&rec, &sat, &settings)
        .expect("diagnosis")
        .output;
    assert!(
        out.effects.is_empty(),
        "{:?}",
        out.effects.iter().map(|e| &e.effect).collect::<Vec<_>>()
    );
}

/// All three together: damping, inertia error and rise are each recovered and nothing else
/// is named. Each seed takes another path through the selection (`diagnosis.rs`): on 15,
/// damping and inertia each predict some held-out block worse alone and are named as a
/// pair; on 16, a mass-property change is named first and then exchanged for the constant
/// inertia error; on 18, a uniform thrust scale (on yaw rate alone exactly an Izz error) is
/// named first and then exchanged for the inertia error.
#[test]
fn damping_inertia_and_rise_together_are_recovered_and_nothing_else_is_named() {
    for seed in [15, 16, 18] {
        three_effects_recovered(seed);
    }
}

fn three_effects_recovered(seed: u64) {
    let (rec, sat) = flight(&truth(), 90, seed);
    let settings = Settings {
        horizon_s: Some(10.0),
        ..Settings::default()
    };
    let out = diagnose_rate_recording(&rec, &sat, &settings)
        .expect("diagnosis")
        .output;
    let mut named: Vec<&str> = out.effects.iter().map(|e| e.effect.as_str()).collect();
    named.sort_unstable();
    assert_eq!(
        named,
        vec!["inertia", "rate_damping", "thrust_rise"],
        "seed {seed}"
    );
    let get = |name: &str| out.effects.iter().find(|e| e.effect == name).expect(name);
    let z = |v: &serde_json::Value| v.as_array().expect("array")[2].as_f64().expect("z");
    let damping = get("rate_damping");
    within(
        "damping",
        z(&damping.params["nms_per_rad"]),
        z(&damping.stderr["nms_per_rad"]),
        DAMPING,
    );
    let inertia = get("inertia");
    within(
        "Izz",
        z(&inertia.params["inertia_kgm2"]),
        z(&inertia.stderr["inertia_kgm2"]),
        IZZ,
    );
    let rise = get("thrust_rise");
    within(
        "rise",
        rise.params["tau_ms"].as_f64().unwrap(),
        rise.stderr["tau_ms"].as_f64().unwrap(),
        TAU_MS,
    );
}

/// Held-out validation (not run in CI: about 12 min). Conditions none of which was used
/// while building the selection (other seeds, values, rates, noise): each must either
/// recover exactly its true effects within 10 % or 2 stderr, or name nothing and report
/// the result unexplained. A confident wrong answer fails; the table is printed.
///
///     cargo test --release -p massid-tests --test planar_sim -- --ignored --nocapture
#[test]
#[ignore]
fn held_out_conditions_are_recovered_or_reported_unexplained() {
    // (seed, Izz, damping, rise ms, seconds, sample step ms, noise rad/s)
    let conditions: [(u64, f64, f64, f64, u64, usize, f64); 12] = [
        (50, IZZ, DAMPING, TAU_MS, 90, 20, 0.002),
        (51, IZZ, DAMPING, TAU_MS, 90, 20, 0.002),
        (52, IZZ, DAMPING, TAU_MS, 90, 20, 0.002),
        (53, 0.26, 0.01, 20.0, 90, 20, 0.002),
        (54, IZZ, DAMPING, TAU_MS, 90, 10, 0.002),
        (55, IZZ, DAMPING, TAU_MS, 90, 20, 0.005),
        (56, NOMINAL_IZZ, 0.01, 0.0, 90, 20, 0.002),
        (57, 0.38, 0.0, 0.0, 90, 20, 0.002),
        (58, NOMINAL_IZZ, 0.0, 0.0, 90, 20, 0.002),
        (59, NOMINAL_IZZ, 0.0, 0.0, 90, 20, 0.005),
        (60, NOMINAL_IZZ, 0.03, 15.0, 60, 20, 0.002),
        (61, 0.36, 0.005, 10.0, 90, 60, 0.002),
    ];
    let mut wrong = vec![];
    for (seed, izz, damping, tau, seconds, step, noise) in conditions {
        let mut effects = vec![];
        let mut truth: Vec<(&str, f64)> = vec![];
        if izz != NOMINAL_IZZ {
            effects.push(Effect::Inertia(Inertia {
                inertia_kgm2: [NOMINAL_IZZ, NOMINAL_IZZ, izz, 0.0, 0.0, 0.0],
            }));
            truth.push(("inertia", izz));
        }
        if damping > 0.0 {
            effects.push(Effect::RateDamping(RateDamping {
                nms_per_rad: [0.0, 0.0, damping],
            }));
            truth.push(("rate_damping", damping));
        }
        if tau > 0.0 {
            effects.push(Effect::ThrustRise(ThrustRise { tau_ms: tau }));
            truth.push(("thrust_rise", tau));
        }
        let (rec, sat) = flight_sampled(&effects, seconds, seed, step, noise);
        let settings = Settings {
            horizon_s: Some(10.0),
            ..Settings::default()
        };
        let out = diagnose_rate_recording(&rec, &sat, &settings)
            .expect("diagnosis")
            .output;
        let mut line = format!("seed {seed}:");
        let mut right = out.effects.len() == truth.len();
        for e in &out.effects {
            let (v, se) = z_value(e);
            let want = truth.iter().find(|t| t.0 == e.effect).map(|t| t.1);
            let ok = want.is_some_and(|w| (v - w).abs() <= (0.1 * w.abs()).max(2.0 * se));
            right &= ok;
            line += &format!(" {} {v:.5} +- {se:.5} (truth {want:?});", e.effect);
        }
        let unexplained = out.unexplained.is_some();
        if out.effects.is_empty() && unexplained {
            line += " nothing named, unexplained";
            // an honest "unexplained" is not a wrong answer
            right = true;
        }
        println!("{line}");
        if !right {
            wrong.push(line);
        }
    }
    assert!(wrong.is_empty(), "confident wrong answers: {wrong:#?}");
}

/// The named effect's yaw-axis value and stderr (the scalar for a rise).
fn z_value(e: &massid_diagnose::output::EffectReport) -> (f64, f64) {
    let key = match e.effect.as_str() {
        "inertia" => "inertia_kgm2",
        "rate_damping" => "nms_per_rad",
        "thrust_rise" => "tau_ms",
        _ => return (f64::NAN, f64::NAN),
    };
    let pick = |v: &serde_json::Value| match v.as_array() {
        Some(a) => a[2].as_f64().unwrap_or(f64::NAN),
        None => v.as_f64().unwrap_or(f64::NAN),
    };
    (pick(&e.params[key]), pick(&e.stderr[key]))
}
