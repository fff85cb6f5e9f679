//! `massid diagnose`: explain why a recording and the nominal model disagree.
//!
//! Also the per-recording job every way of diagnosing many recordings runs: [`diagnose_file`]
//! (one recording diagnosed), [`to_json`] (its massid-diagnosis/1 text) and [`Row`] (its
//! summary row, built from that text alone, or the error row). `massid diagnose FILE
//! --summary-row`, the batch (`cmd::batch`, `--out DIR`) and an external engine mapping that
//! command over files (`scripts/batch_ray.py`) so give the same rows. This module knows
//! nothing of the batch: the choice between one recording and many is the command
//! dispatch's (`cmd::run_diagnose`).
use std::path::{Path, PathBuf};

use anyhow::{bail, Context};
use massid_diagnose::{
    diagnose_rate_recording, diagnose_recording, holdout, model, report, Settings,
};
use reference_f64::rate_recording::{format_version, RateRecording};
use reference_f64::recording::Recording;
use reference_f64::satellite::Satellite;
use serde::{Deserialize, Serialize};
use serde_json::Value;

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
    /// directory, one JSON per recording (`KEY.json`, KEY its path below the folder holding
    /// every recording, e.g. `a/flight.json`; the bytes `--json` writes) plus
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

impl Args {
    /// The options every recording is diagnosed with, checked (`--horizon`, `--holdout`).
    pub fn options(&self) -> anyhow::Result<Options> {
        if let Some(h) = self.horizon {
            anyhow::ensure!(
                h.is_finite() && h > 0.0,
                "--horizon {h}: must be a positive number of seconds"
            );
        }
        if let Some(f) = self.holdout {
            anyhow::ensure!(
                f > 0.0 && f < 1.0,
                "--holdout {f}: the fraction fitted must be strictly between 0 and 1"
            );
        }
        Ok(Options {
            satellite: self.satellite.clone(),
            model: self.model.clone(),
            horizon: self.horizon,
        })
    }
}

/// `massid diagnose RECORDING`: one recording (many, `--out DIR`, are the batch's; the
/// command dispatch `cmd::run_diagnose` sends them there).
///
/// With `--summary-row` every failure, a refused option or output included, still prints its
/// error row (the row names the first recording given): an engine mapping the job over
/// recordings gets one row per job whatever happened.
pub fn run(args: Args) -> anyhow::Result<()> {
    let started = std::time::Instant::now();
    let result = run_one(&args, started);
    if let (Err(e), true) = (&result, args.summary_row) {
        let file = args
            .recordings
            .first()
            .cloned()
            .unwrap_or_else(|| std::path::PathBuf::from("-"));
        let row = Row::error(
            &file,
            &format!("{e:#}"),
            Some(started.elapsed().as_secs_f64()),
        );
        super::mix::emit(&row.line())?;
    }
    result
}

fn run_one(args: &Args, started: std::time::Instant) -> anyhow::Result<()> {
    let options = args.options()?;
    if let Some(out) = &args.out {
        bail!(
            "--out {}: many recordings are diagnosed by the batch, not here",
            out.display()
        );
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
    let diagnosed = diagnose_file(&recording, &options, true)?;
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
        let row = Row::from_json(&recording, &json, Some(started.elapsed().as_secs_f64()))?;
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

/// One recording's line of the summary (`summary.jsonl`; `summary.csv` holds the same
/// fields). Everything but `seconds` comes from the recording's massid-diagnosis/1 JSON, so
/// two runs that wrote the same JSONs have the same rows but for `seconds`.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Row {
    /// The recording as given (a folder's recordings as FOLDER/NAME.csv).
    pub file: String,
    /// `ok`, or `error` when the recording could not be diagnosed.
    pub status: String,
    pub model: Option<String>,
    pub samples: Option<u64>,
    /// The named effects, in the order the diagnosis accepted them.
    pub effects: Vec<String>,
    /// Each named effect's fitted parameters (contract units), in the order of `effects`.
    pub params: Vec<Value>,
    /// Per axis, rad/s: before any effect and after the named ones.
    pub residual_rms_before: Option<Value>,
    pub residual_rms_after: Option<Value>,
    /// What no named effect explains (axes, condition, apparent_hz, note), or null.
    pub unexplained: Option<Value>,
    /// Why the recording could not be diagnosed (`file:line: reason`).
    pub error: Option<String>,
    /// Wall time of the recording's diagnosis (reading included); null when unknown (a
    /// JSON written by another run).
    pub seconds: Option<f64>,
}

fn seconds_rounded(s: Option<f64>) -> Option<f64> {
    s.map(|s| (s * 1000.0).round() / 1000.0)
}

impl Row {
    /// The row of a recording whose diagnosis is `json` (the massid-diagnosis/1 text).
    pub fn from_json(file: &Path, json: &str, seconds: Option<f64>) -> anyhow::Result<Row> {
        let doc: Value =
            serde_json::from_str(json).map_err(|e| anyhow::anyhow!("not a JSON document ({e})"))?;
        if doc.get("format").and_then(Value::as_str) != Some(massid_diagnose::output::FORMAT) {
            bail!("not a {} document", massid_diagnose::output::FORMAT);
        }
        let effects = doc
            .get("effects")
            .and_then(Value::as_array)
            .context("no `effects` list")?;
        let unexplained = doc.get("unexplained").filter(|u| !u.is_null()).map(|u| {
            let mut m = serde_json::Map::new();
            for k in ["axes", "condition", "apparent_hz", "note"] {
                m.insert(k.into(), u.get(k).cloned().unwrap_or(Value::Null));
            }
            Value::Object(m)
        });
        Ok(Row {
            file: file.display().to_string(),
            status: "ok".into(),
            model: doc.get("model").and_then(Value::as_str).map(str::to_string),
            samples: doc.get("samples").and_then(Value::as_u64),
            effects: effects
                .iter()
                .map(|e| {
                    e.get("effect")
                        .and_then(Value::as_str)
                        .unwrap_or("?")
                        .to_string()
                })
                .collect(),
            params: effects
                .iter()
                .map(|e| e.get("params").cloned().unwrap_or(Value::Null))
                .collect(),
            residual_rms_before: doc.get("residual_rms_before").cloned(),
            residual_rms_after: doc.get("residual_rms_after").cloned(),
            unexplained,
            error: None,
            seconds: seconds_rounded(seconds),
        })
    }

    /// The row of a recording that could not be diagnosed.
    pub fn error(file: &Path, error: &str, seconds: Option<f64>) -> Row {
        Row {
            file: file.display().to_string(),
            status: "error".into(),
            model: None,
            samples: None,
            effects: Vec::new(),
            params: Vec::new(),
            residual_rms_before: None,
            residual_rms_after: None,
            unexplained: None,
            error: Some(error.to_string()),
            seconds: seconds_rounded(seconds),
        }
    }

    /// The row as one JSON line (with its newline).
    pub fn line(&self) -> String {
        serde_json::to_string(self).expect("a row serialises") + "\n"
    }

    /// The row as one CSV line (with its newline), columns as [`CSV_HEADER`].
    pub fn csv(&self) -> String {
        let nums = |v: &Option<Value>| match v.as_ref().and_then(Value::as_array) {
            Some(a) => a.iter().map(Value::to_string).collect::<Vec<_>>().join(" "),
            None => String::new(),
        };
        let fields = [
            self.file.clone(),
            self.status.clone(),
            self.model.clone().unwrap_or_default(),
            self.samples.map(|n| n.to_string()).unwrap_or_default(),
            self.effects.join(";"),
            if self.params.is_empty() {
                String::new()
            } else {
                Value::Array(self.params.clone()).to_string()
            },
            nums(&self.residual_rms_before),
            nums(&self.residual_rms_after),
            self.unexplained
                .as_ref()
                .and_then(|u| u.get("note"))
                .and_then(Value::as_str)
                .unwrap_or_default()
                .to_string(),
            self.error.clone().unwrap_or_default(),
            self.seconds.map(|s| s.to_string()).unwrap_or_default(),
        ];
        fields
            .iter()
            .map(|f| csv_field(f))
            .collect::<Vec<_>>()
            .join(",")
            + "\n"
    }
}

/// The columns of `summary.csv` (effects `;`-separated, params the JSON list of each
/// effect's parameters, residuals space-separated x y z, unexplained its note).
pub const CSV_HEADER: &str = "file,status,model,samples,effects,params,residual_rms_before,residual_rms_after,unexplained,error,seconds\n";

fn csv_field(f: &str) -> String {
    if f.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", f.replace('"', "\"\""))
    } else {
        f.to_string()
    }
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
    fn rows_come_from_the_json_alone_and_csv_quotes() {
        let json = r#"{"format":"massid-diagnosis/1","recording":"a.csv","model":"sph2","samples":100,
            "residual_rms_before":[0.1,0.2,0.3],"residual_rms_after":[0.01,0.02,0.03],
            "effects":[{"effect":"thruster_latency","params":{"open_ms":6.1,"close_ms":5.8}}],
            "unexplained":{"axes":["x"],"condition":"c, d","apparent_hz":null,"note":"n \"q\""},
            "data_issues":{}}"#;
        let r = Row::from_json(Path::new("d/a.csv"), json, Some(1.23456)).unwrap();
        assert_eq!(r.effects, vec!["thruster_latency"]);
        assert_eq!(r.params[0]["open_ms"], 6.1);
        assert_eq!(r.seconds, Some(1.235));
        assert_eq!(r.unexplained.as_ref().unwrap()["condition"], "c, d");
        let back: Row = serde_json::from_str(&r.line()).unwrap();
        assert_eq!(back, r);
        let csv = r.csv();
        assert!(
            csv.starts_with("d/a.csv,ok,sph2,100,thruster_latency,"),
            "{csv}"
        );
        assert!(csv.contains("\"n \"\"q\"\"\""), "{csv}");
        assert!(csv.contains(",0.1 0.2 0.3,"), "{csv}");
        assert!(Row::from_json(Path::new("x"), "{}", None).is_err());
        assert!(Row::from_json(Path::new("x"), "nope", None).is_err());
    }

    /// The top-level keys of a JSON line in their order (the line's values must not
    /// contain `"KEY":` for a known key).
    fn key_order(line: &str, keys: &[&str]) -> Vec<String> {
        let mut found: Vec<(usize, String)> = keys
            .iter()
            .filter_map(|k| line.find(&format!("\"{k}\":")).map(|i| (i, k.to_string())))
            .collect();
        found.sort();
        found.into_iter().map(|(_, k)| k).collect()
    }

    #[test]
    fn every_row_has_the_csv_columns_in_their_order() {
        let columns: Vec<&str> = CSV_HEADER.trim_end().split(',').collect();
        let json = r#"{"format":"massid-diagnosis/1","recording":"a.csv","model":"sph2","samples":1,
            "residual_rms_before":[1,2,3],"residual_rms_after":[1,2,3],"effects":[],
            "unexplained":null,"data_issues":{}}"#;
        let ok = Row::from_json(Path::new("a.csv"), json, None)
            .unwrap()
            .line();
        let error = Row::error(Path::new("b.csv"), "b.csv:2: bad", Some(0.5)).line();
        for line in [&ok, &error] {
            let n = serde_json::from_str::<serde_json::Map<String, Value>>(line)
                .unwrap()
                .len();
            assert_eq!(n, columns.len(), "{line}");
            assert_eq!(key_order(line, &columns), columns, "{line}");
        }
        // the check catches a row that lacks a field or has them in another order
        let short = r#"{"file":"x","status":"error","error":"e"}"#;
        assert_ne!(key_order(short, &columns), columns);
        let swapped = ok
            .replacen("\"file\"", "\"f\"", 1)
            .replacen("\"status\"", "\"file\"", 1);
        assert_ne!(key_order(&swapped, &columns), columns);
    }

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
