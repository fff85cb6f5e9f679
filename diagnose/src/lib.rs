//! Mismatch diagnosis between a recording and the nominal model: predict the recording
//! from its own commands, locate where the residual concentrates (time, axis, input
//! condition, frequency with alias folding), fit each mechanism of the effect
//! vocabulary, accept them one at a time by BIC backed by whiteness tests, and report.

pub mod model;
pub mod series;
pub mod alias;
pub mod diagnosis;
pub mod effects;
pub mod fit;
pub mod locate;
pub mod noise;
pub mod output;
pub mod ringing;
pub mod select;
pub mod spectrum;
pub mod stats;
pub mod report;

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
}

/// Diagnoses `rec` against the nominal model `sat`: the library entry point behind
/// `massid diagnose`.
pub fn diagnose_recording(rec: &Recording, sat: &Satellite, settings: &Settings) -> Result<Analysis, DiagnoseError> {
    let series = series::Series::from_recording(rec, sat).ok_or_else(|| DiagnoseError::Empty(rec.source.clone()))?;
    let plant = model::Plant::new(sat);
    let issues = DataIssues {
        gaps: rec.issues.gaps as u64,
        missing_samples: rec.issues.missing_samples as u64,
        duplicates: rec.issues.duplicates as u64,
        saturated: rec.issues.saturated as u64,
    };
    let name = std::path::Path::new(&rec.source)
        .file_name()
        .map(|f| f.to_string_lossy().into_owned())
        .unwrap_or_else(|| rec.source.clone());
    Ok(diagnose(&series, &plant, &name, &sat.name, issues, settings))
}
pub mod synth;
pub mod score;
