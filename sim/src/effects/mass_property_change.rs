//! A step change of mass properties (a proof mass attached, docking; seed ch. 4's
//! motivation for *online* identification).
use super::{Component, MassPhase, PlantConfig};
use serde::{Deserialize, Serialize};

/// From `at_s` on, the CoM is `offset_mm` from the model's and the inertia is `inertia_kgm2`.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct MassPropertyChange {
    pub at_s: f64,
    pub offset_mm: [f64; 3],
    pub inertia_kgm2: [f64; 6],
}

impl Component for MassPropertyChange {
    fn apply(&self, plant: &mut PlantConfig) {
        plant.changes.push((
            self.at_s,
            MassPhase {
                com_offset_m: self.offset_mm.map(|v| v * 1e-3),
                inertia_kgm2: self.inertia_kgm2,
            },
        ));
        plant.changes.sort_by(|a, b| a.0.total_cmp(&b.0));
    }
}
