//! Diagnoses the recordings given on the command line and prints the summary and the
//! candidate scores (development aid; `massid diagnose` is the user-facing command).
use massid_diagnose::{diagnose_recording, model, report, Settings};
use reference_f64::recording::Recording;
use reference_f64::satellite::Satellite;

fn main() {
    for f in std::env::args().skip(1) {
        let rec = Recording::read(std::path::Path::new(&f)).unwrap();
        let sat = Satellite::builtin(rec.satellite().unwrap_or("sph2")).unwrap();
        let t0 = std::time::Instant::now();
        let a = diagnose_recording(&rec, &sat, &Settings::default()).unwrap();
        println!(
            "== {f} ({:?}, {} predictions)",
            t0.elapsed(),
            model::PREDICTIONS.swap(0, std::sync::atomic::Ordering::Relaxed)
        );
        print!("{}", report::summary(&a));
        for sc in &a.scores {
            print!("[{} {} {:.0}] ", sc.round, sc.effect, sc.delta_bic);
        }
        println!();
        let stem = std::path::Path::new(&f)
            .file_stem()
            .unwrap()
            .to_string_lossy()
            .to_string();
        report::write_html(&std::path::Path::new("/tmp/E").join(stem), &a).unwrap();
    }
}
