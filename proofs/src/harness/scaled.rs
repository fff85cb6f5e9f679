//! `Scaled<S>` (the kernel's block floating point: the Kalman information and the RLS weights
//! live in it): normalisation, product, quotient, sum, difference, scaling by a plain scalar
//! and conversion from an exact integer accumulator keep the value within a few steps of the
//! mantissa's resolution (relative), never panic, and the quotient is `None` exactly for a
//! zero divisor.

use super::Harness;
use crate::budget::{fixed_step, Exact};
use crate::cover;
use crate::engine::{any_bool, any_f64_in, any_in};
use massid_kernel::{Scaled, Q8_24};

fn value<S: Exact>(x: Scaled<S>) -> f64 {
    x.m.exact() * (2.0f64).powi(x.e)
}

/// Relative resolution of a normalised mantissa in [1, 2): the format's step (Q8.24: 2^-24
/// absolute on [1, 2)) or f32's unit roundoff.
fn unit<S: Exact>() -> f64 {
    let s = fixed_step::<S>();
    if s == 0.0 {
        f32::EPSILON as f64 / 2.0
    } else {
        s
    }
}

/// A block-floating-point operand. `full`: any mantissa below 100 (zero included) with any
/// exponent in +-200, the contract's whole domain; otherwise the kernel's envelope: exponents
/// within +-80 (information ~2^31, covariances ~2^-32, RLS exponents measured below 2^40),
/// and zero only as `Scaled::zero()`.
fn any_scaled<S: Exact>(full: bool) -> Scaled<S> {
    let m = match any_in(0u8, 3) {
        0 => 0.0,
        1 => any_f64_in(-100.0, 100.0),
        _ => any_f64_in(1.0, 1.999) * if any_bool() { 1.0 } else { -1.0 },
    };
    let e = if full {
        any_in(-200i32, 200)
    } else if m == 0.0 {
        0
    } else {
        any_in(-80i32, 80)
    };
    Scaled {
        m: S::from_f32(m as f32),
        e,
    }
}

fn close(got: f64, want: f64, rel: f64, what: &str) {
    let tol = rel * want.abs();
    assert!(
        (got - want).abs() <= tol,
        "{what}: {got:e} vs {want:e} (tolerance {tol:e})"
    );
}

fn scaled_ops<S: Exact>(full: bool) {
    let u = unit::<S>();
    let (a, b) = (any_scaled::<S>(full), any_scaled::<S>(full));
    let (va, vb) = (value(a), value(b));
    let na = a.normalized();
    // Normalising shifts right (dropping one bit each, at most 7 for |m| < 128) or left (exact).
    close(value(na), va, 16.0 * u, "normalized");
    if va != 0.0 {
        let m = na.m.exact().abs();
        assert!(
            (1.0..2.0).contains(&m),
            "normalized mantissa {m} outside [1, 2)"
        );
        cover!(a.m.exact().abs() >= 2.0, "normalised down");
    }
    // Product and quotient: mantissas in [1, 2) carry <= 16 u relative each, product/quotient
    // rounding and renormalisation add <= 4 u.
    close(value(a.times(b)), va * vb, 40.0 * u, "times");
    match a.over(b) {
        None => {
            cover!(true, "zero divisor");
            assert_eq!(vb, 0.0, "over returned None for a nonzero divisor");
        }
        Some(q) => {
            assert!(vb != 0.0);
            close(value(q), va / vb, 40.0 * u, "over");
        }
    }
    // Sum and difference: aligned to the larger exponent + 1, so the error is relative to the
    // larger operand, not to the (possibly cancelled) result.
    // (A zero operand returns the other: kernel finding 12, fixed in 6177694.)
    let big = va.abs().max(vb.abs());
    let sum = value(a.plus(b));
    assert!(
        (sum - (va + vb)).abs() <= 40.0 * u * big,
        "plus: {sum:e} vs {:e}",
        va + vb
    );
    let diff = value(a.minus(b));
    assert!(
        (diff - (va - vb)).abs() <= 40.0 * u * big,
        "minus: {diff:e} vs {:e}",
        va - vb
    );
    cover!(va != 0.0 && (va + vb).abs() < 1e-3 * big, "cancellation");
    // Scaling by a plain O(1) scalar (the kernel scales normalised values or `from_i64`
    // mantissas in [0.5, 1); the full domain also scales raw mantissas up to 100).
    let k = any_f64_in(-4.0, 4.0);
    let ks = S::from_f32(k as f32);
    let sa = if full { a } else { na };
    // The product m k is formed in the format before renormalising: one step of the format at
    // the operand's exponent, absolute, besides the relative part.
    let (got, want) = (value(sa.scale(ks)), value(sa) * ks.exact());
    let tol = 40.0 * u * want.abs() + 2.0 * fixed_step::<S>() * (2.0f64).powi(sa.e);
    assert!(
        (got - want).abs() <= tol,
        "scale: {got:e} vs {want:e} (tolerance {tol:e})"
    );
}

fn from_integer<S: Exact>() {
    let v: i64 = match any_in(0u8, 3) {
        0 => any_in(-1000i64, 1000),
        1 => any_in(i64::MIN, i64::MAX),
        _ => any_in(-(1i64 << 40), 1i64 << 40),
    };
    let x = Scaled::<S>::from_i64(v);
    cover!(v.unsigned_abs() > 1 << 30, "beyond 30 bits");
    // The top 30 bits, then the format's rounding of a mantissa in [0.5, 1).
    close(
        value(x),
        v as f64,
        2.0f64.powi(-29) + 4.0 * unit::<S>(),
        "from_i64",
    );
}

#[cfg_attr(kani, kani::proof)]
#[cfg_attr(kani, kani::unwind(65))]
pub fn scaled_ops_q8_24() {
    scaled_ops::<Q8_24>(false)
}
#[cfg_attr(kani, kani::proof)]
#[cfg_attr(kani, kani::unwind(65))]
pub fn scaled_ops_f32() {
    scaled_ops::<f32>(false)
}
/// The contract's whole domain (zero mantissas with any exponent, exponents to +-200).
#[cfg_attr(kani, kani::proof)]
#[cfg_attr(kani, kani::unwind(65))]
pub fn scaled_ops_full_q8_24() {
    scaled_ops::<Q8_24>(true)
}
#[cfg_attr(kani, kani::proof)]
#[cfg_attr(kani, kani::unwind(65))]
pub fn scaled_ops_full_f32() {
    scaled_ops::<f32>(true)
}
#[cfg_attr(kani, kani::proof)]
#[cfg_attr(kani, kani::unwind(65))]
pub fn scaled_from_i64_q8_24() {
    from_integer::<Q8_24>()
}
#[cfg_attr(kani, kani::proof)]
#[cfg_attr(kani, kani::unwind(65))]
pub fn scaled_from_i64_f32() {
    from_integer::<f32>()
}

const OPS: &[&str] = &["normalised down", "zero divisor", "cancellation"];
pub const HARNESSES: [Harness; 6] = [
    Harness {
        name: "scaled_ops_full_q8_24",
        body: scaled_ops_full_q8_24,
        covers: OPS,
        random_runs: 50_000,
        exhaustive_limit: None,
    },
    Harness {
        name: "scaled_ops_full_f32",
        body: scaled_ops_full_f32,
        covers: OPS,
        random_runs: 50_000,
        exhaustive_limit: None,
    },
    Harness {
        name: "scaled_ops_q8_24",
        body: scaled_ops_q8_24,
        covers: OPS,
        random_runs: 50_000,
        exhaustive_limit: None,
    },
    Harness {
        name: "scaled_ops_f32",
        body: scaled_ops_f32,
        covers: OPS,
        random_runs: 50_000,
        exhaustive_limit: None,
    },
    Harness {
        name: "scaled_from_i64_q8_24",
        body: scaled_from_i64_q8_24,
        covers: &["beyond 30 bits"],
        random_runs: 50_000,
        exhaustive_limit: None,
    },
    Harness {
        name: "scaled_from_i64_f32",
        body: scaled_from_i64_f32,
        covers: &["beyond 30 bits"],
        random_runs: 50_000,
        exhaustive_limit: None,
    },
];
