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
        Satellite::from_toml_file(m)?
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
    let analysis = diagnose_recording(&rec, &sat, &Settings::default())?;
    print!("{}", report::summary(&analysis));
    if let Some(out) = &args.json {
        super::check_output(out, &[&args.recording])?;
        let text = serde_json::to_string_pretty(&analysis.output)?;
        std::fs::write(out, text + "\n")
            .with_context(|| format!("{}: cannot write", out.display()))?;
    }
    if let Some(dir) = &args.report {
        super::check_output(&dir.join("report.html"), &[&args.recording])?;
        report::write_html(dir, &analysis)
            .with_context(|| format!("{}: cannot write the report", dir.display()))?;
        println!("report: {}", dir.join("report.html").display());
    }
    Ok(())
}
