//! Mismatch diagnosis between a recording and the nominal model: predict the recording
//! from its own commands, locate where the residual concentrates (time, axis, input
//! condition, frequency with alias folding), fit each mechanism of the effect
//! vocabulary, accept them one at a time by BIC backed by whiteness tests, and report.

pub mod acceptance;
pub mod alias;
mod candidate;
pub mod diagnosis;
pub mod effects;
pub mod equation_error;
pub mod equivalence;
pub mod fit;
pub mod holdout;
pub mod json_number;
pub mod locate;
pub mod model;
pub mod noise;
pub mod numfmt;
pub mod output;
pub mod profile;
pub mod report;
pub mod response;
pub mod ringing;
pub mod rows;
pub mod select;
pub mod series;
pub mod spectrum;
pub mod stats;
pub mod unexplained;

pub use diagnosis::{diagnose, Analysis};
pub use output::{DataIssues, DiagnosisOutput, EffectReport};
pub use select::Settings;

use reference_f64::rate_recording::{Commands, RateRecording};
use reference_f64::recording::Recording;
use reference_f64::satellite::Satellite;

/// Why a diagnosis could not run.
#[derive(Debug, thiserror::Error)]
pub enum DiagnoseError {
    #[error("{0}: the recording has no samples")]
    Empty(String),
    #[error("{0}: no usable gyro sample (every sample is at a rail or stuck on every axis)")]
    NoUsableSamples(String),
    /// Sample index (0-based), its `time_ms` and the previous sample's. The reader
    /// guarantees increasing times; a `Recording` built by hand may not.
    #[error("{0}: sample {1}: time_ms {2} does not increase (previous sample at {3}); the diagnosis needs strictly increasing times")]
    TimeNotIncreasing(String, usize, u64, u64),
    /// Sample index (0-based) and its `time_ms`.
    #[error("{0}: sample {1}: time_ms {2} is past {max} ms (2^53, about 285,000 years), the latest time the diagnosis can represent exactly", max = MAX_TIME_MS)]
    TimeTooLate(String, usize, u64),
    /// Recording and model names.
    #[error("{0}: the nominal model {1} does not give a finite prediction of this recording (check its inertia, thrusts and thruster positions); nothing can be diagnosed against it")]
    NoPrediction(String, String),
    /// Recording, its thruster count, model, the model's.
    #[error("{0}: the recording has {1} thrusters but the model {2} has {3}; the diagnosis needs the model of the craft that flew")]
    ThrusterCount(String, usize, String, usize),
    /// A recording of commanded body force/torque instead of thruster states.
    #[error("{0}: the commands are a body wrench, not thruster states; the diagnosis predicts from thruster states (valve timing, per-thruster force) and cannot use it")]
    WrenchCommands(String),
    /// A planar recording against a 3-D model or the other way round.
    #[error("{0}: {1}")]
    Geometry(String, String),
}

/// The latest `time_ms` the diagnosis accepts: 2^53 ms, so that every time (and the
/// difference of any two) is exact in the f64 times of the report and no integer
/// arithmetic on times (model clock, lags of the noise estimate) can overflow.
pub const MAX_TIME_MS: u64 = 1 << 53;

/// The time axis checks the diagnosis relies on and a hand-built `Recording` may break:
/// strictly increasing `time_ms`, none past [`MAX_TIME_MS`].
fn check_times(source: &str, times: impl Iterator<Item = u64>) -> Result<(), DiagnoseError> {
    let mut previous: Option<u64> = None;
    for (i, t) in times.enumerate() {
        if t > MAX_TIME_MS {
            return Err(DiagnoseError::TimeTooLate(source.to_string(), i, t));
        }
        if let Some(p) = previous.filter(|&p| t <= p) {
            return Err(DiagnoseError::TimeNotIncreasing(
                source.to_string(),
                i,
                t,
                p,
            ));
        }
        previous = Some(t);
    }
    Ok(())
}

/// The series of a recording in format v2 (rates in rad/s), checked against the model:
/// same thruster count, thruster states (not a wrench), a planar model for a recording
/// that measures z only and the other way round.
pub fn rate_series(rec: &RateRecording, sat: &Satellite) -> Result<series::Series, DiagnoseError> {
    let Commands::Thrusters { n, words } = &rec.commands else {
        return Err(DiagnoseError::WrenchCommands(rec.source.clone()));
    };
    if *n != sat.n_thrusters() {
        return Err(DiagnoseError::ThrusterCount(
            rec.source.clone(),
            *n,
            sat.name.clone(),
            sat.n_thrusters(),
        ));
    }
    let z_only = rec.axes == [false, false, true];
    if sat.planar && !rec.axes[2] {
        return Err(DiagnoseError::Geometry(
            rec.source.clone(),
            format!(
                "the model {} is planar (yaw only) but the recording has no z rate",
                sat.name
            ),
        ));
    }
    if !sat.planar && z_only {
        return Err(DiagnoseError::Geometry(
            rec.source.clone(),
            format!(
                "the recording measures z only but the model {} is 3-D: x and y would be \
                 unconstrained; give a planar model (`planar = true`)",
                sat.name
            ),
        ));
    }
    check_times(&rec.source, rec.time_ms.iter().copied())?;
    let t: Vec<i64> = rec.time_ms.iter().map(|&ms| ms as i64).collect();
    // a planar craft's bearing holds x and y: whatever the file says about them, they
    // carry no information about the model
    let rates: Vec<[f64; 3]> = rec
        .rate
        .iter()
        .map(|r| {
            if sat.planar {
                [f64::NAN, f64::NAN, r[2]]
            } else {
                *r
            }
        })
        .collect();
    let declared = rec
        .meta("sample_rate_hz")
        .and_then(|v| v.trim().parse::<f64>().ok());
    let s = series::Series::from_rates(&t, &rates, words, sat.word_mask(), declared)
        .ok_or_else(|| DiagnoseError::Empty(rec.source.clone()))?;
    if s.usable() == 0 {
        return Err(DiagnoseError::NoUsableSamples(rec.source.clone()));
    }
    Ok(s)
}

/// Diagnoses a recording in format v2 (rates in rad/s, any thruster count up to 16, a
/// planar craft measuring z only) against the nominal model `sat`.
pub fn diagnose_rate_recording(
    rec: &RateRecording,
    sat: &Satellite,
    settings: &Settings,
) -> Result<Analysis, DiagnoseError> {
    let series = rate_series(rec, sat)?;
    diagnose_series(
        series,
        sat,
        &rec.source,
        rec.issues.duplicates as u64,
        0,
        settings,
    )
}

/// The part both formats share: the horizon's resets, the data issues and the run.
fn diagnose_series(
    mut series: series::Series,
    sat: &Satellite,
    source: &str,
    duplicates: u64,
    saturated: u64,
    settings: &Settings,
) -> Result<Analysis, DiagnoseError> {
    if let Some(h) = settings.horizon_s {
        series.reset_every(h);
    }
    if series.usable() == 0 {
        return Err(DiagnoseError::NoUsableSamples(source.to_string()));
    }
    let plant = model::Plant::new(sat);
    let issues = DataIssues {
        // from the time steps, which win over a contradicting declared rate
        gaps: series.gaps,
        missing_samples: series.missing_samples,
        duplicates,
        saturated,
        railed: series.railed,
    };
    diagnose(
        &series,
        &plant,
        &file_name(source),
        &sat.name,
        issues,
        settings,
    )
    .ok_or_else(|| DiagnoseError::NoPrediction(source.to_string(), sat.name.clone()))
}

/// The recording's file name, as the report names it.
fn file_name(source: &str) -> String {
    std::path::Path::new(source)
        .file_name()
        .map(|f| f.to_string_lossy().into_owned())
        .unwrap_or_else(|| source.to_string())
}

/// Diagnoses `rec` against the nominal model `sat`: the library entry point behind
/// `massid diagnose`.
pub fn diagnose_recording(
    rec: &Recording,
    sat: &Satellite,
    settings: &Settings,
) -> Result<Analysis, DiagnoseError> {
    check_times(&rec.source, rec.samples.iter().map(|s| s.time_ms))?;
    let series = series::Series::from_recording(rec, sat)
        .ok_or_else(|| DiagnoseError::Empty(rec.source.clone()))?;
    diagnose_series(
        series,
        sat,
        &rec.source,
        rec.issues.duplicates as u64,
        rec.issues.saturated as u64,
        settings,
    )
}
pub mod score;
pub mod synth;
