//! Exploratory: per-edge sin/cos fit of the o05 ringing.
use massid_sim::{predict, PredictOptions};
use reference_f64::recording::Recording;
use reference_f64::satellite::Satellite;

fn main() {
    let p = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/open/o05_gyro_ringing_100hz_rga12.csv");
    let rec = Recording::read(&p).unwrap();
    let sat = Satellite::builtin("sph2").unwrap();
    let t: Vec<u64> = rec.samples.iter().map(|s| s.time_ms).collect();
    let w: Vec<u16> = rec.samples.iter().map(|s| s.thrusters).collect();
    let pred = predict(&sat, &[], &t, &w, [0.0; 3], PredictOptions::default());
    let f: f64 = std::env::args().nth(1).map(|s| s.parse().unwrap()).unwrap_or(338.0);
    let decay: f64 = std::env::args().nth(2).map(|s| s.parse().unwrap()).unwrap_or(30.0);
    let lead: f64 = std::env::args().nth(3).map(|s| s.parse().unwrap()).unwrap_or(0.0);
    let mut edges: Vec<f64> = pred.edges.iter().map(|e| e.t_ms - lead).collect();
    edges.dedup();
    let mut r: Vec<[f64; 3]> = (0..t.len()).map(|k| std::array::from_fn(|a| sat.gyro_counts_to_rad_s(a, rec.samples[k].gyro[a] as f64) - pred.gyro_rad_s[k][a])).collect();
    let before: Vec<f64> = (0..3).map(|a| (r.iter().map(|x| x[a] * x[a]).sum::<f64>() / t.len() as f64).sqrt()).collect();
    let mut amps = vec![];
    for &te in &edges {
        let idx: Vec<usize> = (0..t.len()).filter(|&k| { let d = t[k] as f64 - te; d >= 0.0 && d < 6.0 * decay }).collect();
        for a in 0..3 {
            let (mut ss, mut sc, mut cc, mut rs, mut rc) = (0.0, 0.0, 0.0, 0.0, 0.0);
            let basis = |k: usize| { let dt = (t[k] as f64 - te) * 1e-3; let env = (-dt * 1e3 / decay).exp(); let ph = 2.0 * std::f64::consts::PI * f * dt; (env * ph.sin(), env * ph.cos()) };
            for &k in &idx { let (bs, bc) = basis(k); ss += bs * bs; sc += bs * bc; cc += bc * bc; rs += r[k][a] * bs; rc += r[k][a] * bc; }
            let det = ss * cc - sc * sc;
            let (a_s, a_c) = ((rs * cc - rc * sc) / det, (rc * ss - rs * sc) / det);
            amps.push((a_s * a_s + a_c * a_c).sqrt());
            for &k in &idx { let (bs, bc) = basis(k); r[k][a] -= a_s * bs + a_c * bc; }
        }
    }
    let after: Vec<f64> = (0..3).map(|a| (r.iter().map(|x| x[a] * x[a]).sum::<f64>() / t.len() as f64).sqrt()).collect();
    let mean_amp = amps.iter().sum::<f64>() / amps.len() as f64;
    println!("edges {} before {:?} after {:?} mean amplitude {:.5} rad/s", edges.len(), before, after, mean_amp);
}
