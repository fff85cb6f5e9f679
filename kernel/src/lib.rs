//! The onboard kernel: what flies. `no_std`, no allocation, no panics.
//!
//! Generic over [`scalar::Scalar`] (an `f32` impl and the fixed-point [`scalar::Q8_24`]):
//! one call of [`pipeline::Pipeline::tick`] per gyro sample runs the angular-acceleration
//! Kalman filter ([`omega_dot`]), the batch and recursive mass-property identification
//! ([`rls`]: its update in one file, [`rls::update`]; solved with [`lu`]), and [`mixer`] turns force/torque
//! commands into integer millisecond thruster on/off times. See `kernel/README.md` for
//! formats, range analysis and status codes.
//!
//! # Design principles
//!
//! These are the rules every module keeps; each names where it is enforced.
//!
//! 1. **No allocation, fixed size.** All state is in plain structs whose size is known at
//!    compile time (`Pipeline` is 3.5 kB); the C ABI reserves blocks for them and a
//!    compile-time assertion in `capi` (feature `capi`) fails the build if they outgrow the reservation.
//! 2. **No panic, on any input.** The crate denies `unwrap`, `expect`, `panic`, indexing and
//!    unchecked integer arithmetic (the lints below; CI runs clippy with `-D warnings` for
//!    the host and a Cortex-M0 target). Arithmetic goes through [`scalar::Scalar`]'s named
//!    operations: saturating for fixed point, IEEE for `f32`.
//! 3. **A status, never garbage.** Every failure becomes a value: an estimate that is not
//!    observable is held at the model ([`observability`]), one that is not physical keeps the
//!    previous estimate ([`validity`]), one that does not fit the format says `Overflow`,
//!    data that cannot be used (railed gyros, no response) is counted. `Ok` means "use these
//!    mass properties"; nothing else may reach it.
//! 4. **Formats from a range analysis.** Every quantity's representation (Q8.24, integer
//!    sums, block floating point) follows from measured and proved ranges (`proofs/`, the
//!    same generic code instantiated with an interval type), not from guesses; the formats
//!    table is in `kernel/README.md`.
//! 5. **Integer per-sample path.** The work done on every sample (gyro low-pass, Kalman
//!    sums) is exact integer arithmetic, so it is identical on every target and cannot drift;
//!    floating point or fixed-point products appear only per firing.
//! 6. **Staged end-of-firing work.** What a firing's end needs (its estimate, the fold into
//!    the information, the change test, the solves) is one [`rls::FiringFold`] stepped one
//!    stage per tick, so no tick exceeds the M4F budget (8,400 instructions, measured on QEMU
//!    by `scripts/kernel-report.sh`); the stage order is carried by the fold's types.
//! 7. **One algorithm, one oracle.** The kernel shares no numerical code with the f64
//!    reference (`reference-f64`), which is the oracle every kernel output is compared with;
//!    the decisions (observability, validity, unresponsive firings) are the reference's,
//!    written once in its docs and implemented in both.
//! 8. **Integer primitives proved on their source.** Products, divisions, shifts and
//!    block-float splits are written once in [`int`] over a machine model; the kernel runs
//!    them on native words and `proofs-solver` runs the same functions on Z3 bit-vectors
//!    and integers, so what is proved is what is compiled (`proofs/README.md` lists what is
//!    proved and what is only tested).
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

pub mod allocation;
#[cfg(feature = "capi")]
pub mod capi;
pub mod craft;
pub mod craft_mixer;
pub mod deferred_stage;
pub mod flight_id;
pub mod gyro_filter;
mod in_place;
pub mod int;
pub mod int_float;
pub mod lu;
pub mod mixer;
pub mod model;
pub mod observability;
pub mod omega_dot;
pub mod pipeline;
pub mod rls;
pub mod scalar;
pub mod validity;

pub use int_float::IntFloat;
pub use pipeline::{Estimates, Pipeline, PipelineConfig, PipelineStatus, TickEvent, TickReport};
pub use scalar::{Fx, Scalar, Scaled, Q16_16, Q8_24};
