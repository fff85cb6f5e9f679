//! Issue 11: an honest "unexplained", and issue 15: a thrust rise told from a latency.
//! A first-order valve thrust rise (`thrust_rise`, an extra effect since issue 15) must be
//! named as itself, not as its nearest neighbour, a latency (and a latency not as a rise).
//! A nominal recording of the same kind yields no `unexplained`, so the verdict is not a
//! constant; a recording whose thruster column was zeroed (the commands lost) must not end
//! silently with a residual far above the noise.

use massid_diagnose::synth::{self, Maneuver};
use massid_diagnose::{diagnose_recording, Settings};

fn diagnose(effects: &[&str], seed: u64) -> massid_diagnose::DiagnosisOutput {
    let eff: Vec<_> = effects.iter().map(|j| synth::effect(j)).collect();
    let s = synth::make("sph2", Maneuver::Combo { seconds: 20 }, 1000, eff, seed);
    diagnose_recording(&s.recording, &s.satellite, &Settings::default())
        .unwrap()
        .output
}

/// A first-order thrust rise is now in the diagnosis's (extended) vocabulary: it must be
/// named as a rise, not stood in for by a latency (its nearest neighbour, which the old
/// vocabulary named), with its time constant recovered, and nothing left unexplained.
#[test]
fn thrust_rise_is_named_as_a_rise_not_a_latency() {
    let out = diagnose(&[r#"{"effect":"thrust_rise","params":{"tau_ms":25.0}}"#], 7);
    let named: Vec<&str> = out.effects.iter().map(|e| e.effect.as_str()).collect();
    eprintln!("named {named:?}; unexplained {:?}", out.unexplained);
    assert_eq!(
        named,
        vec!["thrust_rise"],
        "a rise is a rise, not a latency"
    );
    let e = &out.effects[0];
    let tau = e.params["tau_ms"].as_f64().unwrap();
    let se = e.stderr["tau_ms"].as_f64().unwrap();
    assert!(
        (tau - 25.0).abs() <= (0.1 * 25.0f64).max(2.0 * se),
        "tau {tau} +- {se} ms, truth 25"
    );
    assert!(out.unexplained.is_none(), "{:?}", out.unexplained);
}

/// And a latency is still a latency: the rise must not steal it.
#[test]
fn latency_is_not_taken_for_a_rise() {
    let out = diagnose(
        &[r#"{"effect":"thruster_latency","params":{"open_ms":8.0,"close_ms":8.0}}"#],
        7,
    );
    let named: Vec<&str> = out.effects.iter().map(|e| e.effect.as_str()).collect();
    assert_eq!(named, vec!["thruster_latency"]);
}

#[test]
fn nominal_recording_has_nothing_unexplained() {
    let out = diagnose(&[], 7);
    assert!(out.effects.is_empty(), "{:?}", out.effects);
    assert!(out.unexplained.is_none(), "{:?}", out.unexplained);
    assert!(serde_json::to_value(&out)
        .unwrap()
        .get("unexplained")
        .is_none());
}

#[test]
fn lost_thruster_column_is_not_silently_explained() {
    let mut s = synth::make("sph2", Maneuver::Combo { seconds: 20 }, 1000, vec![], 11);
    for x in s.recording.samples.iter_mut() {
        x.thrusters = 0;
    }
    let out = diagnose_recording(&s.recording, &s.satellite, &Settings::default())
        .unwrap()
        .output;
    let u = out
        .unexplained
        .as_ref()
        .expect("a residual far above the noise must be reported");
    eprintln!(
        "named {:?}; {}",
        out.effects.iter().map(|e| &e.effect).collect::<Vec<_>>(),
        u.note
    );
    assert!((0..3).any(|a| u.rms[a] > 3.0 * u.noise_rms[a]), "{u:?}");
}
