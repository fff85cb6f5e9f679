//! Differential: the kernel's LU solve and the RLS information form (f32 and Q8.24) against
//! `reference_f64::mass_id` (`lu_solve`, `BatchLs`) on the same inputs: random
//! diagonally dominant systems, and weighted measurement sequences with the seed's
//! regressor structure, including near-singular information (single-axis excitation).

use massid_kernel::lu;
use massid_kernel::model::inertia_rows;
use massid_kernel::rls::InfoLs;
use massid_kernel::{Scaled, Q8_24};
use massid_proofs::budget::{fmt_of, Exact, Worst};
use nalgebra::{SMatrix, SVector};
use proptest::prelude::*;
use reference_f64::mass_id::lu_solve;

/// A diagonally dominant matrix scaled by 1/8 (margin >= 1/16, so |A^-1|_inf <= 16, and no
/// pivot growth beyond 2) and a solution in [-4, 4]^N; right-hand side b = A x.
fn system<const N: usize>(off: &[f64], diag: &[f64], x: &[f64]) -> ([[f64; N]; N], [f64; N]) {
    let mut a = [[0.0; N]; N];
    for i in 0..N {
        let mut row_sum = 0.0;
        for j in 0..N {
            if i != j {
                a[i][j] = off[i * N + j];
                row_sum += a[i][j].abs();
            }
        }
        a[i][i] = (row_sum + diag[i]) * if i % 2 == 0 { 1.0 } else { -1.0 };
    }
    let b = core::array::from_fn(|i| (0..N).map(|j| a[i][j] * x[j]).sum::<f64>() / 8.0);
    (a.map(|r| r.map(|v| v / 8.0)), b)
}

fn compare_lu<S: Exact, const N: usize>(
    a: &[[f64; N]; N],
    b: &[f64; N],
    w: &mut Worst,
) -> Result<(), String> {
    let a_s = a.map(|r| r.map(|v| S::from_f32(v as f32)));
    let b_s = b.map(|v| S::from_f32(v as f32));
    let x = lu::solve(&a_s, &b_s, S::from_int_pow2(1, -20))
        .map_err(|e| format!("kernel LU failed: {e:?}"))?;
    // The reference solves the system the kernel saw (inputs rounded into S).
    let am = SMatrix::<f64, N, N>::from_fn(|i, j| a_s[i][j].exact());
    let bv = SVector::<f64, N>::from_fn(|i, _| b_s[i].exact());
    let xr = lu_solve(&am, &bv).ok_or("reference singular")?;
    let scale = xr.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for i in 0..N {
        w.record_normwise(fmt_of::<S>(), x[i].exact(), xr[i], scale, 0.0)
            .map_err(|m| format!("x[{i}]: {m}"))?;
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, rng_seed: proptest::test_runner::RngSeed::Fixed(0x5eed_0001), failure_persistence: None, ..ProptestConfig::default() })]
    #[test]
    fn lu_solution_3(off in prop::collection::vec(-1.0f64..1.0, 9), diag in prop::collection::vec(0.5f64..2.0, 3), x in prop::collection::vec(-4.0f64..4.0, 3)) {
        let (a, b) = system::<3>(&off, &diag, &x);
        let (mut wq, mut wf) = (Worst::new("lu.solution"), Worst::new("lu.solution"));
        compare_lu::<Q8_24, 3>(&a, &b, &mut wq).map_err(TestCaseError::fail)?;
        compare_lu::<f32, 3>(&a, &b, &mut wf).map_err(TestCaseError::fail)?;
    }

    #[test]
    fn lu_solution_6(off in prop::collection::vec(-1.0f64..1.0, 36), diag in prop::collection::vec(0.5f64..2.0, 6), x in prop::collection::vec(-4.0f64..4.0, 6)) {
        let (a, b) = system::<6>(&off, &diag, &x);
        let (mut wq, mut wf) = (Worst::new("lu.solution"), Worst::new("lu.solution"));
        compare_lu::<Q8_24, 6>(&a, &b, &mut wq).map_err(TestCaseError::fail)?;
        compare_lu::<f32, 6>(&a, &b, &mut wf).map_err(TestCaseError::fail)?;
    }
}

#[test]
fn lu_figures_for_the_readme() {
    let mut x = 99u64;
    let mut rnd = move || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        (x % 2_000_001) as f64 / 1_000_000.0 - 1.0
    };
    let (mut wq, mut wf) = (Worst::new("lu.solution"), Worst::new("lu.solution"));
    for _ in 0..2000 {
        let off: Vec<f64> = (0..36).map(|_| rnd()).collect();
        let diag: Vec<f64> = (0..6).map(|_| 1.25 + 0.75 * rnd()).collect();
        let xs: Vec<f64> = (0..6).map(|_| 4.0 * rnd()).collect();
        let (a, b) = system::<6>(&off, &diag, &xs);
        compare_lu::<Q8_24, 6>(&a, &b, &mut wq).unwrap();
        compare_lu::<f32, 6>(&a, &b, &mut wf).unwrap();
    }
    println!("2000 diagonally dominant 6x6: Q8_24 {wq}");
    println!("2000 diagonally dominant 6x6: F32 {wf}");
}

/// RLS: the kernel's information-form estimate after `updates` weighted measurements with
/// the inverse-inertia regressor structure, against the reference's batch LS solution of
/// the same weighted rows (no prior, information-weighted exactly as the kernel).
fn rls_inertia<S: Exact>(
    torques: &[[f64; 3]],
    theta: &[f64; 6],
    weight_exp: &[i32],
) -> Result<(f64, Option<[f64; 6]>), String> {
    let mut ls = InfoLs::<S, 6>::new();
    let mut info = SMatrix::<f64, 6, 6>::zeros();
    let mut rhs = SVector::<f64, 6>::zeros();
    for (t, e) in torques.iter().zip(weight_exp.iter()) {
        let rows = inertia_rows(&t.map(|v| S::from_f32(v as f32)));
        let b: [S; 3] = core::array::from_fn(|i| {
            let v: f64 = (0..6).map(|j| rows[i][j].exact() * theta[j]).sum();
            S::from_f32(v as f32)
        });
        let w = [Scaled {
            m: S::from_f32(1.5),
            e: *e,
        }; 3];
        ls.add(&rows, &b, &w);
        for i in 0..3 {
            let a = SVector::<f64, 6>::from_fn(|j, _| rows[i][j].exact());
            let wi = 1.5 * (2.0f64).powi(*e);
            info += a * a.transpose() * wi;
            rhs += a * (b[i].exact() * wi);
        }
    }
    let xr = lu_solve(&info, &rhs);
    let sol = ls.solve(
        &[S::ZERO; 6],
        &[false; 6],
        S::from_int_pow2(1, -14),
        S::from_int_pow2(1, -20),
    );
    let cond = {
        let e = info.symmetric_eigen().eigenvalues;
        e.max() / e.min().max(1e-300)
    };
    match (sol, xr) {
        // Terms held at the prior: a reduced estimate, not the full one (the mask says so).
        (Ok(s), _) if s.unobservable.iter().any(|u| *u) => Ok((cond, None)),
        (Ok(s), Some(xr)) => {
            let x: [f64; 6] = core::array::from_fn(|i| s.x[i].exact());
            let mut out = [0.0; 6];
            for i in 0..6 {
                out[i] = x[i] - xr[i];
            }
            Ok((cond, Some(out)))
        }
        (Err(_), _) => Ok((cond, None)),
        (Ok(_), None) => Err("kernel solved a system the reference finds singular".into()),
    }
}

#[test]
fn rls_inertia_matches_the_batch_reference_and_flags_single_axis_excitation() {
    // theta: the SPH2 inverse-inertia parameters in kernel units (1/(kg m^2)/100).
    let theta = [0.4133, 0.4674, 0.5156, -0.0021, -0.0033, -0.0003];
    let mut worst_q = 0.0f64;
    let mut worst_f = 0.0f64;
    let mut flagged = 0;
    let mut x = 12345u64;
    let mut rnd = move || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        (x % 2_000_001) as f64 / 1_000_000.0 - 1.0
    };
    for case in 0..200 {
        let single_axis = case % 4 == 0;
        let n = 3 + case % 20;
        let axis = case % 3;
        let torques: Vec<[f64; 3]> = (0..n)
            .map(|_| {
                let mut t = [rnd() * 10.0, rnd() * 10.0, rnd() * 10.0];
                if single_axis {
                    for k in 0..3 {
                        if k != axis {
                            t[k] = 0.0;
                        }
                    }
                }
                t
            })
            .collect();
        let exps: Vec<i32> = (0..n).map(|k| (k % 9) as i32 * 2).collect();
        let (cond, dq) = rls_inertia::<Q8_24>(&torques, &theta, &exps).unwrap();
        let (_, df) = rls_inertia::<f32>(&torques, &theta, &exps).unwrap();
        if single_axis {
            // Excitation about one axis leaves 3 of the 6 terms unobservable: the kernel must
            // say so (status / mask), never return a full estimate.
            assert!(
                dq.is_none() && df.is_none(),
                "single-axis case {case}: full estimate returned (cond {cond:e})"
            );
            flagged += 1;
            continue;
        }
        if let (Some(dq), Some(df)) = (dq, df) {
            let m = |d: [f64; 6]| d.iter().fold(0.0f64, |a, v| a.max(v.abs()));
            worst_q = worst_q.max(m(dq) / cond.max(1.0));
            worst_f = worst_f.max(m(df) / cond.max(1.0));
        }
    }
    println!("RLS inverse inertia vs reference batch: max |dx| / cond: Q8_24 {worst_q:e}, f32 {worst_f:e}; single-axis flagged {flagged}/50");
    // Forward error <= cond x backward error; backward error of the information form is a
    // few format steps relative to the diagonal (< 2^-16 for Q8.24 mantissas below 16).
    assert!(worst_q < (2.0f64).powi(-12), "Q8_24 {worst_q:e}");
    assert!(worst_f < (2.0f64).powi(-16), "f32 {worst_f:e}");
}
