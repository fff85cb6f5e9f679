//! Rate damping: a torque against the body rate, `-b omega` per axis, as an air-bearing
//! film's shear or air drag gives a craft on a float table. Outside the contract's
//! vocabulary (like `thrust_rise`); the diagnosis names it `rate_damping`
//! (`diagnose/src/effects/rate_damping.rs`).
use super::{Component, PlantConfig};
use serde::{Deserialize, Serialize};

/// Damping coefficient per body axis, N m s/rad (>= 0; 0 = no effect).
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct RateDamping {
    pub nms_per_rad: [f64; 3],
}

impl Component for RateDamping {
    fn apply(&self, plant: &mut PlantConfig) {
        for k in 0..3 {
            plant.rate_damping_nms[k] += self.nms_per_rad[k];
        }
    }
}
