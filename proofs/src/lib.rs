//! Proof harnesses and the envelope they assume.
//!
//! * [`envelope`]: every input range, once (SPHERES); [`craft_envelope`]: any craft's, from
//!   its model, and whether the fixed format holds it.
//! * [`engine`]: the `any`/`assume`/`cover!` abstraction; Kani under `cfg(kani)`, else an
//!   executing shim with random and exhaustive modes and cover counting.
//! * [`interval`]: a sound interval scalar for the range analysis.
//! * [`budget`]: the error budget of every kernel output against `reference_f64`, in one table.
#![allow(clippy::needless_range_loop)] // index loops mirror the matrix formulas

pub mod budget;
pub mod craft_envelope;
pub mod engine;
pub mod envelope;
pub mod harness;
pub mod interval;
pub mod range;
