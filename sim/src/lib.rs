//! massid-sim: a 6-DOF simulator of a SPHERES satellite with every effect of the vocabulary
//! (`shared/contracts/diagnosis-output.md`) as a pluggable part.
//!
//! - [`effects`]: the vocabulary ([`effects::Effect`], [`effects::Truth`]), one file per effect.
//! - [`predict`](mod@predict): fast noise-free prediction of gyro rates for given commands and effects.
//! - [`dynamics`], [`propagate`], [`valves`]: rigid body + slosh, RK4 stepping split at valve edges.

pub mod dynamics;
pub mod effects;
pub mod predict;
pub mod propagate;
pub mod valves;

pub use effects::{Effect, PlantConfig, Truth};
pub use predict::{predict, predict_gyro_rates, PredictOptions, Prediction, Predictor};
pub mod maneuvers;
pub mod model_file;
pub mod sensors;
pub mod simulate;

pub use simulate::{
    simulate, simulate_into, simulate_to, Maneuver, SimError, SimOutput, SimSpec, Streamed,
};
pub mod reproduce;
