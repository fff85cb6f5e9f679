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
        }
    }
}

/// Band-limited gyro noise: a first-order Gauss-Markov process sampled exactly at any instants
/// (so its correlation between samples is right at every sample rate).
pub struct GyroNoise {
    sigma: [f64; 3],
    tau_ms: f64,
    state: Option<([f64; 3], f64)>,
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
        }
    }

    /// The noise at `t_ms` (instants must not decrease).
    pub fn sample(&mut self, t_ms: f64, rng: &mut ChaCha8Rng) -> [f64; 3] {
        let w: [f64; 3] = std::array::from_fn(|_| StandardNormal.sample(rng));
        let n = match self.state {
            None => std::array::from_fn(|a| self.sigma[a] * w[a]),
            Some((prev, t0)) => {
                let c = (-(t_ms - t0).max(0.0) / self.tau_ms).exp();
                let s = (1.0 - c * c).sqrt();
                std::array::from_fn(|a| c * prev[a] + s * self.sigma[a] * w[a])
            }
        };
        self.state = Some((n, t_ms));
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
}
