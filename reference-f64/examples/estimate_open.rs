//! Runs the offline and online pipelines over an open recording and prints the estimate
//! next to the model: `cargo run --release -p reference-f64 --example estimate_open -- FILE.csv [sphN]`.
use reference_f64::pipeline::{estimate_offline, estimate_online, PipelineConfig};
use reference_f64::recording::Recording;
use reference_f64::satellite::Satellite;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let Some(path) = args.get(1) else {
        eprintln!("usage: estimate_open FILE.csv [sphN]");
        std::process::exit(2);
    };
    let rec = match Recording::read(std::path::Path::new(path)) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(1);
        }
    };
    let name = args
        .get(2)
        .cloned()
        .or_else(|| rec.satellite().map(str::to_string))
        .unwrap_or("sph2".into());
    let sat = if let Some(model) = name.strip_suffix(".toml").map(|_| name.clone()) {
        match Satellite::from_toml_file(std::path::Path::new(&model)) {
            Ok(s) => s,
            Err(e) => {
                eprintln!("{e}");
                std::process::exit(1);
            }
        }
    } else if let Some(s) = Satellite::builtin(&name) {
        s
    } else {
        eprintln!("unknown satellite {name}");
        std::process::exit(1);
    };
    let cfg = PipelineConfig {
        keep_history: false,
        ..PipelineConfig::default()
    };
    if std::env::var("UNFILTERED").is_ok() {
        unfiltered_experiment(&rec, &sat);
    }
    for (label, est) in [
        ("offline", estimate_offline(&rec, &sat, &cfg)),
        ("online", estimate_online(&rec, &sat, &cfg)),
    ] {
        println!(
            "== {label}: status {} updates {} unobservable {:?}",
            est.status, est.updates, est.unobservable
        );
        println!(
            "com_offset_mm   {:?} +- {:?}",
            est.com_offset_mm, est.com_offset_stderr_mm
        );
        println!("batch_all com   {:?}", est.batch_all_com_offset_mm);
        println!(
            "inertia         {:?} +- {:?}",
            est.inertia_kgm2, est.inertia_stderr_kgm2
        );
        println!("batch_all inert {:?}", est.batch_all_inertia_kgm2);
        println!("model inertia   {:?}", sat.inertia_kgm2);
        let rel: Vec<f64> = (0..3)
            .map(|j| est.inertia_kgm2[j] / sat.inertia_kgm2[j] - 1.0)
            .collect();
        println!(
            "principal rel err {:?}  variance factor {:?}",
            rel, est.variance_factor
        );
        println!(
            "ROW | {} | {label} | {:+.2} {:+.2} {:+.2} | {:+.3} {:+.3} {:+.3} | {} |",
            rec.source.rsplit('/').next().unwrap_or(""),
            rel[0] * 100.0,
            rel[1] * 100.0,
            rel[2] * 100.0,
            est.com_offset_mm[0],
            est.com_offset_mm[1],
            est.com_offset_mm[2],
            est.status
        );
    }
}

#[allow(dead_code)]
fn unfiltered_experiment(rec: &Recording, sat: &Satellite) {
    let cfg = PipelineConfig {
        keep_history: false,
        ..PipelineConfig::default()
    };
    let rates = reference_f64::preprocess::uniform_rates(rec, sat);
    let est = reference_f64::pipeline::estimate_from_rates(&rates, sat, &cfg);
    let rel: Vec<f64> = (0..3)
        .map(|j| est.inertia_kgm2[j] / sat.inertia_kgm2[j] - 1.0)
        .collect();
    println!(
        "== unfiltered: com {:?} principal rel err {:?}",
        est.com_offset_mm, rel
    );
}
