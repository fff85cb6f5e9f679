//! Prints the reproduction table of the open recordings (the crate README's table):
//! `cargo run --release -p massid-sim --example reproduce_open`
use massid_sim::reproduce::reproduce;
use massid_sim::Truth;
use reference_f64::recording::Recording;

fn main() {
    let dir = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/open");
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "csv"))
        .collect();
    files.sort();
    println!("| file | samples | nominal rms (x y z) | reproduced rms (x y z) | noise floor (x y z) | ratio max | fitted |");
    println!("|---|---|---|---|---|---|---|");
    for p in files {
        let rec = Recording::read(&p).unwrap();
        let truth = Truth::read(&Truth::path_for(&p)).unwrap();
        let r = reproduce(&rec, &truth).unwrap();
        let f = |x: [f64; 3]| x.map(|v| format!("{:.5}", v)).join(" ");
        let ratio = (0..3)
            .map(|a| r.residual_rms[a] / r.noise_floor[a])
            .fold(0.0, f64::max);
        println!(
            "| {} | {} | {} | {} | {} | {:.3} | {} |",
            p.file_name().unwrap().to_string_lossy(),
            r.samples,
            f(r.nominal_rms),
            f(r.residual_rms),
            f(r.noise_floor),
            ratio,
            r.fitted.join("; ")
        );
    }
}
