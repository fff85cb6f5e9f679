//! Thruster strength errors (seed Table C.3's spread, or a clogged / dead thruster).
use super::{Component, PlantConfig};
use serde::{Deserialize, Serialize};

/// True force / nominal force per thruster (thruster 1 first); 0 is a dead thruster.
/// Thrusters past the end of the list keep their force (a list per model's thruster count).
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct ThrustScale {
    pub scale: Vec<f64>,
}

impl Component for ThrustScale {
    fn apply(&self, plant: &mut PlantConfig) {
        for (s, k) in plant.thrust_scale.iter_mut().zip(&self.scale) {
            *s *= k;
        }
    }
}
