//! The diagnosis of a planar craft whose yaw rate is motion-capture attitude
//! central-differenced, `(a_(k+1) - a_(k-1)) / 2 dt` (the sensor of open3's pl6): the noise is
//! read as differenced attitude over two samples, the prediction as the mean rate over those
//! two periods (`massid_diagnose::response`), and a nominal flight names nothing and leaves
//! nothing unexplained. Planted: the same flight judged with the noise read as a band-limited
//! gyro (the kind the lag-1 rule gave it) is reported `unexplained`; judged with the point
//! rate as the sensor's response, the residual stands above the noise.
//!
//! The flights: `massid_tests::mocap_flight` (the air-bearing craft, written independently
//! of the simulator).

use massid_diagnose::{diagnose_rate_recording, DiagnosisOutput, Settings};
use massid_tests::identification_mc::airbearing_model;
use massid_tests::mocap_flight::{
    central_differenced_csv as flight_csv, ATTITUDE_RAD, WHITE_RAD_S,
};
use reference_f64::rate_recording::RateRecording;

fn diagnose(csv: &str) -> DiagnosisOutput {
    let rec = RateRecording::from_reader(csv.as_bytes(), "central.csv").expect("recording");
    diagnose_rate_recording(&rec, &airbearing_model(), &Settings::default())
        .expect("diagnosis")
        .output
}

fn named(out: &DiagnosisOutput) -> Vec<&str> {
    out.effects.iter().map(|e| e.effect.as_str()).collect()
}

/// One test (the planted faults set process-wide overrides, which no other test in this
/// binary may see).
#[test]
fn central_differences_are_the_sensor_s_and_a_nominal_flight_names_nothing() {
    for seed in [1, 2] {
        let out = diagnose(&flight_csv(seed, 1.0));
        let noise = out.noise.as_ref().expect("noise");
        assert_eq!(noise.kind.name(), "differenced_attitude", "seed {seed}");
        assert_eq!(noise.difference_samples, Some(2), "seed {seed}");
        assert_eq!(
            noise.response.as_deref(),
            Some("central_mean"),
            "seed {seed}"
        );
        assert!(named(&out).is_empty(), "seed {seed}: {:?}", named(&out));
        assert!(
            out.unexplained.is_none(),
            "seed {seed}: {:?}",
            out.unexplained
        );
    }
    // The same kind of flight with the true Izz 20 % above the model's: named, as the inertia
    // or as what gives the same yaw rates with the inertia listed under `equivalent_to` (a
    // gyro scale), and nothing left unexplained.
    let out = diagnose(&flight_csv(3, 1.2));
    let lists_inertia = |e: &massid_diagnose::EffectReport| {
        e.effect == "inertia"
            || e.equivalent_to
                .iter()
                .any(|v| v.get("effect").and_then(|x| x.as_str()) == Some("inertia"))
    };
    assert!(
        out.effects.len() == 1 && lists_inertia(&out.effects[0]),
        "{:?}",
        named(&out)
    );
    assert!(out.unexplained.is_none(), "{:?}", out.unexplained);
    // The residual of the nominal model is the noise: over eight flights its RMS is the
    // true per-sample noise within 2 % (measured 0.3 %). Planted: the point rate as the
    // sensor's response leaves the mean's difference in it (4.3 %).
    let truth = (WHITE_RAD_S.powi(2) + 2.0 * (ATTITUDE_RAD / 0.08).powi(2)).sqrt();
    let mean_level = || {
        (1..=8)
            .map(|seed| diagnose(&flight_csv(seed, 1.0)).residual_rms_before[2] / truth)
            .sum::<f64>()
            / 8.0
    };
    let level = mean_level();
    assert!(
        (level - 1.0).abs() < 0.02,
        "residual RMS {level:.4} of the noise"
    );
    std::env::set_var(massid_diagnose::response::FORCE_POINT_ENV, "1");
    let point = mean_level();
    std::env::remove_var(massid_diagnose::response::FORCE_POINT_ENV);
    assert!(
        point - 1.0 > 0.02,
        "point response: residual RMS {point:.4} of the noise"
    );
    // Planted: the noise read as a band-limited gyro. Most of the same eight nominal flights
    // are then reported unexplained (measured: 6 of 8; 14 of 20 on held-out seeds).
    std::env::set_var(massid_diagnose::noise::FORCE_KIND_ENV, "band_limited");
    let flagged = (1..=8)
        .filter(|&seed| diagnose(&flight_csv(seed, 1.0)).unexplained.is_some())
        .count();
    std::env::remove_var(massid_diagnose::noise::FORCE_KIND_ENV);
    assert!(
        flagged >= 4,
        "read as a gyro's noise, {flagged} of 8 nominal flights reported unexplained"
    );
}
