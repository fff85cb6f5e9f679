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

fn flight(
    effects: &[Effect],
    seconds: u64,
    seed: u64,
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
    // sampled at 50 Hz; the word of a sample is the one commanded at its time
    let keep: Vec<usize> = (0..n_ms as usize).step_by(20).collect();
    let rate = keep
        .iter()
        .map(|&k| {
            [
                f64::NAN,
                f64::NAN,
                p.gyro_rad_s[k][2] + 0.002 * normal(&mut x),
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
            inertia_kgm2: [0.3237, 0.3237, IZZ, 0.0, 0.0, 0.0],
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
