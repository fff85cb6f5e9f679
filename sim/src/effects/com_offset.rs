//! Centre-of-mass offset (seed ch. 4: the lever arms are measured from the CoM, so an
//! offset turns pure translations into small rotations).
use super::{Component, PlantConfig};
use serde::{Deserialize, Serialize};

/// True centre of mass minus the model's, body axes, millimetres.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct ComOffset {
    pub offset_mm: [f64; 3],
}

impl Component for ComOffset {
    fn apply(&self, plant: &mut PlantConfig) {
        for k in 0..3 {
            plant.initial.com_offset_m[k] += self.offset_mm[k] * 1e-3;
        }
    }
}
