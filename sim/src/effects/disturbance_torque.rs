//! A constant external torque (air-bearing drag, a cable, gravity gradient on the table).
use super::{Component, PlantConfig};
use serde::{Deserialize, Serialize};

/// Constant external torque, body axes, N m.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct DisturbanceTorque {
    pub torque_nm: [f64; 3],
}

impl Component for DisturbanceTorque {
    fn apply(&self, plant: &mut PlantConfig) {
        for k in 0..3 {
            plant.disturbance_torque_nm[k] += self.torque_nm[k];
        }
    }
}
