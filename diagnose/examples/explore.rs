use massid_diagnose::{diagnosis, model, output::DataIssues, select::Settings, series::Series};
use reference_f64::satellite::Satellite;

fn load(path: &str, sat: &Satellite) -> Series {
    let text = std::fs::read_to_string(path).unwrap();
    let mut t = vec![];
    let mut g = vec![];
    let mut w = vec![];
    let mut rate = None;
    for line in text.lines() {
        if line.starts_with('#') {
            if line.contains("sample_rate_hz") {
                rate = line.split('=').nth(1).map(|s| s.trim().parse::<f64>().unwrap());
            }
            continue;
        }
        if line.starts_with("time") {
            continue;
        }
        let f: Vec<i64> = line.split(',').map(|s| s.parse().unwrap()).collect();
        if let Some(&last) = t.last() {
            if f[0] <= last {
                continue;
            }
        }
        t.push(f[0]);
        g.push([f[1] as i32, f[2] as i32, f[3] as i32]);
        w.push(f[7] as u16);
    }
    Series::from_counts(&t, &g, &w, sat.gyro_bias_counts, sat.gyro_counts_per_rad_s, rate).unwrap()
}

fn main() {
    let sat = Satellite::builtin("sph2").unwrap();
    let plant = model::Plant::new(&sat);
    for f in std::env::args().skip(1) {
        let s = load(&f, &sat);
        let t0 = std::time::Instant::now();
        let a = diagnosis::diagnose(&s, &plant, &f, "sph2", DataIssues::default(), &Settings::default());
        println!("== {f} ({:?}) noise var {:?} lr {:?} rho1 {:?}", t0.elapsed(), a.noise.var, a.noise.long_run_var, a.noise.rho1);
        println!("rms before {:?} after {:?}", a.output.residual_rms_before, a.output.residual_rms_after);
        for sc in &a.scores {
            print!("[{} {} {:.0}] ", sc.round, sc.effect, sc.delta_bic);
        }
        println!();
        for e in &a.output.effects {
            println!("  {} {} se {} dbic {:.0}", e.effect, serde_json::to_string(&e.params).unwrap(), serde_json::to_string(&e.stderr).unwrap(), e.delta_bic);
        }
    }
}
