//! The recording as the diagnosis sees it: measured body rates (rad/s, nominal gyro
//! conversion) at the recorded sample times, which samples are usable, and the commanded
//! thruster word on a 1 ms grid (held from the last recorded sample, because pulses have
//! 1 ms resolution but a 100 Hz or 50 Hz recording only shows the word at its samples).

/// Measured rates plus the command history, gaps left as gaps.
#[derive(Clone, Debug)]
pub struct Series {
    /// Sample times, ms since test start, strictly increasing.
    pub t_ms: Vec<i64>,
    /// Measured body rate per sample, rad/s, using the model's nominal bias and scale.
    pub rate: Vec<[f64; 3]>,
    /// Per sample and axis: false when the count was saturated (0 or 4095), so the
    /// sample carries no rate information on that axis.
    pub valid: Vec<[bool; 3]>,
    /// Commanded thruster word for each 1 ms tick from 0 to the last sample time.
    pub word_ms: Vec<u16>,
    /// Nominal sample rate, Hz.
    pub sample_rate_hz: f64,
    /// Indices of the first sample after each telemetry gap (longest first, at most
    /// [`MAX_GAP_RESETS`]): the commands inside a gap are unknown, so the model's state is
    /// re-estimated there instead of trusting the held command.
    pub gap_resets: Vec<usize>,
}

/// At most this many gaps get their own state re-estimate (the longest ones).
pub const MAX_GAP_RESETS: usize = 24;

impl Series {
    /// Builds the series from per-sample times, gyro counts and thruster words.
    /// `bias` and `counts_per_rad_s` are the model's gyro calibration.
    /// Returns None when there are no samples or times are not increasing.
    pub fn from_counts(
        t_ms: &[i64],
        gyro_counts: &[[i32; 3]],
        words: &[u16],
        bias: [f64; 3],
        counts_per_rad_s: [f64; 3],
        sample_rate_hz: Option<f64>,
    ) -> Option<Series> {
        let n = t_ms.len();
        if n == 0 || gyro_counts.len() != n || words.len() != n {
            return None;
        }
        if t_ms.windows(2).any(|w| w[1] <= w[0]) || t_ms[0] < 0 {
            return None;
        }
        let mut rate = Vec::with_capacity(n);
        let mut valid = Vec::with_capacity(n);
        for c in gyro_counts {
            let mut r = [0.0; 3];
            let mut v = [true; 3];
            for a in 0..3 {
                r[a] = (c[a] as f64 - bias[a]) / counts_per_rad_s[a];
                v[a] = c[a] > 0 && c[a] < 4095;
            }
            rate.push(r);
            valid.push(v);
        }
        let last = *t_ms.last().unwrap() as usize;
        let mut word_ms = vec![0u16; last + 1];
        let mut k = 0usize;
        let mut current = 0u16;
        for (tick, w) in word_ms.iter_mut().enumerate() {
            while k < n && t_ms[k] as usize <= tick {
                current = words[k] & 0x0fff;
                k += 1;
            }
            *w = current;
        }
        let sample_rate_hz = sample_rate_hz.unwrap_or_else(|| infer_rate(t_ms));
        let period = 1000.0 / sample_rate_hz;
        let mut gaps: Vec<(i64, usize)> = (1..n)
            .filter(|&i| (t_ms[i] - t_ms[i - 1]) as f64 > 1.5 * period)
            .map(|i| (t_ms[i] - t_ms[i - 1], i))
            .collect();
        gaps.sort_by(|a, b| b.0.cmp(&a.0));
        gaps.truncate(MAX_GAP_RESETS);
        let mut gap_resets: Vec<usize> = gaps.into_iter().map(|g| g.1).collect();
        gap_resets.sort_unstable();
        Some(Series { t_ms: t_ms.to_vec(), rate, valid, word_ms, sample_rate_hz, gap_resets })
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.t_ms.len()
    }

    /// True when there are no samples.
    pub fn is_empty(&self) -> bool {
        self.t_ms.is_empty()
    }

    /// Duration covered by the command grid, s.
    pub fn duration_s(&self) -> f64 {
        self.word_ms.len() as f64 * 1e-3
    }

    /// Times (ms) at which the commanded word changes, with the old and new word.
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
}

/// Median sample spacing as a rate, Hz (used when the recording does not say).
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
    pub fn from_recording(rec: &reference_f64::recording::Recording, sat: &reference_f64::satellite::Satellite) -> Option<Series> {
        let t: Vec<i64> = rec.samples.iter().map(|s| s.time_ms as i64).collect();
        let g: Vec<[i32; 3]> = rec.samples.iter().map(|s| s.gyro.map(|c| c as i32)).collect();
        let w: Vec<u16> = rec.samples.iter().map(|s| s.thrusters).collect();
        Series::from_counts(&t, &g, &w, sat.gyro_bias_counts, sat.gyro_counts_per_rad_s, Some(rec.sample_rate_hz()))
    }
}
