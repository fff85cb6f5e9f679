//! Exploratory: residual of the prediction against every open recording.
use massid_sim::{predict, PredictOptions, Truth};
use reference_f64::recording::Recording;
use reference_f64::satellite::Satellite;

fn main() {
    let dir = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/open");
    let mut names: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().path()).filter(|p| p.extension().map(|e| e == "csv").unwrap_or(false)).collect();
    names.sort();
    let step: f64 = std::env::args().nth(1).map(|s| s.parse().unwrap()).unwrap_or(1.0);
    let shift: i64 = std::env::args().nth(2).map(|s| s.parse().unwrap()).unwrap_or(0);
    for p in names {
        let rec = Recording::read(&p).unwrap();
        let truth = Truth::read(&Truth::path_for(&p)).unwrap();
        let sat = Satellite::builtin(&truth.satellite).unwrap();
        let t: Vec<u64> = rec.samples.iter().map(|s| s.time_ms).collect();
        let w: Vec<u16> = rec.samples.iter().map(|s| s.thrusters).collect();
        let meas: Vec<[f64; 3]> = rec.samples.iter().map(|s| std::array::from_fn(|a| sat.gyro_counts_to_rad_s(a, s.gyro[a] as f64))).collect();
        let mut effects = truth.effects.clone();
        if let Ok(f) = std::env::var("FRAC") {
            let f: f64 = f.parse().unwrap();
            for e in effects.iter_mut() {
                if e.name() == "fuel_slosh" {
                    *e = e.with_params(&[("inertia_fraction[0]", f), ("inertia_fraction[1]", f), ("inertia_fraction[2]", f)]).unwrap();
                }
            }
        }
        let pred = predict(&sat, &effects, &t, &w, [0.0; 3], PredictOptions { max_step_ms: step });
        let pred0 = predict(&sat, &[], &t, &w, [0.0; 3], PredictOptions { max_step_ms: step });
        let n = t.len();
        let mut rms = [0.0; 3];
        let mut rms0 = [0.0; 3];
        let mut mean = [0.0; 3];
        for k in 0..n {
            let kk = (k as i64 + shift).clamp(0, n as i64 - 1) as usize;
            for a in 0..3 {
                let r = meas[kk][a] - pred.gyro_rad_s[k][a];
                rms[a] += r * r;
                mean[a] += r;
                let r0 = meas[kk][a] - pred0.gyro_rad_s[k][a];
                rms0[a] += r0 * r0;
            }
        }
        let f = |x: [f64; 3]| x.map(|v| format!("{:.5}", (v / n as f64).sqrt())).join(" ");
        println!("{:40} truth-model rms {}   nominal rms {}  mean {:?}", p.file_name().unwrap().to_string_lossy(), f(rms), f(rms0), mean.map(|m| (m / n as f64 * 1e4).round() / 1e4));
    }
}
