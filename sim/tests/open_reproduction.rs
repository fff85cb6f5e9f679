//! Two independent simulators agree: fed the commands of each open recording with the
//! effects of its truth file (fitting only what the truth leaves open, see
//! `massid_sim::reproduce`), this simulator reproduces the recorded body rates to within
//! the gyro noise. The noise floor is measured on each recording's own rest period.
use massid_sim::reproduce::reproduce;
use massid_sim::Truth;
use reference_f64::recording::Recording;
use std::path::PathBuf;

fn open_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/open")
}

/// A residual within 10% of the noise floor: the floor estimate from 1000 rest samples has
/// a 2-3% spread (7% for the 100 Hz file's 100 samples); the smallest effect in the open
/// data (6 ms latency, or o05's ringing) leaves more than 20% above it when not modelled.
const WITHIN_NOISE: f64 = 1.10;

#[test]
fn every_open_recording_is_reproduced_to_the_noise_floor() {
    let mut files: Vec<PathBuf> = std::fs::read_dir(open_dir())
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "csv"))
        .collect();
    files.sort();
    assert_eq!(files.len(), 9);
    for p in files {
        let rec = Recording::read(&p).unwrap();
        let truth = Truth::read(&Truth::path_for(&p)).unwrap();
        let r = reproduce(&rec, &truth).unwrap();
        let name = p.file_name().unwrap().to_string_lossy().into_owned();
        for a in 0..3 {
            assert!(
                r.residual_rms[a] <= WITHIN_NOISE * r.noise_floor[a],
                "{name} axis {a}: residual {:.5} rad/s vs noise {:.5} ({:?})",
                r.residual_rms[a],
                r.noise_floor[a],
                r.fitted
            );
        }
        // Where the truth has a dynamic effect, the nominal model alone is visibly worse.
        if !truth.effects.is_empty() {
            let worst = (0..3)
                .map(|a| r.nominal_rms[a] / r.noise_floor[a])
                .fold(0.0, f64::max);
            assert!(
                worst > 1.2,
                "{name}: the nominal model already fits ({worst:.3})"
            );
        }
    }
}

#[test]
fn the_fitted_slosh_coupling_is_the_generators_three_percent() {
    let p = open_dir().join("o04_fuel_slosh_rga12.csv");
    let r = reproduce(
        &Recording::read(&p).unwrap(),
        &Truth::read(&Truth::path_for(&p)).unwrap(),
    )
    .unwrap();
    let line = r
        .fitted
        .iter()
        .find(|f| f.starts_with("slosh liquid inertia fraction"))
        .unwrap();
    let f: f64 = line.rsplit(' ').next().unwrap().parse().unwrap();
    // The open data's README: "fluid inertia 3% per axis".
    assert!((f - 0.03).abs() < 0.002, "{line}");
}

#[test]
fn accelerometer_agrees_with_the_open_data_over_every_firing() {
    use massid_sim::{predict, PredictOptions};
    use reference_f64::satellite::Satellite;
    for name in [
        "o01_nominal_rga12.csv",
        "o08_com_offset_rga12.csv",
        "o06_thrust_scale_combo.csv",
    ] {
        let p = open_dir().join(name);
        let rec = Recording::read(&p).unwrap();
        let truth = Truth::read(&Truth::path_for(&p)).unwrap();
        let sat = Satellite::builtin(&truth.satellite).unwrap();
        let t: Vec<u64> = rec.samples.iter().map(|s| s.time_ms).collect();
        let w: Vec<u16> = rec.samples.iter().map(|s| s.thrusters).collect();
        let pred = predict(
            &sat,
            &truth.effects,
            &t,
            &w,
            [0.0; 3],
            PredictOptions::default(),
        );
        // Mean over 1 s windows (the noise of a 1000-sample mean is about 0.06 counts).
        let mut compared = 0;
        for start in (1000..t.len().saturating_sub(1000)).step_by(1000) {
            for a in 0..3 {
                let recorded: f64 = rec.samples[start..start + 1000]
                    .iter()
                    .map(|s| s.accel[a] as f64)
                    .sum::<f64>()
                    / 1000.0;
                let predicted: f64 = pred.specific_force[start..start + 1000]
                    .iter()
                    .map(|f| sat.accel_bias_counts[a] + f[a] / sat.accel_m_s2_per_count)
                    .sum::<f64>()
                    / 1000.0;
                assert!(
                    (recorded - predicted).abs() < 0.3,
                    "{name} {start} ms axis {a}: {recorded:.3} vs {predicted:.3} counts"
                );
                compared += 1;
            }
        }
        assert!(compared >= 75);
    }
}
