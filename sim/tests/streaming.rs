//! `simulate_to` streams the recording as it flies: its bytes are those of `simulate`'s
//! in-memory recording written whole, for v1 and v2 craft, every sample rate, telemetry
//! artefacts (lost and re-sent rows) and several ringing effects (whose phases the stream
//! must draw in the whole-flight order).
use massid_sim::model_file::ModelFile;
use massid_sim::sensors::Artefacts;
use massid_sim::{simulate, simulate_to, Maneuver, SimSpec};
use std::path::PathBuf;

fn model(name: &str) -> ModelFile {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../examples/models")
        .join(name);
    ModelFile::read(&path).unwrap()
}

/// sph2 with two ringing effects, a valve latency, a measurement delay and artefacts.
fn effects_model() -> ModelFile {
    ModelFile::parse(
        r#"satellite = "sph2"
[[effects]]
effect = "gyro_ringing"
params = { freq_hz = 338.0, decay_ms = 30.0, apparent_hz = 38.0 }
[[effects]]
effect = "gyro_ringing"
params = { freq_hz = 211.0, decay_ms = 12.0, apparent_hz = 11.0 }
[[effects]]
effect = "thruster_latency"
params = { open_ms = 6.3, close_ms = 2.7 }
[[effects]]
effect = "measurement_delay"
params = { delay_ms = 17.5 }
"#,
        "fx.toml",
    )
    .unwrap()
}

fn spec_of(m: ModelFile, maneuver: Maneuver, seconds: f64, rate_hz: f64, seed: u64) -> SimSpec {
    let mut s = SimSpec::new(m.satellite, m.effects, maneuver);
    s.sensors = m.sensors;
    s.artefacts = m.artefacts;
    s.seconds = Some(seconds);
    s.rate_hz = rate_hz;
    s.seed = seed;
    s
}

/// The in-memory recording written whole (v2 when there is one), and its row count.
fn collected(spec: &SimSpec) -> (Vec<u8>, usize, usize) {
    let out = simulate(spec).unwrap();
    let mut v = Vec::new();
    let rows = match &out.rate_recording {
        Some(r) => {
            r.write_to(&mut v).unwrap();
            r.time_ms.len()
        }
        None => {
            out.recording.write_to(&mut v).unwrap();
            out.recording.samples.len()
        }
    };
    (v, rows, out.commands.len())
}

fn check(spec: &SimSpec) {
    let (whole, rows, commanded_ms) = collected(spec);
    let mut streamed = Vec::new();
    let s = simulate_to(spec, &mut streamed).unwrap();
    assert_eq!(s.rows, rows);
    assert_eq!(s.commanded_ms, commanded_ms);
    // Compare line by line first so a failure names the first differing row.
    let (a, b) = (
        String::from_utf8(whole).unwrap(),
        String::from_utf8(streamed).unwrap(),
    );
    for (i, (x, y)) in a.lines().zip(b.lines()).enumerate() {
        assert_eq!(x, y, "line {}", i + 1);
    }
    assert_eq!(a.lines().count(), b.lines().count(), "line counts");
    assert_eq!(a, b);
}

#[test]
fn streamed_v1_equals_the_whole_recording_with_artefacts_and_two_ringings() {
    let mut spec = spec_of(effects_model(), Maneuver::Combo, 4.0, 1000.0, 2);
    spec.artefacts = Artefacts {
        gaps: 4,
        max_gap: 7,
        duplicates: 3,
    };
    check(&spec);
    // a lower rate, a closed loop
    spec.rate_hz = 250.0;
    spec.maneuver = Maneuver::ClosedLoop;
    check(&spec);
}

#[test]
fn streamed_v2_equals_the_whole_recording() {
    let mut spec = spec_of(model("freeflyer16.toml"), Maneuver::Combo, 3.0, 1000.0, 3);
    check(&spec);
    spec.rate_hz = 50.0;
    spec.maneuver = Maneuver::RandomPwm;
    spec.artefacts = Artefacts {
        gaps: 2,
        max_gap: 3,
        duplicates: 2,
    };
    check(&spec);
    // planar: one rate column
    check(&spec_of(
        model("airbearing-mpc.toml"),
        Maneuver::Single,
        6.0,
        100.0,
        5,
    ));
}

#[test]
fn a_bad_spec_writes_nothing() {
    let mut spec = spec_of(effects_model(), Maneuver::Combo, 2.0, 3.0, 1);
    let mut v = Vec::new();
    assert!(simulate_to(&spec, &mut v).is_err());
    spec.rate_hz = 1000.0;
    spec.seconds = Some(-1.0);
    assert!(simulate_to(&spec, &mut v).is_err());
    assert!(v.is_empty());
}
