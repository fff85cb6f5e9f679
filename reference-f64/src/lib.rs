//! The f64 reference: the seed thesis' algorithms in f64, written to read like its
//! equations. Every kernel output is differentially tested against this crate, so it
//! shares no numerical code with `massid-kernel`.
//!
//! Modules mirror the seed's chapters.

pub mod allocation;
pub mod characterize;
pub mod flight_id;
pub mod import;
pub mod mass_id;
pub mod mixer;
pub mod mixer_check;
pub mod omega_dot;
pub mod pipeline;
pub mod planar_id;
pub mod preprocess;
pub mod rate_recording;
pub mod recording;
pub mod satellite;
pub mod slosh;
