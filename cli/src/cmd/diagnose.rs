//! `massid diagnose`: explain why a recording and the nominal model disagree.
use std::path::PathBuf;

use anyhow::Context;
use massid_diagnose::{
    diagnose_rate_recording, diagnose_recording, holdout, model, report, Settings,
};
use reference_f64::rate_recording::{format_version, RateRecording};
use reference_f64::recording::Recording;
use reference_f64::satellite::Satellite;

#[derive(clap::Args, Debug)]
#[command(allow_negative_numbers = true)]
pub struct Args {
    /// The recording (massid-recording/1 or /2 CSV; `massid import` makes /2 from other logs).
    pub recording: PathBuf,
    /// Built-in satellite model (sph1..sph5); default: the recording's `satellite` metadata.
    #[arg(long, conflicts_with = "model")]
    pub satellite: Option<String>,
    /// Satellite model file (TOML), or a built-in name (sph1..sph5), instead of --satellite.
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// Write the massid-diagnosis/1 JSON here (`-`: stdout, the summary then goes to stderr).
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write an HTML report with SVG plots into this directory.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Replace existing output files (--json, the report's files).
    #[arg(long)]
    pub force: bool,
    /// Also validate without truth: diagnose only the first FRACTION of the samples (e.g.
    /// 0.5), predict the rest with the nominal and with the fitted model, and print both
    /// residuals on the part the fit never saw.
    #[arg(long, value_name = "FRACTION")]
    pub holdout: Option<f64>,
    /// Compare the model with the craft over this many seconds: the body rate is
    /// re-estimated at the start of every stretch (default: open loop over the whole
    /// recording, re-anchored only after telemetry gaps). For long closed-loop flights of a
    /// craft whose model is off, e.g. 10.
    #[arg(long, value_name = "SECONDS")]
    pub horizon: Option<f64>,
}

/// The recording in either format, as the diagnosis reads it.
enum Input {
    Counts(Recording),
    Rates(RateRecording),
}

impl Input {
    fn satellite(&self) -> Option<&str> {
        match self {
            Input::Counts(r) => r.satellite(),
            Input::Rates(r) => r.satellite(),
        }
    }
    fn len(&self) -> usize {
        match self {
            Input::Counts(r) => r.samples.len(),
            Input::Rates(r) => r.time_ms.len(),
        }
    }
}

pub fn run(args: Args) -> anyhow::Result<()> {
    if let Some(h) = args.horizon {
        anyhow::ensure!(
            h.is_finite() && h > 0.0,
            "--horizon {h}: must be a positive number of seconds"
        );
    }
    if let Some(f) = args.holdout {
        anyhow::ensure!(
            f > 0.0 && f < 1.0,
            "--holdout {f}: the fraction fitted must be strictly between 0 and 1"
        );
    }
    // Every output is checked before anything is read, computed or written: a refused
    // output must not leave another one half-written, nor come after a long analysis.
    let mut inputs: Vec<&std::path::Path> = vec![&args.recording];
    if let Some(m) = &args.model {
        inputs.push(m);
    }
    if let Some(out) = &args.json {
        super::check_output(out, &inputs, args.force)?;
    }
    if let Some(dir) = &args.report {
        if super::is_stdout(dir) {
            anyhow::bail!("--report -: the report is a directory of files, not a stream");
        }
        if dir.exists() && !dir.is_dir() {
            anyhow::bail!(
                "{}: exists and is not a directory (--report names a directory)",
                dir.display()
            );
        }
        super::check_output(&dir.join("report.html"), &inputs, args.force)?;
    }
    let rec = match format_version(&args.recording)? {
        2 => Input::Rates(RateRecording::read(&args.recording)?),
        _ => Input::Counts(Recording::read(&args.recording)?),
    };
    let sat = if let Some(m) = &args.model {
        // The one model format (either layout) or a built-in name: the nominal model is its
        // satellite.
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
    let checked = match &rec {
        Input::Counts(r) => super::inputs::Rec::V1(r),
        Input::Rates(r) => super::inputs::Rec::V2(r),
    };
    super::inputs::check_recording(
        checked,
        &args.recording,
        &sat,
        &super::inputs::Needs::DIAGNOSE,
    )?;
    // A diagnosis of a long recording takes tens of seconds: say that it is working (stderr,
    // drawn only on a terminal; indicatif hides it otherwise).
    let spinner = indicatif::ProgressBar::new_spinner();
    spinner.set_message(format!(
        "diagnosing {} ({} samples): locating, fitting and checking candidate effects",
        args.recording.display(),
        rec.len()
    ));
    spinner.enable_steady_tick(std::time::Duration::from_millis(200));
    let settings = Settings {
        horizon_s: args.horizon,
        ..Settings::default()
    };
    let analysis = match &rec {
        Input::Counts(r) => diagnose_recording(r, &sat, &settings),
        Input::Rates(r) => diagnose_rate_recording(r, &sat, &settings),
    };
    let holdout = match (args.holdout, &analysis) {
        (Some(fraction), Ok(a)) => {
            spinner.set_message(format!(
                "held-out check: diagnosing the first {:.0} % and predicting the rest",
                fraction * 100.0
            ));
            let plant = model::Plant::new(&sat);
            holdout::fit_then_predict(
                &a.series,
                &plant,
                &a.output.recording,
                &sat.name,
                &settings,
                fraction,
            )
        }
        _ => None,
    };
    spinner.finish_and_clear();
    let analysis = analysis?;
    // With `--json -` stdout carries the JSON alone; the summary goes to stderr.
    let json_to_stdout = args.json.as_deref().is_some_and(super::is_stdout);
    let mut text = report::summary(&analysis);
    if let Some(f) = args.holdout {
        match &holdout {
            Some(h) => text.push_str(&report::holdout_summary(h)),
            None => text.push_str(&format!(
                "held-out check ({:.0} % fitted): not possible (a part is empty or cannot be predicted)\n",
                f * 100.0
            )),
        }
    }
    if let Some(dir) = &args.report {
        report::write_html(dir, &analysis)
            .with_context(|| format!("{}: cannot write the report", dir.display()))?;
        text.push_str(&format!("report: {}\n", dir.join("report.html").display()));
    }
    if json_to_stdout {
        eprint!("{text}");
    } else {
        super::mix::emit(&text)?;
    }
    if let Some(out) = &args.json {
        let json = serde_json::to_string_pretty(&analysis.output)? + "\n";
        super::write_output(out, &json)?;
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
            holdout: None,
            horizon: None,
            force: false,
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
