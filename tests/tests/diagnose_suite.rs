//! Concealed effects made with the simulator (kept small so CI stays fast; the full
//! suite with its score table is `cargo run --release -p massid-diagnose --example
//! score_suite`): satellites other than the open data's sph2, 100 and 50 Hz sampling,
//! two effects at once, ringing aliased below Nyquist, and a nominal recording that must
//! yield no effect.

use massid_diagnose::synth::{self, Maneuver};
use massid_diagnose::{diagnose_recording, score, Settings};

fn run(
    sat: &str,
    m: Maneuver,
    rate: u32,
    effects: &[&str],
    seed: u64,
) -> (score::Score, massid_diagnose::DiagnosisOutput) {
    let eff: Vec<_> = effects.iter().map(|j| synth::effect(j)).collect();
    let truth: Vec<serde_json::Value> = effects
        .iter()
        .map(|j| serde_json::from_str(j).unwrap())
        .collect();
    let s = synth::make(sat, m, rate, eff, seed);
    let a = diagnose_recording(&s.recording, &s.satellite, &Settings::default()).unwrap();
    (score::score(&a.output, &truth), a.output)
}

#[test]
fn nominal_sph5_at_50_hz_yields_no_effect() {
    let (sc, out) = run("sph5", Maneuver::Combo { seconds: 20 }, 50, &[], 101);
    assert!(sc.named_correctly, "extra effects {:?}", sc.extra);
    assert!(out.effects.is_empty());
    assert_eq!(out.residual_rms_before, out.residual_rms_after);
}

#[test]
fn ringing_and_latency_together_on_sph1_at_100_hz() {
    let (sc, out) = run(
        "sph1",
        Maneuver::Rga12,
        100,
        &[
            r#"{"effect":"gyro_ringing","params":{"freq_hz":338.0,"decay_ms":30.0,"apparent_hz":38.0}}"#,
            r#"{"effect":"thruster_latency","params":{"open_ms":6.0,"close_ms":6.0}}"#,
        ],
        102,
    );
    assert!(
        sc.named_correctly,
        "missing {:?} extra {:?}",
        sc.missing, sc.extra
    );
    assert_eq!(
        sc.params_ok, sc.params,
        "worst {} {:.3}",
        sc.worst_param, sc.worst_rel_err
    );
    let ring = out
        .effects
        .iter()
        .find(|e| e.effect == "gyro_ringing")
        .unwrap();
    assert!(ring.evidence.contains("prior"), "{}", ring.evidence);
}

#[test]
fn pressure_drop_on_sph4_at_100_hz() {
    let (sc, _) = run(
        "sph4",
        Maneuver::Combo { seconds: 20 },
        100,
        &[r#"{"effect":"pressure_drop","params":{"newton_per_extra_thruster":0.006}}"#],
        103,
    );
    assert!(
        sc.named_correctly,
        "missing {:?} extra {:?}",
        sc.missing, sc.extra
    );
    assert_eq!(
        sc.params_ok, sc.params,
        "worst {} {:.3}",
        sc.worst_param, sc.worst_rel_err
    );
}
