//! The model file (TOML): which satellite and which effects are on, plus optional sensor and
//! telemetry-artefact settings.
//!
//! ```toml
//! satellite = "sph2"                  # a built-in name, or a [satellite] table (reference-f64 model format)
//!
//! [[effects]]                          # the vocabulary of diagnosis-output.md
//! effect = "thruster_latency"
//! params = { open_ms = 6.0, close_ms = 6.0 }
//!
//! [sensors]                            # optional; defaults in sensors.rs
//! gyro_bandwidth_hz = 300.0
//!
//! [artefacts]                          # optional
//! gaps = 8
//! max_gap = 20
//! duplicates = 5
//! ```
use crate::effects::Effect;
use crate::sensors::{Artefacts, SensorConfig};
use reference_f64::satellite::Satellite;
use serde::Deserialize;
use std::path::Path;

#[derive(Deserialize)]
#[serde(untagged)]
enum SatelliteRef {
    Name(String),
    Inline(Box<Satellite>),
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawModel {
    satellite: SatelliteRef,
    #[serde(default)]
    effects: Vec<Effect>,
    #[serde(default)]
    sensors: SensorConfig,
    #[serde(default)]
    artefacts: Artefacts,
}

/// A parsed model file.
#[derive(Clone, Debug, PartialEq)]
pub struct ModelFile {
    pub satellite: Satellite,
    pub effects: Vec<Effect>,
    pub sensors: SensorConfig,
    pub artefacts: Artefacts,
}

/// Why a model file is unusable: the file, the line (0 when unknown) and the reason.
#[derive(Debug, thiserror::Error)]
#[error("{file}:{line}: {reason}")]
pub struct ModelFileError {
    pub file: String,
    pub line: usize,
    pub reason: String,
}

impl ModelFile {
    pub fn read(path: &Path) -> Result<ModelFile, ModelFileError> {
        let file = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| ModelFileError {
            file: file.clone(),
            line: 0,
            reason: format!("cannot read: {e}"),
        })?;
        Self::parse(&text, &file)
    }

    /// Parses model-file text; `file` names it in errors.
    pub fn parse(text: &str, file: &str) -> Result<ModelFile, ModelFileError> {
        let err = |line: usize, reason: String| ModelFileError {
            file: file.to_string(),
            line,
            reason,
        };
        let raw: RawModel = toml::from_str(text).map_err(|e| {
            let line = e
                .span()
                .map(|s| text[..s.start.min(text.len())].lines().count().max(1))
                .unwrap_or(0);
            err(line, e.message().to_string())
        })?;
        let satellite = match raw.satellite {
            SatelliteRef::Name(n) => Satellite::builtin(&n).ok_or_else(|| {
                err(
                    line_of(text, "satellite"),
                    format!(
                        "unknown satellite {n:?} (built-in: {})",
                        Satellite::BUILTIN_NAMES.join(", ")
                    ),
                )
            })?,
            SatelliteRef::Inline(s) => {
                s.validate()
                    .map_err(|r| err(line_of(text, "[satellite]"), r))?;
                *s
            }
        };
        for (i, e) in raw.effects.iter().enumerate() {
            e.validate()
                .map_err(|r| err(nth_line_of(text, "[[effects]]", i), r))?;
        }
        Ok(ModelFile {
            satellite,
            effects: raw.effects,
            sensors: raw.sensors,
            artefacts: raw.artefacts,
        })
    }
}

fn line_of(text: &str, needle: &str) -> usize {
    nth_line_of(text, needle, 0)
}

fn nth_line_of(text: &str, needle: &str, n: usize) -> usize {
    text.lines()
        .enumerate()
        .filter(|(_, l)| l.trim_start().starts_with(needle))
        .nth(n)
        .map(|(i, _)| i + 1)
        .unwrap_or(0)
}
