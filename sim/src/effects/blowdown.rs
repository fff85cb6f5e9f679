//! Tank blowdown (seed eq. 4.3's B term): once the liquid CO2 is gone the tank pressure,
//! hence every thruster's force, decays exponentially.
use super::{Component, PlantConfig};
use serde::{Deserialize, Serialize};

/// After `start_s` all thrust scales by exp(-(t - start_s) / tau_s).
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct Blowdown {
    pub start_s: f64,
    pub tau_s: f64,
}

impl Blowdown {
    /// The thrust factor at time `t_s` (1 before the start).
    pub fn factor(&self, t_s: f64) -> f64 {
        if t_s <= self.start_s {
            1.0
        } else {
            (-(t_s - self.start_s) / self.tau_s).exp()
        }
    }
}

impl Component for Blowdown {
    fn apply(&self, plant: &mut PlantConfig) {
        plant.blowdowns.push(self.clone());
    }
}
