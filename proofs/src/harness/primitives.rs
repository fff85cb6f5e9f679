//! Arithmetic primitives of `kernel/src/scalar.rs`: the saturating Q-format operations must
//! equal the exact (i128) result clamped to the format, and never panic.
//!
//! The same property functions are run exhaustively over i16-sized operand domains by
//! `proofs/tests/exhaustive.rs`.

use super::Harness;
use crate::cover;
use crate::engine::any_in;
use fixed::types::extra::U24;
use fixed::FixedI32;
use massid_kernel::{Fx, Scalar, Q8_24};

const FRAC: u32 = 24;

fn q(bits: i32) -> Q8_24 {
    Fx(FixedI32::<U24>::from_bits(bits))
}
fn clamp(v: i128) -> i32 {
    v.clamp(i32::MIN as i128, i32::MAX as i128) as i32
}

/// `a + b`, `a - b`, `-a`, `|a|` equal the exact result clamped.
pub fn check_add_sub(a: i32, b: i32) {
    let (x, y) = (q(a), q(b));
    assert_eq!(
        (x + y).0.to_bits(),
        clamp(a as i128 + b as i128),
        "add {a} {b}"
    );
    assert_eq!(
        (x - y).0.to_bits(),
        clamp(a as i128 - b as i128),
        "sub {a} {b}"
    );
    assert_eq!((-x).0.to_bits(), clamp(-(a as i128)), "neg {a}");
    assert_eq!(x.abs().0.to_bits(), clamp((a as i128).abs()), "abs {a}");
}

/// `a * b` is the exact product rounded to the format (within one step) and clamped.
pub fn check_mul(a: i32, b: i32) {
    let exact = a as i128 * b as i128; // value * 2^(2 FRAC)
    let got = (q(a) * q(b)).0.to_bits() as i128;
    let lo = clamp(exact.div_euclid(1 << FRAC)) as i128;
    let hi = clamp(exact.div_euclid(1 << FRAC) + 1) as i128;
    assert!(
        lo <= got && got <= hi,
        "mul {a} {b}: {got} not in [{lo}, {hi}]"
    );
}

/// `checked_div` is `None` exactly for a zero divisor or a quotient that does not fit, else
/// the quotient within one step.
pub fn check_div(a: i32, b: i32) {
    let got = q(a).checked_div(q(b));
    if b == 0 {
        assert!(got.is_none(), "div by zero {a}");
        return;
    }
    let exact = ((a as i128) << FRAC) as f64 / b as f64;
    let fits = exact >= i32::MIN as f64 && exact < i32::MAX as f64 + 1.0;
    match got {
        Some(v) => {
            assert!((v.0.to_bits() as f64 - exact).abs() <= 1.0, "div {a} {b}");
        }
        None => assert!(
            !fits || (exact.abs() - i32::MAX as f64).abs() <= 1.0,
            "div {a} {b} fits but None"
        ),
    }
}

/// `mul_pow2` and `from_int_pow2` scale by 2^e exactly when representable, saturate above,
/// and round toward -inf below the resolution.
pub fn check_pow2(a: i32, e: i32) {
    assert_eq!(
        q(a).mul_pow2(e).0.to_bits(),
        clamp(scale_pow2(a as i128, e)),
        "mul_pow2 {a} {e}"
    );
    let e_bits = e + FRAC as i32;
    assert_eq!(
        Q8_24::from_int_pow2(a, e).0.to_bits(),
        clamp(scale_pow2(a as i128, e_bits)),
        "from_int_pow2 {a} {e}"
    );
}

/// `v * 2^sh` exactly, saturated to i128 (|v| < 2^32, so any |result| past 2^100 is "huge");
/// negative `sh` rounds toward -inf (arithmetic shift).
fn scale_pow2(v: i128, sh: i32) -> i128 {
    if sh >= 0 {
        if v == 0 {
            0
        } else if sh >= 90 {
            if v > 0 {
                i128::MAX
            } else {
                i128::MIN
            }
        } else {
            v << sh
        }
    } else {
        v >> sh.unsigned_abs().min(127)
    }
}

/// `lt` is the exact order of the values and `is_valid` rejects exactly the two limits.
pub fn check_order(a: i32, b: i32) {
    assert_eq!(q(a).lt(q(b)), a < b);
    assert_eq!(q(a).is_valid(), a != i32::MIN && a != i32::MAX);
}

#[cfg_attr(kani, kani::proof)]
pub fn q8_24_add_sub() {
    let a = any_in(i32::MIN, i32::MAX);
    let b = any_in(i32::MIN, i32::MAX);
    cover!(
        (a as i64 + b as i64) > i32::MAX as i64,
        "add saturates high"
    );
    cover!((a as i64 + b as i64) < i32::MIN as i64, "add saturates low");
    check_add_sub(a, b);
}

#[cfg_attr(kani, kani::proof)]
pub fn q8_24_mul() {
    let a = any_in(i32::MIN, i32::MAX);
    let b = any_in(i32::MIN, i32::MAX);
    cover!(
        ((a as i128 * b as i128) >> FRAC) > i32::MAX as i128,
        "mul saturates"
    );
    cover!(
        ((a as i128 * b as i128) >> FRAC).abs() < 1 << 20,
        "mul in range"
    );
    check_mul(a, b);
}

#[cfg_attr(kani, kani::proof)]
pub fn q8_24_div() {
    let a = any_in(i32::MIN, i32::MAX);
    let b = any_in(i32::MIN, i32::MAX);
    cover!(b == 0, "zero divisor");
    cover!(
        b != 0 && (((a as i128) << FRAC) / b as i128).abs() > i32::MAX as i128,
        "quotient too big"
    );
    check_div(a, b);
}

#[cfg_attr(kani, kani::proof)]
pub fn q8_24_pow2() {
    let a = any_in(i32::MIN, i32::MAX);
    let e = any_in(-80i32, 80);
    cover!(a != 0 && e > 8, "shift saturates or fits high");
    cover!(e < -31, "shift below resolution");
    check_pow2(a, e);
}

#[cfg_attr(kani, kani::proof)]
pub fn q8_24_order() {
    let a = any_in(i32::MIN, i32::MAX);
    let b = any_in(i32::MIN, i32::MAX);
    cover!(a == i32::MAX, "limit");
    check_order(a, b);
}

pub const HARNESSES: [Harness; 5] = [
    Harness {
        name: "q8_24_add_sub",
        body: q8_24_add_sub,
        covers: &["add saturates high", "add saturates low"],
        random_runs: 200_000,
        exhaustive_limit: None,
    },
    Harness {
        name: "q8_24_mul",
        body: q8_24_mul,
        covers: &["mul saturates", "mul in range"],
        random_runs: 200_000,
        exhaustive_limit: None,
    },
    Harness {
        name: "q8_24_div",
        body: q8_24_div,
        covers: &["zero divisor", "quotient too big"],
        random_runs: 200_000,
        exhaustive_limit: None,
    },
    Harness {
        name: "q8_24_pow2",
        body: q8_24_pow2,
        covers: &["shift saturates or fits high", "shift below resolution"],
        random_runs: 200_000,
        exhaustive_limit: None,
    },
    Harness {
        name: "q8_24_order",
        body: q8_24_order,
        covers: &["limit"],
        random_runs: 100_000,
        exhaustive_limit: None,
    },
];
