//! Hand-made recording rows for the robustness tests (`tests/tests/diagnose_fuzz.rs`,
//! `diagnose/tests/no_panic_fuzz.rs`): quiet or simulated samples, railed and stuck gyro
//! axes, thruster words, time jumps and re-sent rows, written as `massid-recording/1` text
//! so the reader sees them as it would see a file.
//!
//! (Moved here from `tests/tests/diagnose_fuzz.rs` so that both fuzz tests build their
//! recordings with the same code.)

use crate::synth::{self, Maneuver};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use reference_f64::recording::{Recording, Sample, COLUMNS, FORMAT_V1, MAX_COUNT};
use reference_f64::satellite::Satellite;
use std::fmt::Write as _;

/// `massid-recording/1` text: `format`, then `satellite` and `sample_rate_hz` when given,
/// the header and one row per sample, *every* row written (repeated `time_ms` included,
/// unlike `Recording::write_to`, which writes kept samples only).
pub fn csv_text(
    satellite: Option<&str>,
    declared_rate_hz: Option<f64>,
    samples: &[Sample],
) -> String {
    let mut s = String::with_capacity(40 * samples.len() + 200);
    // writing to a String cannot fail
    let _ = writeln!(s, "# format = {FORMAT_V1}");
    if let Some(sat) = satellite {
        let _ = writeln!(s, "# satellite = {sat}");
    }
    if let Some(r) = declared_rate_hz {
        let _ = writeln!(s, "# sample_rate_hz = {r}");
    }
    let _ = writeln!(s, "{}", COLUMNS.join(","));
    for x in samples {
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{},{}",
            x.time_ms,
            x.gyro[0],
            x.gyro[1],
            x.gyro[2],
            x.accel[0],
            x.accel[1],
            x.accel[2],
            x.thrusters
        );
    }
    s
}

/// Parses recording text as `massid diagnose` reads a file; panics with the reader's
/// `file:line: reason` if the text is not a valid recording (a generator bug).
pub fn parse_recording(text: &str, source: &str) -> Recording {
    Recording::from_reader(text.as_bytes(), source)
        .unwrap_or_else(|e| panic!("generated recording rejected: {e}"))
}

/// `n` sample times `step_ms` apart from `t0_ms`.
pub fn regular_times(n: usize, step_ms: u64, t0_ms: u64) -> Vec<u64> {
    (0..n as u64).map(|k| t0_ms + k * step_ms).collect()
}

/// A satellite at rest: gyro counts at the satellite's bias plus a slow random walk and
/// about +-3 counts of noise (kept inside 1..4094, so not saturated), accelerometer at
/// 2048 +- 2, no thruster commanded.
pub fn quiet_samples(sat: &Satellite, times: &[u64], rng: &mut ChaCha8Rng) -> Vec<Sample> {
    let mut drift = [0.0f64; 3];
    times
        .iter()
        .map(|&t| {
            let gyro = std::array::from_fn(|a| {
                drift[a] = (drift[a] + rng.gen_range(-0.3..0.3)).clamp(-40.0, 40.0);
                let c = sat.gyro_bias_counts[a] + drift[a] + rng.gen_range(-3.0..3.0);
                c.round().clamp(1.0, (MAX_COUNT - 1) as f64) as u16
            });
            let accel = std::array::from_fn(|_| 2048 + rng.gen_range(0..5) - 2);
            Sample {
                time_ms: t,
                gyro,
                accel,
                thrusters: 0,
            }
        })
        .collect()
}

/// The first `n` samples of a simulated nominal flight of `sat_name` (random PWM pulses
/// from t = 1 s, gyro noise, 12-bit counts) at `rate_hz` (1000, 500, 100 or 50).
pub fn simulated_samples(sat_name: &str, rate_hz: u32, n: usize, seed: u64) -> Vec<Sample> {
    let period_ms = (1000 / rate_hz).max(1) as usize;
    let seconds = (n * period_ms).div_ceil(1000) as u32 + 1;
    let s = synth::make(sat_name, Maneuver::Combo { seconds }, rate_hz, vec![], seed);
    let mut v = s.recording.samples;
    v.truncate(n);
    v
}

/// Sets the thruster word of `samples[range]` to `word` (0 = no firing, 0x0fff = all 12).
pub fn set_word(samples: &mut [Sample], range: std::ops::Range<usize>, word: u16) {
    for s in &mut samples[range] {
        s.thrusters = word;
    }
}

/// Random PWM-like pulses: each sample, with probability `p_change`, one to three random
/// thrusters toggle; the word is held between changes.
pub fn random_pulses(samples: &mut [Sample], p_change: f64, rng: &mut ChaCha8Rng) {
    let mut word = 0u16;
    for s in samples {
        if rng.gen_bool(p_change) {
            for _ in 0..rng.gen_range(1..=3) {
                word ^= 1 << rng.gen_range(0..12);
            }
        }
        s.thrusters = word;
    }
}

/// Gyro `axis` of `samples[range]` at `count` (0 or 4095: railed; anything else: stuck).
pub fn set_gyro(samples: &mut [Sample], axis: usize, range: std::ops::Range<usize>, count: u16) {
    for s in &mut samples[range] {
        s.gyro[axis] = count;
    }
}

/// Moves every sample from index `from` on forward by `jump_ms` (one telemetry gap).
pub fn jump_forward(samples: &mut [Sample], from: usize, jump_ms: u64) {
    for s in &mut samples[from..] {
        s.time_ms += jump_ms;
    }
}

/// Inserts `count` repeated rows (a re-sent packet: same `time_ms`, possibly other
/// content; the reader keeps the first), at random positions, the first and last sample
/// included when `count >= 2`.
pub fn with_duplicates(samples: &[Sample], count: usize, rng: &mut ChaCha8Rng) -> Vec<Sample> {
    let n = samples.len();
    if n == 0 {
        return vec![];
    }
    let mut at: Vec<usize> = (0..count).map(|_| rng.gen_range(0..n)).collect();
    if count >= 2 {
        at[0] = 0;
        at[1] = n - 1;
    }
    let mut extra = vec![0usize; n];
    for i in at {
        extra[i] += 1;
    }
    let mut out = Vec::with_capacity(n + count);
    for (s, &e) in samples.iter().zip(&extra) {
        out.push(*s);
        for _ in 0..e {
            let mut d = *s;
            if rng.gen_bool(0.5) {
                d.gyro[rng.gen_range(0..3)] = rng.gen_range(0..=MAX_COUNT);
                d.thrusters = rng.gen_range(0..=0x0fff);
            }
            out.push(d);
        }
    }
    out
}

/// True when some gyro axis carries information by any standard: at least two distinct
/// counts off the rails. (A diagnosis may refuse a recording without it with an error,
/// e.g. every sample saturated or a single sample; with it, it must diagnose.)
pub fn has_usable_gyro(samples: &[Sample]) -> bool {
    (0..3).any(|a| {
        let mut first = None;
        samples
            .iter()
            .map(|s| s.gyro[a])
            .filter(|&c| c != 0 && c != MAX_COUNT)
            .any(|c| match first {
                None => {
                    first = Some(c);
                    false
                }
                Some(f) => f != c,
            })
    })
}
