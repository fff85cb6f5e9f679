//! The onboard kernel: what flies. `no_std`, no allocation, no panics.
//!
//! Generic over [`scalar::Scalar`] (an `f32` impl and the fixed-point [`scalar::Q8_24`]):
//! one call of [`pipeline::Pipeline::tick`] per gyro sample runs the angular-acceleration
//! Kalman filter ([`omega_dot`]), the batch and recursive mass-property identification
//! ([`rls`], solved with [`lu`]), and [`mixer`] turns force/torque commands into integer
//! millisecond thruster on/off times. See `kernel/README.md` for formats, range analysis and
//! status codes.
#![no_std]
#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing,
    clippy::arithmetic_side_effects,
    clippy::unreachable,
    clippy::todo,
    clippy::unimplemented
)]
#![warn(missing_docs)]

#[cfg(feature = "capi")]
pub mod capi;
pub mod fold;
pub mod gyro_filter;
pub mod lu;
pub mod mixer;
pub mod model;
pub mod observability;
pub mod omega_dot;
pub mod pipeline;
pub mod rls;
pub mod scalar;
pub mod validity;

pub use pipeline::{Estimates, Pipeline, PipelineConfig, PipelineStatus, TickEvent, TickReport};
pub use scalar::{Fx, Scalar, Scaled, Q16_16, Q8_24};
