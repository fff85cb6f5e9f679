//! The effect vocabulary (de)serialises exactly as the contract says.
use massid_sim::effects::{Effect, ThrusterLatency, Truth, EFFECT_NAMES};
use std::path::PathBuf;

fn open_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/open")
}

#[test]
fn latency_serialises_as_the_contract_example() {
    let e = Effect::ThrusterLatency(ThrusterLatency {
        open_ms: 6.0,
        close_ms: 6.0,
    });
    assert_eq!(
        serde_json::to_string(&e).unwrap(),
        r#"{"effect":"thruster_latency","params":{"open_ms":6.0,"close_ms":6.0}}"#
    );
    let back: Effect = serde_json::from_str(
        r#"{"effect": "thruster_latency", "params": {"open_ms": 6.0, "close_ms": 6.0}}"#,
    )
    .unwrap();
    assert_eq!(back, e);
}

/// One document per contract row, with the contract's parameter names and shapes.
const EVERY_EFFECT: &str = r#"{"satellite": "sph2", "effects": [
 {"effect": "thruster_latency", "params": {"open_ms": 6.0, "close_ms": 5.0}},
 {"effect": "pressure_drop", "params": {"newton_per_extra_thruster": 0.0106}},
 {"effect": "blowdown", "params": {"start_s": 20.0, "tau_s": 30.0}},
 {"effect": "thrust_scale", "params": {"scale": [1,1,1,1,1,0.7,1,1,1,1,1,0]}},
 {"effect": "com_offset", "params": {"offset_mm": [1.5, -2.0, 3.0]}},
 {"effect": "inertia", "params": {"inertia_kgm2": [0.025, 0.022, 0.02, 0.0001, 0.0002, 0.00001]}},
 {"effect": "mass_property_change", "params": {"at_s": 10.0, "offset_mm": [0, 0, 5], "inertia_kgm2": [0.03, 0.03, 0.025, 0, 0, 0]}},
 {"effect": "fuel_slosh", "params": {"freq_hz": 0.39, "damping_ratio": 0.004}},
 {"effect": "gyro_bias", "params": {"counts": [3, -2, 1]}},
 {"effect": "gyro_scale", "params": {"scale": [1.01, 0.99, 1.0]}},
 {"effect": "gyro_ringing", "params": {"freq_hz": 338.0, "decay_ms": 30.0, "apparent_hz": 38.0}},
 {"effect": "disturbance_torque", "params": {"torque_nm": [1e-5, 0, -2e-5]}},
 {"effect": "rate_damping", "params": {"nms_per_rad": [0, 0, 0.02]}},
 {"effect": "thrust_rise", "params": {"tau_ms": 20.0}},
 {"effect": "thruster_misalignment", "params": {"dir": [[1,0,0],[1,0,0],[1,0,0],[0,1,0],[0,1,0],[0,1,0],[0,0,1],[0,0,1],[0,0,1],[0,0.1,1],[0,0,1],[0,0,1]]}},
 {"effect": "measurement_delay", "params": {"delay_ms": 120.0}}
]}"#;

#[test]
fn every_contract_effect_parses_and_round_trips() {
    let t = Truth::from_json_str(EVERY_EFFECT, "inline").unwrap();
    let names: Vec<&str> = t.effects.iter().map(|e| e.name()).collect();
    assert_eq!(names, EFFECT_NAMES.to_vec());
    let again = Truth::from_json_str(&t.to_json(), "again").unwrap();
    assert_eq!(again, t);
    // The serialised form uses the contract's tag and parameter names.
    let v: serde_json::Value = serde_json::from_str(&t.to_json()).unwrap();
    for (e, name) in v["effects"].as_array().unwrap().iter().zip(EFFECT_NAMES) {
        assert_eq!(e["effect"], name);
    }
    assert_eq!(v["effects"][2]["params"]["tau_s"], 30.0);
    assert_eq!(v["effects"][3]["params"]["scale"][5], 0.7);
}

#[test]
fn every_open_truth_file_parses() {
    let mut n = 0;
    for entry in std::fs::read_dir(open_dir()).unwrap() {
        let p = entry.unwrap().path();
        if p.to_string_lossy().ends_with(".truth.json") {
            let t = Truth::read(&p).unwrap_or_else(|e| panic!("{e}"));
            assert_eq!(t.satellite, "sph2");
            n += 1;
        }
    }
    assert_eq!(n, 9);
}

#[test]
fn bad_truth_is_a_clear_error() {
    let e = Truth::from_json_str(
        r#"{"satellite": "sph2", "effects": [{"effect": "warp_drive", "params": {}}]}"#,
        "x.truth.json",
    )
    .unwrap_err()
    .to_string();
    assert!(e.starts_with("x.truth.json: line 1"), "{e}");
    let e = Truth::from_json_str(
        r#"{"satellite": "sph2", "effects": [{"effect": "blowdown", "params": {"start_s": 1}}]}"#,
        "y",
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("tau_s"), "{e}");
    let e = Truth::from_json_str(r#"{"satellite": "s", "effects": [{"effect": "blowdown", "params": {"start_s": 1, "tau_s": -3}}]}"#, "z")
        .unwrap_err()
        .to_string();
    assert!(e.contains("tau_s must be > 0"), "{e}");
}

#[test]
fn params_flatten_and_replace() {
    let t = Truth::from_json_str(EVERY_EFFECT, "inline").unwrap();
    let scale = &t.effects[3];
    let p = scale.params();
    assert_eq!(p.len(), 12);
    assert_eq!(p[5], ("scale[5]".to_string(), 0.7));
    let changed = scale.with_params(&[("scale[5]", 0.5)]).unwrap();
    assert_eq!(changed.params()[5].1, 0.5);
    let lat = t.effects[0].with_params(&[("open_ms", 7.5)]).unwrap();
    assert_eq!(
        lat.params().iter().find(|(k, _)| k == "open_ms").unwrap().1,
        7.5
    );
    assert!(t.effects[0].with_params(&[("nope", 1.0)]).is_err());
}
