//! `rls::InfoLs::add` (the RLS information update, block floating point): for any sequence of
//! weighted measurements in the envelope the information mantissa stays symmetric and
//! positive semidefinite within its rounding, is positive definite whenever the exact
//! information is well conditioned, tracks the exact (f64) information within the rounding
//! bound, and `solve` returns a status or a valid estimate.

use super::Harness;
use crate::budget::Exact;
use crate::cover;
use crate::engine::{any_f64_in, any_in};
use massid_kernel::model::inertia_rows;
use massid_kernel::rls::InfoLs;
use massid_kernel::{Scaled, Q8_24};

/// Most updates drawn per sequence (Kani unwinds this far).
/// Shrunk under Kani, where every extra step multiplies the state space (as s2n-quic
/// shrinks its harness sizes under `cfg(kani)`); the executing engine draws the full size.
#[cfg(not(kani))]
const MAX_UPDATES: usize = 8;
#[cfg(kani)]
const MAX_UPDATES: usize = 3;
/// Largest regressor entry in kernel units (torques in cN m: 12 x 0.2 N x 0.19 m x 100 = 46;
/// CoM rows I^-1 [c]x: 91 x 0.6 N = 55): 64.
const ROW_MAX: f64 = 64.0;

/// Cholesky of `m` succeeds (all pivots > 0).
pub fn cholesky_ok<const N: usize>(m: &[[f64; N]; N]) -> bool {
    let mut l = [[0.0f64; N]; N];
    for j in 0..N {
        let d = m[j][j] - (0..j).map(|k| l[j][k] * l[j][k]).sum::<f64>();
        if d.is_nan() || d <= 0.0 {
            return false;
        }
        l[j][j] = d.sqrt();
        for i in j + 1..N {
            l[i][j] = (m[i][j] - (0..j).map(|k| l[i][k] * l[j][k]).sum::<f64>()) / l[j][j];
        }
    }
    true
}

fn shifted<const N: usize>(m: &[[f64; N]; N], s: f64) -> [[f64; N]; N] {
    let mut o = *m;
    for (i, row) in o.iter_mut().enumerate() {
        row[i] += s;
    }
    o
}

fn rows<const N: usize>(row_max: f64) -> [[f64; N]; 3] {
    if N == 6 {
        // The inverse-inertia regressor structure of seed eq. 3.8.
        let a = [0; 3].map(|_| any_f64_in(-row_max, row_max));
        let r = inertia_rows(&a.map(|v| v as f32));
        core::array::from_fn(|i| core::array::from_fn(|j| r[i][j] as f64))
    } else {
        core::array::from_fn(|_| core::array::from_fn(|_| any_f64_in(-row_max, row_max)))
    }
}

fn information_update<S: Exact, const N: usize>() {
    let mut ls = InfoLs::<S, N>::new();
    let mut exact = [[0.0f64; N]; N];
    let n = any_in(1usize, MAX_UPDATES);
    // Regressor size: the envelope's largest, or smaller ones (where the rounding allowance
    // is small enough for the positive-definiteness check to bite).
    let row_max = [ROW_MAX, 8.0, 1.0][any_in(0usize, 2)];
    let step = crate::budget::fixed_step::<S>();
    let u = if step < 1e-30 {
        f32::EPSILON as f64
    } else {
        0.0
    };
    let mut err_bound = 0.0f64; // in units of 2^exp, accumulated per add
    for _ in 0..n {
        let a = rows::<N>(row_max);
        let b = [0; 3].map(|_| any_f64_in(-50.0, 50.0));
        // Weights 1/variance of the Kalman estimate: 2^-10 .. 2^31.
        let w: [Scaled<S>; 3] = [0; 3].map(|_| Scaled {
            m: S::from_f32(any_f64_in(1.0, 1.99) as f32),
            e: any_in(-10i32, 30),
        });
        let a_s = a.map(|r| r.map(|v| S::from_f32(v as f32)));
        let b_s = b.map(|v| S::from_f32(v as f32));
        ls.add(&a_s, &b_s, &w);
        for r in 0..3 {
            let wr = w[r].m.exact() * (2.0f64).powi(w[r].e);
            let ar = a_s[r].map(|v| v.exact());
            for i in 0..N {
                for j in 0..N {
                    exact[i][j] += wr * ar[i] * ar[j];
                }
            }
            let r1: f64 = ar.iter().map(|v| v.abs()).sum();
            err_bound += 4.0 * (r1 * r1 + r1 + 2.0);
        }
        err_bound += 64.0;
    }
    if ls.is_saturated() {
        cover!(true, "saturated status");
        return;
    }
    let m = ls.information();
    let mf = m.map(|r| r.map(|v| v.exact()));
    for i in 0..N {
        for j in 0..N {
            assert_eq!(mf[i][j], mf[j][i], "not symmetric");
        }
    }
    let scale = (2.0f64).powi(ls.exponent());
    let max_diag = (0..N).map(|i| mf[i][i]).fold(0.0, f64::max);
    // Rounding allowance in mantissa units: absolute steps (fixed) or relative (f32).
    let tol = err_bound * step + 8.0 * (N * N) as f64 * u * max_diag * n as f64;
    // Tracks the exact information.
    for i in 0..N {
        for j in 0..N {
            let d = (mf[i][j] - exact[i][j] / scale).abs();
            assert!(d <= tol, "info[{i}][{j}] off by {d:e} > {tol:e} ({} steps > {err_bound} steps; n {n}, row_max {row_max}, exponent {}, mantissa {}, exact {})", d / step.max(1e-300), ls.exponent(), mf[i][j], exact[i][j] / scale);
        }
    }
    // Positive semidefinite within its rounding.
    assert!(
        cholesky_ok(&shifted(&mf, N as f64 * tol + 1e-300)),
        "information not PSD within {tol:e}"
    );
    // Positive definite whenever the exact information is well conditioned.
    let ex = exact.map(|r| r.map(|v| v / scale));
    let margin = 1e-3 * max_diag;
    if margin > N as f64 * tol && cholesky_ok(&shifted(&ex, -margin)) {
        cover!(true, "well conditioned: PD");
        assert!(
            cholesky_ok(&mf),
            "information not positive definite although exact lambda_min > {margin:e}"
        );
    } else {
        cover!(true, "rank deficient or ill conditioned");
    }
    // The solve gives a status or valid numbers.
    let prior = [S::ZERO; N];
    if let Ok(sol) = ls.solve(
        &prior,
        &[false; N],
        S::from_int_pow2(1, -14),
        S::from_int_pow2(1, -20),
    ) {
        cover!(true, "solved");
        assert!(sol.x.iter().all(|v| v.is_valid()));
    }
}

#[cfg_attr(kani, kani::proof)]
#[cfg_attr(kani, kani::unwind(65))]
pub fn rls_inertia_q8_24() {
    information_update::<Q8_24, 6>()
}
#[cfg_attr(kani, kani::proof)]
#[cfg_attr(kani, kani::unwind(65))]
pub fn rls_com_f32() {
    information_update::<f32, 3>()
}

const COVERS: &[&str] = &[
    "well conditioned: PD",
    "rank deficient or ill conditioned",
    "solved",
];
pub const HARNESSES: [Harness; 2] = [
    Harness {
        name: "rls_inertia_q8_24",
        body: rls_inertia_q8_24,
        covers: COVERS,
        random_runs: 10_000,
        exhaustive_limit: None,
    },
    Harness {
        name: "rls_com_f32",
        body: rls_com_f32,
        covers: COVERS,
        random_runs: 10_000,
        exhaustive_limit: None,
    },
];

/// `MassId` (the identification state the pipeline drives) with the optional exponential
/// forgetting and the innovation change detector: for any sequence of firings of envelope
/// measurements (consistent with some parameters, or with a jump in them: a proof mass
/// attached), every status is one of the enum's, the estimates are valid numbers whenever the
/// status is Ok / PartlyUnobservable, the information never silently saturates, and a
/// detector alarm (covariance reset) only deflates the information.
fn mass_id_options<S: Exact>() {
    use massid_kernel::rls::FiringFold;
    use massid_kernel::rls::{DetectorConfig, MassId, Measurement, RlsConfig, RlsStatus};
    let p = super::draw::params_or_sph2();
    let Ok(terms) = p.terms::<S>() else {
        panic!("envelope parameters rejected")
    };
    let forgetting = crate::engine::any_bool();
    let detector = crate::engine::any_bool();
    let cfg = RlsConfig {
        forgetting: forgetting.then(|| S::from_f32(any_f64_in(0.99, 0.99999) as f32)),
        detector: detector.then(DetectorConfig::standard),
        ..RlsConfig::default()
    };
    let mut mass = MassId::<S>::new(cfg, terms.theta_inertia_nominal);
    let firings = any_in(3usize, 12);
    let jump_at = any_in(0usize, firings);
    let mut theta: [f64; 6] = core::array::from_fn(|j| terms.theta_inertia_nominal[j].exact());
    for f in 0..firings {
        if f == jump_at {
            for t in theta.iter_mut().take(3) {
                *t *= any_f64_in(0.7, 1.0); // inertia raised by up to 43 %
            }
        }
        let word = any_in(1u16, 0x0fff);
        let ft = terms.firing_terms(word);
        let rows = massid_kernel::model::inertia_rows(&ft.torque_cnm);
        let len = any_in(1usize, 6);
        // The firing's per-sample measurements share the regressors; the pipeline folds them
        // in aggregate (total information, information-weighted mean), as here.
        let (mut w_sum, mut wb_in, mut wb_com) = ([0.0f64; 3], [0.0f64; 3], [0.0f64; 3]);
        for k in 1..=len {
            let var = [0; 3].map(|_| any_f64_in(1e-9, 1e-3));
            for i in 0..3 {
                let w = 1.0 / (var[i] * k as f64);
                let b_in = (0..6).map(|j| rows[i][j].exact() * theta[j]).sum::<f64>()
                    + any_f64_in(-1.0, 1.0) * var[i].sqrt();
                w_sum[i] += w;
                wb_in[i] += w * b_in;
                wb_com[i] += w * any_f64_in(-1.0, 1.0);
            }
        }
        let agg = Measurement {
            a_com: ft.a_com,
            b_com: core::array::from_fn(|i| S::from_f32((wb_com[i] / w_sum[i]) as f32)),
            a_inertia: rows,
            b_inertia: core::array::from_fn(|i| S::from_f32((wb_in[i] / w_sum[i]) as f32)),
            weight: w_sum.map(Scaled::<S>::from_f64),
            variance: w_sum.map(|w| Scaled::<S>::from_f64(1.0 / w)),
        };
        let resets_before = mass.resets;
        // The deployed end-of-firing fold (batch for the first two firings, solved after the
        // second; then RLS with the change test and forgetting).
        let Some(solved) = FiringFold::new(agg, len as u32, f < 2, f == 1).run(&mut mass) else {
            continue;
        };
        let st = solved.status;
        cover!(mass.resets > resets_before, "change detector reset");
        cover!(st == RlsStatus::Ok, "ok");
        cover!(forgetting && st == RlsStatus::Ok, "ok with forgetting");
        if matches!(st, RlsStatus::Ok | RlsStatus::PartlyUnobservable) {
            assert!(
                mass.delta_com_m
                    .iter()
                    .chain(mass.theta_inertia.iter())
                    .all(|v| v.is_valid()),
                "invalid estimate under {st:?}"
            );
            let (c, i) = mass.problems();
            assert!(
                !c.is_saturated() && !i.is_saturated(),
                "saturated information under {st:?}"
            );
        }
        if mass.problems().1.is_saturated() {
            assert_eq!(
                st,
                RlsStatus::Overflow,
                "saturated information must give Overflow"
            );
        }
    }
}

#[cfg_attr(kani, kani::proof)]
#[cfg_attr(kani, kani::unwind(65))]
pub fn mass_id_options_q8_24() {
    mass_id_options::<Q8_24>()
}
#[cfg_attr(kani, kani::proof)]
#[cfg_attr(kani, kani::unwind(65))]
pub fn mass_id_options_f32() {
    mass_id_options::<f32>()
}

pub const OPTION_HARNESSES: [Harness; 2] = [
    Harness {
        name: "mass_id_options_q8_24",
        body: mass_id_options_q8_24,
        covers: &["ok", "ok with forgetting", "change detector reset"],
        random_runs: 3_000,
        exhaustive_limit: None,
    },
    Harness {
        name: "mass_id_options_f32",
        body: mass_id_options_f32,
        covers: &["ok", "ok with forgetting", "change detector reset"],
        random_runs: 3_000,
        exhaustive_limit: None,
    },
];
