//! A wrong inertia matrix (seed ch. 2: the trifilar pendulum's error budget; fuel use).
use super::{Component, PlantConfig};
use serde::{Deserialize, Serialize};

/// The true inertia about the centre of mass: xx, yy, zz, xy, xz, yz (kg m^2).
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct Inertia {
    pub inertia_kgm2: [f64; 6],
}

impl Component for Inertia {
    fn apply(&self, plant: &mut PlantConfig) {
        plant.initial.inertia_kgm2 = self.inertia_kgm2;
    }
}
