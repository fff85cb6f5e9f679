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
    /// With --out: any number of recordings and folders (a folder: its `*.csv` files).
    #[arg(value_name = "RECORDING", required_unless_present = "list")]
    pub recordings: Vec<PathBuf>,
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
    /// Replace existing output files (--json, the report's files; with --out: diagnose again
    /// the recordings whose JSON is already there).
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
    /// Many recordings: diagnose every RECORDING (and every line of --list) into this
    /// directory, one JSON per recording (`NAME.json`, the bytes `--json` writes) plus
    /// `summary.jsonl` and `summary.csv` (one row per recording, sorted by file). Resumable:
    /// a recording whose JSON is there is skipped (unless --force) and the summary is
    /// rebuilt from the JSONs present.
    #[arg(long, value_name = "DIR", conflicts_with_all = ["json", "report", "holdout", "summary_row"])]
    pub out: Option<PathBuf>,
    /// With --out: a file naming one recording per line (blank lines and `#` comments
    /// skipped; relative paths from the current directory).
    #[arg(long, value_name = "FILE", requires = "out")]
    pub list: Option<PathBuf>,
    /// With --out: diagnose this many recordings at once (default: every core).
    #[arg(long, value_name = "N", requires = "out")]
    pub jobs: Option<usize>,
    /// Print the recording's summary row (one JSON line, the row `--out` puts in
    /// `summary.jsonl`) on stdout, the text summary going to stderr; a recording that
    /// cannot be diagnosed prints an error row and exits non-zero. The unit an external
    /// engine maps over (`scripts/batch_ray.py`).
    #[arg(long)]
    pub summary_row: bool,
}

/// What the diagnosis of one recording depends on besides the recording: the options shared
/// by every recording of a batch.
#[derive(Clone, Debug, Default)]
pub struct Options {
    pub satellite: Option<String>,
    pub model: Option<PathBuf>,
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
    let options = Options {
        satellite: args.satellite.clone(),
        model: args.model.clone(),
        horizon: args.horizon,
    };
    if let Some(out) = &args.out {
        return super::batch::run(super::batch::Batch {
            recordings: args.recordings.clone(),
            list: args.list.clone(),
            out: out.clone(),
            jobs: args.jobs,
            force: args.force,
            options,
        });
    }
    let recording = match args.recordings.as_slice() {
        [one] => one.clone(),
        _ => anyhow::bail!(
            "{} recordings given: one recording, or several with --out DIR (one JSON each plus a summary)",
            args.recordings.len()
        ),
    };
    if recording.is_dir() {
        anyhow::bail!(
            "{}: is a directory; diagnose a folder of recordings with --out DIR",
            recording.display()
        );
    }
    if args.summary_row && args.json.as_deref().is_some_and(super::is_stdout) {
        anyhow::bail!(
            "--summary-row and --json -: both would be on stdout; write the JSON to a file"
        );
    }
    // Every output is checked before anything is read, computed or written: a refused
    // output must not leave another one half-written, nor come after a long analysis.
    let mut inputs: Vec<&std::path::Path> = vec![&recording];
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
    let started = std::time::Instant::now();
    let diagnosed = match diagnose_file(&recording, &options, true) {
        Ok(d) => d,
        Err(e) => {
            if args.summary_row {
                let row = super::batch::Row::error(
                    &recording,
                    &format!("{e:#}"),
                    Some(started.elapsed().as_secs_f64()),
                );
                super::mix::emit(&row.line())?;
            }
            return Err(e);
        }
    };
    let holdout = args.holdout.and_then(|fraction| {
        let spinner = spinner(format!(
            "held-out check: diagnosing the first {:.0} % and predicting the rest",
            fraction * 100.0
        ));
        let plant = model::Plant::new(&diagnosed.sat);
        let h = holdout::fit_then_predict(
            &diagnosed.analysis.series,
            &plant,
            &diagnosed.analysis.output.recording,
            &diagnosed.sat.name,
            &diagnosed.settings,
            fraction,
        );
        spinner.finish_and_clear();
        h
    });
    let analysis = &diagnosed.analysis;
    let json = to_json(analysis)?;
    // With `--json -` or `--summary-row` stdout carries the JSON (or the row) alone; the
    // summary goes to stderr.
    let json_to_stdout = args.json.as_deref().is_some_and(super::is_stdout);
    let mut text = report::summary(analysis);
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
        report::write_html(dir, analysis)
            .with_context(|| format!("{}: cannot write the report", dir.display()))?;
        text.push_str(&format!("report: {}\n", dir.join("report.html").display()));
    }
    if json_to_stdout || args.summary_row {
        eprint!("{text}");
    } else {
        super::mix::emit(&text)?;
    }
    if let Some(out) = &args.json {
        super::write_output(out, &json)?;
    }
    if args.summary_row {
        let row =
            super::batch::Row::from_json(&recording, &json, Some(started.elapsed().as_secs_f64()))?;
        super::mix::emit(&row.line())?;
    }
    Ok(())
}

/// One recording diagnosed, with what it was diagnosed against.
pub struct Diagnosed {
    pub analysis: massid_diagnose::Analysis,
    pub sat: Satellite,
    pub settings: Settings,
}

/// The massid-diagnosis/1 document exactly as `--json` writes it (pretty, one final newline).
pub fn to_json(analysis: &massid_diagnose::Analysis) -> anyhow::Result<String> {
    Ok(serde_json::to_string_pretty(&analysis.output)? + "\n")
}

/// A spinner on stderr (drawn only on a terminal; indicatif hides it otherwise).
fn spinner(message: String) -> indicatif::ProgressBar {
    let spinner = indicatif::ProgressBar::new_spinner();
    spinner.set_message(message);
    spinner.enable_steady_tick(std::time::Duration::from_millis(200));
    spinner
}

/// The per-recording job, the one function both `massid diagnose FILE` and the batch
/// (`--out`) run: reads the recording (either format), takes the model (`--model`,
/// `--satellite` or the recording's metadata), checks the recording against it and
/// diagnoses it. `show_spinner`: say on a terminal that it is working (a single recording;
/// the batch draws its own progress).
pub fn diagnose_file(
    recording: &std::path::Path,
    options: &Options,
    show_spinner: bool,
) -> anyhow::Result<Diagnosed> {
    let rec = match format_version(recording)? {
        2 => Input::Rates(RateRecording::read(recording)?),
        _ => Input::Counts(Recording::read(recording)?),
    };
    let sat = if let Some(m) = &options.model {
        // The one model format (either layout) or a built-in name: the nominal model is its
        // satellite.
        massid_sim::model_file::ModelFile::read(m)?.satellite
    } else {
        let name = options
            .satellite
            .clone()
            .or_else(|| rec.satellite().map(str::to_string))
            .with_context(|| {
                format!(
                    "{}: no `satellite` metadata; pass --satellite or --model",
                    recording.display()
                )
            })?;
        Satellite::builtin(&name)
            .with_context(|| format!("unknown satellite `{name}` (built-in: sph1..sph5)"))?
    };
    let checked = match &rec {
        Input::Counts(r) => super::inputs::Rec::V1(r),
        Input::Rates(r) => super::inputs::Rec::V2(r),
    };
    super::inputs::check_recording(checked, recording, &sat, &super::inputs::Needs::DIAGNOSE)?;
    // A diagnosis of a long recording takes tens of seconds: say that it is working.
    let spinner = show_spinner.then(|| {
        spinner(format!(
            "diagnosing {} ({} samples): locating, fitting and checking candidate effects",
            recording.display(),
            rec.len()
        ))
    });
    let settings = Settings {
        horizon_s: options.horizon,
        ..Settings::default()
    };
    let analysis = match &rec {
        Input::Counts(r) => diagnose_recording(r, &sat, &settings),
        Input::Rates(r) => diagnose_rate_recording(r, &sat, &settings),
    };
    if let Some(s) = spinner {
        s.finish_and_clear();
    }
    Ok(Diagnosed {
        analysis: analysis?,
        sat,
        settings,
    })
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
            recordings: vec![rec.clone()],
            satellite: None,
            model: None,
            json: Some(json.clone()),
            report: Some(dir.clone()),
            holdout: None,
            horizon: None,
            force: false,
            out: None,
            list: None,
            jobs: None,
            summary_row: false,
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
