//! Mismatch diagnosis between a recording and the nominal model: predict the recording
//! from its own commands, locate where the residual concentrates (time, axis, input
//! condition, frequency with alias folding), fit each mechanism of the effect
//! vocabulary, accept them one at a time by BIC backed by whiteness tests, and report.

pub mod acceptance;
pub mod alias;
pub mod diagnosis;
pub mod effects;
pub mod fit;
pub mod locate;
pub mod model;
pub mod noise;
pub mod numfmt;
pub mod output;
pub mod report;
pub mod ringing;
pub mod select;
pub mod series;
pub mod spectrum;
pub mod stats;
pub mod unexplained;

pub use diagnosis::{diagnose, Analysis};
pub use output::{DataIssues, DiagnosisOutput, EffectReport};
pub use select::Settings;

use reference_f64::recording::Recording;
use reference_f64::satellite::Satellite;

/// Why a diagnosis could not run.
#[derive(Debug, thiserror::Error)]
pub enum DiagnoseError {
    #[error("{0}: the recording has no samples")]
    Empty(String),
    #[error("{0}: no usable gyro sample (every sample is at a rail or stuck on every axis)")]
    NoUsableSamples(String),
}

/// Diagnoses `rec` against the nominal model `sat`: the library entry point behind
/// `massid diagnose`.
pub fn diagnose_recording(
    rec: &Recording,
    sat: &Satellite,
    settings: &Settings,
) -> Result<Analysis, DiagnoseError> {
    let series = series::Series::from_recording(rec, sat)
        .ok_or_else(|| DiagnoseError::Empty(rec.source.clone()))?;
    if series.usable() == 0 {
        return Err(DiagnoseError::NoUsableSamples(rec.source.clone()));
    }
    let plant = model::Plant::new(sat);
    let issues = DataIssues {
        // from the time steps, which win over a contradicting declared rate
        gaps: series.gaps,
        missing_samples: series.missing_samples,
        duplicates: rec.issues.duplicates as u64,
        saturated: rec.issues.saturated as u64,
        railed: series.railed,
    };
    let name = std::path::Path::new(&rec.source)
        .file_name()
        .map(|f| f.to_string_lossy().into_owned())
        .unwrap_or_else(|| rec.source.clone());
    Ok(diagnose(
        &series, &plant, &name, &sat.name, issues, settings,
    ))
}
pub mod score;
pub mod synth;
