//! `Pipeline::tick` (the per-sample entry point): for any parameters in the envelope and any
//! sequence of gyro counts, thruster words and telemetry gaps, no panic, and the estimates
//! are valid numbers whenever the status says so (`Ok`/`PartlyUnobservable`); a format
//! limit shows up as `Overflow`/`KfOverflow`, never as a silently wrong number.

use super::{draw, Harness};
use crate::cover;
use crate::engine::{any_bool, any_in};
use massid_kernel::{Pipeline, PipelineConfig, PipelineStatus, Scalar, TickEvent, Q8_24};

/// Longest run drawn (Kani unwinds this far).
/// Shrunk under Kani, where every extra step multiplies the state space (as s2n-quic
/// shrinks its harness sizes under `cfg(kani)`); the executing engine draws the full size.
#[cfg(not(kani))]
const MAX_TICKS: u32 = 120;
#[cfg(kani)]
const MAX_TICKS: u32 = 12;

fn any_run<S: Scalar>() {
    let p = draw::params_or_sph2();
    let mut pl =
        Pipeline::<S>::new(&p, PipelineConfig::seed(1)).expect("envelope parameters are valid");
    let n = any_in(1u32, MAX_TICKS);
    let mut word = 0u16;
    // Firings of 12..30 ticks so that several firings (batch, then RLS) fit in a run.
    let mut left = 0u32;
    for _ in 0..n {
        if left == 0 {
            word = if any_bool() { draw::word() } else { 0 };
            left = any_in(12u32, 30);
        }
        left -= 1;
        let counts = if any_in(0u8, 15) == 0 {
            draw::counts()
        } else {
            draw::counts_off_rail()
        };
        let r = if any_in(0u8, 15) == 0 {
            pl.tick_gap()
        } else {
            pl.tick(counts, word)
        };
        cover!(
            r.event == TickEvent::Railed,
            "railed sample cuts the firing"
        );
        cover!(r.event == TickEvent::Solved, "solved");
        if r.event == TickEvent::KfOverflow {
            // Only a fixed format can fail to hold an estimate (f32 never reaches this).
            cover!(true, "kf overflow status");
        }
        let e = pl.estimates();
        // Random counts rarely make a physical body: the kept estimate after an Implausible
        // solve must be as valid as an accepted one.
        if matches!(
            e.status,
            PipelineStatus::Ok | PipelineStatus::PartlyUnobservable | PipelineStatus::Implausible
        ) {
            cover!(true, "estimates valid");
            assert!(e
                .delta_com_m
                .iter()
                .chain(e.theta_inertia.iter())
                .all(|v| v.is_valid()));
        }
    }
    let _ = pl.finish();
}

#[cfg_attr(kani, kani::proof)]
#[cfg_attr(kani, kani::unwind(65))]
pub fn pipeline_q8_24() {
    any_run::<Q8_24>()
}
#[cfg_attr(kani, kani::proof)]
#[cfg_attr(kani, kani::unwind(65))]
pub fn pipeline_f32() {
    any_run::<f32>()
}

pub const HARNESSES: [Harness; 2] = [
    Harness {
        name: "pipeline_q8_24",
        body: pipeline_q8_24,
        covers: &["solved", "estimates valid"],
        random_runs: 2_000,
        exhaustive_limit: None,
    },
    Harness {
        name: "pipeline_f32",
        body: pipeline_f32,
        covers: &["solved", "estimates valid"],
        random_runs: 2_000,
        exhaustive_limit: None,
    },
];
