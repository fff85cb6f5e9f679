//! Liquid CO2 slosh (seed App. B: a lightly damped mode, H(s) = 1/(s^2 + 0.02 s + 6),
//! poles at -0.01 +/- 2.45i).
//!
//! Coupling used here (the seed gives only the mode's shape): per body axis a a rotor of
//! inertia J = `inertia_fraction[a] * I_aa` (the liquid) is tied to the body by a torsional
//! spring k and damper c. The liquid's inertia is *part of* the satellite's inertia (the
//! rigid part is I - J), so a long firing still accelerates the satellite as the nominal
//! model says and slosh is a pure transient. With phi the liquid's angle relative to the body:
//!   J (w_dot_a + phi_ddot) = -k phi - c phi_dot                           (liquid, per axis)
//!   (I - J) w_dot + w x [(I - J) w + J (w + phi_dot)] = tau + k phi + c phi_dot   (body)
//! i.e. the body's gyroscopic term uses the total angular momentum (rigid part plus
//! liquid), while the liquid's relative motion is a plain oscillator in body axes. This is
//! the convention of the open data's generator: with it `o04_fuel_slosh_rga12` reproduces
//! to its noise floor with the fitted fraction 0.0300; without the liquid in the
//! gyroscopic term the spins of the RGA set leave 0.007-0.017 rad/s cross-axis residuals,
//! and adding a gyroscopic term to the liquid's own equation makes them worse (crate README).
//! k and c are set from the reduced inertia mu = J (I_aa - J) / I_aa, so that the free-flying
//! two-body mode, the ringing seen in the body rate, has natural frequency `freq_hz` and
//! damping ratio `damping_ratio`: k = mu (2 pi f)^2, c = 2 zeta mu (2 pi f).
use super::{Component, PlantConfig};
use serde::{Deserialize, Serialize};

fn default_fraction() -> [f64; 3] {
    [0.03; 3]
}

/// A lightly damped liquid mode coupled to the body rates.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct FuelSlosh {
    pub freq_hz: f64,
    pub damping_ratio: f64,
    /// Liquid inertia as a fraction of the body's inertia per axis (extra key, default 3%).
    #[serde(default = "default_fraction")]
    pub inertia_fraction: [f64; 3],
}

impl FuelSlosh {
    /// The seed's App. B mode: sqrt(6) rad/s, 2 zeta wn = 0.02.
    pub fn seed_mode() -> Self {
        let wn = 6f64.sqrt();
        FuelSlosh {
            freq_hz: wn / (2.0 * std::f64::consts::PI),
            damping_ratio: 0.02 / (2.0 * wn),
            inertia_fraction: default_fraction(),
        }
    }
}

impl Component for FuelSlosh {
    fn apply(&self, plant: &mut PlantConfig) {
        plant.slosh.push(self.clone());
    }
}
