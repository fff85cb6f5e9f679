//! The model file (TOML), the one format every `massid` subcommand reads: which satellite
//! (a built-in name or a full description) and, for the simulator, which effects are on, plus
//! optional sensor and telemetry-artefact settings. Two layouts are read:
//!
//! * this one (a `satellite` key, then effects etc.), written back by
//!   [`ModelFile::to_toml_string`] with the satellite in full;
//! * the plain satellite description (`reference_f64::satellite::Satellite` as TOML, no
//!   `satellite` key), which is a model without effects.
//!
//! Unknown keys are errors naming the file, line and column.
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
use serde::{Deserialize, Serialize};
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

/// Why a model file is unusable: the file, the line (0 when unknown) and the reason (which
/// starts with the column when the parser knows it). Shown as `file:line: reason`, or
/// `file: reason` when no line is known (never `file:0:`).
#[derive(Debug, thiserror::Error)]
pub struct ModelFileError {
    pub file: String,
    pub line: usize,
    pub reason: String,
}

impl std::fmt::Display for ModelFileError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.line == 0 {
            write!(f, "{}: {}", self.file, self.reason)
        } else {
            write!(f, "{}:{}: {}", self.file, self.line, self.reason)
        }
    }
}

/// The normalised layout [`ModelFile::to_toml_string`] writes.
#[derive(Serialize)]
struct WrittenModel<'a> {
    satellite: &'a Satellite,
    effects: &'a [Effect],
    sensors: &'a SensorConfig,
    artefacts: &'a Artefacts,
}

/// `(line, "column C: message")` of a TOML error in `text`.
fn locate(text: &str, e: &toml::de::Error) -> (usize, String) {
    match e.span() {
        Some(span) => {
            let before = &text[..span.start.min(text.len())];
            let line = before.matches('\n').count() + 1;
            let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
            (line, format!("column {column}: {}", e.message()))
        }
        None => (0, e.message().to_string()),
    }
}

impl ModelFile {
    /// Reads a model file; a path that names no file but a built-in satellite (`sph2`) is
    /// that satellite without effects, so every `--model` takes the built-in names too.
    pub fn read(path: &Path) -> Result<ModelFile, ModelFileError> {
        let file = path.display().to_string();
        if !path.exists() {
            if let Some(satellite) = path.to_str().and_then(Satellite::builtin) {
                return Ok(ModelFile {
                    satellite,
                    effects: Vec::new(),
                    sensors: SensorConfig::default(),
                    artefacts: Artefacts::default(),
                });
            }
        }
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
        // A UTF-8 byte-order mark is not part of the text.
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let table: toml::Table = toml::from_str(text).map_err(|e| {
            let (line, reason) = locate(text, &e);
            err(line, reason)
        })?;
        if !table.contains_key("satellite") {
            // The plain satellite description: a model without effects.
            let satellite: Satellite = toml::from_str(text).map_err(|e| {
                let (line, reason) = locate(text, &e);
                err(line, format!("{reason} (a model file has a `satellite` key, or is a satellite description)"))
            })?;
            satellite
                .check_plausible()
                .map_err(|r| err(key_line(text, &r, 0), r))?;
            return Ok(ModelFile {
                satellite,
                effects: Vec::new(),
                sensors: SensorConfig::default(),
                artefacts: Artefacts::default(),
            });
        }
        let raw: RawModel = toml::from_str(text).map_err(|e| {
            let (line, reason) = locate(text, &e);
            err(line, reason)
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
                s.check_plausible()
                    .map_err(|r| err(key_line(text, &r, line_of(text, "[satellite]")), r))?;
                *s
            }
        };
        for (i, e) in raw.effects.iter().enumerate() {
            e.check_plausible(&satellite)
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

impl ModelFile {
    /// The model in the normalised layout (the satellite in full, every section present);
    /// [`ModelFile::parse`] reads it back to the same model.
    pub fn to_toml_string(&self) -> String {
        let w = WrittenModel {
            satellite: &self.satellite,
            effects: &self.effects,
            sensors: &self.sensors,
            artefacts: &self.artefacts,
        };
        toml::to_string_pretty(&w).unwrap_or_default()
    }
}

/// The line of the key a validation reason starts with (`thrust_n[3] = ...` names
/// `thrust_n`), at or after line `from`; else `from` (0: unknown).
fn key_line(text: &str, reason: &str, from: usize) -> usize {
    let key: String = reason
        .chars()
        .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
        .collect();
    if key.is_empty() {
        return from;
    }
    text.lines()
        .enumerate()
        .skip(from.saturating_sub(1))
        .find(|(_, l)| {
            let t = l.trim_start();
            t.strip_prefix(key.as_str())
                .is_some_and(|rest| rest.trim_start().starts_with('='))
        })
        .map(|(i, _)| i + 1)
        .unwrap_or(from)
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

#[cfg(test)]
mod tests {
    use super::*;

    fn sph2() -> Satellite {
        Satellite::builtin("sph2").expect("sph2")
    }

    #[test]
    fn both_layouts_read_and_the_normalised_one_reads_back() {
        let flat = sph2().to_toml_string();
        let a = ModelFile::parse(&flat, "flat.toml").expect("a plain satellite description");
        assert_eq!(a.satellite, sph2());
        assert!(a.effects.is_empty());
        let sim = "satellite = \"sph2\"\n\n[[effects]]\neffect = \"thruster_latency\"\nparams = { open_ms = 6.0, close_ms = 6.0 }\n";
        let b = ModelFile::parse(sim, "sim.toml").expect("the simulator layout");
        assert_eq!(b.effects.len(), 1);
        let back = ModelFile::parse(&b.to_toml_string(), "normalised.toml")
            .expect("normalised reads back");
        assert_eq!(back, b);
        // with a byte-order mark too
        assert!(ModelFile::parse(&format!("\u{feff}{sim}"), "bom.toml").is_ok());
    }

    #[test]
    fn unknown_keys_are_errors_with_line_and_column() {
        let flat = sph2().to_toml_string().replacen("mass_kg", "mass_kgg", 1);
        let e = ModelFile::parse(&flat, "typo.toml")
            .expect_err("a typo is not ignored")
            .to_string();
        assert!(
            e.starts_with("typo.toml:") && e.contains("column") && e.contains("mass_kgg"),
            "{e}"
        );
        let sim = "satellite = \"sph2\"\nefects = []\n";
        let e = ModelFile::parse(sim, "sim.toml")
            .expect_err("unknown key")
            .to_string();
        assert!(
            e.starts_with("sim.toml:2:") && e.contains("column 1"),
            "{e}"
        );
    }
}
