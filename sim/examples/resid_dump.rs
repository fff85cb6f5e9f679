//! Exploratory: dump measured and predicted rates of one open recording (decimated).
use massid_sim::{predict, PredictOptions, Truth};
use reference_f64::recording::Recording;
use reference_f64::satellite::Satellite;

fn main() {
    let p = std::path::PathBuf::from(std::env::args().nth(1).unwrap());
    let every: usize = std::env::args().nth(2).map(|s| s.parse().unwrap()).unwrap_or(50);
    let nominal = std::env::args().nth(3).is_some();
    let rec = Recording::read(&p).unwrap();
    let truth = Truth::read(&Truth::path_for(&p)).unwrap();
    let sat = Satellite::builtin(&truth.satellite).unwrap();
    let t: Vec<u64> = rec.samples.iter().map(|s| s.time_ms).collect();
    let w: Vec<u16> = rec.samples.iter().map(|s| s.thrusters).collect();
    let eff = if nominal { vec![] } else { truth.effects.clone() };
    let pred = predict(&sat, &eff, &t, &w, [0.0; 3], PredictOptions::default());
    for k in (0..t.len()).step_by(every) {
        let m: [f64; 3] = std::array::from_fn(|a| sat.gyro_counts_to_rad_s(a, rec.samples[k].gyro[a] as f64));
        println!("{} {} meas {:8.4} {:8.4} {:8.4} pred {:8.4} {:8.4} {:8.4}", t[k], w[k], m[0], m[1], m[2], pred.gyro_rad_s[k][0], pred.gyro_rad_s[k][1], pred.gyro_rad_s[k][2]);
    }
}
