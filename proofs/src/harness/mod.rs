//! The proof harnesses: one per kernel entry point and arithmetic primitive.
//!
//! Each `pub fn` here with `#[cfg_attr(kani, kani::proof)]` is a Kani proof harness
//! (`cargo kani -p massid-proofs --harness <name>`; the `kani::unwind` bound is the longest
//! loop reached: 64 normalisation steps in the kernel's block floating point, the drawn
//! sequence lengths in the pipeline), written only against
//! [`crate::engine`]'s `any`/`assume`/`cover!`. [`ALL`] lists them with the cover points
//! they declare and the engine modes CI runs them in (`proofs/tests/harnesses.rs`).

pub mod capi;
pub mod draw;
pub mod gyro_filter;
pub mod lu;
pub mod mixer;
pub mod model;
pub mod omega_dot;
pub mod pipeline;
pub mod primitives;
pub mod rls;
pub mod scaled;

use crate::engine::Mode;

/// A harness as CI runs it.
#[derive(Clone, Copy)]
pub struct Harness {
    pub name: &'static str,
    pub body: fn(),
    /// Cover points that must each be reached on some accepted draw.
    pub covers: &'static [&'static str],
    /// Random draws CI makes.
    pub random_runs: u64,
    /// `Some(limit)` when the input domain is small enough to enumerate in CI.
    pub exhaustive_limit: Option<u64>,
}

impl Harness {
    /// The engine modes this harness runs in (random always; exhaustive when feasible).
    pub fn modes(&self, seed: u64) -> Vec<Mode> {
        let mut m = vec![Mode::Random {
            runs: self.random_runs,
            seed,
        }];
        if let Some(limit) = self.exhaustive_limit {
            m.push(Mode::Exhaustive { limit });
        }
        m
    }
}

/// Every harness, for CI.
pub const ALL: &[Harness] = &[
    primitives::HARNESSES[0],
    primitives::HARNESSES[1],
    primitives::HARNESSES[2],
    primitives::HARNESSES[3],
    primitives::HARNESSES[4],
    scaled::HARNESSES[0],
    scaled::HARNESSES[1],
    scaled::HARNESSES[2],
    scaled::HARNESSES[3],
    scaled::HARNESSES[4],
    scaled::HARNESSES[5],
    gyro_filter::HARNESSES[0],
    gyro_filter::HARNESSES[1],
    model::HARNESSES[0],
    model::HARNESSES[1],
    model::HARNESSES[2],
    model::HARNESSES[3],
    omega_dot::HARNESSES[0],
    omega_dot::HARNESSES[1],
    omega_dot::HARNESSES[2],
    lu::HARNESSES[0],
    lu::HARNESSES[1],
    lu::HARNESSES[2],
    rls::HARNESSES[0],
    rls::HARNESSES[1],
    rls::OPTION_HARNESSES[0],
    rls::OPTION_HARNESSES[1],
    pipeline::HARNESSES[0],
    pipeline::HARNESSES[1],
    mixer::HARNESSES[0],
    mixer::HARNESSES[1],
    mixer::HARNESSES[2],
    capi::HARNESSES[0],
    capi::HARNESSES[1],
    capi::HARNESSES[2],
    capi::HARNESSES[3],
];
