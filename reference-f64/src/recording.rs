//! Recordings in `massid-recording/1` format (`contracts/recording-format.md`): raw 12-bit
//! IMU counts plus the commanded thruster word per sample, as SPHERES telemetered them.
//!
//! Reading is streaming ([`RecordingReader`]): one line at a time, duplicates dropped
//! (first row wins) and issues counted on the fly, so an hour of 1 kHz data is held once
//! (as `Vec<Sample>` in [`Recording`]) or not at all (iterate the reader).
//!
//! Parsing rules beyond the contract, chosen to be forgiving where the contract is silent:
//! - blank (whitespace-only) lines are skipped anywhere;
//! - `#` lines before the header without `=` are comments and ignored;
//! - fields and header names may carry surrounding spaces; header columns may come in
//!   any order (each exactly once);
//! - a known key with an unusable value (`sample_rate_hz` not a positive number) is an error.
use std::collections::BTreeMap;
use std::io::{BufRead, Write};
use std::path::Path;

/// The only format version this crate reads and writes.
pub const FORMAT_V1: &str = "massid-recording/1";
/// Header columns in the order this crate writes them.
pub const COLUMNS: [&str; 8] = [
    "time_ms",
    "gyro_x",
    "gyro_y",
    "gyro_z",
    "accel_x",
    "accel_y",
    "accel_z",
    "thrusters",
];
/// Largest 12-bit count; counts at 0 or this value are saturated readings.
pub const MAX_COUNT: u16 = 4095;
/// Sample rate assumed when neither metadata nor timestamps tell (the SPHERES IMU rate).
pub const DEFAULT_SAMPLE_RATE_HZ: f64 = 1000.0;

/// One IMU sample: raw counts and the commanded thruster word (bit i = thruster i+1).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Sample {
    pub time_ms: u64,
    pub gyro: [u16; 3],
    pub accel: [u16; 3],
    pub thrusters: u16,
}

impl Sample {
    /// True when any gyro or accelerometer count is at 0 or 4095.
    pub fn is_saturated(&self) -> bool {
        self.gyro
            .iter()
            .chain(self.accel.iter())
            .any(|&c| c == 0 || c == MAX_COUNT)
    }
}

/// What the reader survived: counted, not errors.
/// - `gaps`: steps between consecutive kept samples longer than 1.5 sample periods;
/// - `missing_samples`: samples those gaps lost (`round(step / period) - 1` each);
/// - `duplicates`: rows dropped for repeating the previous time_ms;
/// - `saturated`: kept samples with at least one count at 0 or 4095.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DataIssues {
    pub gaps: usize,
    pub missing_samples: usize,
    pub duplicates: usize,
    pub saturated: usize,
}

/// A whole recording in memory.
#[derive(Clone, Debug)]
pub struct Recording {
    /// File name (for messages and JSON).
    pub source: String,
    /// Metadata in file order, including format/satellite/sample_rate_hz and unknown keys.
    pub metadata: Vec<(String, String)>,
    /// Samples, duplicates removed (first wins), gaps left as gaps.
    pub samples: Vec<Sample>,
    pub issues: DataIssues,
    /// The 1-based line of the `sample_rate_hz` key, when read from a file.
    pub rate_line: Option<usize>,
}

/// A rejected recording: the file, the 1-based line and the reason.
#[derive(Debug, thiserror::Error)]
pub struct RecordingError {
    pub file: String,
    pub line: usize,
    pub reason: String,
}

/// `file:line: reason`, or `file: reason` when no line is known (line 0; never `file:0:`).
impl std::fmt::Display for RecordingError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.line == 0 {
            write!(f, "{}: {}", self.file, self.reason)
        } else {
            write!(f, "{}:{}: {}", self.file, self.line, self.reason)
        }
    }
}

impl Recording {
    /// Builds a recording from samples (e.g. a simulator's output). Metadata gets
    /// `format`, then `satellite` and `sample_rate_hz` when given. Samples must be in
    /// time order; repeated times are dropped (first wins) and counted, like a reader would.
    pub fn new(
        source: &str,
        satellite: Option<&str>,
        sample_rate_hz: Option<f64>,
        samples: Vec<Sample>,
    ) -> Recording {
        let mut metadata = vec![("format".to_string(), FORMAT_V1.to_string())];
        if let Some(s) = satellite {
            metadata.push(("satellite".to_string(), s.to_string()));
        }
        if let Some(r) = sample_rate_hz {
            metadata.push(("sample_rate_hz".to_string(), format_rate(r)));
        }
        let mut steps = StepHistogram::default();
        let mut kept: Vec<Sample> = Vec::with_capacity(samples.len());
        let mut duplicates = 0;
        let mut saturated = 0;
        for s in samples {
            if let Some(last) = kept.last() {
                if s.time_ms <= last.time_ms {
                    duplicates += 1;
                    continue;
                }
                steps.add(s.time_ms - last.time_ms);
            }
            if s.is_saturated() {
                saturated += 1;
            }
            kept.push(s);
        }
        let period = sample_rate_hz
            .map(|r| 1000.0 / r)
            .or_else(|| steps.median())
            .unwrap_or(1.0);
        let (gaps, missing_samples) = steps.gaps(period);
        Recording {
            source: source.to_string(),
            metadata,
            samples: kept,
            issues: DataIssues {
                gaps,
                missing_samples,
                duplicates,
                saturated,
            },
            rate_line: None,
        }
    }

    /// Reads a recording file. Errors name the file, the line and the reason.
    pub fn read(path: &Path) -> Result<Recording, RecordingError> {
        let source = path.display().to_string();
        let f = std::fs::File::open(path).map_err(|e| RecordingError {
            file: source.clone(),
            line: 0,
            reason: format!("cannot open: {e}"),
        })?;
        Self::from_reader(std::io::BufReader::new(f), &source)
    }

    /// Reads a recording from any buffered reader; `source` names it in errors.
    pub fn from_reader<R: BufRead>(r: R, source: &str) -> Result<Recording, RecordingError> {
        let mut reader = RecordingReader::new(r, source)?;
        let mut samples = Vec::new();
        for s in reader.by_ref() {
            samples.push(s?);
        }
        Ok(Recording {
            source: source.to_string(),
            metadata: reader.metadata().to_vec(),
            issues: reader.issues(),
            rate_line: reader.rate_line,
            samples,
        })
    }

    /// Writes the recording to `path` atomically (a temporary file beside it, then a
    /// rename). The caller checks that `path` is not an input.
    pub fn write(&self, path: &Path) -> Result<(), RecordingError> {
        let name = path.display().to_string();
        let err = |e: std::io::Error| RecordingError {
            file: name.clone(),
            line: 0,
            reason: e.to_string(),
        };
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
        result.map_err(err)
    }

    /// Writes the recording as `massid-recording/1` text: `format` first, then the other
    /// metadata in order, the header and one row per sample.
    pub fn write_to<W: Write>(&self, w: W) -> std::io::Result<()> {
        let mut w = std::io::BufWriter::new(w);
        writeln!(w, "# format = {FORMAT_V1}")?;
        for (k, v) in &self.metadata {
            if k != "format" {
                writeln!(w, "# {k} = {v}")?;
            }
        }
        writeln!(w, "{}", COLUMNS.join(","))?;
        for s in &self.samples {
            writeln!(
                w,
                "{},{},{},{},{},{},{},{}",
                s.time_ms,
                s.gyro[0],
                s.gyro[1],
                s.gyro[2],
                s.accel[0],
                s.accel[1],
                s.accel[2],
                s.thrusters
            )?;
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

    /// Sets (replaces or appends) a metadata key.
    pub fn set_meta(&mut self, key: &str, value: &str) {
        match self.metadata.iter_mut().find(|(k, _)| k == key) {
            Some(kv) => kv.1 = value.to_string(),
            None => self.metadata.push((key.to_string(), value.to_string())),
        }
    }

    /// The `satellite` metadata, if any.
    pub fn satellite(&self) -> Option<&str> {
        self.meta("satellite")
    }

    /// Sample rate: the `sample_rate_hz` metadata, else 1000 / median time step, else 1000 Hz.
    pub fn sample_rate_hz(&self) -> f64 {
        if let Some(r) = self
            .meta("sample_rate_hz")
            .and_then(|v| v.trim().parse::<f64>().ok())
        {
            if r.is_finite() && r > 0.0 {
                return r;
            }
        }
        let mut steps = StepHistogram::default();
        for w in self.samples.windows(2) {
            steps.add(w[1].time_ms - w[0].time_ms);
        }
        steps
            .median()
            .map(|p| 1000.0 / p)
            .unwrap_or(DEFAULT_SAMPLE_RATE_HZ)
    }

    /// The sample period in whole milliseconds, checked: a declared `sample_rate_hz` must
    /// agree with the median `time_ms` step within 10 % (flight code counts time in ticks of
    /// the declared period, so a mislabel would scale every acceleration). The error names the
    /// file and the key's line. Without a declared rate, the median step; a recording with
    /// fewer than two samples, the declared (or default) period.
    pub fn checked_period_ms(&self) -> Result<u64, RecordingError> {
        let mut steps = StepHistogram::default();
        for w in self.samples.windows(2) {
            steps.add(w[1].time_ms - w[0].time_ms);
        }
        let declared = self
            .meta("sample_rate_hz")
            .and_then(|v| v.trim().parse::<f64>().ok())
            .filter(|r| r.is_finite() && *r > 0.0);
        match (declared, steps.median()) {
            (Some(r), Some(step)) => {
                let period = 1000.0 / r;
                if (step - period).abs() > 0.1 * period.max(step) {
                    return Err(RecordingError {
                        file: self.source.clone(),
                        line: self.rate_line.unwrap_or(0),
                        reason: format!(
                            "sample_rate_hz = {r} declares a {period} ms period, but the time_ms steps are {step} ms (median); fix the rate or the time stamps"
                        ),
                    });
                }
                Ok((period.round() as u64).max(1))
            }
            (None, Some(step)) => Ok((step.round() as u64).max(1)),
            _ => Ok(self.sample_period_ms()),
        }
    }

    /// Nominal sample period in whole milliseconds (at least 1).
    pub fn sample_period_ms(&self) -> u64 {
        ((1000.0 / self.sample_rate_hz()).round() as u64).max(1)
    }
}

/// A field as quoted in an error: at most 40 characters, then how long it really was.
pub(crate) fn clip(f: &str) -> String {
    const SHOWN: usize = 40;
    match f.char_indices().nth(SHOWN) {
        None => f.to_string(),
        Some((cut, _)) => format!("{}... ({} bytes)", &f[..cut], f.len()),
    }
}

pub(crate) fn format_rate(r: f64) -> String {
    if r.fract() == 0.0 && r.abs() < 1e15 {
        format!("{}", r as i64)
    } else {
        format!("{r}")
    }
}

/// Counts of each time step between kept samples; enough to find the nominal period
/// (median) and the gaps after a streaming read without keeping the samples.
#[derive(Clone, Debug, Default)]
pub(crate) struct StepHistogram {
    counts: BTreeMap<u64, usize>,
}

impl StepHistogram {
    pub(crate) fn add(&mut self, step: u64) {
        *self.counts.entry(step).or_insert(0) += 1;
    }

    /// Number of steps added.
    pub(crate) fn count(&self) -> usize {
        self.counts.values().sum()
    }

    pub(crate) fn median(&self) -> Option<f64> {
        let n: usize = self.counts.values().sum();
        if n == 0 {
            return None;
        }
        let mut seen = 0;
        for (&step, &c) in &self.counts {
            seen += c;
            if 2 * seen >= n {
                return Some(step as f64);
            }
        }
        None
    }

    /// (gaps, missing samples) for a nominal period in ms.
    pub(crate) fn gaps(&self, period_ms: f64) -> (usize, usize) {
        let mut gaps = 0;
        let mut missing = 0;
        for (&step, &c) in &self.counts {
            if step as f64 > 1.5 * period_ms {
                gaps += c;
                // saturating: a tiny declared period (sample_rate_hz = 1e12) and a long gap
                // make more "missing samples" than a usize holds (overflowed before)
                let per_gap = ((step as f64 / period_ms).round() as usize).saturating_sub(1);
                missing = c.saturating_mul(per_gap).saturating_add(missing);
            }
        }
        (gaps, missing)
    }
}

/// The next physical line of `input` without its line end (`\n` or `\r\n`), or None at end
/// of input; `line_no` counts lines read (1-based after the call). A UTF-8 byte-order mark
/// on line 1 is dropped (spreadsheet exports write one). Shared by the v1 and v2 readers.
pub(crate) fn read_text_line<R: BufRead>(
    input: &mut R,
    buf: &mut Vec<u8>,
    line_no: &mut usize,
    source: &str,
) -> Result<Option<String>, RecordingError> {
    let err = |line: usize, reason: String| RecordingError {
        file: source.to_string(),
        line,
        reason,
    };
    buf.clear();
    let n = input
        .read_until(b'\n', buf)
        .map_err(|e| err(*line_no + 1, format!("read error: {e}")))?;
    if n == 0 {
        return Ok(None);
    }
    *line_no += 1;
    if buf.last() == Some(&b'\n') {
        buf.pop();
    }
    if buf.last() == Some(&b'\r') {
        buf.pop();
    }
    // A UTF-8 byte-order mark (spreadsheet exports write one) is not part of the text.
    let text = if *line_no == 1 {
        buf.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(buf)
    } else {
        &buf[..]
    };
    match std::str::from_utf8(text) {
        Ok(s) => Ok(Some(s.to_string())),
        Err(_) => Err(err(*line_no, "line is not valid UTF-8".to_string())),
    }
}

/// Streaming reader: the metadata and header are read by [`RecordingReader::new`], then
/// each `next()` yields one kept sample (duplicates dropped, first wins). After an error
/// it yields nothing more. [`RecordingReader::issues`] is final once the iterator ends.
pub struct RecordingReader<R> {
    input: R,
    source: String,
    line_no: usize,
    metadata: Vec<(String, String)>,
    /// column index in the file -> field slot in COLUMNS order
    column_slot: Vec<usize>,
    nominal_period_ms: Option<f64>,
    rate_line: Option<usize>,
    last_time: Option<u64>,
    steps: StepHistogram,
    duplicates: usize,
    saturated: usize,
    done: bool,
    buf: Vec<u8>,
}

impl<R: BufRead> RecordingReader<R> {
    /// Reads metadata and header; errors for an empty file, a missing/unknown format,
    /// missing or unknown header columns.
    pub fn new(input: R, source: &str) -> Result<Self, RecordingError> {
        let mut rd = RecordingReader {
            input,
            source: source.to_string(),
            line_no: 0,
            metadata: Vec::new(),
            column_slot: Vec::new(),
            nominal_period_ms: None,
            rate_line: None,
            last_time: None,
            steps: StepHistogram::default(),
            duplicates: 0,
            saturated: 0,
            done: false,
            buf: Vec::new(),
        };
        let mut format_line = None;
        let mut any_line = false;
        let header = loop {
            let Some(line) = rd.next_line()? else {
                return Err(if any_line {
                    rd.error("no header line (expected time_ms,gyro_x,...,thrusters)")
                } else {
                    rd.error_at(1, "empty file")
                });
            };
            any_line = true;
            let t = line.trim();
            if t.is_empty() {
                continue;
            }
            if let Some(body) = t.strip_prefix('#') {
                if let Some((k, v)) = body.split_once('=') {
                    let (k, v) = (k.trim().to_string(), v.trim().to_string());
                    if k == "format" && format_line.is_none() {
                        format_line = Some((rd.line_no, v.clone()));
                    }
                    if k == "sample_rate_hz" && rd.nominal_period_ms.is_none() {
                        match v.parse::<f64>() {
                            Ok(r) if r.is_finite() && r > 0.0 => {
                                rd.nominal_period_ms = Some(1000.0 / r);
                                rd.rate_line = Some(rd.line_no);
                            }
                            _ => {
                                return Err(rd.error(format!(
                                    "sample_rate_hz '{}' is not a positive number",
                                    clip(&v)
                                )))
                            }
                        }
                    }
                    rd.metadata.push((k, v));
                }
                continue;
            }
            break line;
        };
        let header_line = rd.line_no;
        match format_line {
            None => {
                return Err(rd.error_at(
                    header_line,
                    "missing 'format' metadata key (expected '# format = massid-recording/1')",
                ))
            }
            Some((_, v)) if v == FORMAT_V1 => {}
            Some((l, v)) if v.starts_with("massid-recording/") => {
                return Err(rd.error_at(
                    l,
                    format!(
                        "unknown format version '{}' (this reader knows {FORMAT_V1})",
                        clip(&v)
                    ),
                ))
            }
            Some((l, v)) => {
                return Err(rd.error_at(
                    l,
                    format!("unknown format '{}' (expected {FORMAT_V1})", clip(&v)),
                ))
            }
        }
        rd.column_slot = rd.parse_header(&header)?;
        Ok(rd)
    }

    fn parse_header(&self, header: &str) -> Result<Vec<usize>, RecordingError> {
        let names: Vec<&str> = header.split(',').map(|s| s.trim()).collect();
        let mut slots = Vec::with_capacity(names.len());
        let mut seen = [false; COLUMNS.len()];
        for n in &names {
            match COLUMNS.iter().position(|c| c == n) {
                Some(i) if seen[i] => {
                    return Err(self.error(format!("header column '{n}' appears twice")))
                }
                Some(i) => {
                    seen[i] = true;
                    slots.push(i);
                }
                None => return Err(self.error(format!("unknown header column '{}'", clip(n)))),
            }
        }
        let missing: Vec<&str> = COLUMNS
            .iter()
            .zip(seen)
            .filter(|(_, s)| !s)
            .map(|(c, _)| *c)
            .collect();
        if !missing.is_empty() {
            return Err(self.error(format!("missing header column(s): {}", missing.join(", "))));
        }
        Ok(slots)
    }

    /// Metadata read so far (all of it: metadata precedes the header).
    pub fn metadata(&self) -> &[(String, String)] {
        &self.metadata
    }

    /// The source name used in errors.
    pub fn source(&self) -> &str {
        &self.source
    }

    /// Issues counted over the samples yielded so far (gaps judged against the metadata
    /// sample rate, else the median step so far).
    pub fn issues(&self) -> DataIssues {
        let period = self
            .nominal_period_ms
            .or_else(|| self.steps.median())
            .unwrap_or(1.0);
        let (gaps, missing_samples) = self.steps.gaps(period);
        DataIssues {
            gaps,
            missing_samples,
            duplicates: self.duplicates,
            saturated: self.saturated,
        }
    }

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

    /// The next physical line without its line end, or None at end of input.
    fn next_line(&mut self) -> Result<Option<String>, RecordingError> {
        read_text_line(
            &mut self.input,
            &mut self.buf,
            &mut self.line_no,
            &self.source,
        )
    }

    fn parse_row(&self, line: &str) -> Result<Sample, RecordingError> {
        let fields: Vec<&str> = line.split(',').collect();
        if fields.len() != self.column_slot.len() {
            return Err(self.error(format!(
                "row has {} fields, the header has {}",
                fields.len(),
                self.column_slot.len()
            )));
        }
        let mut values = [0u64; COLUMNS.len()];
        for (field, &slot) in fields.iter().zip(&self.column_slot) {
            let f = field.trim();
            let name = COLUMNS[slot];
            // A field quoted in an error is cut to a readable length (a 2 MB field is data
            // corruption; echoing it whole buries the message).
            let shown = clip(f);
            let v: u64 = if f.is_empty() {
                return Err(self.error(format!("{name} is empty")));
            } else if f.bytes().all(|b| b.is_ascii_digit()) {
                f.parse()
                    .map_err(|_| self.error(format!("{name} '{shown}' is out of range")))?
            } else if f.starts_with('-')
                && f.len() > 1
                && f[1..].bytes().all(|b| b.is_ascii_digit())
            {
                return Err(self.error(format!("{name} '{shown}' is out of range (negative)")));
            } else {
                return Err(self.error(format!("{name} '{shown}' is not an integer")));
            };
            if slot > 0 && v > MAX_COUNT as u64 {
                return Err(self.error(format!("{name} {v} is out of range 0..{MAX_COUNT}")));
            }
            values[slot] = v;
        }
        let c = |i: usize| values[i] as u16;
        Ok(Sample {
            time_ms: values[0],
            gyro: [c(1), c(2), c(3)],
            accel: [c(4), c(5), c(6)],
            thrusters: c(7),
        })
    }

    fn next_sample(&mut self) -> Result<Option<Sample>, RecordingError> {
        loop {
            let Some(line) = self.next_line()? else {
                return Ok(None);
            };
            if line.trim().is_empty() {
                continue;
            }
            let s = self.parse_row(&line)?;
            if let Some(last) = self.last_time {
                if s.time_ms < last {
                    return Err(self.error(format!(
                        "time_ms goes backwards ({} after {last})",
                        s.time_ms
                    )));
                }
                if s.time_ms == last {
                    self.duplicates += 1;
                    continue;
                }
                self.steps.add(s.time_ms - last);
            }
            self.last_time = Some(s.time_ms);
            if s.is_saturated() {
                self.saturated += 1;
            }
            return Ok(Some(s));
        }
    }
}

impl<R: BufRead> Iterator for RecordingReader<R> {
    type Item = Result<Sample, RecordingError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        match self.next_sample() {
            Ok(Some(s)) => Some(Ok(s)),
            Ok(None) => {
                self.done = true;
                None
            }
            Err(e) => {
                self.done = true;
                Some(Err(e))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = "# format = massid-recording/1\n# satellite = sph2\n# sample_rate_hz = 1000\n# custom = kept\ntime_ms,gyro_x,gyro_y,gyro_z,accel_x,accel_y,accel_z,thrusters\n0,2077,2070,2058,2048,2048,2048,0\n1,2077,2071,2058,2048,2049,2047,0\n";

    fn read(s: &str) -> Result<Recording, RecordingError> {
        Recording::from_reader(s.as_bytes(), "t.csv")
    }

    #[test]
    fn a_byte_order_mark_is_not_text() {
        // Spreadsheet exports start with a UTF-8 BOM; it was read as part of '# format' and the
        // file rejected as missing its format key.
        let with_bom = format!("\u{feff}{GOOD}");
        let r = read(&with_bom).expect("a BOM is accepted");
        assert_eq!(r.samples.len(), 2);
        // ... only at the start of the file: inside a row it is still bad data.
        let inside = GOOD.replace("0,2077,2070", "0,\u{feff}2077,2070");
        assert!(read(&inside).is_err());
    }

    #[test]
    fn a_huge_field_is_not_echoed_whole() {
        let big = "9".repeat(2_000_000) + "x";
        let bad = GOOD.replace("1,2077,2071", &format!("1,{big},2071"));
        let e = read(&bad).expect_err("not an integer").to_string();
        assert!(
            e.len() < 200 && e.contains("gyro_x") && e.contains("2000001 bytes"),
            "{}",
            &e[..e.len().min(300)]
        );
        assert!(e.starts_with("t.csv:7:"), "{e}");
    }

    #[test]
    fn reads_the_contract_example() {
        let r = read(GOOD).unwrap();
        assert_eq!(r.samples.len(), 2);
        assert_eq!(r.satellite(), Some("sph2"));
        assert_eq!(r.meta("custom"), Some("kept"));
        assert_eq!(r.sample_rate_hz(), 1000.0);
        assert_eq!(
            r.samples[1],
            Sample {
                time_ms: 1,
                gyro: [2077, 2071, 2058],
                accel: [2048, 2049, 2047],
                thrusters: 0
            }
        );
        assert_eq!(r.issues, DataIssues::default());
    }

    #[test]
    fn crlf_and_round_trip() {
        let r = read(&GOOD.replace('\n', "\r\n")).unwrap();
        let mut out = Vec::new();
        r.write_to(&mut out).unwrap();
        let back = read(std::str::from_utf8(&out).unwrap()).unwrap();
        assert_eq!(back.samples, r.samples);
        assert_eq!(back.metadata, r.metadata);
    }

    #[test]
    fn gaps_duplicates_saturation() {
        let body = "0,1,2,3,4,5,6,0\n1,1,2,3,4,5,6,0\n1,9,9,9,9,9,9,9\n5,0,2,3,4,5,6,0\n6,1,2,3,4,5,4095,0\n7,1,2,3,4,5,6,0\n";
        let text = format!("# format = massid-recording/1\ntime_ms,gyro_x,gyro_y,gyro_z,accel_x,accel_y,accel_z,thrusters\n{body}");
        let r = read(&text).unwrap();
        assert_eq!(r.samples.len(), 5);
        assert_eq!(r.samples[1].gyro, [1, 2, 3], "first duplicate wins");
        assert_eq!(
            r.issues,
            DataIssues {
                gaps: 1,
                missing_samples: 3,
                duplicates: 1,
                saturated: 2
            }
        );
        assert_eq!(r.sample_rate_hz(), 1000.0, "inferred from the median step");
    }

    #[test]
    fn columns_in_any_order() {
        let text = "# format = massid-recording/1\nthrusters,time_ms,gyro_z,gyro_y,gyro_x,accel_z,accel_y,accel_x\n5,10,3,2,1,6,5,4\n";
        let r = read(text).unwrap();
        assert_eq!(
            r.samples[0],
            Sample {
                time_ms: 10,
                gyro: [1, 2, 3],
                accel: [4, 5, 6],
                thrusters: 5
            }
        );
    }

    fn err(s: &str) -> RecordingError {
        read(s).expect_err("must be rejected")
    }

    #[test]
    fn every_error_class_names_file_line_reason() {
        let h = "time_ms,gyro_x,gyro_y,gyro_z,accel_x,accel_y,accel_z,thrusters";
        let f = "# format = massid-recording/1";
        let cases: Vec<(String, usize, &str)> = vec![
            (String::new(), 1, "empty file"),
            (format!("{f}\n"), 1, "no header"),
            (format!("{h}\n0,1,2,3,4,5,6,0\n"), 1, "missing 'format'"),
            (
                format!("# format = massid-recording/2\n{h}\n"),
                1,
                "unknown format version",
            ),
            (format!("# format = csv\n{h}\n"), 1, "unknown format"),
            (
                format!("{f}\ntime_ms,gyro_x,gyro_y,gyro_z,accel_x,accel_y,accel_z\n"),
                2,
                "missing header column",
            ),
            (
                format!("{f}\n{h},extra\n"),
                2,
                "unknown header column 'extra'",
            ),
            (
                format!("{f}\n{h}\n0,1,2,3,4,5,6,0\n1,1,2,x,4,5,6,0\n"),
                4,
                "gyro_z 'x' is not an integer",
            ),
            (
                format!("{f}\n{h}\n0,1,2,3,4,5,6,1.5\n"),
                3,
                "not an integer",
            ),
            (
                format!("{f}\n{h}\n0,1,2,3,4096,5,6,0\n"),
                3,
                "accel_x 4096 is out of range",
            ),
            (
                format!("{f}\n{h}\n0,1,-2,3,4,5,6,0\n"),
                3,
                "out of range (negative)",
            ),
            (
                format!("{f}\n{h}\n99999999999999999999999,1,2,3,4,5,6,0\n"),
                3,
                "time_ms",
            ),
            (
                format!("{f}\n{h}\n5,1,2,3,4,5,6,0\n4,1,2,3,4,5,6,0\n"),
                4,
                "time_ms goes backwards",
            ),
            (
                format!("{f}\n{h}\n0,1,2,3,4,5,6\n"),
                3,
                "row has 7 fields, the header has 8",
            ),
            (
                format!("{f}\n{h}\n0,1,2,3,4,5,6,0,9\n"),
                3,
                "row has 9 fields",
            ),
            (
                format!("{f}\n# sample_rate_hz = fast\n{h}\n"),
                2,
                "sample_rate_hz",
            ),
        ];
        for (text, line, reason) in cases {
            let e = err(&text);
            assert_eq!(e.file, "t.csv");
            assert_eq!(e.line, line, "{text:?} -> {e}");
            assert!(e.reason.contains(reason), "{text:?} -> {e}");
            assert!(e.to_string().starts_with(&format!("t.csv:{line}: ")));
        }
    }

    #[test]
    fn streaming_reader_stops_after_error() {
        let text = "# format = massid-recording/1\ntime_ms,gyro_x,gyro_y,gyro_z,accel_x,accel_y,accel_z,thrusters\n0,1,2,3,4,5,6,0\nbad\n2,1,2,3,4,5,6,0\n";
        let rd = RecordingReader::new(text.as_bytes(), "s.csv").unwrap();
        let items: Vec<_> = rd.collect();
        assert_eq!(items.len(), 2);
        assert!(items[0].is_ok());
        assert_eq!(items[1].as_ref().unwrap_err().line, 4);
    }

    #[test]
    fn file_write_is_atomic_and_reads_back() {
        let dir = std::env::temp_dir().join(format!("massid-rec-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("x.csv");
        let r = Recording::new(
            "x.csv",
            Some("sph1"),
            Some(100.0),
            vec![
                Sample {
                    time_ms: 0,
                    gyro: [1, 2, 3],
                    accel: [4, 5, 6],
                    thrusters: 4095,
                },
                Sample {
                    time_ms: 10,
                    gyro: [0, 2, 3],
                    accel: [4, 5, 6],
                    thrusters: 1,
                },
                Sample {
                    time_ms: 40,
                    gyro: [1, 2, 3],
                    accel: [4, 5, 6],
                    thrusters: 1,
                },
            ],
        );
        assert_eq!(
            r.issues,
            DataIssues {
                gaps: 1,
                missing_samples: 2,
                duplicates: 0,
                saturated: 1
            }
        );
        r.write(&p).unwrap();
        let back = Recording::read(&p).unwrap();
        assert_eq!(back.samples, r.samples);
        assert_eq!(back.metadata, r.metadata);
        assert_eq!(back.issues, r.issues);
        assert_eq!(back.sample_period_ms(), 10);
        let leftovers: Vec<_> = std::fs::read_dir(&dir).unwrap().collect();
        assert_eq!(leftovers.len(), 1, "no temporary file left behind");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
