//! Issue 24 items 1-2 on craft other than SPHERES, flown by our simulator (format v2
//! recordings, rates in rad/s): a measurement delay far longer than a valve's and a valve
//! latency longer than the command step are each named, with the right value, and nothing
//! else; the equal latency / delay is listed once under `equivalent_to`, never named twice.
//! Craft: the 8-thruster cubesat and the 16-thruster free-flyer of `examples/models/` (3-D,
//! canted thrusters) and the planar air-bearing craft. Random PWM at 100 Hz, 40 s.

use massid_diagnose::{diagnose_rate_recording, DiagnosisOutput, Settings};
use massid_sim::effects::{Effect, MeasurementDelay, ThrusterLatency};
use massid_sim::model_file::ModelFile;
use massid_sim::simulate::{simulate, Maneuver, SimSpec};
use std::path::Path;

fn diagnose(model: &str, effects: Vec<Effect>, seed: u64) -> DiagnosisOutput {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("ws");
    let sat = ModelFile::read(&root.join("examples/models").join(model))
        .expect("model")
        .satellite;
    let mut spec = SimSpec::new(sat.clone(), effects, Maneuver::RandomPwm);
    spec.seconds = Some(40.0);
    spec.rate_hz = 100.0;
    spec.seed = seed;
    let out = simulate(&spec).expect("simulate");
    let rec = out.rate_recording.expect("a v2 craft");
    diagnose_rate_recording(&rec, &sat, &Settings::default())
        .expect("diagnosis")
        .output
}

fn named(out: &DiagnosisOutput) -> Vec<&str> {
    out.effects.iter().map(|e| e.effect.as_str()).collect()
}

/// `got` within 2 % or 3 stderr of `want`.
fn near(what: &str, got: f64, se: f64, want: f64) {
    assert!(
        (got - want).abs() <= (0.02 * want).max(3.0 * se),
        "{what}: {got} +- {se}, truth {want}"
    );
}

fn delay(ms: f64) -> Effect {
    Effect::MeasurementDelay(MeasurementDelay { delay_ms: ms })
}

#[test]
fn a_long_measurement_delay_is_named_with_its_equal_latency_listed() {
    for (model, seed) in [("cubesat8.toml", 5), ("airbearing-mpc.toml", 6)] {
        let out = diagnose(model, vec![delay(150.0)], seed);
        assert_eq!(named(&out), vec!["measurement_delay"], "{model}");
        let e = &out.effects[0];
        let d = e.params["delay_ms"].as_f64().unwrap();
        near(model, d, e.stderr["delay_ms"].as_f64().unwrap(), 150.0);
        assert_eq!(e.equivalent_to.len(), 1, "{model}");
        assert_eq!(e.equivalent_to[0]["effect"], "thruster_latency");
        assert_eq!(e.equivalent_to[0]["params"]["open_ms"].as_f64(), Some(d));
        assert!(out.unexplained.is_none(), "{model}: {:?}", out.unexplained);
    }
}

#[test]
fn a_valve_latency_longer_than_the_command_step_is_named() {
    // random PWM fires pulses 10-190 ms wide, centred in 200 ms periods: a 70 ms latency
    // is longer than many pulses, and a local fit from a short latency finds the wrong one
    let lat = Effect::ThrusterLatency(ThrusterLatency {
        open_ms: 70.0,
        close_ms: 70.0,
    });
    let out = diagnose("freeflyer16.toml", vec![lat], 7);
    assert_eq!(named(&out), vec!["thruster_latency"]);
    let e = &out.effects[0];
    for k in ["open_ms", "close_ms"] {
        near(
            k,
            e.params[k].as_f64().unwrap(),
            e.stderr[k].as_f64().unwrap(),
            70.0,
        );
    }
    // equal open and close: the delay of the same size is listed, not named
    assert_eq!(e.equivalent_to[0]["effect"], "measurement_delay");
}

/// The planted fault: the same craft with nothing wrong names nothing (so the checks above
/// can fail on a diagnosis that names a delay regardless).
#[test]
fn the_same_flights_without_a_delay_name_nothing() {
    let out = diagnose("cubesat8.toml", vec![], 5);
    assert_eq!(named(&out), Vec::<&str>::new());
}
