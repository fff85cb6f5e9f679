//! `lu::Lu::factor` / `solve`: for any matrix and right-hand side in the box, the result is
//! a status (`Singular`, `ZeroMatrix`, `Overflow`) or a solution whose residual is bounded
//! by the backward-error bound of partial-pivoting LU in the scalar's own arithmetic.

use super::Harness;
use crate::budget::Exact;
use crate::cover;
use crate::engine::{any_f64_in, any_in};
use massid_kernel::lu::{Lu, LuError};
use massid_kernel::Q8_24;

/// Unit roundoff and absolute step of the scalar, measured through the trait.
fn roundoff<S: Exact>() -> (f64, f64) {
    let step = crate::budget::fixed_step::<S>();
    // f32 has no absolute step worth the name (subnormals): relative 2^-24; fixed: absolute.
    if step < 1e-30 {
        (f32::EPSILON as f64 / 2.0, 0.0)
    } else {
        (0.0, step)
    }
}

/// The residual bound checked: `|A x - b|_inf <= c (u (|A|_inf |x|_inf + |b|_inf) + s (1 + |x|_1) n)`
/// with `c = 2^(n-1) * 4 n^2` (partial pivoting growth times the operation count), `u` the
/// relative and `s` the absolute rounding step of the format.
pub fn residual_bound(
    n: usize,
    a_inf: f64,
    x_inf: f64,
    x_1: f64,
    b_inf: f64,
    u: f64,
    s: f64,
) -> f64 {
    let c = (1u64 << (n - 1)) as f64 * 4.0 * (n * n) as f64;
    c * (u * (a_inf * x_inf + b_inf) + s * (1.0 + x_1) * n as f64)
}

fn factor_solve<S: Exact, const N: usize>() {
    // Entries O(1) (the kernel's information mantissas are kept below 2^4), with a chance of
    // a repeated row (exactly singular) or a tiny column (near-singular).
    let scale = [1.0, 4.0, 1.0 / 64.0][any_in(0usize, 2)];
    let mut a = [[0.0f64; N]; N];
    for row in a.iter_mut() {
        for v in row.iter_mut() {
            *v = any_f64_in(-scale, scale);
        }
    }
    match any_in(0u8, 3) {
        0 => {
            let (i, j) = (any_in(0usize, N - 1), any_in(0usize, N - 1));
            a[i] = a[j];
        }
        1 => {
            let j = any_in(0usize, N - 1);
            for row in a.iter_mut() {
                row[j] *= 1e-7;
            }
        }
        _ => {}
    }
    let b: [f64; N] = core::array::from_fn(|_| any_f64_in(-1.0, 1.0));
    let a_s: [[S; N]; N] = a.map(|r| r.map(|v| S::from_f32(v as f32)));
    let b_s: [S; N] = b.map(|v| S::from_f32(v as f32));
    let rel_tol = S::from_int_pow2(1, -20);
    let res = Lu::factor(&a_s, rel_tol).and_then(|lu| lu.solve(&b_s));
    match res {
        Err(LuError::Singular { column }) => {
            assert!(column < N);
            cover!(true, "singular status");
        }
        Err(LuError::ZeroMatrix) => cover!(true, "zero matrix status"),
        Err(LuError::Overflow) => cover!(true, "overflow status"),
        Ok(x) => {
            cover!(true, "solved");
            // Residual of the format's own matrix (what the kernel saw) in f64.
            let af = a_s.map(|r| r.map(|v| v.exact()));
            let bf = b_s.map(|v| v.exact());
            let xf = x.map(|v| v.exact());
            assert!(x.iter().all(|v| v.is_valid()));
            let a_inf = af
                .iter()
                .map(|r| r.iter().map(|v| v.abs()).sum::<f64>())
                .fold(0.0, f64::max);
            let x_inf = xf.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let x_1: f64 = xf.iter().map(|v| v.abs()).sum();
            let b_inf = bf.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let (u, s) = roundoff::<S>();
            let bound = residual_bound(N, a_inf, x_inf, x_1, b_inf, u, s);
            for i in 0..N {
                let r: f64 = (0..N).map(|j| af[i][j] * xf[j]).sum::<f64>() - bf[i];
                assert!(
                    r.abs() <= bound,
                    "row {i}: residual {r:e} > bound {bound:e}; A = {af:?} b = {bf:?} x = {xf:?}"
                );
            }
        }
    }
}

#[cfg_attr(kani, kani::proof)]
#[cfg_attr(kani, kani::unwind(65))]
pub fn lu3_q8_24() {
    factor_solve::<Q8_24, 3>()
}
#[cfg_attr(kani, kani::proof)]
#[cfg_attr(kani, kani::unwind(65))]
pub fn lu6_q8_24() {
    factor_solve::<Q8_24, 6>()
}
#[cfg_attr(kani, kani::proof)]
#[cfg_attr(kani, kani::unwind(65))]
pub fn lu6_f32() {
    factor_solve::<f32, 6>()
}

const COVERS: &[&str] = &["singular status", "solved"];
pub const HARNESSES: [Harness; 3] = [
    Harness {
        name: "lu3_q8_24",
        body: lu3_q8_24,
        covers: COVERS,
        random_runs: 20_000,
        exhaustive_limit: None,
    },
    Harness {
        name: "lu6_q8_24",
        body: lu6_q8_24,
        covers: COVERS,
        random_runs: 20_000,
        exhaustive_limit: None,
    },
    Harness {
        name: "lu6_f32",
        body: lu6_f32,
        covers: COVERS,
        random_runs: 20_000,
        exhaustive_limit: None,
    },
];
