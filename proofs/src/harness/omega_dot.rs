//! `OmegaDotKf::update` / `estimate` (the per-sample angular-acceleration Kalman filter on
//! filtered Q12 gyro counts): no panic for any count sequence; the first sample anchors;
//! every estimate is either a status (`None`: a quotient does not fit) or valid numbers with
//! a positive variance and information; and on an exact ramp the estimate is the filter's
//! closed form (computed here in f64) within the budget of `budget::TABLE` `kf.omega_dot`.

use super::Harness;
use crate::budget::{allowance, fmt_of, Exact};
use crate::cover;
use crate::engine::{any_bool, any_f64_in, any_in};
use crate::envelope as env;
use massid_kernel::omega_dot::{KfConfig, KfStatus, KfSums, OmegaDotKf};
use massid_kernel::Q8_24;

/// Longest sequence drawn (Kani unwinds this far).
/// Shrunk under Kani, where every extra step multiplies the state space (as s2n-quic
/// shrinks its harness sizes under `cfg(kani)`); the executing engine draws the full size.
#[cfg(not(kani))]
const MAX_SAMPLES: u32 = 40;
#[cfg(kani)]
const MAX_SAMPLES: u32 = 6;
/// Q12: filtered counts carry 12 fractional bits.
const Q12: i32 = 4096;

fn any_sequence<S: Exact>() {
    let cfg = KfConfig::seed(1);
    let mut kf = OmegaDotKf::<S>::new(&cfg);
    let prior = [0; 3]
        .map(|_| S::from_f32(any_f64_in(env::OMEGA_DOT_RAD_S2.0, env::OMEGA_DOT_RAD_S2.1) as f32));
    kf.reset(prior);
    let n = any_in(1u32, MAX_SAMPLES);
    let saturated_gyro = any_bool();
    let max_q12 = env::GYRO_COUNTS.1 as i32 * Q12;
    for t in 0..n {
        let counts = if t > 0 && any_in(0u8, 7) == 0 {
            None // telemetry gap
        } else if saturated_gyro {
            Some([0; 3].map(|_| if any_bool() { 0 } else { max_q12 }))
        } else {
            Some([0; 3].map(|_| any_in(0, max_q12)))
        };
        let st = kf.update(counts);
        if t == 0 {
            assert_eq!(
                st,
                if counts.is_some() {
                    KfStatus::Anchored
                } else {
                    KfStatus::Missing
                }
            );
        }
        match kf.estimate() {
            None => cover!(true, "estimate does not fit: status"),
            Some(e) => {
                cover!(e.updates > 0, "estimate after updates");
                for i in 0..3 {
                    assert!(
                        e.omega_dot[i].is_valid(),
                        "omega_dot[{i}] invalid: {} sums {:?}",
                        e.omega_dot[i].exact(),
                        kf.sums()
                    );
                    assert!(S::ZERO.lt(e.variance[i].m), "variance not positive");
                    assert!(S::ZERO.lt(e.information[i].m), "information not positive");
                }
            }
        }
    }
}

/// The filter's closed form in f64 from its exact sums: `x = (x0 alpha + gamma Sz) / (alpha + S2)`
/// with `S2 = sum k^2 - 2 kappa sum k + kappa^2 n`, `Sz = sum k z - kappa sum z` (z in Q12
/// counts), `alpha = R / (P0 dt^2)`, `gamma = 1 / (g dt 4096)`. Returns (x, cancellation
/// ratio `(sum k^2 + 2 kappa sum k + kappa^2 n) / S2`).
pub fn closed_form(cfg: &KfConfig, kappa: f64, prior: [f64; 3], s: &KfSums) -> ([f64; 3], f64) {
    let (n, sk, sk2) = (s.n as f64, s.sk as f64, s.sk2 as f64);
    let s2 = sk2 - 2.0 * kappa * sk + kappa * kappa * n;
    let ratio = (sk2 + 2.0 * kappa * sk + kappa * kappa * n) / s2;
    let x = [0, 1, 2].map(|i| {
        let alpha = cfg.r_rad2_s2[i] / (cfg.p0 * cfg.dt_s * cfg.dt_s);
        let gamma = 1.0 / (cfg.counts_per_rad_s[i] * cfg.dt_s * Q12 as f64);
        let sz = s.skz[i] as f64 - kappa * s.sz[i] as f64;
        (prior[i] * alpha + gamma * sz) / (alpha + s2)
    });
    (x, ratio)
}

/// A ramp of filtered counts `c_k = c_0 + slope k` (Q12): the estimate is the closed form.
fn ramp<S: Exact>() {
    let cfg = KfConfig::seed(1);
    let mut kf = OmegaDotKf::<S>::new(&cfg);
    let prior_s = [0; 3].map(|_| S::from_f32(any_f64_in(-5.0, 5.0) as f32));
    kf.reset(prior_s);
    let slope = [0; 3].map(|_| any_in(-20 * Q12, 20 * Q12));
    let c0 = [0; 3].map(|_| any_in(1000 * Q12, 3000 * Q12));
    let n = any_in(cfg.transient_ticks + 3, cfg.transient_ticks + MAX_SAMPLES);
    for k in 0..n as i32 {
        kf.update(Some([0, 1, 2].map(|i| c0[i] + slope[i] * k)));
    }
    let Some(e) = kf.estimate() else {
        panic!("a ramp inside the envelope fits");
    };
    cover!(slope.iter().any(|s| *s != 0), "nonzero slope");
    let kappa = S::from_f32(cfg.delay_ticks.clamp(0.0, 60.0) as f32).exact();
    let (x, ratio) = closed_form(&cfg, kappa, prior_s.map(|v| v.exact()), &kf.sums());
    for i in 0..3 {
        let tol = allowance("kf.omega_dot", fmt_of::<S>(), x[i], ratio);
        let got = e.omega_dot[i].exact();
        assert!(
            (got - x[i]).abs() <= tol,
            "axis {i}: {got} vs {} (tol {tol:e}, sums {:?})",
            x[i],
            kf.sums()
        );
    }
}

#[cfg_attr(kani, kani::proof)]
#[cfg_attr(kani, kani::unwind(65))]
pub fn kf_any_sequence_q8_24() {
    any_sequence::<Q8_24>()
}
#[cfg_attr(kani, kani::proof)]
#[cfg_attr(kani, kani::unwind(65))]
pub fn kf_ramp_q8_24() {
    ramp::<Q8_24>()
}
#[cfg_attr(kani, kani::proof)]
#[cfg_attr(kani, kani::unwind(65))]
pub fn kf_ramp_f32() {
    ramp::<f32>()
}

pub const HARNESSES: [Harness; 3] = [
    Harness {
        name: "kf_any_sequence_q8_24",
        body: kf_any_sequence_q8_24,
        covers: &["estimate after updates"],
        random_runs: 5_000,
        exhaustive_limit: None,
    },
    Harness {
        name: "kf_ramp_q8_24",
        body: kf_ramp_q8_24,
        covers: &["nonzero slope"],
        random_runs: 5_000,
        exhaustive_limit: None,
    },
    Harness {
        name: "kf_ramp_f32",
        body: kf_ramp_f32,
        covers: &["nonzero slope"],
        random_runs: 5_000,
        exhaustive_limit: None,
    },
];
