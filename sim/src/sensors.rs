//! The IMU as the recording sees it: gyro and accelerometer noise, 12-bit quantisation and
//! saturation, point sampling; plus telemetry artefacts (gaps, duplicate packets).
//!
//! Noise levels: the seed's spec sheet (Fig. 3.10) gives upper bounds (gyro < 0.05 deg/s/sqrt(Hz)
//! below 100 Hz, 300 Hz bandwidth; accelerometer < 70 ug rms 10-500 Hz). The defaults below
//! are the levels of the open recordings' generator, measured on the rest period of
//! `o01_nominal_rga12.csv` (crate README): gyro 3.06 / 2.15 / 2.04 counts rms with the lag-1
//! correlation 0.15 that a first-order 300 Hz low-pass gives at 1 kHz (exp(-2 pi 300 / 1000)),
//! accelerometer 1.96 counts rms, white. Both are inside the spec bounds.
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use reference_f64::recording::{Sample, MAX_COUNT};
use serde::{Deserialize, Serialize};

/// Sensor settings (model-file section `[sensors]`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SensorConfig {
    /// Gyro noise, rms per axis at the sensor output, rad/s.
    pub gyro_noise_rad_s: [f64; 3],
    /// Gyro bandwidth, Hz: the noise is white noise through a first-order low-pass.
    pub gyro_bandwidth_hz: f64,
    /// Accelerometer noise, rms per axis, m/s^2 (white).
    pub accel_noise_m_s2: [f64; 3],
    /// Accelerometer location relative to the CoM, body axes, m (rotation terms appear when
    /// it is not at the CoM).
    pub accel_location_m: [f64; 3],
    /// Turn every noise off (for tests of the deterministic parts).
    pub noiseless: bool,
    /// What the rate column measures: `"gyro"` (the default: the noise above) or
    /// `"differenced_attitude"` (rates differenced from motion-capture attitude: the noise
    /// above as its white part, plus attitude noise of `attitude_noise_rad` per sample
    /// differenced over one sample, which correlates neighbouring rates at down to -0.5).
    /// The rate itself is the point rate at the sample; a real differenced rate is also the
    /// mean over the sample period, i.e. half a period late: add a `measurement_delay` for that.
    #[serde(skip_serializing_if = "RateSensor::is_gyro")]
    pub rate_sensor: RateSensor,
    /// Attitude noise per axis of a differenced-attitude sensor, rad rms per sample (white);
    /// unused by a gyro. Default 0.0003 rad, a motion-capture system's few 0.01 degrees.
    #[serde(skip_serializing_if = "is_default_attitude_noise")]
    pub attitude_noise_rad: f64,
}

/// The kind of rate sensor (model-file `[sensors] rate_sensor`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RateSensor {
    #[default]
    Gyro,
    DifferencedAttitude,
}

impl RateSensor {
    fn is_gyro(&self) -> bool {
        *self == RateSensor::Gyro
    }
}

/// Default attitude noise of a differenced-attitude sensor, rad.
pub const ATTITUDE_NOISE_RAD: f64 = 0.0003;

fn is_default_attitude_noise(x: &f64) -> bool {
    *x == ATTITUDE_NOISE_RAD
}

impl Default for SensorConfig {
    fn default() -> Self {
        let per_count = 1.0 / reference_f64::satellite::GYRO_COUNTS_PER_RAD_S;
        SensorConfig {
            gyro_noise_rad_s: [3.06 * per_count, 2.15 * per_count, 2.04 * per_count],
            gyro_bandwidth_hz: 300.0,
            accel_noise_m_s2: [1.96 * reference_f64::satellite::ACCEL_M_S2_PER_COUNT; 3],
            accel_location_m: [0.0; 3],
            noiseless: false,
            rate_sensor: RateSensor::Gyro,
            attitude_noise_rad: ATTITUDE_NOISE_RAD,
        }
    }
}

/// Band-limited gyro noise: a first-order Gauss-Markov process sampled exactly at any instants
/// (so its correlation between samples is right at every sample rate). For a
/// differenced-attitude sensor, plus the attitude noise differenced between consecutive
/// instants (the first instant has no earlier attitude and gets none).
pub struct GyroNoise {
    sigma: [f64; 3],
    tau_ms: f64,
    state: Option<([f64; 3], f64)>,
    /// Attitude noise (rad) of a differenced-attitude sensor, 0 for a gyro.
    attitude_rad: f64,
    /// The attitude noise drawn at the previous instant.
    attitude_prev: Option<[f64; 3]>,
}

impl GyroNoise {
    pub fn new(cfg: &SensorConfig) -> Self {
        let bw = cfg.gyro_bandwidth_hz.max(1e-6);
        GyroNoise {
            sigma: if cfg.noiseless {
                [0.0; 3]
            } else {
                cfg.gyro_noise_rad_s
            },
            tau_ms: 1e3 / (2.0 * std::f64::consts::PI * bw),
            state: None,
            attitude_rad: match cfg.rate_sensor {
                RateSensor::DifferencedAttitude if !cfg.noiseless => cfg.attitude_noise_rad,
                _ => 0.0,
            },
            attitude_prev: None,
        }
    }

    /// The noise at `t_ms` (instants must not decrease).
    pub fn sample(&mut self, t_ms: f64, rng: &mut ChaCha8Rng) -> [f64; 3] {
        let w: [f64; 3] = std::array::from_fn(|_| StandardNormal.sample(rng));
        let prev = self.state;
        let mut n: [f64; 3] = match prev {
            None => std::array::from_fn(|a| self.sigma[a] * w[a]),
            Some((prev, t0)) => {
                let c = (-(t_ms - t0).max(0.0) / self.tau_ms).exp();
                let s = (1.0 - c * c).sqrt();
                std::array::from_fn(|a| c * prev[a] + s * self.sigma[a] * w[a])
            }
        };
        self.state = Some((n, t_ms));
        if self.attitude_rad > 0.0 {
            // a gyro draws nothing more, so its stream (and every recording) is unchanged
            let att: [f64; 3] = std::array::from_fn(|_| {
                let z: f64 = StandardNormal.sample(rng);
                self.attitude_rad * z
            });
            if let (Some(a0), Some((_, t0))) = (self.attitude_prev, prev) {
                let dt_s = (t_ms - t0) * 1e-3;
                if dt_s > 0.0 {
                    for a in 0..3 {
                        n[a] += (att[a] - a0[a]) / dt_s;
                    }
                }
            }
            self.attitude_prev = Some(att);
        }
        n
    }
}

/// White accelerometer noise.
pub fn accel_noise(cfg: &SensorConfig, rng: &mut ChaCha8Rng) -> [f64; 3] {
    std::array::from_fn(|a| {
        let w: f64 = StandardNormal.sample(rng);
        if cfg.noiseless {
            0.0
        } else {
            cfg.accel_noise_m_s2[a] * w
        }
    })
}

/// 12-bit ADC: round to the nearest count and saturate at 0 and 4095.
pub fn quantise(counts: f64) -> u16 {
    if counts.is_nan() {
        return 0;
    }
    counts.round().clamp(0.0, MAX_COUNT as f64) as u16
}

/// Telemetry artefacts (model-file section `[artefacts]`): dropped packets and re-sent ones.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Artefacts {
    /// Number of gaps (each 1..=max_gap consecutive samples dropped).
    pub gaps: usize,
    pub max_gap: usize,
    /// Number of duplicated rows (a row repeated right after itself).
    pub duplicates: usize,
}

impl Artefacts {
    /// Drops and duplicates rows as configured; the first and last 10 rows stay intact.
    pub fn apply(&self, mut rows: Vec<Sample>, rng: &mut ChaCha8Rng) -> Vec<Sample> {
        let max_gap = self.max_gap.max(1);
        for _ in 0..self.gaps {
            if rows.len() < 20 + max_gap + 1 {
                break;
            }
            let len = rng.gen_range(1..=max_gap);
            let start = rng.gen_range(10..rows.len() - 10 - len);
            rows.drain(start..start + len);
        }
        for _ in 0..self.duplicates {
            if rows.len() < 21 {
                break;
            }
            let at = rng.gen_range(10..rows.len() - 10);
            let row = rows[at];
            rows.insert(at + 1, row);
        }
        rows
    }

    /// What [`Artefacts::apply`] does to `n` rows, drawing the same numbers from `rng`, as
    /// a count per row (so a streamed recording needs no row in memory): row k of the
    /// clean recording is written [`RowCopies::next`] times, in order.
    pub fn plan(&self, n: usize, rng: &mut ChaCha8Rng) -> RowCopies {
        // The recording as runs (first clean row, length); a re-sent row is a run of its own.
        let mut runs: Vec<(usize, usize)> = if n > 0 { vec![(0, n)] } else { Vec::new() };
        let mut len = n;
        // Index of a run starting at row position `pos` (splitting a run there).
        fn cut(runs: &mut Vec<(usize, usize)>, pos: usize) -> usize {
            let mut at = 0;
            for i in 0..runs.len() {
                let (first, l) = runs[i];
                if pos == at {
                    return i;
                }
                if pos < at + l {
                    let head = pos - at;
                    runs[i] = (first, head);
                    runs.insert(i + 1, (first + head, l - head));
                    return i + 1;
                }
                at += l;
            }
            runs.len()
        }
        let max_gap = self.max_gap.max(1);
        for _ in 0..self.gaps {
            if len < 20 + max_gap + 1 {
                break;
            }
            let gap: usize = rng.gen_range(1..=max_gap);
            let start: usize = rng.gen_range(10..len - 10 - gap);
            let a = cut(&mut runs, start);
            let b = cut(&mut runs, start + gap);
            runs.drain(a..b);
            len -= gap;
        }
        for _ in 0..self.duplicates {
            if len < 21 {
                break;
            }
            let at: usize = rng.gen_range(10..len - 10);
            let i = cut(&mut runs, at);
            let row = runs[i].0;
            let j = cut(&mut runs, at + 1);
            runs.insert(j, (row, 1));
            len += 1;
        }
        RowCopies {
            runs,
            run: 0,
            pos: 0,
        }
    }
}

/// How many times each clean row is in a recording with telemetry artefacts
/// ([`Artefacts::plan`]): 0 for a row lost in a gap, 2 or more for a re-sent one.
#[derive(Clone, Debug)]
pub struct RowCopies {
    /// The recording's rows as runs of clean rows (first, length), in order.
    runs: Vec<(usize, usize)>,
    run: usize,
    pos: usize,
}

impl RowCopies {
    /// Copies of clean row `k`; rows must be asked for in order 0, 1, 2, ...
    pub fn next(&mut self, k: usize) -> usize {
        let mut copies = 0;
        while let Some(&(first, len)) = self.runs.get(self.run) {
            if first + self.pos != k {
                break;
            }
            copies += 1;
            self.pos += 1;
            if self.pos == len {
                self.run += 1;
                self.pos = 0;
            }
        }
        copies
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    /// The plan keeps, drops and repeats the rows `apply` does, and leaves the random
    /// stream where `apply` leaves it.
    #[test]
    fn a_plan_is_what_apply_does() {
        for (seed, n, gaps, max_gap, duplicates) in [
            (1u64, 100usize, 3usize, 5usize, 4usize),
            (2, 40, 2, 3, 6),
            (3, 25, 5, 9, 1),
            (4, 5000, 20, 50, 30),
            (5, 21, 0, 0, 3),
            (6, 0, 2, 2, 2),
        ] {
            let a = Artefacts {
                gaps,
                max_gap,
                duplicates,
            };
            let rows: Vec<Sample> = (0..n as u64)
                .map(|t| Sample {
                    time_ms: t,
                    gyro: [0; 3],
                    accel: [0; 3],
                    thrusters: 0,
                })
                .collect();
            let mut r1 = ChaCha8Rng::seed_from_u64(seed);
            let mut r2 = r1.clone();
            let want: Vec<u64> = a.apply(rows, &mut r1).iter().map(|s| s.time_ms).collect();
            let mut plan = a.plan(n, &mut r2);
            let got: Vec<u64> = (0..n)
                .flat_map(|k| std::iter::repeat_n(k as u64, plan.next(k)))
                .collect();
            assert_eq!(got, want, "seed {seed}");
            assert_eq!(r1.gen::<u64>(), r2.gen::<u64>());
        }
    }
}
