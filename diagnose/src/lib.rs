//! Mismatch diagnosis between a recording and the nominal model: predict the recording
//! from its own commands, locate where the residual concentrates (time, axis, input
//! condition, frequency with alias folding), fit each mechanism of the effect
//! vocabulary, accept them one at a time by BIC backed by whiteness tests, and report.

pub mod model;
pub mod series;
pub mod alias;
pub mod diagnosis;
pub mod effects;
pub mod fit;
pub mod locate;
pub mod noise;
pub mod output;
pub mod ringing;
pub mod select;
pub mod spectrum;
pub mod stats;
