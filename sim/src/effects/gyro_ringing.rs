//! Gyro ringing (seed ch. 3.8 and App. A): the tuning-fork gyro's deltaF (about 338 Hz) is
//! excited by the small shock of every valve opening or closing and decays. Sampled at
//! 100 Hz or 50 Hz it aliases (338.33 Hz -> 38.33 Hz, 338.55 Hz -> 11.45 Hz).
//!
//! Each instant at which valves actually open or close (after latency) starts, on axis a,
//!   amplitude_rad_s[a] * exp(-(t - t_e) / decay_ms) * sin(2 pi freq_hz (t - t_e) + phase)
//! added to the sensed rate (before the gyro's scale factor). The simulator evaluates it at
//! the sample instants only, so the aliasing is the real one. The shock's phase relative to
//! the tines' motion differs from edge to edge: the full simulation draws it uniformly per
//! edge and axis from its seed; the deterministic prediction uses phase 0. (Fitting the open
//! recording o05 edge by edge with free phase brings its residual to the gyro noise floor,
//! with a mean amplitude of 0.0124 rad/s: see the crate README.)
use super::{Component, PlantConfig};
use serde::{Deserialize, Serialize};

/// Mean per-edge amplitude measured on the open recording o05 (crate README).
fn default_amplitude() -> [f64; 3] {
    [0.0124; 3]
}

/// A decaying tone excited at valve edges.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct GyroRinging {
    pub freq_hz: f64,
    pub decay_ms: f64,
    /// Where the tone shows after sampling (informative; the simulator samples for real).
    pub apparent_hz: f64,
    /// Peak of the tone per axis, rad/s (extra key).
    #[serde(default = "default_amplitude")]
    pub amplitude_rad_s: [f64; 3],
}

impl GyroRinging {
    /// The frequency at which a tone of `freq_hz` appears when point-sampled at `rate_hz`.
    pub fn aliased_hz(freq_hz: f64, rate_hz: f64) -> f64 {
        let r = freq_hz.rem_euclid(rate_hz);
        r.min(rate_hz - r)
    }

    /// The tone's value `dt_s` after an edge, axis `a`, with the given phase (0 before the edge).
    #[inline]
    pub fn response(&self, a: usize, dt_s: f64, phase: f64) -> f64 {
        if dt_s < 0.0 {
            return 0.0;
        }
        self.amplitude_rad_s[a]
            * (-dt_s * 1e3 / self.decay_ms).exp()
            * (2.0 * std::f64::consts::PI * self.freq_hz * dt_s + phase).sin()
    }
}

impl Component for GyroRinging {
    fn apply(&self, plant: &mut PlantConfig) {
        plant.ringing.push(self.clone());
    }
}
