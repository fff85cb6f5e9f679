//! Issue 24 items 1-2 on craft other than SPHERES, flown by our simulator (format v2
//! recordings, rates in rad/s): a measurement delay far longer than a valve's, a valve
//! latency longer than the command step and a tilted thruster are each named, with the right
//! value, and nothing else; equivalent effects (equal latency / delay, a uniform thrust scale
//! / an inertia) are named once with the other under `equivalent_to`, never named together.
//! Craft: the 8-thruster cubesat and the 16-thruster free-flyer of `examples/models/` (3-D,
//! canted thrusters) and the planar air-bearing craft. Random PWM at 100 Hz.

use massid_diagnose::{diagnose_rate_recording, DiagnosisOutput, Settings};
use massid_sim::effects::{
    Effect, MeasurementDelay, ThrustScale, ThrusterLatency, ThrusterMisalignment,
};
use massid_sim::model_file::ModelFile;
use massid_sim::simulate::{simulate, Maneuver, SimSpec};
use std::path::Path;

fn diagnose(model: &str, effects: Vec<Effect>, seed: u64) -> DiagnosisOutput {
    diagnose_with(model, effects, seed, 40.0, None)
}

/// `seconds` of random PWM; `horizon_s` re-anchors the rate (a tumbling 3-D craft's
/// open-loop prediction drifts over a long flight).
fn diagnose_with(
    model: &str,
    effects: Vec<Effect>,
    seed: u64,
    seconds: f64,
    horizon_s: Option<f64>,
) -> DiagnosisOutput {
    diagnose_noisy(model, effects, seed, seconds, horizon_s, None)
}

/// As [`diagnose_with`], with the gyro's white noise at `noise_rad_s` on each axis (the
/// simulator's default when `None`).
fn diagnose_noisy(
    model: &str,
    effects: Vec<Effect>,
    seed: u64,
    seconds: f64,
    horizon_s: Option<f64>,
    noise_rad_s: Option<f64>,
) -> DiagnosisOutput {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("ws");
    let sat = ModelFile::read(&root.join("examples/models").join(model))
        .expect("model")
        .satellite;
    let mut spec = SimSpec::new(sat.clone(), effects, Maneuver::RandomPwm);
    spec.seconds = Some(seconds);
    spec.rate_hz = 100.0;
    spec.seed = seed;
    if let Some(sigma) = noise_rad_s {
        spec.sensors.gyro_noise_rad_s = [sigma; 3];
    }
    let out = simulate(&spec).expect("simulate");
    let rec = out.rate_recording.expect("a v2 craft");
    let settings = Settings {
        horizon_s,
        ..Settings::default()
    };
    diagnose_rate_recording(&rec, &sat, &settings)
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

/// Thruster 3 of the cubesat tilted 3 degrees (toward the body's z axis): named as a
/// misalignment of that thruster alone, not as thrust scales.
#[test]
fn a_tilted_thruster_is_named_as_a_misalignment_of_that_thruster() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("ws");
    let sat = ModelFile::read(&root.join("examples/models/cubesat8.toml"))
        .expect("model")
        .satellite;
    let mut dir: Vec<[f64; 3]> = sat.thrust_dir.clone();
    let d = nalgebra::Vector3::from(dir[2]);
    let axis = nalgebra::Unit::new_normalize(d.cross(&nalgebra::Vector3::z()));
    dir[2] = (nalgebra::Rotation3::from_axis_angle(&axis, 3f64.to_radians()) * d).into();
    let tilt = Effect::ThrusterMisalignment(ThrusterMisalignment { dir: dir.clone() });
    let out = diagnose_with("cubesat8.toml", vec![tilt], 4, 30.0, Some(5.0));
    assert_eq!(named(&out), vec!["thruster_misalignment"]);
    let e = &out.effects[0];
    assert_eq!(e.params["thrusters"], serde_json::json!([3]));
    near(
        "tilt of thruster 3",
        e.params["tilt_deg"][2].as_f64().unwrap(),
        e.stderr["tilt_deg"][2].as_f64().unwrap(),
        3.0,
    );
    let got = &e.params["dir"][2];
    let cos: f64 = (0..3).map(|k| got[k].as_f64().unwrap() * dir[2][k]).sum();
    assert!(
        cos.clamp(-1.0, 1.0).acos().to_degrees() < 0.5,
        "direction {got}"
    );
}

/// All eight thrusters at 90 %: the same rates as an inertia / 0.9. One effect is named and
/// the other listed under `equivalent_to`; the two are never named together.
#[test]
fn a_uniform_thrust_scale_is_named_once_with_its_inertia_equivalent() {
    let scale = Effect::ThrustScale(ThrustScale {
        scale: vec![0.9; 8],
    });
    let out = diagnose_with("cubesat8.toml", vec![scale], 4, 30.0, Some(5.0));
    let names = named(&out);
    assert_eq!(names.len(), 1, "{names:?}");
    let e = &out.effects[0];
    let other = match names[0] {
        "inertia" => "thrust_scale",
        "thrust_scale" => "inertia",
        n => panic!("named {n}"),
    };
    assert_eq!(e.equivalent_to.len(), 1);
    assert_eq!(e.equivalent_to[0]["effect"], other);
    let s = if other == "thrust_scale" {
        e.equivalent_to[0]["params"]["scale"][0].as_f64().unwrap()
    } else {
        e.params["scale"][0].as_f64().unwrap()
    };
    assert!((s - 0.9).abs() < 0.01, "scale {s}");
}

/// The 16-thruster free-flyer (0.26 m from its CoM to its farthest thruster) with its CoM
/// 70 mm off: named, near the truth. The CoM search was fixed at 50 mm for every craft (a
/// 0.2 m SPHERES' tolerance), so this offset was clamped at the bound, called implausible
/// and replaced by other effects; the bound now scales with the craft (118 mm here).
#[test]
fn a_large_craft_s_com_offset_beyond_spheres_tolerance_is_named() {
    let com = Effect::ComOffset(massid_sim::effects::ComOffset {
        offset_mm: [70.0, -40.0, 30.0],
    });
    let out = diagnose_with("freeflyer16.toml", vec![com], 8, 30.0, Some(5.0));
    assert_eq!(named(&out), vec!["com_offset"]);
    let e = &out.effects[0];
    for (k, want) in [70.0, -40.0, 30.0].into_iter().enumerate() {
        near(
            "CoM offset",
            e.params["offset_mm"][k].as_f64().unwrap(),
            e.stderr["offset_mm"][k].as_f64().unwrap(),
            want,
        );
    }
}

/// The free-flyer (0.6 N thrusters, 0.26 m) under an external torque of a few percent of a
/// thruster's, and with a tank that loses 0.1 N per extra open valve: each named, near the
/// truth. Both searches were SPHERES-sized (a disturbance over 1e-3 N m implausible, a drop
/// searched to 0.05 N), so a larger craft's disturbance was refused and something else named
/// (`diagnose_random_craft`: 2 of 12 planar and 0 of 12 3-D random craft named it), and its
/// drop would have been clamped at the bound; the bounds now scale with the craft's thrust
/// and size (`effects::craft_scale`).
#[test]
fn a_large_craft_s_disturbance_and_pressure_drop_are_named_at_their_size() {
    let want = [6e-3, -4e-3, 3e-3];
    let torque =
        Effect::DisturbanceTorque(massid_sim::effects::DisturbanceTorque { torque_nm: want });
    let out = diagnose_with("freeflyer16.toml", vec![torque], 8, 30.0, Some(5.0));
    assert_eq!(named(&out), vec!["disturbance_torque"]);
    let e = &out.effects[0];
    for (k, want) in want.into_iter().enumerate() {
        near(
            "disturbance torque",
            e.params["torque_nm"][k].as_f64().unwrap().abs(),
            e.stderr["torque_nm"][k].as_f64().unwrap(),
            want.abs(),
        );
        assert_eq!(
            e.params["torque_nm"][k].as_f64().unwrap().signum(),
            want.signum()
        );
    }
    let drop = Effect::PressureDrop(massid_sim::effects::PressureDrop {
        newton_per_extra_thruster: 0.1,
    });
    let out = diagnose_with("freeflyer16.toml", vec![drop], 8, 30.0, Some(5.0));
    assert_eq!(named(&out), vec!["pressure_drop"]);
    let e = &out.effects[0];
    near(
        "pressure drop",
        e.params["newton_per_extra_thruster"].as_f64().unwrap(),
        e.stderr["newton_per_extra_thruster"].as_f64().unwrap(),
        0.1,
    );
}

/// One of the cubesat's canted thrusters at 80 % of its force. A tilt toward the thruster's
/// lever arm changes only the size of its torque, so the rates cannot tell the two apart: the
/// scale is named, or the tilt with the scale listed under `equivalent_to`, with the same
/// thruster at 0.8 either way (a misalignment used to be named alone, an 18 degree tilt for a
/// weak valve). A named scale does not list a tilt.
#[test]
fn a_weak_canted_thruster_is_named_with_its_equivalent_tilt_or_scale() {
    let mut scale = vec![1.0; 8];
    scale[2] = 0.8;
    let weak = Effect::ThrustScale(ThrustScale { scale });
    let out = diagnose_with("cubesat8.toml", vec![weak], 4, 30.0, Some(5.0));
    let names = named(&out);
    assert_eq!(names.len(), 1, "{names:?}");
    let e = &out.effects[0];
    let s = match names[0] {
        "thrust_scale" => e.params["scale"][2].as_f64().unwrap(),
        "thruster_misalignment" => {
            assert_eq!(e.params["thrusters"], serde_json::json!([3]));
            assert_eq!(e.equivalent_to.len(), 1, "{:?}", e.equivalent_to);
            assert_eq!(e.equivalent_to[0]["effect"], "thrust_scale");
            e.equivalent_to[0]["params"]["scale"][2].as_f64().unwrap()
        }
        n => panic!("named {n}"),
    };
    assert!((s - 0.8).abs() < 0.03, "scale of thruster 3: {s}");
}

/// A 20 ms first-order thrust rise on the cubesat, 15 s at 100 Hz. At the simulator's gyro
/// noise the rates tell it from a 20 ms valve latency (their fits differ by hundreds in
/// chi-square): the rise is named alone. With the noise at 0.014 rad/s (a differenced
/// attitude's) the two deliver the same impulse with the same centroid within the noise
/// (chi-square about 5 against ln n 8.6): whichever is named lists the other, saying the
/// recording cannot tell them apart (a latency used to be named alone,
/// the rise missing the materiality check by 0.01 of the noise). Planted either way: listing
/// nothing fails the noisy flight, listing every strong candidate fails the quiet one.
#[test]
fn a_thrust_rise_is_listed_with_a_latency_only_where_the_noise_hides_the_difference() {
    let rise = || Effect::ThrustRise(massid_sim::effects::ThrustRise { tau_ms: 20.0 });
    let listed = |out: &DiagnosisOutput| -> Vec<String> {
        out.effects
            .iter()
            .flat_map(|e| e.equivalent_to.iter())
            .filter_map(|v| v["effect"].as_str().map(String::from))
            .collect()
    };
    let quiet = diagnose_noisy("cubesat8.toml", vec![rise()], 3, 15.0, None, None);
    assert_eq!(named(&quiet), vec!["thrust_rise"]);
    near(
        "rise",
        quiet.effects[0].params["tau_ms"].as_f64().unwrap(),
        quiet.effects[0].stderr["tau_ms"].as_f64().unwrap(),
        20.0,
    );
    assert!(listed(&quiet).is_empty(), "{:?}", listed(&quiet));
    let noisy = diagnose_noisy("cubesat8.toml", vec![rise()], 3, 15.0, None, Some(0.014));
    let names = named(&noisy);
    assert_eq!(names.len(), 1, "{names:?}");
    let all: Vec<String> = listed(&noisy)
        .into_iter()
        .chain(names.iter().map(|s| s.to_string()))
        .collect();
    for want in ["thrust_rise", "thruster_latency"] {
        assert!(all.iter().any(|a| a == want), "{want} not in {all:?}");
    }
    assert!(
        noisy.effects[0].evidence.contains("cannot tell it from"),
        "{}",
        noisy.effects[0].evidence
    );
}

/// A random 3-D craft (15 canted thrusters, 44 kg m^2; `random_craft`, seed 81210) whose
/// principal moments are 10 % above its model's, products unchanged: named an inertia, the
/// moments near the truth, the products held at the model's or fitted near it. The
/// selection used to price only the whole tensor (6 parameters), and the per-axis gyro scale
/// (3), which fits worse, won by the three products' BIC price. (Here the final refit with
/// the products free is a uniform thrust scale's exact equal within its errors, so it is
/// kept whole and the thrust scale listed: `diagnosis/held.rs`.) Planted: without the
/// moments-only form (`Effect::holdable` empty) this flight names `gyro_scale`.
#[test]
fn a_3d_craft_s_moments_alone_are_named_an_inertia_not_a_gyro_scale() {
    moments_up_are_named_near_their_truth(81210);
}

/// A random 3-D craft tumbling for 40 s (11 thrusters, rates up to 1 rad/s, a quiet gyro;
/// `random_craft`, seed 86022) whose principal moments are 10 % above its model's: named an
/// inertia near the truth, nothing left unexplained. A fit started at the model's inertia
/// alone ended 30-90 standard errors from the truth with the residual 4 times the noise and
/// "unexplained": over a long tumble the rates depend on the inertia too unevenly for the
/// fit to walk there. The recording's own linear estimate (`equation_error.rs`) is a
/// second start, fitted with nuisances of its own (`select.rs`). Planted: without that start
/// (`Context::inertia_start` left `None`) a product of inertia ends more than 3 errors off.
#[test]
fn a_tumbling_3d_craft_s_inertia_is_found_from_the_recording_s_own_estimate() {
    let out = moments_up_are_named_near_their_truth(86022);
    assert!(out.unexplained.is_none(), "{:?}", out.unexplained);
}

/// The random craft of `seed` (3-D or `planar`, 1-16 thrusters: `massid_tests::random_craft`)
/// flown for 40 s of random PWM at 100 Hz with `effects(model)` planted, and its diagnosis
/// against the craft's own model: (the model, the diagnosis).
fn random_craft_diagnosis(
    seed: u64,
    planar: bool,
    effects: impl Fn(&reference_f64::satellite::Satellite) -> Vec<Effect>,
) -> (reference_f64::satellite::Satellite, DiagnosisOutput) {
    use massid_tests::random_craft::{draw, CraftClass};
    let class = CraftClass {
        planar,
        thrusters: (1, 16),
        mocap: false,
    };
    let d = draw(&class, seed);
    let mut spec = d.spec.clone();
    spec.effects = effects(&d.model);
    spec.maneuver = Maneuver::RandomPwm;
    spec.seconds = Some(40.0);
    spec.rate_hz = 100.0;
    let rec = simulate(&spec)
        .expect("simulate")
        .rate_recording
        .expect("a v2 craft");
    let out = diagnose_rate_recording(&rec, &d.model, &Settings::default())
        .expect("diagnosis")
        .output;
    (d.model, out)
}

/// Flies the random 3-D craft of `seed` for 40 s of random PWM at 100 Hz with its principal
/// moments 10 % above its model's (products unchanged), and checks that the diagnosis
/// names an inertia alone, its moments within 3 errors of the truth and its products held
/// at the model's or near the truth.
fn moments_up_are_named_near_their_truth(seed: u64) -> massid_diagnose::DiagnosisOutput {
    use massid_sim::effects::Inertia;
    let moments_up = |m: &[f64; 6]| {
        let mut t = *m;
        for v in t.iter_mut().take(3) {
            *v *= 1.1;
        }
        t
    };
    let (sat, out) = random_craft_diagnosis(seed, false, |sat| {
        vec![Effect::Inertia(Inertia {
            inertia_kgm2: moments_up(&sat.inertia_kgm2),
        })]
    });
    let model = sat.inertia_kgm2;
    let truth = moments_up(&model);
    assert_eq!(named(&out), vec!["inertia"]);
    let e = &out.effects[0];
    let got = |k: usize| e.params["inertia_kgm2"][k].as_f64().unwrap();
    for k in 0..3 {
        near(
            "principal moment",
            got(k),
            e.stderr["inertia_kgm2"][k]
                .as_f64()
                .unwrap_or(f64::INFINITY),
            truth[k],
        );
    }
    products_held_or_near(e, &model, &truth);
    out
}

/// Each product of inertia of the named inertia `e` is either held at the `model`'s, where
/// that is the `truth`, or fitted within 3 of its standard errors of the truth.
fn products_held_or_near(e: &massid_diagnose::EffectReport, model: &[f64; 6], truth: &[f64; 6]) {
    for k in 3..6 {
        let got = e.params["inertia_kgm2"][k].as_f64().unwrap();
        let se = e.stderr["inertia_kgm2"][k].as_f64().unwrap();
        let held = e
            .held
            .get("inertia_kgm2")
            .and_then(|v| v.as_array())
            .is_some_and(|ix| ix.iter().any(|i| i.as_u64() == Some(k as u64)));
        if held {
            assert!(got == model[k] && se >= 1e6, "held {k}: {got} +- {se}");
            assert_eq!(truth[k], model[k], "product {k} held at the model's");
        } else {
            assert!(
                (got - truth[k]).abs() <= 3.0 * se,
                "product {k}: {got} +- {se}, truth {}",
                truth[k]
            );
        }
    }
}

/// `open3/r05` (the independent simulator's ten-thruster cube, never used to develop the
/// diagnosis until this check: moments changed, Ixy 0.0006 -> 0.001 kg m^2, the other two
/// products as the model's, and a disturbance torque): the changed product is fitted, near
/// its truth, and the unchanged ones are held or fitted near theirs. The products were
/// first held in a round where a thrust scale, dropped later, stood in for Ixy; held
/// parameters are decided again against the final set of effects (`diagnosis/held.rs`).
/// Planted: without that second decision Ixy stays at the model's 0.0006.
#[test]
fn open3_r05_s_changed_product_of_inertia_is_fitted_and_its_unchanged_ones_held() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/open3");
    let name = "r05_ft10_inertia_dist";
    let rec = reference_f64::rate_recording::RateRecording::read(&dir.join(format!("{name}.csv")))
        .expect("recording");
    let sat = ModelFile::read(&dir.join(format!("{name}.model.toml")))
        .expect("model")
        .satellite;
    let truth: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.join(format!("{name}.truth.json"))).expect("truth"),
    )
    .expect("truth json");
    let want: [f64; 6] = std::array::from_fn(|k| {
        truth["effects"][0]["params"]["inertia_kgm2"][k]
            .as_f64()
            .unwrap()
    });
    assert_eq!(truth["effects"][0]["effect"], "inertia");
    let out = diagnose_rate_recording(&rec, &sat, &Settings::default())
        .expect("diagnosis")
        .output;
    let e = out
        .effects
        .iter()
        .find(|e| e.effect == "inertia")
        .expect("inertia named");
    products_held_or_near(e, &sat.inertia_kgm2, &want);
}

/// A valve latency whose open - close difference is a commanded pulse width: pulses that
/// short are swallowed from that difference on, so the rates have a kink there. A random
/// planar craft (seed 88118: 6 thrusters, commands on the 100 Hz samples' 10 ms steps) with
/// 40/20 ms: both latencies within 3 of their errors. With forward differences for the
/// latency's Jacobian (the planted fault: `ThrusterLatency::kinked` false) the fit stopped
/// at 40.52/20.52 ms, 37 errors off, and the residual was left unexplained.
#[test]
fn a_latency_whose_difference_is_a_pulse_width_is_named_within_its_errors() {
    let (_, out) = random_craft_diagnosis(88118, true, |_| {
        vec![Effect::ThrusterLatency(ThrusterLatency {
            open_ms: 40.0,
            close_ms: 20.0,
        })]
    });
    assert_eq!(named(&out), vec!["thruster_latency"]);
    let e = &out.effects[0];
    for (key, want) in [("open_ms", 40.0), ("close_ms", 20.0)] {
        let got = e.params[key].as_f64().unwrap();
        let se = e.stderr[key].as_f64().unwrap();
        assert!(
            (got - want).abs() <= 3.0 * se,
            "{key}: {got} +- {se}, truth {want}"
        );
    }
    assert!(out.unexplained.is_none(), "{:?}", out.unexplained);
}

/// Every thruster 10 % weak on a random 3-D craft (seed 88017, 7 thrusters): on rates the
/// inertia over 0.9, products too. Whichever of the two is named, every term it fits is
/// within 3 of its errors of that truth. The screen's fit had held Ixy at the model's,
/// within its BIC price, which moved the moments by 5 of their errors: named with Ixy held,
/// Ixx was 12.5 errors off and nothing was unexplained (the planted fault: a hold
/// whatever it moves, `MAX_HELD_SHIFT` infinite).
#[test]
fn a_hold_that_would_move_the_other_terms_past_their_errors_is_not_kept() {
    let (model, out) = random_craft_diagnosis(88017, false, |sat| {
        vec![Effect::ThrustScale(ThrustScale {
            scale: vec![0.9; sat.n_thrusters()],
        })]
    });
    let names = named(&out);
    assert_eq!(names.len(), 1, "{names:?}");
    let e = &out.effects[0];
    let (key, truth): (&str, Vec<f64>) = match names[0] {
        "inertia" => (
            "inertia_kgm2",
            model.inertia_kgm2.iter().map(|v| v / 0.9).collect(),
        ),
        "thrust_scale" => ("scale", vec![0.9; model.n_thrusters()]),
        other => panic!("named {other}"),
    };
    let held = e.held.get(key).cloned().unwrap_or_default();
    for (k, want) in truth.iter().enumerate() {
        let got = e.params[key][k].as_f64().unwrap();
        let se = e.stderr[key][k].as_f64().unwrap();
        let is_held = held
            .as_array()
            .is_some_and(|h| h.iter().any(|i| i.as_u64() == Some(k as u64)));
        if is_held || se >= 1e6 {
            continue;
        }
        assert!(
            (got - want).abs() <= 3.0 * se,
            "{key}[{k}]: {got} +- {se}, truth {want}"
        );
    }
}
