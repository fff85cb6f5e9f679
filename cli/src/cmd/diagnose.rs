//! `massid diagnose`: explain why a recording and the nominal model disagree.
use std::path::PathBuf;

use anyhow::Context;
use massid_diagnose::{diagnose_recording, report, Settings};
use reference_f64::recording::Recording;
use reference_f64::satellite::Satellite;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// The recording (massid-recording/1 CSV).
    pub recording: PathBuf,
    /// Built-in satellite model (sph1..sph5); default: the recording's `satellite` metadata.
    #[arg(long, conflicts_with = "model")]
    pub satellite: Option<String>,
    /// Satellite model file (TOML) instead of a built-in one.
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// Write the massid-diagnosis/1 JSON here.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write an HTML report with SVG plots into this directory.
    #[arg(long)]
    pub report: Option<PathBuf>,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let rec = Recording::read(&args.recording)?;
    let sat = if let Some(m) = &args.model {
        // The one model format (either layout): the nominal model is its satellite.
        massid_sim::model_file::ModelFile::read(m)?.satellite
    } else {
        let name = args
            .satellite
            .clone()
            .or_else(|| rec.satellite().map(str::to_string))
            .with_context(|| {
                format!(
                    "{}: no `satellite` metadata; pass --satellite or --model",
                    args.recording.display()
                )
            })?;
        Satellite::builtin(&name)
            .with_context(|| format!("unknown satellite `{name}` (built-in: sph1..sph5)"))?
    };
    // Every output is checked before anything is computed or written: a refused output must
    // not leave another one half-written.
    if let Some(out) = &args.json {
        super::check_output(out, &[&args.recording])?;
    }
    if let Some(dir) = &args.report {
        super::check_output(&dir.join("report.html"), &[&args.recording])?;
    }
    // A diagnosis of a long recording takes tens of seconds: say that it is working (stderr,
    // drawn only on a terminal; indicatif hides it otherwise).
    let spinner = indicatif::ProgressBar::new_spinner();
    spinner.set_message(format!(
        "diagnosing {} ({} samples): locating, fitting and checking candidate effects",
        args.recording.display(),
        rec.samples.len()
    ));
    spinner.enable_steady_tick(std::time::Duration::from_millis(200));
    let analysis = diagnose_recording(&rec, &sat, &Settings::default());
    spinner.finish_and_clear();
    let analysis = analysis?;
    print!("{}", report::summary(&analysis));
    if let Some(out) = &args.json {
        let text = serde_json::to_string_pretty(&analysis.output)?;
        std::fs::write(out, text + "\n")
            .with_context(|| format!("{}: cannot write", out.display()))?;
    }
    if let Some(dir) = &args.report {
        report::write_html(dir, &analysis)
            .with_context(|| format!("{}: cannot write the report", dir.display()))?;
        println!("report: {}", dir.join("report.html").display());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_refused_output_leaves_nothing_written() {
        // The report would overwrite the input (the recording is DIR/report.html): refused
        // before the JSON is written (it used to write the JSON first, then refuse).
        let dir = std::env::temp_dir().join(format!("massid-diag-out-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let rec = dir.join("report.html");
        let good = "# format = massid-recording/1\n# satellite = sph2\n# sample_rate_hz = 1000\ntime_ms,gyro_x,gyro_y,gyro_z,accel_x,accel_y,accel_z,thrusters\n0,2077,2070,2058,2048,2048,2048,0\n1,2077,2070,2058,2048,2048,2048,0\n";
        std::fs::write(&rec, good).unwrap();
        let json = dir.join("out.json");
        let args = Args {
            recording: rec.clone(),
            satellite: None,
            model: None,
            json: Some(json.clone()),
            report: Some(dir.clone()),
        };
        let e = run(args).expect_err("overwriting the input is refused");
        assert!(e.to_string().contains("refusing to overwrite"), "{e}");
        assert_eq!(
            std::fs::read_to_string(&rec).unwrap(),
            good,
            "the input is untouched"
        );
        assert!(!json.exists(), "nothing else was written");
        std::fs::remove_dir_all(&dir).ok();
    }
}
