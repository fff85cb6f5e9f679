//! Recordings in `massid-recording/2` format: angular rates in physical units (rad/s) on any
//! subset of the body axes, plus either a thruster word for up to 16 thrusters or a commanded
//! body wrench. v1 ([`crate::recording`]) stores 12-bit gyro counts and a 12-thruster word,
//! which fits SPHERES but not a craft whose rates come from motion capture; forcing those
//! rates through counts would quantise them, so v2 keeps them as they were measured.
//!
//! ```text
//! # format = massid-recording/2
//! # satellite = airbearing-mpc
//! # axes = z                 (measured rate axes: non-empty subset of x,y,z, in that order)
//! # thrusters = 8            (N, 1..=16; absent when the commands are a body wrench)
//! # sample_rate_hz = 16.667  (optional, as in v1)
//! time_ms,rate_z,thrusters
//! 0,0.261371637295856,85
//! 60,0.268115155702507,116
//! ```
//!
//! - `time_ms`: integer >= 0. As in v1: a repeated time keeps the first row (counted in
//!   [`DataIssues::duplicates`]), a step over 1.5 nominal periods is a gap (gaps and missing
//!   samples counted), time going backwards is an error.
//! - `rate_<axis>`: one column per listed axis, f64 rad/s, finite. An empty field is a sample
//!   missing on that axis (NaN in memory); anything else that is not a finite number is an error.
//! - Commands, held until the next row, either `thrusters` (integer 0..2^N-1, bit i =
//!   thruster i+1 commanded open; needs the `thrusters` key) or any non-empty subset of
//!   `force_x,force_y,force_z` (N) and `torque_x,torque_y,torque_z` (N m, about the model's
//!   centre of mass), body axes, finite (no `thrusters` key then).
//! - Columns may come in any order, each once; metadata, comments, blank lines, `\r\n` and a
//!   byte-order mark follow the v1 rules. `saturated` is always 0 (there are no counts).
//!
//! Every rejection is `file:line: reason`; nothing allocates in proportion to a number read
//! from the input.
use crate::recording::{
    clip, format_rate, read_text_line, DataIssues, RecordingError, StepHistogram, FORMAT_V1,
};
use std::io::{BufRead, Write};
use std::path::Path;

/// The format version this module reads and writes.
pub const FORMAT_V2: &str = "massid-recording/2";
/// Most thrusters a v2 word holds: the models' limit.
pub use crate::satellite::MAX_THRUSTERS;
/// Axis names in storage order.
pub const AXES: [&str; 3] = ["x", "y", "z"];
/// Wrench columns in storage order (N for forces, N m for torques).
pub const WRENCH_COLUMNS: [&str; 6] = [
    "force_x", "force_y", "force_z", "torque_x", "torque_y", "torque_z",
];

/// The commands of every kept sample, one entry per sample.
#[derive(Clone, Debug, PartialEq)]
pub enum Commands {
    /// `n` thrusters; bit i of a word = thruster i+1 commanded open.
    Thrusters { n: usize, words: Vec<u16> },
    /// Commanded body wrench; `present` says which of [`WRENCH_COLUMNS`] the file has
    /// (absent components are NaN in `values`).
    Wrench {
        present: [bool; 6],
        values: Vec<[f64; 6]>,
    },
}

/// One sample's command, before it is stored in [`Commands`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Command {
    Word(u16),
    Wrench([f64; 6]),
}

impl Commands {
    /// Number of samples.
    pub fn len(&self) -> usize {
        match self {
            Commands::Thrusters { words, .. } => words.len(),
            Commands::Wrench { values, .. } => values.len(),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The same kind of commands with no samples.
    fn empty_like(&self) -> Commands {
        match self {
            Commands::Thrusters { n, .. } => Commands::Thrusters {
                n: *n,
                words: Vec::new(),
            },
            Commands::Wrench { present, .. } => Commands::Wrench {
                present: *present,
                values: Vec::new(),
            },
        }
    }

    fn push(&mut self, c: Command) {
        match (self, c) {
            (Commands::Thrusters { words, .. }, Command::Word(w)) => words.push(w),
            (Commands::Wrench { values, .. }, Command::Wrench(v)) => values.push(v),
            // The builder only pushes the kind it was made with.
            _ => {}
        }
    }
}

/// A whole v2 recording in memory.
#[derive(Clone, Debug)]
pub struct RateRecording {
    /// File name (for messages).
    pub source: String,
    /// Every `# key = value`, in file order, unknown keys kept.
    pub metadata: Vec<(String, String)>,
    /// Which of x, y, z are measured.
    pub axes: [bool; 3],
    /// Sample times, strictly increasing (duplicates removed, first wins).
    pub time_ms: Vec<u64>,
    /// rad/s; NaN on unmeasured axes and for missing fields.
    pub rate: Vec<[f64; 3]>,
    pub commands: Commands,
    pub issues: DataIssues,
}

/// Collects rows in time order with v1's rules (first duplicate wins, backwards time is an
/// error); the v2 reader and the importer share it so both count issues the same way.
#[derive(Clone, Debug)]
pub(crate) struct RowCollector {
    time_ms: Vec<u64>,
    rate: Vec<[f64; 3]>,
    commands: Commands,
    steps: StepHistogram,
    duplicates: usize,
}

impl RowCollector {
    /// `kind` gives the command kind (its samples are ignored).
    pub(crate) fn new(kind: &Commands) -> RowCollector {
        RowCollector {
            time_ms: Vec::new(),
            rate: Vec::new(),
            commands: kind.empty_like(),
            steps: StepHistogram::default(),
            duplicates: 0,
        }
    }

    /// Median step between kept rows, ms, when there are at least `min_steps` steps.
    pub(crate) fn median_step_ms(&self, min_steps: usize) -> Option<f64> {
        if self.steps.count() < min_steps.max(1) {
            return None;
        }
        self.steps.median()
    }

    /// True before the first kept row.
    pub(crate) fn is_empty(&self) -> bool {
        self.time_ms.is_empty()
    }

    /// Adds a row; Ok(false) when it repeats the last time (dropped), Err(reason) when
    /// time goes backwards.
    pub(crate) fn push(&mut self, t: u64, rate: [f64; 3], c: Command) -> Result<bool, String> {
        if let Some(&last) = self.time_ms.last() {
            if t < last {
                return Err(format!("time_ms goes backwards ({t} after {last})"));
            }
            if t == last {
                self.duplicates += 1;
                return Ok(false);
            }
            self.steps.add(t - last);
        }
        self.time_ms.push(t);
        self.rate.push(rate);
        self.commands.push(c);
        Ok(true)
    }

    /// The recording; gaps judged against `sample_rate_hz` when given, else the median step.
    pub(crate) fn finish(
        self,
        source: &str,
        metadata: Vec<(String, String)>,
        axes: [bool; 3],
        sample_rate_hz: Option<f64>,
    ) -> RateRecording {
        let period = sample_rate_hz
            .map(|r| 1000.0 / r)
            .or_else(|| self.steps.median())
            .unwrap_or(1.0);
        let (gaps, missing_samples) = self.steps.gaps(period);
        RateRecording {
            source: source.to_string(),
            metadata,
            axes,
            time_ms: self.time_ms,
            rate: self.rate,
            commands: self.commands,
            issues: DataIssues {
                gaps,
                missing_samples,
                duplicates: self.duplicates,
                saturated: 0,
            },
        }
    }
}

/// `x,y,z` style list of the measured axes.
fn axes_text(axes: [bool; 3]) -> String {
    AXES.iter()
        .zip(axes)
        .filter(|(_, on)| *on)
        .map(|(a, _)| *a)
        .collect::<Vec<_>>()
        .join(",")
}

/// Parses the `axes` value: a non-empty subset of x,y,z in that order.
fn parse_axes(v: &str) -> Result<[bool; 3], String> {
    let mut axes = [false; 3];
    let mut next = 0;
    for a in v.split(',').map(str::trim) {
        match AXES.iter().position(|x| *x == a) {
            Some(i) if i >= next => {
                axes[i] = true;
                next = i + 1;
            }
            Some(_) => {
                return Err(format!(
                    "axes '{}': each of x, y, z at most once, in that order",
                    clip(v)
                ))
            }
            None => {
                return Err(format!(
                    "axes '{}': expected a non-empty subset of x,y,z (e.g. 'z' or 'x,y,z')",
                    clip(v)
                ))
            }
        }
    }
    Ok(axes)
}

/// Reads only the metadata lines of a recording and returns its format version (1 or 2),
/// so a tool can pick the reader. Errors like the readers': missing or unknown format.
pub fn format_version(path: &Path) -> Result<u32, RecordingError> {
    let source = path.display().to_string();
    let f = std::fs::File::open(path).map_err(|e| RecordingError {
        file: source.clone(),
        line: 0,
        reason: format!("cannot open: {e}"),
    })?;
    format_version_from(std::io::BufReader::new(f), &source)
}

/// [`format_version`] on any buffered reader.
pub fn format_version_from<R: BufRead>(mut r: R, source: &str) -> Result<u32, RecordingError> {
    let err = |line: usize, reason: String| RecordingError {
        file: source.to_string(),
        line,
        reason,
    };
    let mut buf = Vec::new();
    let mut line_no = 0;
    while let Some(line) = read_text_line(&mut r, &mut buf, &mut line_no, source)? {
        let t = line.trim();
        if t.is_empty() {
            continue;
        }
        let Some(body) = t.strip_prefix('#') else {
            break;
        };
        if let Some((k, v)) = body.split_once('=') {
            if k.trim() == "format" {
                return match v.trim() {
                    FORMAT_V1 => Ok(1),
                    FORMAT_V2 => Ok(2),
                    v => Err(err(
                        line_no,
                        format!(
                            "unknown format '{}' (this tool knows {FORMAT_V1} and {FORMAT_V2})",
                            clip(v)
                        ),
                    )),
                };
            }
        }
    }
    if line_no == 0 {
        return Err(err(1, "empty file".to_string()));
    }
    Err(err(
        line_no,
        "missing 'format' metadata key (expected '# format = massid-recording/1' or '/2')"
            .to_string(),
    ))
}

/// What a header column holds.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Slot {
    Time,
    Rate(usize),
    Thrusters,
    Wrench(usize),
}

impl Slot {
    fn name(self) -> String {
        match self {
            Slot::Time => "time_ms".to_string(),
            Slot::Rate(i) => format!("rate_{}", AXES[i]),
            Slot::Thrusters => "thrusters".to_string(),
            Slot::Wrench(i) => WRENCH_COLUMNS[i].to_string(),
        }
    }
}

/// Parses a v2 file line by line (the recording is held once, as the result).
struct Parser<R> {
    input: R,
    source: String,
    line_no: usize,
    buf: Vec<u8>,
}

impl<R: BufRead> Parser<R> {
    fn error(&self, reason: impl Into<String>) -> RecordingError {
        self.error_at(self.line_no, reason)
    }

    fn error_at(&self, line: usize, reason: impl Into<String>) -> RecordingError {
        RecordingError {
            file: self.source.clone(),
            line,
            reason: reason.into(),
        }
    }

    fn next_line(&mut self) -> Result<Option<String>, RecordingError> {
        read_text_line(
            &mut self.input,
            &mut self.buf,
            &mut self.line_no,
            &self.source,
        )
    }

    fn read(mut self) -> Result<RateRecording, RecordingError> {
        let mut metadata: Vec<(String, String)> = Vec::new();
        let mut format_line: Option<(usize, String)> = None;
        let mut axes: Option<[bool; 3]> = None;
        let mut thrusters: Option<usize> = None;
        let mut rate_hz: Option<f64> = None;
        let mut any_line = false;
        let header = loop {
            let Some(line) = self.next_line()? else {
                return Err(if any_line {
                    self.error("no header line (expected time_ms,rate_...,thrusters)")
                } else {
                    self.error_at(1, "empty file")
                });
            };
            any_line = true;
            let t = line.trim();
            if t.is_empty() {
                continue;
            }
            let Some(body) = t.strip_prefix('#') else {
                break line;
            };
            let Some((k, v)) = body.split_once('=') else {
                continue; // a comment
            };
            let (k, v) = (k.trim().to_string(), v.trim().to_string());
            let first = !metadata.iter().any(|(key, _)| *key == k);
            match k.as_str() {
                "format" if first => format_line = Some((self.line_no, v.clone())),
                "axes" if first => axes = Some(parse_axes(&v).map_err(|r| self.error(r))?),
                "thrusters" if first => {
                    let n = v
                        .parse::<usize>()
                        .ok()
                        .filter(|n| (1..=MAX_THRUSTERS).contains(n))
                        .ok_or_else(|| {
                            self.error(format!(
                                "thrusters '{}' is not a count in 1..={MAX_THRUSTERS}",
                                clip(&v)
                            ))
                        })?;
                    thrusters = Some(n);
                }
                "sample_rate_hz" if first => match v.parse::<f64>() {
                    Ok(r) if r.is_finite() && r > 0.0 => rate_hz = Some(r),
                    _ => {
                        return Err(self.error(format!(
                            "sample_rate_hz '{}' is not a positive number",
                            clip(&v)
                        )))
                    }
                },
                _ => {}
            }
            metadata.push((k, v));
        };
        let header_line = self.line_no;
        match &format_line {
            None => {
                return Err(self.error_at(
                    header_line,
                    format!("missing 'format' metadata key (expected '# format = {FORMAT_V2}')"),
                ))
            }
            Some((_, v)) if v == FORMAT_V2 => {}
            Some((l, v)) if v.starts_with("massid-recording/") => {
                return Err(self.error_at(
                    *l,
                    format!(
                        "unknown format version '{}' (this reader knows {FORMAT_V2}; {FORMAT_V1} has its own reader)",
                        clip(v)
                    ),
                ))
            }
            Some((l, v)) => {
                return Err(self.error_at(
                    *l,
                    format!("unknown format '{}' (expected {FORMAT_V2})", clip(v)),
                ))
            }
        }
        let axes = axes.ok_or_else(|| {
            self.error_at(
                header_line,
                "missing 'axes' metadata key (e.g. '# axes = z' or '# axes = x,y,z')",
            )
        })?;
        let slots = self.parse_header(&header, axes, thrusters)?;
        let kind = match thrusters {
            Some(n) => Commands::Thrusters {
                n,
                words: Vec::new(),
            },
            None => {
                let mut present = [false; 6];
                for s in &slots {
                    if let Slot::Wrench(i) = s {
                        present[*i] = true;
                    }
                }
                Commands::Wrench {
                    present,
                    values: Vec::new(),
                }
            }
        };
        let mut rows = RowCollector::new(&kind);
        while let Some(line) = self.next_line()? {
            if line.trim().is_empty() {
                continue;
            }
            let (t, rate, c) = self.parse_row(&line, &slots, thrusters)?;
            rows.push(t, rate, c).map_err(|r| self.error(r))?;
        }
        Ok(rows.finish(&self.source, metadata, axes, rate_hz))
    }

    fn parse_header(
        &self,
        header: &str,
        axes: [bool; 3],
        thrusters: Option<usize>,
    ) -> Result<Vec<Slot>, RecordingError> {
        let mut slots: Vec<Slot> = Vec::new();
        for n in header.split(',').map(str::trim) {
            let slot = if n == "time_ms" {
                Slot::Time
            } else if n == "thrusters" {
                if thrusters.is_none() {
                    return Err(self.error(
                        "header column 'thrusters' needs a '# thrusters = N' metadata key",
                    ));
                }
                Slot::Thrusters
            } else if let Some(i) = n
                .strip_prefix("rate_")
                .and_then(|a| AXES.iter().position(|x| *x == a))
            {
                if !axes[i] {
                    return Err(self.error(format!(
                        "header column '{n}' is not in axes = {}",
                        axes_text(axes)
                    )));
                }
                Slot::Rate(i)
            } else if let Some(i) = WRENCH_COLUMNS.iter().position(|c| *c == n) {
                if thrusters.is_some() {
                    return Err(self.error(format!(
                        "header column '{n}': a recording has thruster words or a wrench, not both"
                    )));
                }
                Slot::Wrench(i)
            } else {
                return Err(self.error(format!("unknown header column '{}'", clip(n))));
            };
            if slots.contains(&slot) {
                return Err(self.error(format!("header column '{n}' appears twice")));
            }
            slots.push(slot);
        }
        let mut missing: Vec<String> = Vec::new();
        if !slots.contains(&Slot::Time) {
            missing.push("time_ms".to_string());
        }
        for i in 0..3 {
            if axes[i] && !slots.contains(&Slot::Rate(i)) {
                missing.push(Slot::Rate(i).name());
            }
        }
        match thrusters {
            Some(_) if !slots.contains(&Slot::Thrusters) => missing.push("thrusters".to_string()),
            None if !slots.iter().any(|s| matches!(s, Slot::Wrench(_))) => missing.push(
                "thrusters (with a '# thrusters = N' key) or a wrench column (force_x, ..., torque_z)"
                    .to_string(),
            ),
            _ => {}
        }
        if !missing.is_empty() {
            return Err(self.error(format!("missing header column(s): {}", missing.join(", "))));
        }
        Ok(slots)
    }

    fn parse_row(
        &self,
        line: &str,
        slots: &[Slot],
        thrusters: Option<usize>,
    ) -> Result<(u64, [f64; 3], Command), RecordingError> {
        let fields: Vec<&str> = line.split(',').collect();
        if fields.len() != slots.len() {
            return Err(self.error(format!(
                "row has {} fields, the header has {}",
                fields.len(),
                slots.len()
            )));
        }
        let mut t = 0;
        let mut rate = [f64::NAN; 3];
        let mut word = 0u16;
        let mut wrench = [f64::NAN; 6];
        for (field, &slot) in fields.iter().zip(slots) {
            let f = field.trim();
            let name = slot.name();
            match slot {
                Slot::Time => t = self.integer(f, &name)?,
                Slot::Thrusters => {
                    let n = thrusters.unwrap_or(MAX_THRUSTERS);
                    let w = self.integer(f, &name)?;
                    if w >> n != 0 {
                        return Err(self.error(format!(
                            "thrusters {w} is out of range 0..{} for {n} thrusters",
                            (1u64 << n) - 1
                        )));
                    }
                    word = w as u16;
                }
                Slot::Rate(i) => {
                    if !f.is_empty() {
                        rate[i] = self.number(f, &name)?;
                    }
                }
                Slot::Wrench(i) => {
                    if f.is_empty() {
                        return Err(self.error(format!("{name} is empty")));
                    }
                    wrench[i] = self.number(f, &name)?;
                }
            }
        }
        let c = match thrusters {
            Some(_) => Command::Word(word),
            None => Command::Wrench(wrench),
        };
        Ok((t, rate, c))
    }

    fn integer(&self, f: &str, name: &str) -> Result<u64, RecordingError> {
        let shown = clip(f);
        if f.is_empty() {
            Err(self.error(format!("{name} is empty")))
        } else if f.bytes().all(|b| b.is_ascii_digit()) {
            f.parse()
                .map_err(|_| self.error(format!("{name} '{shown}' is out of range")))
        } else if f.len() > 1 && f.starts_with('-') && f[1..].bytes().all(|b| b.is_ascii_digit()) {
            Err(self.error(format!("{name} '{shown}' is out of range (negative)")))
        } else {
            Err(self.error(format!("{name} '{shown}' is not an integer")))
        }
    }

    fn number(&self, f: &str, name: &str) -> Result<f64, RecordingError> {
        match f.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            Ok(_) => Err(self.error(format!("{name} '{}' is not finite", clip(f)))),
            Err(_) => Err(self.error(format!("{name} '{}' is not a number", clip(f)))),
        }
    }
}

impl RateRecording {
    /// Reads a v2 file. Errors name the file, the line and the reason.
    pub fn read(path: &Path) -> Result<RateRecording, RecordingError> {
        let source = path.display().to_string();
        let f = std::fs::File::open(path).map_err(|e| RecordingError {
            file: source.clone(),
            line: 0,
            reason: format!("cannot open: {e}"),
        })?;
        Self::from_reader(std::io::BufReader::new(f), &source)
    }

    /// Reads v2 text from any buffered reader; `source` names it in errors.
    pub fn from_reader<R: BufRead>(r: R, source: &str) -> Result<RateRecording, RecordingError> {
        Parser {
            input: r,
            source: source.to_string(),
            line_no: 0,
            buf: Vec::new(),
        }
        .read()
    }

    /// Writes the recording to `path` atomically (a temporary file beside it, then a
    /// rename), as v1's writer does; the caller checks that `path` is not an input.
    pub fn write(&self, path: &Path) -> Result<(), RecordingError> {
        let name = path.display().to_string();
        let file_name = path
            .file_name()
            .map(|f| f.to_string_lossy().into_owned())
            .unwrap_or_default();
        let tmp = path.with_file_name(format!(".{file_name}.tmp{}", std::process::id()));
        let result = (|| {
            let f = std::fs::File::create(&tmp)?;
            let mut w = std::io::BufWriter::new(f);
            self.write_to(&mut w)?;
            w.flush()?;
            w.get_ref().sync_all()?;
            drop(w);
            std::fs::rename(&tmp, path)
        })();
        if result.is_err() {
            let _ = std::fs::remove_file(&tmp);
        }
        result.map_err(|e| RecordingError {
            file: name,
            line: 0,
            reason: e.to_string(),
        })
    }

    /// Writes v2 text: `format` first, the other metadata in order (the `axes` and
    /// `thrusters` values taken from the fields, so the file always agrees with them), the
    /// header and one row per sample. Rates print in Rust's shortest round-trip form, so
    /// reading back gives the same f64 bits; a NaN rate is an empty field.
    pub fn write_to<W: Write>(&self, w: W) -> std::io::Result<()> {
        let mut w = std::io::BufWriter::new(w);
        let n = match &self.commands {
            Commands::Thrusters { n, .. } => Some(*n),
            Commands::Wrench { .. } => None,
        };
        writeln!(w, "# format = {FORMAT_V2}")?;
        let (mut wrote_axes, mut wrote_n) = (false, false);
        for (k, v) in &self.metadata {
            match k.as_str() {
                "format" => {}
                "axes" if !wrote_axes => {
                    writeln!(w, "# axes = {}", axes_text(self.axes))?;
                    wrote_axes = true;
                }
                "thrusters" if !wrote_n => {
                    if let Some(n) = n {
                        writeln!(w, "# thrusters = {n}")?;
                    }
                    wrote_n = true;
                }
                "axes" | "thrusters" => {}
                _ => writeln!(w, "# {k} = {v}")?,
            }
        }
        if !wrote_axes {
            writeln!(w, "# axes = {}", axes_text(self.axes))?;
        }
        if let (Some(n), false) = (n, wrote_n) {
            writeln!(w, "# thrusters = {n}")?;
        }
        let mut header = vec!["time_ms".to_string()];
        for i in 0..3 {
            if self.axes[i] {
                header.push(format!("rate_{}", AXES[i]));
            }
        }
        match &self.commands {
            Commands::Thrusters { .. } => header.push("thrusters".to_string()),
            Commands::Wrench { present, .. } => {
                for i in 0..6 {
                    if present[i] {
                        header.push(WRENCH_COLUMNS[i].to_string());
                    }
                }
            }
        }
        writeln!(w, "{}", header.join(","))?;
        for k in 0..self.time_ms.len() {
            write!(w, "{}", self.time_ms[k])?;
            for i in 0..3 {
                if self.axes[i] {
                    match self.rate.get(k).map(|r| r[i]) {
                        Some(v) if v.is_finite() => write!(w, ",{v}")?,
                        _ => write!(w, ",")?,
                    }
                }
            }
            match &self.commands {
                Commands::Thrusters { words, .. } => {
                    write!(w, ",{}", words.get(k).copied().unwrap_or(0))?
                }
                Commands::Wrench { present, values } => {
                    for i in 0..6 {
                        if present[i] {
                            write!(w, ",{}", values.get(k).map_or(0.0, |v| v[i]))?;
                        }
                    }
                }
            }
            writeln!(w)?;
        }
        w.flush()
    }

    /// The first value of a metadata key.
    pub fn meta(&self, key: &str) -> Option<&str> {
        self.metadata
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    }

    /// The `satellite` metadata, if any.
    pub fn satellite(&self) -> Option<&str> {
        self.meta("satellite")
    }

    /// The measured axes as written in the file (`z`, `x,y,z`, ...).
    pub fn axes_text(&self) -> String {
        axes_text(self.axes)
    }

    /// Sample rate: the `sample_rate_hz` metadata, else 1000 / median time step, else
    /// v1's default (1000 Hz).
    pub fn sample_rate_hz(&self) -> f64 {
        if let Some(r) = self
            .meta("sample_rate_hz")
            .and_then(|v| v.trim().parse::<f64>().ok())
            .filter(|r| r.is_finite() && *r > 0.0)
        {
            return r;
        }
        let mut steps = StepHistogram::default();
        for w in self.time_ms.windows(2) {
            steps.add(w[1].saturating_sub(w[0]));
        }
        steps
            .median()
            .map(|p| 1000.0 / p)
            .unwrap_or(crate::recording::DEFAULT_SAMPLE_RATE_HZ)
    }

    /// The metadata a new recording starts with: format, satellite, axes, thrusters (for
    /// thruster words) and sample_rate_hz when given, in that order.
    pub fn base_metadata(
        satellite: &str,
        axes: [bool; 3],
        commands: &Commands,
        sample_rate_hz: Option<f64>,
    ) -> Vec<(String, String)> {
        let mut m = vec![
            ("format".to_string(), FORMAT_V2.to_string()),
            ("satellite".to_string(), satellite.to_string()),
            ("axes".to_string(), axes_text(axes)),
        ];
        if let Commands::Thrusters { n, .. } = commands {
            m.push(("thrusters".to_string(), n.to_string()));
        }
        if let Some(r) = sample_rate_hz {
            m.push(("sample_rate_hz".to_string(), format_rate(r)));
        }
        m
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    const GOOD: &str = "# format = massid-recording/2\n# satellite = airbearing-mpc\n# axes = z\n# thrusters = 8\n# sample_rate_hz = 16.667\n# custom = kept\ntime_ms,rate_z,thrusters\n0,0.261371637295856,85\n60,0.268115155702507,116\n";

    fn read(s: &str) -> Result<RateRecording, RecordingError> {
        RateRecording::from_reader(s.as_bytes(), "t.csv")
    }

    fn write(r: &RateRecording) -> String {
        let mut out = Vec::new();
        r.write_to(&mut out).unwrap();
        String::from_utf8(out).unwrap()
    }

    #[test]
    fn reads_the_spec_example_and_writes_it_back_byte_for_byte() {
        let r = read(GOOD).unwrap();
        assert_eq!(r.axes, [false, false, true]);
        assert_eq!(r.time_ms, vec![0, 60]);
        assert_eq!(r.rate[0][2], 0.261371637295856);
        assert!(r.rate[0][0].is_nan() && r.rate[1][1].is_nan());
        assert_eq!(
            r.commands,
            Commands::Thrusters {
                n: 8,
                words: vec![85, 116]
            }
        );
        assert_eq!(r.satellite(), Some("airbearing-mpc"));
        assert_eq!(r.meta("custom"), Some("kept"));
        assert_eq!(r.sample_rate_hz(), 16.667);
        assert_eq!(r.issues, DataIssues::default());
        assert_eq!(write(&r), GOOD);
    }

    #[test]
    fn crlf_a_byte_order_mark_comments_and_blank_lines_read_as_in_v1() {
        let text = format!("\u{feff}{}", GOOD.replace('\n', "\r\n")).replace(
            "# custom",
            "# a comment without an equals sign\r\n\r\n# custom",
        );
        let r = read(&text).unwrap();
        assert_eq!(r.time_ms, vec![0, 60]);
        assert_eq!(write(&r), GOOD);
    }

    #[test]
    fn empty_rate_fields_are_missing_samples_and_survive_a_round_trip() {
        let text = "# format = massid-recording/2\n# axes = x,y,z\n# thrusters = 16\ntime_ms,rate_x,rate_y,rate_z,thrusters\n0,1,,3,65535\n10,,-0,1e-300,0\n";
        let r = read(text).unwrap();
        assert!(r.rate[0][1].is_nan() && r.rate[1][0].is_nan());
        assert!(r.rate[1][1] == 0.0 && r.rate[1][1].is_sign_negative());
        assert_eq!(r.rate[1][2], 1e-300);
        let back = read(&write(&r)).unwrap();
        assert_eq!(bits(&back.rate), bits(&r.rate));
        assert_eq!(back.commands, r.commands);
    }

    #[test]
    fn a_wrench_recording_reads_and_round_trips() {
        let text = "# format = massid-recording/2\n# axes = z\ntorque_z,time_ms,force_x,rate_z\n0.5,0,-1.25,0.1\n0,100,0,0.2\n";
        let r = read(text).unwrap();
        let Commands::Wrench { present, values } = &r.commands else {
            panic!("wrench expected")
        };
        assert_eq!(present, &[true, false, false, false, false, true]);
        assert_eq!(values[0][0], -1.25);
        assert_eq!(values[0][5], 0.5);
        assert!(values[0][1].is_nan());
        let back = read(&write(&r)).unwrap();
        assert_eq!(back.time_ms, r.time_ms);
        assert_eq!(bits(&back.rate), bits(&r.rate));
        let Commands::Wrench { values: v2, .. } = &back.commands else {
            panic!("wrench expected")
        };
        assert_eq!(
            v2.iter().map(|v| v.map(f64::to_bits)).collect::<Vec<_>>(),
            values
                .iter()
                .map(|v| v.map(f64::to_bits))
                .collect::<Vec<_>>()
        );
    }

    #[test]
    fn duplicates_gaps_like_v1() {
        let text = "# format = massid-recording/2\n# axes = z\n# thrusters = 1\ntime_ms,rate_z,thrusters\n0,1,0\n10,2,1\n10,9,0\n50,3,0\n60,4,1\n";
        let r = read(text).unwrap();
        assert_eq!(r.time_ms, vec![0, 10, 50, 60]);
        assert_eq!(r.rate[1][2], 2.0, "first duplicate wins");
        assert_eq!(
            r.issues,
            DataIssues {
                gaps: 1,
                missing_samples: 3,
                duplicates: 1,
                saturated: 0
            }
        );
        assert_eq!(r.sample_rate_hz(), 100.0);
    }

    fn bits(r: &[[f64; 3]]) -> Vec<[u64; 3]> {
        r.iter().map(|v| v.map(f64::to_bits)).collect()
    }

    #[test]
    fn every_error_names_file_line_reason() {
        let f = "# format = massid-recording/2";
        let m = "# format = massid-recording/2\n# axes = z\n# thrusters = 8";
        let h = "time_ms,rate_z,thrusters";
        let cases: Vec<(String, usize, &str)> = vec![
            (String::new(), 1, "empty file"),
            (format!("{m}\n"), 3, "no header"),
            (format!("# axes = z\n{h}\n"), 2, "missing 'format'"),
            (
                format!("# format = massid-recording/3\n# axes = z\n{h}\n"),
                1,
                "unknown format version",
            ),
            (format!("# format = csv\n{h}\n"), 1, "unknown format"),
            (format!("{f}\n# thrusters = 8\n{h}\n"), 3, "missing 'axes'"),
            (format!("{f}\n# axes = w\n{h}\n"), 2, "axes 'w'"),
            (format!("{f}\n# axes = z,x\n{h}\n"), 2, "in that order"),
            (format!("{f}\n# axes = \n{h}\n"), 2, "non-empty subset"),
            (
                format!("{f}\n# axes = z\n# thrusters = 17\n{h}\n"),
                3,
                "not a count in 1..=16",
            ),
            (
                format!("{f}\n# axes = z\n# thrusters = 0\n{h}\n"),
                3,
                "not a count",
            ),
            (
                format!("{f}\n# axes = z\n# sample_rate_hz = -1\n{h}\n"),
                3,
                "sample_rate_hz",
            ),
            (
                format!("{m}\ntime_ms,thrusters\n"),
                4,
                "missing header column(s): rate_z",
            ),
            (
                format!("{m}\ntime_ms,rate_z\n"),
                4,
                "missing header column(s): thrusters",
            ),
            (
                format!("{m}\n{h},rate_x\n"),
                4,
                "'rate_x' is not in axes = z",
            ),
            (
                format!("{m}\n{h},extra\n"),
                4,
                "unknown header column 'extra'",
            ),
            (format!("{m}\n{h},time_ms\n"), 4, "appears twice"),
            (format!("{m}\n{h},force_x\n"), 4, "not both"),
            (
                format!("{f}\n# axes = z\n{h}\n"),
                3,
                "needs a '# thrusters = N' metadata key",
            ),
            (
                format!("{f}\n# axes = z\ntime_ms,rate_z\n"),
                3,
                "or a wrench column",
            ),
            (
                format!("{m}\n{h}\n0,1,2\n10,1\n"),
                6,
                "row has 2 fields, the header has 3",
            ),
            (format!("{m}\n{h}\n0,1,2,3\n"), 5, "row has 4 fields"),
            (
                format!("{m}\n{h}\n0,abc,2\n"),
                5,
                "rate_z 'abc' is not a number",
            ),
            (
                format!("{m}\n{h}\n0,inf,2\n"),
                5,
                "rate_z 'inf' is not finite",
            ),
            (format!("{m}\n{h}\n0,NaN,2\n"), 5, "not finite"),
            (
                format!("{m}\n{h}\n0,1,256\n"),
                5,
                "thrusters 256 is out of range 0..255",
            ),
            (
                format!("{m}\n{h}\n0,1,1.5\n"),
                5,
                "thrusters '1.5' is not an integer",
            ),
            (format!("{m}\n{h}\n0,1,\n"), 5, "thrusters is empty"),
            (format!("{m}\n{h}\n-1,1,0\n"), 5, "out of range (negative)"),
            (
                format!("{m}\n{h}\n99999999999999999999999,1,0\n"),
                5,
                "time_ms '99999999999999999999999' is out of range",
            ),
            (
                format!("{m}\n{h}\n5,1,0\n4,1,0\n"),
                6,
                "time_ms goes backwards (4 after 5)",
            ),
            (
                format!("{f}\n# axes = z\ntime_ms,rate_z,torque_z\n0,1,\n"),
                4,
                "torque_z is empty",
            ),
            (
                format!("{f}\n# axes = z\ntime_ms,rate_z,torque_z\n0,1,x\n"),
                4,
                "torque_z 'x' is not a number",
            ),
        ];
        for (text, line, reason) in cases {
            let e = read(&text).expect_err(&text);
            assert_eq!(e.file, "t.csv");
            assert_eq!(e.line, line, "{text:?} -> {e}");
            assert!(e.reason.contains(reason), "{text:?} -> {e}");
            assert!(e.to_string().starts_with(&format!("t.csv:{line}: ")));
        }
    }

    #[test]
    fn format_version_dispatches() {
        let v = |s: &str| format_version_from(s.as_bytes(), "t.csv");
        assert_eq!(v(GOOD).unwrap(), 2);
        assert_eq!(
            v("# satellite = sph2\n# format = massid-recording/1\ntime_ms\n").unwrap(),
            1
        );
        let e = v("# format = massid-recording/9\n").unwrap_err();
        assert_eq!((e.line, e.reason.contains("unknown format")), (1, true));
        let e = v("# satellite = sph2\ntime_ms\n").unwrap_err();
        assert_eq!((e.line, e.reason.contains("missing 'format'")), (2, true));
        assert_eq!(v("").unwrap_err().reason, "empty file");
        // A v1 file is not a v2 file and the reverse: each reader names the other.
        let e = read(&GOOD.replace("recording/2", "recording/1")).unwrap_err();
        assert!(e.reason.contains("has its own reader"), "{e}");
    }

    /// A planted fault: a writer that swaps two columns' values must not survive the round
    /// trip the property test checks (so the property is strong enough to catch it).
    #[test]
    fn a_column_swap_fails_the_round_trip() {
        let text = "# format = massid-recording/2\n# axes = x,z\n# thrusters = 4\ntime_ms,rate_x,rate_z,thrusters\n0,0.5,0.25,3\n";
        let r = read(text).unwrap();
        let swapped = write(&r).replace("rate_x,rate_z", "rate_z,rate_x");
        let back = read(&swapped).unwrap();
        assert_ne!(bits(&back.rate), bits(&r.rate));
    }

    fn recording_strategy() -> impl Strategy<Value = RateRecording> {
        let rate = prop_oneof![
            4 => any::<f64>().prop_filter("finite", |v| v.is_finite()),
            1 => Just(f64::NAN),
        ];
        (
            1usize..8,
            1usize..=16,
            any::<bool>(),
            proptest::collection::vec(
                (
                    1u64..1000,
                    [rate.clone(), rate.clone(), rate],
                    any::<u16>(),
                    proptest::array::uniform6(-1e3f64..1e3),
                ),
                0..40,
            ),
            any::<bool>(),
        )
            .prop_map(|(axes_bits, n, wrench, rows, with_rate)| {
                let axes = [axes_bits & 1 != 0, axes_bits & 2 != 0, axes_bits & 4 != 0];
                let present = [true, false, true, false, false, true];
                let mut t = 0;
                let mut time_ms = Vec::new();
                let mut rate = Vec::new();
                let mut words = Vec::new();
                let mut values = Vec::new();
                for (dt, r, w, v) in rows {
                    t += dt;
                    time_ms.push(t);
                    rate.push([0, 1, 2].map(|i| if axes[i] { r[i] } else { f64::NAN }));
                    words.push(if n == 16 { w } else { w & ((1u16 << n) - 1) });
                    values
                        .push([0, 1, 2, 3, 4, 5].map(|i| if present[i] { v[i] } else { f64::NAN }));
                }
                let commands = if wrench {
                    Commands::Wrench { present, values }
                } else {
                    Commands::Thrusters { n, words }
                };
                let mut metadata = RateRecording::base_metadata(
                    "craft",
                    axes,
                    &commands,
                    with_rate.then_some(50.0),
                );
                metadata.push(("note".to_string(), "kept as is".to_string()));
                RateRecording {
                    source: "p.csv".to_string(),
                    metadata,
                    axes,
                    time_ms,
                    rate,
                    commands,
                    issues: DataIssues::default(),
                }
            })
    }

    proptest! {
        #[test]
        fn round_trip_is_lossless(r in recording_strategy()) {
            let text = write(&r);
            let back = read(&text).map_err(|e| TestCaseError::fail(format!("{e}\n{text}")))?;
            prop_assert_eq!(&back.metadata, &r.metadata);
            prop_assert_eq!(back.axes, r.axes);
            prop_assert_eq!(&back.time_ms, &r.time_ms);
            prop_assert_eq!(bits(&back.rate), bits(&r.rate));
            match (&back.commands, &r.commands) {
                (Commands::Thrusters { .. }, Commands::Thrusters { .. }) => {
                    prop_assert_eq!(&back.commands, &r.commands)
                }
                (Commands::Wrench { present: p1, values: v1 }, Commands::Wrench { present: p2, values: v2 }) => {
                    prop_assert_eq!(p1, p2);
                    let b = |v: &Vec<[f64; 6]>| v.iter().map(|x| x.map(f64::to_bits)).collect::<Vec<_>>();
                    prop_assert_eq!(b(v1), b(v2));
                }
                _ => prop_assert!(false, "command kind changed"),
            }
            prop_assert_eq!(write(&back), text);
        }
    }
}
