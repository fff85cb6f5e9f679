//! Gyro scale-factor error (seed ch. 3.8).
use super::{Component, PlantConfig};
use serde::{Deserialize, Serialize};

/// True gyro scale / the model's, per axis.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct GyroScale {
    pub scale: [f64; 3],
}

impl Component for GyroScale {
    fn apply(&self, plant: &mut PlantConfig) {
        for k in 0..3 {
            plant.gyro_scale[k] *= self.scale[k];
        }
    }
}
