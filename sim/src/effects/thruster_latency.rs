//! Solenoid valve latency (seed ch. 3.6: about 6 ms between the command and the force).
use super::{Component, PlantConfig};
use serde::{Deserialize, Serialize};

/// Valves open `open_ms` after a commanded rising edge and close `close_ms` after a falling one.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct ThrusterLatency {
    pub open_ms: f64,
    pub close_ms: f64,
}

impl Component for ThrusterLatency {
    fn apply(&self, plant: &mut PlantConfig) {
        plant.open_delay_ms += self.open_ms;
        plant.close_delay_ms += self.close_ms;
    }
}
