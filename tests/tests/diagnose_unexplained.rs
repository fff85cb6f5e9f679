//! Issue 11: an honest "unexplained". A mechanism outside the effect vocabulary, made by
//! our own simulator (a first-order valve thrust rise, `thrust_rise`), must not be dressed
//! up as vocabulary physics: at most the nearest physical stand-in (a valve latency) is
//! named, and what it cannot explain is reported in the contract's `unexplained` object.
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

#[test]
fn thrust_rise_outside_the_vocabulary_is_reported_unexplained() {
    let out = diagnose(&[r#"{"effect":"thrust_rise","params":{"tau_ms":25.0}}"#], 7);
    let named: Vec<&str> = out.effects.iter().map(|e| e.effect.as_str()).collect();
    eprintln!("named {named:?}; unexplained {:?}", out.unexplained);
    assert!(
        named.iter().all(|n| *n == "thruster_latency"),
        "a rise time may only be stood in for by a latency, named {named:?}"
    );
    let u = out
        .unexplained
        .as_ref()
        .expect("a rise time the vocabulary cannot model must be reported unexplained");
    assert!(!u.axes.is_empty());
    assert!(u.note.contains("no effect of the vocabulary"));
    // the contract's shape
    let v = serde_json::to_value(&out).unwrap();
    for key in [
        "rms",
        "noise_rms",
        "ljung_box",
        "white_below",
        "axes",
        "condition",
        "apparent_hz",
        "windows_ms",
        "note",
    ] {
        assert!(
            v["unexplained"].get(key).is_some(),
            "unexplained lacks {key}"
        );
    }
    // where it concentrates: the rise lives at valve edges and while valves are open
    assert!(
        !u.condition.contains("coasting"),
        "condition {}",
        u.condition
    );
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
