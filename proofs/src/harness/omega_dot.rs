//! `OmegaDotKf::update` / `estimate` (the per-sample angular-acceleration Kalman filter):
//! no panic for any count sequence; the status sequence is transient -> anchor -> updates;
//! every estimate is either a status (`None`: the quotient does not fit) or valid numbers
//! with a positive variance and information; and on an exact ramp (constant angular
//! acceleration) the estimate is the ramp's slope.

use super::Harness;
use crate::cover;
use crate::engine::{any_bool, any_f64_in, any_in};
use crate::envelope as env;
use massid_kernel::omega_dot::{KfConfig, KfStatus, OmegaDotKf};
use massid_kernel::Q8_24;
use crate::budget::Exact;

/// Longest sequence drawn (Kani unwinds this far).
const MAX_SAMPLES: u32 = 40;

fn any_sequence<S: Exact>() {
    let cfg = KfConfig::seed(1);
    let mut kf = OmegaDotKf::<S>::new(&cfg);
    let prior = [0; 3].map(|_| S::from_f32(any_f64_in(env::OMEGA_DOT_RAD_S2.0, env::OMEGA_DOT_RAD_S2.1) as f32));
    kf.reset(prior);
    let n = any_in(1u32, MAX_SAMPLES);
    let saturated_gyro = any_bool();
    for t in 0..n {
        let counts = if t > cfg.transient_ticks + 1 && any_bool() {
            None // telemetry gap
        } else if saturated_gyro {
            Some([0; 3].map(|_| if any_bool() { 0 } else { 4095 }))
        } else {
            Some([0; 3].map(|_| any_in(env::GYRO_COUNTS.0, env::GYRO_COUNTS.1)))
        };
        let st = kf.update(counts);
        if t < cfg.transient_ticks {
            assert_eq!(st, KfStatus::Skipping);
        }
        match kf.estimate() {
            None => cover!(true, "estimate does not fit: status"),
            Some(e) => {
                cover!(e.updates > 0, "estimate after updates");
                for i in 0..3 {
                    assert!(e.omega_dot[i].is_valid(), "omega_dot[{i}] invalid: {} sums {:?}", e.omega_dot[i].to_f32(), kf.sums());
                    assert!(S::ZERO.lt(e.variance[i].m), "variance not positive");
                    assert!(S::ZERO.lt(e.information[i].m), "information not positive");
                }
            }
        }
    }
}

/// A ramp `c_k = c_0 + round(k * slope)` with `|slope|` counts per sample: the estimate is
/// the slope converted to rad/s^2 within what the count rounding allows.
fn ramp<S: Exact>() {
    let cfg = KfConfig::seed(1);
    let mut kf = OmegaDotKf::<S>::new(&cfg);
    kf.reset([S::ZERO; 3]);
    let slope = [0; 3].map(|_| any_in(-20i32, 20));
    let c0 = [0; 3].map(|_| any_in(1000i32, 3000));
    let n = any_in(cfg.transient_ticks + 3, cfg.transient_ticks + MAX_SAMPLES);
    for t in 0..n {
        let k = t as i32 - cfg.transient_ticks as i32;
        let c = [0, 1, 2].map(|i| (c0[i] + slope[i] * k.max(0)) as u16);
        kf.update(Some(c));
    }
    let e = kf.estimate().expect("a ramp inside the envelope fits");
    cover!(slope.iter().any(|s| *s != 0), "nonzero slope");
    for i in 0..3 {
        // Exact data: the estimate is the information-weighted mean of the prior (0) and
        // the slope; the prior's weight alpha = R/(P0 dt^2) is < 2 against S2 >= 1.
        let truth = slope[i] as f64 / (cfg.counts_per_rad_s[i] * cfg.dt_s);
        let got = e.omega_dot[i].exact();
        let s2 = kf.sums().0 as f64;
        let alpha = cfg.r_rad2_s2[i] / (cfg.p0 * cfg.dt_s * cfg.dt_s);
        let expect = truth * s2 / (s2 + alpha);
        let tol = estimate_tolerance::<S>(kf.sums(), expect);
        assert!((got - expect).abs() <= tol, "axis {i}: {got} vs {expect} (tol {tol:e}, sums {:?})", kf.sums());
    }
}

/// The rounding allowance of `OmegaDotKf::estimate` in format `S`, derived from its
/// arithmetic: the sums are scaled by `2^-e_norm` (e_norm = 26 + the shift that brings the
/// largest below 2^30) into the format, so with an absolute step `s` the numerator carries
/// <= 6 s and the denominator `den = (alpha + S2) 2^-e_norm` <= 2 s of error, giving
/// `|dx| <= (6 + 2|x|) s / den + s`; for f32 a relative 16 eps.
pub fn estimate_tolerance<S: Exact>(sums: (u64, [i64; 3]), x: f64) -> f64 {
    let step = crate::budget::fixed_step::<S>();
    if step == 0.0 {
        return 16.0 * f32::EPSILON as f64 * x.abs().max(1.0);
    }
    let (s2, sz) = sums;
    let biggest = sz.iter().fold(s2 as i64, |m, v| m.max(v.saturating_abs()));
    let len = 64 - biggest.unsigned_abs().leading_zeros();
    let e_norm = len.saturating_sub(30) as i32 + 26;
    let alpha_max = crate::envelope::GYRO_NOISE_VAR.1 / (0.5 * 1e-6);
    let den = s2 as f64 * (2.0f64).powi(-e_norm);
    let _ = alpha_max;
    (6.0 + 2.0 * x.abs()) * step / den + step
}

#[cfg_attr(kani, kani::proof)]
#[cfg_attr(kani, kani::unwind(41))]
pub fn kf_any_sequence_q8_24() {
    any_sequence::<Q8_24>()
}
#[cfg_attr(kani, kani::proof)]
#[cfg_attr(kani, kani::unwind(51))]
pub fn kf_ramp_q8_24() {
    ramp::<Q8_24>()
}

pub const HARNESSES: [Harness; 2] = [
    Harness { name: "kf_any_sequence_q8_24", body: kf_any_sequence_q8_24, covers: &["estimate does not fit: status", "estimate after updates"], random_runs: 5_000, exhaustive_limit: None },
    Harness { name: "kf_ramp_q8_24", body: kf_ramp_q8_24, covers: &["nonzero slope"], random_runs: 5_000, exhaustive_limit: None },
];
