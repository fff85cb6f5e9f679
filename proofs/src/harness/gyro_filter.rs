//! `GyroLowPass::step` (the seed's 50 Hz two-pole Tustin low-pass in integer arithmetic, before
//! the Kalman filter): for any count sequence, no panic, and every output bounded by what the
//! filter's impulse response allows. Each section `g (z + 1) / (z - p)` has impulse response
//! `g, g (1 + p) p^(k-1)`; its absolute sum is `L = g (1 + |1 + p| / (1 - |p|))`. At 1 kHz
//! (`p > 0`) every term is positive and `L = 1`: the output is a weighted mean of the inputs,
//! inside [0, 4095] counts. Below ~160 Hz sampling (`p < 0`: the 50 Hz cut-off is near
//! Nyquist) the response alternates and the output can leave the input range, by at most
//! `L^2`. Either way the `i32` conversion's fallback (`unwrap_or(0)`, a silent zero) is
//! unreachable: `L^2 x 4095 x 4096 < 2^31`.

use super::Harness;
use crate::cover;
use crate::engine::{any_bool, any_in};
use crate::envelope as env;
use massid_kernel::gyro_filter::{GyroLowPass, LowPassCoefs};

/// Longest sequence drawn.
/// Shrunk under Kani, where every extra step multiplies the state space (as s2n-quic
/// shrinks its harness sizes under `cfg(kani)`); the executing engine draws the full size.
#[cfg(not(kani))]
const MAX_SAMPLES: u32 = 40;
#[cfg(kani)]
const MAX_SAMPLES: u32 = 6;

fn filter_bounds(rails_only: bool) {
    let dt_ms = any_in(1u32, 20);
    let coefs = LowPassCoefs::design(50.0, dt_ms as f64 * 1e-3);
    let (p, g) = (
        coefs.p_q30 as f64 / (1u64 << 30) as f64,
        coefs.g_q30 as f64 / (1u64 << 30) as f64,
    );
    let l = g * (1.0 + (1.0 + p).abs() / (1.0 - p.abs()));
    assert!(
        l * l * 4095.0 * 4096.0 < i32::MAX as f64,
        "the i32 conversion could fall back"
    );
    let mut f = GyroLowPass::new(coefs);
    let n = any_in(1u32, if rails_only { 8 } else { MAX_SAMPLES });
    for _ in 0..n {
        let c: [u16; 3] = if rails_only {
            [if any_bool() {
                env::GYRO_COUNTS.1
            } else {
                env::GYRO_COUNTS.0
            }; 3]
        } else {
            [0; 3].map(|_| any_in(env::GYRO_COUNTS.0, env::GYRO_COUNTS.1))
        };
        let y = f.step(c);
        let top = (env::GYRO_COUNTS.1 as f64) * 4096.0;
        let (lo, hi) = if l <= 1.0 + 1e-9 {
            (0.0, top)
        } else {
            (-(l * l - 1.0) * top / 2.0, top + (l * l - 1.0) * top / 2.0)
        };
        for v in y {
            // Rounding adds at most 1/2 LSB per section per step; 8 LSB of slack over a run.
            assert!(
                (lo - 8.0..=hi + 8.0).contains(&(v as f64)),
                "filtered {v} outside [{lo}, {hi}] (dt {dt_ms} ms, L {l})"
            );
        }
        cover!(
            l > 1.0 && y.iter().any(|v| *v as f64 > top),
            "overshoot above the top rail (p < 0)"
        );
        cover!(y[0] > 4000 * 4096, "near the top rail");
    }
}

#[cfg_attr(kani, kani::proof)]
#[cfg_attr(kani, kani::unwind(7))]
pub fn gyro_filter_any_sequence() {
    filter_bounds(false)
}

/// Rail-to-rail sequences (0 / 4095 on every axis), small enough to enumerate: every
/// sequence of up to 8 samples at every sample period 1..20 ms.
#[cfg_attr(kani, kani::proof)]
#[cfg_attr(kani, kani::unwind(9))]
pub fn gyro_filter_rails() {
    filter_bounds(true)
}

pub const HARNESSES: [Harness; 2] = [
    Harness {
        name: "gyro_filter_any_sequence",
        body: gyro_filter_any_sequence,
        covers: &["near the top rail"],
        random_runs: 20_000,
        exhaustive_limit: None,
    },
    Harness {
        name: "gyro_filter_rails",
        body: gyro_filter_rails,
        covers: &["near the top rail", "overshoot above the top rail (p < 0)"],
        random_runs: 2_000,
        exhaustive_limit: Some(20 * 8 * 512),
    },
];
