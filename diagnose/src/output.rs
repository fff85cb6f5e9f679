//! The machine-readable result, exactly `massid-diagnosis/1`
//! (`shared/contracts/diagnosis-output.md`).

use serde::{Deserialize, Serialize};
use serde_json::{Map, Value};

pub const FORMAT: &str = "massid-diagnosis/1";

/// One accepted effect.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct EffectReport {
    pub effect: String,
    pub params: Map<String, Value>,
    pub stderr: Map<String, Value>,
    pub evidence: String,
    pub windows_ms: Vec<[i64; 2]>,
    pub rms_after: [f64; 3],
    pub delta_bic: f64,
    /// Other effects that give the same rates, with their parameters (`equivalence.rs`;
    /// the contract's extra key, absent when there are none).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub equivalent_to: Vec<Value>,
    /// Array entries held at the model's value rather than fitted, by parameter: 0-based
    /// indices, e.g. `{"inertia_kgm2": [3, 4, 5]}` for an inertia whose products the data
    /// do not move (`diagnosis/held.rs`; an extra key, absent when nothing is held).
    #[serde(default, skip_serializing_if = "Map::is_empty")]
    pub held: Map<String, Value>,
}

/// Data artefacts (never effects).
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, PartialEq, Eq)]
pub struct DataIssues {
    pub gaps: u64,
    pub missing_samples: u64,
    pub duplicates: u64,
    pub saturated: u64,
    /// Per axis, samples masked out of every fit and statistic because the gyro sat at a
    /// rail or was stuck.
    #[serde(default)]
    pub railed: [u64; 3],
}

/// The whole document.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct DiagnosisOutput {
    pub format: String,
    pub recording: String,
    pub model: String,
    pub samples: u64,
    pub residual_rms_before: [f64; 3],
    pub residual_rms_after: [f64; 3],
    pub effects: Vec<EffectReport>,
    /// What remains after the named effects when it is above the noise or not white.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub unexplained: Option<crate::unexplained::Unexplained>,
    pub data_issues: DataIssues,
    /// The rate sensor's noise model the decisions used (an extra key the contract allows).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub noise: Option<crate::noise::NoiseReport>,
}

pub use crate::json_number::{num, nums};
