//! Multi-thruster pressure drop (seed ch. 3.7): the regulator cannot hold the supply pressure
//! when several valves draw gas, so every open thruster gets weaker. The seed's flight code
//! used a linear law, 0.0106 N per thruster; the contract counts the *other* open thrusters.
use super::{Component, PlantConfig};
use serde::{Deserialize, Serialize};

/// Each open thruster loses `newton_per_extra_thruster` for every other thruster open with it.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct PressureDrop {
    pub newton_per_extra_thruster: f64,
}

impl Component for PressureDrop {
    fn apply(&self, plant: &mut PlantConfig) {
        plant.pressure_drop_n += self.newton_per_extra_thruster;
    }
}
