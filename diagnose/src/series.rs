//! The recording as the diagnosis sees it: measured body rates (rad/s, nominal gyro
//! conversion) at the recorded sample times, which samples are usable, and the commanded
//! thruster word on a 1 ms grid (held from the last recorded sample, because pulses have
//! 1 ms resolution but a 100 Hz or 50 Hz recording only shows the word at its samples).
//!
//! Two kinds of bad data are handled here, once, so that no fit, likelihood, spectrum or
//! statistic downstream ever sees them:
//! - gyro samples at a rail (count 0 or 4095) or stuck (a run of identical counts far
//!   longer than the axis's own noise makes likely) are marked unusable per axis;
//! - long telemetry gaps are collapsed on the model's time axis to [`MAX_GAP_MS`]: the
//!   commands inside a gap are unknown and the state is re-estimated after it anyway, so
//!   a 1-hour or 1e11 ms jump costs what a 2 s gap costs (memory and time), while every
//!   reported time is mapped back to the recording's clock ([`Series::real_ms`]).

/// Measured rates plus the command history, gaps left as gaps.
#[derive(Clone, Debug)]
pub struct Series {
    /// Sample times on the model's clock, ms, strictly increasing: the recording's
    /// `time_ms` with every gap longer than [`MAX_GAP_MS`] shortened to it (see
    /// [`Series::real_ms`] for the way back).
    pub t_ms: Vec<i64>,
    /// Measured body rate per sample, rad/s, using the model's nominal bias and scale.
    pub rate: Vec<[f64; 3]>,
    /// Per sample and axis: false when the gyro was at a rail (count 0 or 4095) or stuck,
    /// so the sample carries no rate information on that axis.
    pub valid: Vec<[bool; 3]>,
    /// Commanded thruster word for each 1 ms tick from 0 to the last sample time.
    pub word_ms: Vec<u16>,
    /// Sample rate implied by the time steps (median step), Hz.
    pub sample_rate_hz: f64,
    /// Indices of the first sample after each telemetry gap (longest first, at most
    /// [`MAX_GAP_RESETS`]): the commands inside a gap are unknown, so the model's state is
    /// re-estimated there instead of trusting the held command.
    pub gap_resets: Vec<usize>,
    /// Where the model's clock was shortened: (model ms from which it applies, real minus
    /// model ms from there on), increasing.
    pub clock_shifts: Vec<(i64, i64)>,
    /// Samples excluded per axis because the gyro sat at a rail or was stuck.
    pub railed: [u64; 3],
    /// What the time axis said that the diagnosis had to overrule (declared rate).
    pub warnings: Vec<String>,
    /// Telemetry gaps (steps over 1.5 periods of the time-step rate) and the samples they lost.
    pub gaps: u64,
    pub missing_samples: u64,
}

/// At most this many gaps get their own state re-estimate (the longest ones).
pub const MAX_GAP_RESETS: usize = 24;
/// At most this many periodic state re-estimates ([`Series::reset_every`]).
pub const MAX_HORIZON_RESETS: usize = 100;
/// Gaps (and a late first sample) longer than this are shortened to it on the model's
/// clock, ms.
pub const MAX_GAP_MS: i64 = 2000;
/// A run of identical counts counts as stuck when a run that long would be expected fewer
/// than this many times in the whole recording from the axis's own sample-to-sample
/// repetition rate.
const STUCK_EXPECTED: f64 = 1e-3;
/// Declared and time-step rates that differ by more than this fraction disagree.
const RATE_TOLERANCE: f64 = 0.1;

/// The gyro's rails: a count at either is clipped, not measured.
pub fn at_rail(count: i32) -> bool {
    count <= 0 || count >= 4095
}

/// Per axis, which samples are stuck: runs of one repeated (non-rail) count that the
/// axis's own repetition rate makes implausible.
fn stuck_mask(gyro_counts: &[[i32; 3]]) -> Vec<[bool; 3]> {
    let n = gyro_counts.len();
    let mut stuck = vec![[false; 3]; n];
    if n < 3 {
        return stuck;
    }
    for a in 0..3 {
        let pairs = gyro_counts
            .windows(2)
            .filter(|w| !at_rail(w[0][a]) && !at_rail(w[1][a]));
        let (mut eq, mut tot) = (0usize, 0usize);
        for w in pairs {
            tot += 1;
            eq += usize::from(w[0][a] == w[1][a]);
        }
        // repetition probability, kept away from 0 and 1 so a clean axis still gets a
        // finite run limit and a constant axis is still called stuck past the limit
        let p = ((eq as f64 + 1.0) / (tot as f64 + 2.0)).clamp(1e-3, 0.999);
        let limit = ((STUCK_EXPECTED / n as f64).ln() / p.ln()).ceil().max(5.0) as usize + 1;
        let mut i = 0;
        while i < n {
            let mut j = i + 1;
            while j < n && gyro_counts[j][a] == gyro_counts[i][a] {
                j += 1;
            }
            if j - i >= limit && !at_rail(gyro_counts[i][a]) {
                for s in stuck[i..j].iter_mut() {
                    s[a] = true;
                }
            }
            i = j;
        }
    }
    stuck
}

impl Series {
    /// Builds the series from per-sample times, gyro counts and thruster words.
    /// `bias` and `counts_per_rad_s` are the model's gyro calibration; `declared_rate_hz`
    /// is checked against the time steps, which win (with a warning) when they disagree.
    /// Returns None when there are no samples or times are not increasing.
    pub fn from_counts(
        t_ms: &[i64],
        gyro_counts: &[[i32; 3]],
        words: &[u16],
        bias: [f64; 3],
        counts_per_rad_s: [f64; 3],
        declared_rate_hz: Option<f64>,
    ) -> Option<Series> {
        let n = t_ms.len();
        if n == 0 || gyro_counts.len() != n || words.len() != n {
            return None;
        }
        if t_ms.windows(2).any(|w| w[1] <= w[0]) || t_ms[0] < 0 {
            return None;
        }
        let stuck = stuck_mask(gyro_counts);
        let mut rate = Vec::with_capacity(n);
        let mut valid = Vec::with_capacity(n);
        let mut railed = [0u64; 3];
        for (c, st) in gyro_counts.iter().zip(&stuck) {
            let mut r = [0.0; 3];
            let mut v = [true; 3];
            for a in 0..3 {
                r[a] = (c[a] as f64 - bias[a]) / counts_per_rad_s[a];
                v[a] = !at_rail(c[a]) && !st[a];
                railed[a] += u64::from(!v[a]);
            }
            rate.push(r);
            valid.push(v);
        }
        // recording format v1: the thruster word has 12 bits
        Self::assemble(t_ms, rate, valid, railed, words, 0x0fff, declared_rate_hz)
    }

    /// Builds the series from rates already in rad/s (recording format v2, e.g. motion
    /// capture): a NaN rate is a sample that axis did not measure (an axis the recording
    /// does not have, or a missing field), masked like a railed gyro sample but not
    /// counted as railed. `word_mask` holds the bits that are thrusters of the model.
    /// Returns None when there are no samples or times are not increasing.
    pub fn from_rates(
        t_ms: &[i64],
        rates: &[[f64; 3]],
        words: &[u16],
        word_mask: u16,
        declared_rate_hz: Option<f64>,
    ) -> Option<Series> {
        let n = t_ms.len();
        if n == 0 || rates.len() != n || words.len() != n {
            return None;
        }
        if t_ms.windows(2).any(|w| w[1] <= w[0]) || t_ms[0] < 0 {
            return None;
        }
        let valid: Vec<[bool; 3]> = rates.iter().map(|r| r.map(f64::is_finite)).collect();
        let rate = rates
            .iter()
            .map(|r| r.map(|v| if v.is_finite() { v } else { 0.0 }))
            .collect();
        Self::assemble(
            t_ms,
            rate,
            valid,
            [0; 3],
            words,
            word_mask,
            declared_rate_hz,
        )
    }

    /// The part common to every source: the sample rate (declared vs time steps), the
    /// model's clock with long gaps shortened, the command grid, and the gap resets.
    fn assemble(
        t_ms: &[i64],
        rate: Vec<[f64; 3]>,
        valid: Vec<[bool; 3]>,
        railed: [u64; 3],
        words: &[u16],
        word_mask: u16,
        declared_rate_hz: Option<f64>,
    ) -> Option<Series> {
        let n = t_ms.len();
        let sample_rate_hz = infer_rate(t_ms);
        let mut warnings = vec![];
        if let Some(d) = declared_rate_hz {
            if !(d.is_finite() && d > 0.0) || (d / sample_rate_hz - 1.0).abs() > RATE_TOLERANCE {
                warnings.push(format!(
                    "declared sample_rate_hz {d} contradicts the time_ms steps (median step gives {sample_rate_hz} Hz): \
                     the time steps are used"
                ));
            }
        }
        // the model's clock: late start and long gaps shortened to MAX_GAP_MS
        let mut model_t = Vec::with_capacity(n);
        let mut clock_shifts = vec![];
        let mut shift = 0i64;
        let mut collapsed_after = vec![];
        for (i, &t) in t_ms.iter().enumerate() {
            let step = if i == 0 { t } else { t - t_ms[i - 1] };
            if step > MAX_GAP_MS {
                shift += step - MAX_GAP_MS;
                clock_shifts.push((t - shift, shift));
                if i > 0 {
                    collapsed_after.push(i);
                }
            }
            model_t.push(t - shift);
        }
        let last = *model_t.last()? as usize;
        let mut word_ms = vec![0u16; last + 1];
        let mut k = 0usize;
        let mut current = 0u16;
        for (tick, w) in word_ms.iter_mut().enumerate() {
            while k < n && model_t[k] as usize <= tick {
                current = words[k] & word_mask;
                k += 1;
            }
            *w = current;
        }
        // inside a shortened gap nothing is known: no valve is assumed open past one period
        let period = 1000.0 / sample_rate_hz;
        for &i in &collapsed_after {
            let from = (model_t[i - 1] as f64 + period).ceil() as usize;
            let to = model_t[i] as usize;
            for w in word_ms.iter_mut().take(to).skip(from) {
                *w = 0;
            }
        }
        let mut gaps: Vec<(i64, usize)> = (1..n)
            .filter(|&i| (t_ms[i] - t_ms[i - 1]) as f64 > 1.5 * period)
            .map(|i| (t_ms[i] - t_ms[i - 1], i))
            .collect();
        let n_gaps = gaps.len() as u64;
        let missing_samples = gaps
            .iter()
            .map(|g| ((g.0 as f64 / period).round() as u64).saturating_sub(1))
            .sum();
        gaps.sort_by_key(|g| std::cmp::Reverse(g.0));
        gaps.truncate(MAX_GAP_RESETS);
        let mut gap_resets: Vec<usize> = gaps.into_iter().map(|g| g.1).collect();
        gap_resets.sort_unstable();
        Some(Series {
            t_ms: model_t,
            rate,
            valid,
            word_ms,
            sample_rate_hz,
            gap_resets,
            clock_shifts,
            railed,
            warnings,
            gaps: n_gaps,
            missing_samples,
        })
    }

    /// The samples `range` only, on the same clock and with the same command history up
    /// to the last of them (a prediction of them starts at their first sample): the two
    /// halves of a fit-here, predict-there check. None for an empty range.
    pub fn select(&self, range: std::ops::Range<usize>) -> Option<Series> {
        let range = range.start.min(self.len())..range.end.min(self.len());
        if range.is_empty() {
            return None;
        }
        let last = *self.t_ms.get(range.end - 1)? as usize;
        let mut part = self.clone();
        part.t_ms = self.t_ms[range.clone()].to_vec();
        part.rate = self.rate[range.clone()].to_vec();
        part.valid = self.valid[range.clone()].to_vec();
        part.word_ms.truncate(last + 1);
        part.gap_resets = self
            .gap_resets
            .iter()
            .filter(|&&i| range.contains(&i) && i > range.start)
            .map(|&i| i - range.start)
            .collect();
        Some(part)
    }

    /// Adds a state re-estimate at the first sample of every `horizon_s` stretch (on the
    /// model's clock), on top of the gap resets: the model is then compared with the craft
    /// over that horizon, not open loop over the whole recording. At most
    /// [`MAX_HORIZON_RESETS`] (the horizon widens to fit).
    pub fn reset_every(&mut self, horizon_s: f64) {
        let (Some(&t0), Some(&t1)) = (self.t_ms.first(), self.t_ms.last()) else {
            return;
        };
        if !(horizon_s.is_finite() && horizon_s > 0.0) {
            return;
        }
        let span = (t1 - t0) as f64;
        let h = (horizon_s * 1e3)
            .max(span / MAX_HORIZON_RESETS as f64)
            .max(1.0);
        let mut at = vec![];
        let mut next = t0 as f64 + h;
        for (i, &t) in self.t_ms.iter().enumerate() {
            if t as f64 >= next {
                at.push(i);
                while next <= t as f64 {
                    next += h;
                }
            }
        }
        at.extend_from_slice(&self.gap_resets);
        at.sort_unstable();
        at.dedup();
        self.gap_resets = at;
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.t_ms.len()
    }

    /// True when there are no samples.
    pub fn is_empty(&self) -> bool {
        self.t_ms.is_empty()
    }

    /// Duration covered by the command grid on the model's clock, s.
    pub fn duration_s(&self) -> f64 {
        self.word_ms.len() as f64 * 1e-3
    }

    /// The recording's time (ms) of a time on the model's clock.
    pub fn real_ms(&self, model_ms: f64) -> f64 {
        let i = self
            .clock_shifts
            .partition_point(|&(from, _)| (from as f64) <= model_ms);
        model_ms
            + if i == 0 {
                0.0
            } else {
                self.clock_shifts[i - 1].1 as f64
            }
    }

    /// The model's clock (ms) at a time of the recording: inside a shortened gap, the
    /// end of what is left of it.
    pub fn model_ms(&self, real_ms: f64) -> f64 {
        let mut shift = 0.0;
        for &(from, s) in &self.clock_shifts {
            if real_ms >= (from + s) as f64 {
                shift = s as f64;
            } else if real_ms > from as f64 + shift {
                return from as f64;
            } else {
                break;
            }
        }
        real_ms - shift
    }

    /// Times (ms, model clock) at which the commanded word changes, with the old and new word.
    pub fn edges(&self) -> Vec<(i64, u16, u16)> {
        let mut out = Vec::new();
        let mut prev = 0u16;
        for (k, &w) in self.word_ms.iter().enumerate() {
            if w != prev {
                out.push((k as i64, prev, w));
                prev = w;
            }
        }
        out
    }

    /// Number of usable scalar samples (sample, axis).
    pub fn usable(&self) -> usize {
        self.valid
            .iter()
            .map(|v| v.iter().filter(|&&b| b).count())
            .sum()
    }
}

/// Median sample spacing as a rate, Hz.
fn infer_rate(t_ms: &[i64]) -> f64 {
    if t_ms.len() < 2 {
        return 1000.0;
    }
    let mut d: Vec<i64> = t_ms.windows(2).map(|w| w[1] - w[0]).collect();
    d.sort_unstable();
    1000.0 / d[d.len() / 2].max(1) as f64
}

impl Series {
    /// The recording's samples with `sat`'s gyro calibration. None for an empty recording.
    pub fn from_recording(
        rec: &reference_f64::recording::Recording,
        sat: &reference_f64::satellite::Satellite,
    ) -> Option<Series> {
        let t: Vec<i64> = rec
            .samples
            .iter()
            .map(|s| s.time_ms.min(i64::MAX as u64 / 2) as i64)
            .collect();
        let g: Vec<[i32; 3]> = rec
            .samples
            .iter()
            .map(|s| s.gyro.map(|c| c as i32))
            .collect();
        let w: Vec<u16> = rec.samples.iter().map(|s| s.thrusters).collect();
        let declared = rec
            .meta("sample_rate_hz")
            .and_then(|v| v.trim().parse::<f64>().ok());
        Series::from_counts(
            &t,
            &g,
            &w,
            sat.gyro_bias_counts,
            sat.gyro_counts_per_rad_s,
            declared,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn noisy_counts(n: usize, seed: u64) -> Vec<[i32; 3]> {
        // a deterministic +/-3 count dither around 2048
        let mut x = seed;
        (0..n)
            .map(|_| {
                std::array::from_fn(|_| {
                    x = x
                        .wrapping_mul(6364136223846793005)
                        .wrapping_add(1442695040888963407);
                    2048 + ((x >> 33) % 7) as i32 - 3
                })
            })
            .collect()
    }

    /// A stuck stretch on one axis is masked there and nowhere else; a clean recording
    /// has nothing masked (the run limit adapts to the axis's own repetition rate).
    #[test]
    fn stuck_and_railed_samples_are_masked_per_axis() {
        let n = 5000;
        let t: Vec<i64> = (0..n as i64).collect();
        let mut c = noisy_counts(n, 7);
        let clean = Series::from_counts(&t, &c, &vec![0; n], [2048.0; 3], [800.0; 3], Some(1000.0))
            .unwrap();
        assert_eq!(clean.railed, [0, 0, 0]);
        for s in c.iter_mut().skip(1000).take(300) {
            s[1] = 2051; // stuck at a plausible value
        }
        for s in c.iter_mut().skip(3000).take(50) {
            s[2] = 4095; // railed
        }
        let s = Series::from_counts(&t, &c, &vec![0; n], [2048.0; 3], [800.0; 3], Some(1000.0))
            .unwrap();
        assert_eq!(s.railed[0], 0);
        assert!((300..=302).contains(&s.railed[1]), "{:?}", s.railed);
        assert_eq!(s.railed[2], 50);
        assert!(!s.valid[1100][1] && s.valid[1100][0] && s.valid[1100][2]);
    }

    /// A 1e11 ms jump costs no memory: the model's clock is shortened and maps back.
    #[test]
    fn huge_gap_is_shortened_and_maps_back() {
        let mut t: Vec<i64> = (0..100).collect();
        t.extend((0..100).map(|i| 100_000_000_000 + i));
        let c = noisy_counts(200, 3);
        let s = Series::from_counts(&t, &c, &vec![1; 200], [2048.0; 3], [800.0; 3], Some(1000.0))
            .unwrap();
        assert!(s.word_ms.len() < 3000, "{}", s.word_ms.len());
        assert_eq!(s.real_ms(s.t_ms[150] as f64), t[150] as f64);
        assert_eq!(s.model_ms(t[150] as f64), s.t_ms[150] as f64);
        assert_eq!(s.real_ms(s.t_ms[50] as f64), 50.0);
        assert_eq!(s.gap_resets, vec![100]);
        // nothing is assumed to fire through the unknown stretch
        assert_eq!(s.word_ms[1500], 0);
    }

    /// A declared rate the time steps contradict is overruled, with a warning.
    #[test]
    fn declared_rate_is_checked_against_time_steps() {
        let t: Vec<i64> = (0..100).collect();
        let c = noisy_counts(100, 1);
        let s =
            Series::from_counts(&t, &c, &[0; 100], [2048.0; 3], [800.0; 3], Some(100.0)).unwrap();
        assert_eq!(s.sample_rate_hz, 1000.0);
        assert_eq!(s.warnings.len(), 1);
        let ok =
            Series::from_counts(&t, &c, &[0; 100], [2048.0; 3], [800.0; 3], Some(1000.0)).unwrap();
        assert!(ok.warnings.is_empty());
    }
}
