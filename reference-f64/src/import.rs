//! Import a CSV log from another system into a `massid-recording/2`
//! ([`crate::rate_recording`]), driven by a small TOML mapping that names the log's columns
//! and units. Lives here, not in the CLI, so every tool converts a foreign log the same way.
//!
//! ```toml
//! satellite = "airbearing-mpc"
//! sample_rate_hz = 16.667            # optional; else the median time step
//! [time]
//! column = "Control_Time"
//! unit = "s"                         # s | ms | us; rounded to the nearest ms
//! start = "zero"                     # optional: subtract the first row's time
//! [rates]                            # at least one of x, y, z
//! z = { column = "Current_Angular_Vel", unit = "rad/s" }   # rad/s | deg/s | counts
//! # x = { column = "gx", unit = "counts", counts_per_rad_s = 1412.79, bias_counts = 2055, sign = -1 }
//! [thrusters]                        # or [wrench] with force_x = { column = "Fx", unit = "N" }, ...
//! count = 8                          # 1..=16
//! vector = "Command_Vector"          # or columns = ["T1", ...] or bitmask = { column = "W", base = 16 }
//! ```
//!
//! Mapping errors name the mapping file, line and column; data errors name the log and the
//! 1-based line of the file (the header is line 1). Rows follow v1's time rules: a repeated
//! time keeps the first row (counted), time going backwards is an error. An empty rate field
//! is a sample missing on that axis; an empty time, thruster or wrench field is an error.
use crate::rate_recording::{
    Command, Commands, RateRecording, RowCollector, MAX_THRUSTERS, WRENCH_COLUMNS,
};
use crate::recording::{clip, RecordingError};
use serde::Deserialize;
use std::io::Read;
use std::path::Path;
use toml::Spanned;

/// A rejected mapping file: the file, the 1-based line and the reason (starting with the
/// column when the TOML parser knows it).
#[derive(Debug, thiserror::Error)]
pub struct MappingError {
    pub file: String,
    pub line: usize,
    pub reason: String,
}

/// `file:line: reason`, or `file: reason` when no line is known (line 0; never `file:0:`).
impl std::fmt::Display for MappingError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.line == 0 {
            write!(f, "{}: {}", self.file, self.reason)
        } else {
            write!(f, "{}:{}: {}", self.file, self.line, self.reason)
        }
    }
}

/// Unit of the time column.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
pub enum TimeUnit {
    #[serde(rename = "s")]
    Seconds,
    #[serde(rename = "ms")]
    Milliseconds,
    #[serde(rename = "us")]
    Microseconds,
}

impl TimeUnit {
    fn ms_per_unit(self) -> f64 {
        match self {
            TimeUnit::Seconds => 1000.0,
            TimeUnit::Milliseconds => 1.0,
            TimeUnit::Microseconds => 1e-3,
        }
    }
}

/// Where the imported time starts.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
enum Start {
    #[serde(rename = "zero")]
    Zero,
}

/// The validated `[time]` table.
#[derive(Clone, Debug, PartialEq)]
pub struct TimeColumn {
    pub column: String,
    pub unit: TimeUnit,
    /// Subtract the first row's time (`start = "zero"`).
    pub start_zero: bool,
}

/// How one rate column converts to rad/s.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RateUnit {
    RadPerS,
    DegPerS,
    /// rad/s = (counts - bias_counts) / counts_per_rad_s
    Counts {
        counts_per_rad_s: f64,
        bias_counts: f64,
    },
}

/// One validated `[rates]` entry.
#[derive(Clone, Debug, PartialEq)]
pub struct RateColumn {
    pub column: String,
    pub unit: RateUnit,
    /// +1 or -1 (an axis flip between the log's frame and the body frame).
    pub sign: f64,
}

impl RateColumn {
    /// The rate in rad/s of a value in the column's unit.
    pub fn to_rad_s(&self, v: f64) -> f64 {
        let r = match self.unit {
            RateUnit::RadPerS => v,
            RateUnit::DegPerS => v.to_radians(),
            RateUnit::Counts {
                counts_per_rad_s,
                bias_counts,
            } => (v - bias_counts) / counts_per_rad_s,
        };
        self.sign * r
    }
}

/// How the thruster states are logged.
#[derive(Clone, Debug, PartialEq)]
pub enum ThrusterSource {
    /// One 0/1 (or true/false) column per thruster, thruster 1 first.
    Columns(Vec<String>),
    /// One column holding a list of `count` 0/1 entries, like `"[1, 0, 1, 0]"` or `1 0 1 0`.
    Vector(String),
    /// One integer column, bit i = thruster i+1, in base 2, 10 or 16 (`0x` accepted).
    Bitmask { column: String, base: u32 },
}

/// The validated commands part of the mapping.
#[derive(Clone, Debug, PartialEq)]
pub enum CommandMap {
    Thrusters {
        count: usize,
        source: ThrusterSource,
    },
    /// Column per wrench component, in [`WRENCH_COLUMNS`] order (N, N m).
    Wrench([Option<String>; 6]),
}

/// A validated mapping file.
#[derive(Clone, Debug, PartialEq)]
pub struct Mapping {
    /// The mapping file's name (for the recording's metadata).
    pub source: String,
    pub satellite: String,
    pub sample_rate_hz: Option<f64>,
    /// The line of `sample_rate_hz` in the mapping (0 when absent), for errors.
    pub sample_rate_line: usize,
    pub time: TimeColumn,
    /// x, y, z.
    pub rates: [Option<RateColumn>; 3],
    pub commands: CommandMap,
}

#[derive(Deserialize)]
#[serde(
    deny_unknown_fields,
    expecting = "the mapping table (satellite, time, rates, thrusters or wrench)"
)]
struct RawMapping {
    satellite: Spanned<String>,
    sample_rate_hz: Option<Spanned<f64>>,
    time: RawTime,
    rates: Spanned<RawRates>,
    thrusters: Option<Spanned<RawThrusters>>,
    wrench: Option<Spanned<RawWrench>>,
}

#[derive(Deserialize)]
#[serde(
    deny_unknown_fields,
    expecting = "a [time] table { column = \"NAME\", unit = \"s\" | \"ms\" | \"us\" }"
)]
struct RawTime {
    column: String,
    unit: TimeUnit,
    start: Option<Start>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields, expecting = "a [rates] table with x, y and/or z")]
struct RawRates {
    x: Option<Spanned<RawRate>>,
    y: Option<Spanned<RawRate>>,
    z: Option<Spanned<RawRate>>,
}

#[derive(Clone, Copy, Deserialize)]
enum RawRateUnit {
    #[serde(rename = "rad/s")]
    RadPerS,
    #[serde(rename = "deg/s")]
    DegPerS,
    #[serde(rename = "counts")]
    Counts,
}

#[derive(Deserialize)]
#[serde(
    deny_unknown_fields,
    expecting = "a rate table { column = \"NAME\", unit = \"rad/s\" | \"deg/s\" | \"counts\", ... }"
)]
struct RawRate {
    column: String,
    unit: RawRateUnit,
    counts_per_rad_s: Option<f64>,
    bias_counts: Option<f64>,
    sign: Option<f64>,
}

#[derive(Deserialize)]
#[serde(
    deny_unknown_fields,
    expecting = "a [thrusters] table { count = N, and columns, vector or bitmask }"
)]
struct RawThrusters {
    count: Spanned<i64>,
    columns: Option<Spanned<Vec<String>>>,
    vector: Option<String>,
    bitmask: Option<Spanned<RawBitmask>>,
}

#[derive(Deserialize)]
#[serde(
    deny_unknown_fields,
    expecting = "a bitmask table { column = \"NAME\", base = 10 | 16 }"
)]
struct RawBitmask {
    column: String,
    base: Option<u32>,
}

#[derive(Deserialize)]
enum ForceUnit {
    #[serde(rename = "N")]
    Newton,
}

#[derive(Deserialize)]
enum TorqueUnit {
    #[serde(rename = "N m")]
    NewtonMetre,
}

#[derive(Deserialize)]
#[serde(
    deny_unknown_fields,
    expecting = "a force table { column = \"NAME\", unit = \"N\" }"
)]
struct RawForce {
    column: String,
    #[allow(dead_code)] // the one accepted unit: stating it is what the field is for
    unit: ForceUnit,
}

#[derive(Deserialize)]
#[serde(
    deny_unknown_fields,
    expecting = "a torque table { column = \"NAME\", unit = \"N m\" }"
)]
struct RawTorque {
    column: String,
    #[allow(dead_code)] // the one accepted unit: stating it is what the field is for
    unit: TorqueUnit,
}

#[derive(Deserialize)]
#[serde(
    deny_unknown_fields,
    expecting = "a [wrench] table of force_x .. torque_z"
)]
struct RawWrench {
    force_x: Option<RawForce>,
    force_y: Option<RawForce>,
    force_z: Option<RawForce>,
    torque_x: Option<RawTorque>,
    torque_y: Option<RawTorque>,
    torque_z: Option<RawTorque>,
}

/// 1-based (line, column) of a byte offset in `text`.
fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let mut cut = offset.min(text.len());
    while !text.is_char_boundary(cut) {
        cut -= 1;
    }
    let before = &text[..cut];
    let line = before.matches('\n').count() + 1;
    let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, column)
}

impl Mapping {
    /// Reads and validates a mapping file.
    pub fn read(path: &Path) -> Result<Mapping, MappingError> {
        let file = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| MappingError {
            file: file.clone(),
            line: 0,
            reason: format!("cannot read: {e}"),
        })?;
        Self::parse(&text, &file)
    }

    /// Parses and validates mapping text; `file` names it in errors.
    pub fn parse(text: &str, file: &str) -> Result<Mapping, MappingError> {
        // A UTF-8 byte-order mark is not part of the text.
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let at = |offset: usize, reason: String| {
            let (line, column) = line_col(text, offset);
            MappingError {
                file: file.to_string(),
                line,
                reason: format!("column {column}: {reason}"),
            }
        };
        let raw: RawMapping = toml::from_str(text).map_err(|e| match e.span() {
            Some(span) => at(span.start, e.message().trim().to_string()),
            // Whole-document errors (a missing top-level key) have no place: line 1.
            None => MappingError {
                file: file.to_string(),
                line: 1,
                reason: e.message().trim().to_string(),
            },
        })?;

        let sat = &raw.satellite;
        let name = sat.get_ref();
        if name.trim().is_empty() || name.trim() != name || name.chars().any(char::is_control) {
            return Err(at(
                sat.span().start,
                format!(
                    "satellite {:?}: a non-empty name without surrounding spaces or control characters",
                    clip(name)
                ),
            ));
        }
        let sample_rate_hz = match &raw.sample_rate_hz {
            Some(r) if !(r.get_ref().is_finite() && *r.get_ref() > 0.0) => {
                return Err(at(
                    r.span().start,
                    format!("sample_rate_hz {} is not a positive number", r.get_ref()),
                ))
            }
            r => r.as_ref().map(|r| *r.get_ref()),
        };
        let sample_rate_line = raw
            .sample_rate_hz
            .as_ref()
            .map_or(0, |r| line_col(text, r.span().start).0);

        let rates_table = &raw.rates;
        let raw_rates = rates_table.get_ref();
        let mut rates: [Option<RateColumn>; 3] = [None, None, None];
        for (i, r) in [&raw_rates.x, &raw_rates.y, &raw_rates.z]
            .iter()
            .enumerate()
        {
            if let Some(r) = r {
                rates[i] = Some(rate_column(r.get_ref()).map_err(|m| at(r.span().start, m))?);
            }
        }
        if rates.iter().all(Option::is_none) {
            return Err(at(
                rates_table.span().start,
                "[rates] needs at least one of x, y, z".to_string(),
            ));
        }

        let commands = match (&raw.thrusters, &raw.wrench) {
            (Some(t), None) => thrusters(t.get_ref(), &at, t.span().start)?,
            (None, Some(w)) => {
                let w = w.get_ref();
                let force = |f: &Option<RawForce>| f.as_ref().map(|f| f.column.clone());
                let torque = |f: &Option<RawTorque>| f.as_ref().map(|f| f.column.clone());
                let cols = [
                    force(&w.force_x),
                    force(&w.force_y),
                    force(&w.force_z),
                    torque(&w.torque_x),
                    torque(&w.torque_y),
                    torque(&w.torque_z),
                ];
                if cols.iter().all(Option::is_none) {
                    return Err(at(
                        raw.wrench.as_ref().map_or(0, |w| w.span().start),
                        format!(
                            "[wrench] needs at least one of {}",
                            WRENCH_COLUMNS.join(", ")
                        ),
                    ));
                }
                CommandMap::Wrench(cols)
            }
            (Some(_), Some(w)) => {
                return Err(at(
                    w.span().start,
                    "a mapping has [thrusters] or [wrench], not both".to_string(),
                ))
            }
            (None, None) => {
                return Err(MappingError {
                    file: file.to_string(),
                    line: 1,
                    reason: "the mapping needs a [thrusters] or a [wrench] table".to_string(),
                })
            }
        };
        let t = raw.time;
        Ok(Mapping {
            source: file.to_string(),
            satellite: name.clone(),
            sample_rate_hz,
            sample_rate_line,
            time: TimeColumn {
                column: t.column,
                unit: t.unit,
                start_zero: t.start == Some(Start::Zero),
            },
            rates,
            commands,
        })
    }

    /// Which of x, y, z the mapping measures.
    pub fn axes(&self) -> [bool; 3] {
        [0, 1, 2].map(|i| self.rates[i].is_some())
    }
}

fn rate_column(r: &RawRate) -> Result<RateColumn, String> {
    let sign = match r.sign {
        None => 1.0,
        Some(s) if s == 1.0 || s == -1.0 => s,
        Some(s) => return Err(format!("sign {s}: must be 1 or -1")),
    };
    let unit = match (r.unit, r.counts_per_rad_s, r.bias_counts) {
        (RawRateUnit::Counts, Some(scale), Some(bias)) => {
            if !(scale.is_finite() && scale != 0.0 && bias.is_finite()) {
                return Err(format!(
                    "counts_per_rad_s {scale} must be finite and non-zero, bias_counts {bias} finite"
                ));
            }
            RateUnit::Counts {
                counts_per_rad_s: scale,
                bias_counts: bias,
            }
        }
        (RawRateUnit::Counts, _, _) => {
            return Err("unit = \"counts\" needs counts_per_rad_s and bias_counts".to_string())
        }
        (_, Some(_), _) | (_, _, Some(_)) => {
            return Err(
                "counts_per_rad_s and bias_counts are for unit = \"counts\" only".to_string(),
            )
        }
        (RawRateUnit::RadPerS, None, None) => RateUnit::RadPerS,
        (RawRateUnit::DegPerS, None, None) => RateUnit::DegPerS,
    };
    Ok(RateColumn {
        column: r.column.clone(),
        unit,
        sign,
    })
}

fn thrusters(
    t: &RawThrusters,
    at: &dyn Fn(usize, String) -> MappingError,
    table_start: usize,
) -> Result<CommandMap, MappingError> {
    let count = *t.count.get_ref();
    if !(1..=MAX_THRUSTERS as i64).contains(&count) {
        return Err(at(
            t.count.span().start,
            format!("count {count}: must be in 1..={MAX_THRUSTERS}"),
        ));
    }
    let count = count as usize;
    let source = match (&t.columns, &t.vector, &t.bitmask) {
        (Some(c), None, None) => {
            if c.get_ref().len() != count {
                return Err(at(
                    c.span().start,
                    format!(
                        "columns lists {} names, count is {count}",
                        c.get_ref().len()
                    ),
                ));
            }
            ThrusterSource::Columns(c.get_ref().clone())
        }
        (None, Some(v), None) => ThrusterSource::Vector(v.clone()),
        (None, None, Some(b)) => {
            let base = b.get_ref().base.unwrap_or(10);
            if ![2, 10, 16].contains(&base) {
                return Err(at(
                    b.span().start,
                    format!("bitmask base {base}: must be 2, 10 or 16"),
                ));
            }
            ThrusterSource::Bitmask {
                column: b.get_ref().column.clone(),
                base,
            }
        }
        _ => {
            return Err(at(
                table_start,
                "[thrusters] needs exactly one of columns, vector, bitmask".to_string(),
            ))
        }
    };
    Ok(CommandMap::Thrusters { count, source })
}

/// Converts the log at `log` with `mapping`. Errors name the log and the line.
pub fn import(mapping: &Mapping, log: &Path) -> Result<RateRecording, RecordingError> {
    let source = log.display().to_string();
    let f = std::fs::File::open(log).map_err(|e| RecordingError {
        file: source.clone(),
        line: 0,
        reason: format!("cannot open: {e}"),
    })?;
    import_reader(mapping, std::io::BufReader::new(f), &source)
}

/// Where each mapped column sits in the log's header.
struct Columns {
    time: usize,
    rates: [Option<(usize, RateColumn)>; 3],
    commands: CommandColumns,
}

enum CommandColumns {
    Columns(Vec<usize>),
    Vector(usize),
    Bitmask(usize, u32),
    Wrench([Option<usize>; 6]),
}

/// The named entry of the log's header; a missing or repeated name is an error (a repeated
/// one would make the mapping ambiguous).
fn find(header: &csv::StringRecord, name: &str, role: &str) -> Result<usize, String> {
    let mut hits = header.iter().enumerate().filter(|(_, h)| *h == name);
    match (hits.next(), hits.next()) {
        (Some((i, _)), None) => Ok(i),
        (Some(_), Some(_)) => Err(format!(
            "column {name} ({role}) appears twice in the header"
        )),
        (None, _) => Err(format!("column {name} ({role}) is not in the header")),
    }
}

fn locate(header: &csv::StringRecord, m: &Mapping) -> Result<Columns, String> {
    let time = find(header, &m.time.column, "[time]")?;
    let mut rates: [Option<(usize, RateColumn)>; 3] = [None, None, None];
    for (i, r) in m.rates.iter().enumerate() {
        if let Some(r) = r {
            let role = format!("[rates].{}", ["x", "y", "z"][i]);
            rates[i] = Some((find(header, &r.column, &role)?, r.clone()));
        }
    }
    let commands = match &m.commands {
        CommandMap::Thrusters { source, .. } => match source {
            ThrusterSource::Columns(c) => CommandColumns::Columns(
                c.iter()
                    .enumerate()
                    .map(|(k, n)| find(header, n, &format!("thruster {}", k + 1)))
                    .collect::<Result<_, _>>()?,
            ),
            ThrusterSource::Vector(c) => {
                CommandColumns::Vector(find(header, c, "[thrusters].vector")?)
            }
            ThrusterSource::Bitmask { column, base } => {
                CommandColumns::Bitmask(find(header, column, "[thrusters].bitmask")?, *base)
            }
        },
        CommandMap::Wrench(cols) => {
            let mut at = [None; 6];
            for (i, c) in cols.iter().enumerate() {
                if let Some(c) = c {
                    at[i] = Some(find(header, c, &format!("[wrench].{}", WRENCH_COLUMNS[i]))?);
                }
            }
            CommandColumns::Wrench(at)
        }
    };
    Ok(Columns {
        time,
        rates,
        commands,
    })
}

/// A 0/1 state: `0`, `1`, `true`, `false` (any case).
fn on_off(s: &str) -> Option<bool> {
    match s {
        "0" => Some(false),
        "1" => Some(true),
        _ if s.eq_ignore_ascii_case("true") => Some(true),
        _ if s.eq_ignore_ascii_case("false") => Some(false),
        _ => None,
    }
}

/// A finite number.
fn number(f: &str) -> Result<f64, String> {
    match f.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(_) => Err(format!("{:?} is not finite", clip(f))),
        Err(_) => Err(format!("{:?} is not a number", clip(f))),
    }
}

/// The thruster word of a packed list: `[1, 0, 1]`, `(1 0 1)`, `1,0,1` or `1 0 1`.
fn vector_word(f: &str, n: usize) -> Result<u16, String> {
    let inner = f.trim();
    let inner = inner
        .strip_prefix('[')
        .and_then(|s| s.strip_suffix(']'))
        .or_else(|| inner.strip_prefix('(').and_then(|s| s.strip_suffix(')')))
        .unwrap_or(inner);
    let mut word = 0u16;
    let mut k = 0;
    for e in inner
        .split(|c: char| c == ',' || c.is_whitespace())
        .filter(|e| !e.is_empty())
    {
        if k == n {
            return Err(format!("{:?} has more than {n} entries", clip(f)));
        }
        match on_off(e) {
            Some(true) => word |= 1 << k,
            Some(false) => {}
            None => {
                return Err(format!(
                    "{:?}: entry {} {:?} is not 0/1 or true/false",
                    clip(f),
                    k + 1,
                    clip(e)
                ))
            }
        }
        k += 1;
    }
    if k != n {
        return Err(format!("{:?} has {k} entries, expected {n}", clip(f)));
    }
    Ok(word)
}

/// The thruster word of an integer in `base` (`0x` / `0b` prefixes accepted for 16 / 2).
fn bitmask_word(f: &str, base: u32, n: usize) -> Result<u16, String> {
    let digits = match base {
        16 => f
            .strip_prefix("0x")
            .or_else(|| f.strip_prefix("0X"))
            .unwrap_or(f),
        2 => f
            .strip_prefix("0b")
            .or_else(|| f.strip_prefix("0B"))
            .unwrap_or(f),
        _ => f,
    };
    // from_str_radix accepts a leading '+'; a bitmask is digits only.
    if digits.is_empty() || !digits.chars().all(|c| c.is_digit(base)) {
        return Err(format!("{:?} is not a base-{base} integer", clip(f)));
    }
    let w = u32::from_str_radix(digits, base)
        .map_err(|_| format!("{:?} is out of range for {n} thrusters", clip(f)))?;
    if w >> n != 0 {
        return Err(format!(
            "{:?} = {w} is out of range 0..{} for {n} thrusters",
            clip(f),
            (1u32 << n) - 1
        ));
    }
    Ok(w as u16)
}

/// [`import`] on any reader; `source` names the log in errors.
pub fn import_reader<R: Read>(
    mapping: &Mapping,
    r: R,
    source: &str,
) -> Result<RateRecording, RecordingError> {
    let err = |line: usize, reason: String| RecordingError {
        file: source.to_string(),
        line,
        reason,
    };
    let csv_err = |e: csv::Error| {
        let line = e.position().map_or(0, |p| p.line() as usize);
        let reason = match e.kind() {
            csv::ErrorKind::UnequalLengths {
                expected_len, len, ..
            } => format!("row has {len} fields, the header has {expected_len}"),
            csv::ErrorKind::Utf8 { .. } => "line is not valid UTF-8".to_string(),
            _ => e.to_string(),
        };
        err(line, reason)
    };
    let mut rdr = csv::ReaderBuilder::new()
        .has_headers(true)
        .trim(csv::Trim::All)
        .from_reader(r);
    let header = rdr.headers().map_err(csv_err)?.clone();
    if header.is_empty() || (header.len() == 1 && header[0].is_empty()) {
        return Err(err(1, "empty file (expected a header line)".to_string()));
    }
    let cols = locate(&header, mapping).map_err(|r| err(1, r))?;
    let n = match &mapping.commands {
        CommandMap::Thrusters { count, .. } => *count,
        CommandMap::Wrench(_) => 0,
    };
    let kind = match &mapping.commands {
        CommandMap::Thrusters { count, .. } => Commands::Thrusters {
            n: *count,
            words: Vec::new(),
        },
        CommandMap::Wrench(c) => Commands::Wrench {
            present: [0, 1, 2, 3, 4, 5].map(|i| c[i].is_some()),
            values: Vec::new(),
        },
    };
    let mut rows = RowCollector::new(&kind);
    let ms_per_unit = mapping.time.unit.ms_per_unit();
    let mut t0: Option<f64> = None;
    let mut record = csv::StringRecord::new();
    while rdr.read_record(&mut record).map_err(csv_err)? {
        let line = record.position().map_or(0, |p| p.line() as usize);
        let field = |i: usize| record.get(i).unwrap_or("");
        let bad = |i: usize, reason: String| err(line, format!("column {}: {reason}", &header[i]));

        let tf = field(cols.time);
        if tf.is_empty() {
            return Err(bad(cols.time, "the time is empty".to_string()));
        }
        let t = number(tf).map_err(|r| bad(cols.time, r))?;
        let origin = if mapping.time.start_zero {
            *t0.get_or_insert(t)
        } else {
            0.0
        };
        let ms = ((t - origin) * ms_per_unit).round();
        if ms < 0.0 {
            return Err(bad(
                cols.time,
                if mapping.time.start_zero {
                    format!("time {tf} is before the first row's: time goes backwards")
                } else {
                    format!("time {tf} is negative (start = \"zero\" subtracts the first time)")
                },
            ));
        }
        if ms >= 1.8e19 {
            return Err(bad(cols.time, format!("time {tf} is out of range")));
        }

        let mut rate = [f64::NAN; 3];
        for (i, r) in cols.rates.iter().enumerate() {
            if let Some((c, map)) = r {
                let f = field(*c);
                if !f.is_empty() {
                    rate[i] = map.to_rad_s(number(f).map_err(|r| bad(*c, r))?);
                }
            }
        }

        let command = match &cols.commands {
            CommandColumns::Columns(cs) => {
                let mut w = 0u16;
                for (k, &c) in cs.iter().enumerate() {
                    match on_off(field(c)) {
                        Some(true) => w |= 1 << k,
                        Some(false) => {}
                        None => {
                            return Err(bad(
                                c,
                                format!("{:?} is not 0/1 or true/false", clip(field(c))),
                            ))
                        }
                    }
                }
                Command::Word(w)
            }
            CommandColumns::Vector(c) => {
                Command::Word(vector_word(field(*c), n).map_err(|r| bad(*c, r))?)
            }
            CommandColumns::Bitmask(c, base) => {
                Command::Word(bitmask_word(field(*c), *base, n).map_err(|r| bad(*c, r))?)
            }
            CommandColumns::Wrench(cs) => {
                let mut v = [f64::NAN; 6];
                for (i, c) in cs.iter().enumerate() {
                    if let Some(c) = *c {
                        let f = field(c);
                        if f.is_empty() {
                            return Err(bad(c, "the command is empty".to_string()));
                        }
                        v[i] = number(f).map_err(|r| bad(c, r))?;
                    }
                }
                Command::Wrench(v)
            }
        };
        rows.push(ms as u64, rate, command)
            .map_err(|r| bad(cols.time, r))?;
    }

    if rows.is_empty() {
        return Err(err(1, "the log has a header but no data rows".to_string()));
    }
    let axes = mapping.axes();
    let file_name = |p: &str| {
        Path::new(p)
            .file_name()
            .map(|f| f.to_string_lossy().replace(char::is_control, "?"))
            .unwrap_or_default()
    };
    // A declared rate must agree with the log's time steps within 10 % (the rule every
    // subcommand applies to a recording): 1000 Hz over 60 ms steps is no "3269 gaps". A
    // median of fewer than 10 steps says too little to overrule the mapping.
    if let (Some(r), Some(step)) = (mapping.sample_rate_hz, rows.median_step_ms(10)) {
        let period = 1000.0 / r;
        if (step - period).abs() > 0.1 * period.max(step) {
            return Err(RecordingError {
                file: mapping.source.clone(),
                line: mapping.sample_rate_line,
                reason: format!(
                    "sample_rate_hz = {r} declares a {period} ms period, but the time steps of {} are {step} ms (median): fix the rate or leave it out (the median step is then used)",
                    Path::new(source).display()
                ),
            });
        }
    }
    let mut metadata =
        RateRecording::base_metadata(&mapping.satellite, axes, &kind, mapping.sample_rate_hz);
    metadata.push(("imported_from".to_string(), file_name(source)));
    metadata.push(("mapping".to_string(), file_name(&mapping.source)));
    Ok(rows.finish(source, metadata, axes, mapping.sample_rate_hz))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn packed_lists_and_bitmasks() {
        assert_eq!(vector_word("[1, 0, 1, 0, 1, 0, 1, 0]", 8), Ok(0b0101_0101));
        assert_eq!(vector_word("0 1 1", 3), Ok(0b110));
        assert_eq!(vector_word("(true,false)", 2), Ok(1));
        assert!(vector_word("[1, 0]", 3).unwrap_err().contains("2 entries"));
        assert!(vector_word("[1, 0, 1, 1]", 3)
            .unwrap_err()
            .contains("more than 3"));
        assert!(vector_word("[1, 2]", 2).unwrap_err().contains("entry 2"));
        assert_eq!(bitmask_word("0xff", 16, 8), Ok(255));
        assert_eq!(bitmask_word("FF", 16, 8), Ok(255));
        assert_eq!(bitmask_word("0b101", 2, 3), Ok(5));
        assert_eq!(bitmask_word("65535", 10, 16), Ok(65535));
        assert!(bitmask_word("256", 10, 8)
            .unwrap_err()
            .contains("out of range"));
        assert!(bitmask_word("+1", 10, 8).is_err());
        assert!(bitmask_word("12", 2, 8).is_err());
        assert!(bitmask_word("99999999999", 10, 8).is_err());
    }
}
