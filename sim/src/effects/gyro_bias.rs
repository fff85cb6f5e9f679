//! Gyro bias error (seed ch. 3.8: biases calibrated on a rate table drift).
use super::{Component, PlantConfig};
use serde::{Deserialize, Serialize};

/// True gyro bias minus the model's, ADC counts per axis.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct GyroBias {
    pub counts: [f64; 3],
}

impl Component for GyroBias {
    fn apply(&self, plant: &mut PlantConfig) {
        for k in 0..3 {
            plant.gyro_bias_counts[k] += self.counts[k];
        }
    }
}
