//! Floating point in integer instructions: the fixed kernel's number for the output-error
//! identification ([`crate::flight_id`]).
//!
//! Why not Q8.24: the identification's sums span 10^-14 (products of rate residuals over a
//! window) to 10^9 (their information), and its fit inverts them, so no single 32-bit fixed
//! format holds them (the Q8.24 instantiation saturates and answers `Overflow`). Here every
//! value carries its own power-of-two exponent (block floating point with blocks of one):
//! a 25-bit signed mantissa, one bit finer than `f32`, and an `i32` exponent bounded by
//! [`EXP_LIMIT`]. Every operation is integer arithmetic through the proved primitives of
//! [`crate::int`]: the widening product, the fixed-point quotient, and the rounding and aligned
//! sum of [`crate::int::float`]. So the result is the same bit for bit on every core, with or
//! without an FPU, and each step's rounding is proved (round to nearest, ties away from zero),
//! not assumed from a compiler's float routines.
//!
//! Range: magnitudes from 2^-EXP_LIMIT to 2^EXP_LIMIT; past the top a value saturates (and
//! [`Scalar::is_valid`] turns false), below the bottom it flushes to zero.

use crate::int::float::{aligned_sum, round_to_mantissa, MANT_BITS, MAX_ALIGN};
use crate::int::{self, Native};
use crate::scalar::Scalar;
use core::ops::{Add, Mul, Neg, Sub};

/// Exponents stay within `+-EXP_LIMIT`: far beyond any physical quantity, and far from
/// `i32`'s limits, so exponent arithmetic never wraps.
pub const EXP_LIMIT: i32 = 1 << 20;

/// Smallest normalised mantissa magnitude.
const MANT_MIN: i32 = 1 << (MANT_BITS - 1);
/// The weight of a normalised mantissa's top bit, `MANT_BITS - 1`.
const MANT_TOP: i32 = MANT_BITS as i32 - 1;
/// Largest mantissa magnitude.
const MANT_MAX: i32 = (1 << MANT_BITS) - 1;

/// `m 2^e` with `2^24 <= |m| < 2^25`, or zero as `(0, 0)`; the saturated value has
/// `e = EXP_LIMIT`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct IntFloat {
    m: i32,
    e: i32,
}

impl IntFloat {
    /// The mantissa and exponent: the value is `mantissa * 2^exponent`.
    pub fn parts(self) -> (i32, i32) {
        (self.m, self.e)
    }

    /// `v 2^e`, rounded once to `MANT_BITS` bits (an exact integer sum's value).
    #[inline]
    pub fn from_i64_pow2(v: i64, e: i32) -> Self {
        Self::from_wide(v, e)
    }

    /// `v 2^e`, rounded to `MANT_BITS` bits, saturated or flushed outside the range.
    #[inline]
    fn from_wide(v: i64, e: i32) -> Self {
        let (m, k) = round_to_mantissa(&Native, &(v as u64));
        Self::make(m as i32, e.saturating_add(k as i32))
    }

    /// A normalised mantissa (or zero) with an exponent that may be out of range.
    #[inline]
    fn make(m: i32, e: i32) -> Self {
        if m == 0 || e < EXP_LIMIT.saturating_neg() {
            IntFloat { m: 0, e: 0 }
        } else if e >= EXP_LIMIT {
            IntFloat {
                m: if m < 0 {
                    MANT_MAX.saturating_neg()
                } else {
                    MANT_MAX
                },
                e: EXP_LIMIT,
            }
        } else {
            IntFloat { m, e }
        }
    }

    /// A saturated operand, if either is one: it propagates like IEEE's NaN, so an overflow
    /// anywhere in a computation reaches its result (saturated minus saturated is not zero).
    #[inline]
    fn saturated_of(self, rhs: Self) -> Option<Self> {
        if !self.is_valid() {
            Some(self)
        } else if !rhs.is_valid() {
            Some(rhs)
        } else {
            None
        }
    }

    /// The sum, correctly rounded.
    #[inline]
    fn sum(self, rhs: Self) -> Self {
        if let Some(s) = self.saturated_of(rhs) {
            return s;
        }
        if self.m == 0 {
            return rhs;
        }
        if rhs.m == 0 {
            return self;
        }
        let (big, small) = if self.e < rhs.e {
            (rhs, self)
        } else {
            (self, rhs)
        };
        // both exponents within +-EXP_LIMIT (saturated: = EXP_LIMIT), so this cannot wrap
        let d = big.e.saturating_sub(small.e);
        if d > MAX_ALIGN as i32 {
            // |small| < 2^-13 of big's last bit: big is the nearest
            return big;
        }
        let s = aligned_sum(&Native, &(big.m as u32), &(small.m as u32), &(d as u32));
        Self::from_wide(s as i64, small.e)
    }
}

impl Add for IntFloat {
    type Output = Self;
    #[inline]
    fn add(self, rhs: Self) -> Self {
        self.sum(rhs)
    }
}

impl Sub for IntFloat {
    type Output = Self;
    #[inline]
    fn sub(self, rhs: Self) -> Self {
        self.sum(rhs.neg())
    }
}

impl Mul for IntFloat {
    type Output = Self;
    /// The exact 50-bit product of the mantissas, rounded once.
    #[inline]
    fn mul(self, rhs: Self) -> Self {
        if let Some(s) = self.saturated_of(rhs) {
            return s;
        }
        if self.m == 0 || rhs.m == 0 {
            return Self::ZERO;
        }
        let p = int::mul::widening_mul(&Native, &(self.m as u32), &(rhs.m as u32));
        Self::from_wide(p as i64, self.e.saturating_add(rhs.e))
    }
}

impl Neg for IntFloat {
    type Output = Self;
    #[inline]
    fn neg(self) -> Self {
        // |m| < 2^25: the negation cannot overflow
        IntFloat {
            m: self.m.saturating_neg(),
            e: self.e,
        }
    }
}

/// Fractional bits of the mantissa quotient: `|a| 2^30 / |b|` of two normalised mantissas is
/// in `(2^29, 2^31)`, inside `i32`, and its truncation rounded to nearest once more is the
/// correctly rounded quotient (the truncated bits can only tie where the exact value does).
pub const QUOTIENT_FRAC: u32 = 30;

impl Scalar for IntFloat {
    const ZERO: Self = IntFloat { m: 0, e: 0 };
    const ONE: Self = IntFloat {
        m: MANT_MIN,
        e: 1 - MANT_BITS as i32,
    };
    #[inline]
    fn from_int_pow2(m: i32, e: i32) -> Self {
        Self::from_wide(i64::from(m), e)
    }
    #[inline]
    fn from_f32(v: f32) -> Self {
        // Decoded from the bit pattern: exact (24 significant bits fit 25).
        if v.is_nan() {
            return Self::ZERO;
        }
        let bits = v.to_bits();
        let biased = ((bits >> 23) & 0xff) as i32;
        let frac = i64::from(bits & 0x7f_ffff);
        let (mant, e) = match biased {
            0 => (frac, -149),
            0xff => (MANT_MAX as i64, EXP_LIMIT),
            _ => (frac | (1 << 23), biased.saturating_sub(150)),
        };
        let signed = if bits >> 31 == 1 {
            mant.saturating_neg()
        } else {
            mant
        };
        Self::from_wide(signed, e)
    }
    #[inline]
    fn to_f32(self) -> f32 {
        if !self.is_valid() {
            return if self.m < 0 {
                f32::NEG_INFINITY
            } else {
                f32::INFINITY
            };
        }
        // m is exact in f64; the power of two in two exact steps, one rounding at the end
        let e = self.e.clamp(-2000, 2000);
        let first = e.clamp(-1000, 1000);
        (f64::from(self.m) * pow2_f64(first) * pow2_f64(e.saturating_sub(first))) as f32
    }
    #[inline]
    fn checked_div(self, rhs: Self) -> Option<Self> {
        if rhs.m == 0 || self.saturated_of(rhs).is_some() {
            return None;
        }
        if self.m == 0 {
            return Some(Self::ZERO);
        }
        let q = crate::scalar::fixed_div(self.m, rhs.m, QUOTIENT_FRAC)?;
        let e = self
            .e
            .saturating_sub(rhs.e)
            .saturating_sub(QUOTIENT_FRAC as i32);
        let out = Self::from_wide(i64::from(q), e);
        out.is_valid().then_some(out)
    }
    #[inline]
    fn abs(self) -> Self {
        IntFloat {
            m: self.m.saturating_abs(),
            e: self.e,
        }
    }
    #[inline]
    fn is_certainly_zero(self) -> bool {
        self.m == 0
    }
    #[inline]
    fn lt(self, rhs: Self) -> bool {
        let (sa, sb) = (self.m.signum(), rhs.m.signum());
        if sa != sb {
            return sa < sb;
        }
        if sa == 0 {
            return false;
        }
        // same sign, both normalised: the exponent orders magnitudes first
        let magnitude_lt = if self.e == rhs.e {
            self.m.saturating_abs() < rhs.m.saturating_abs()
        } else {
            self.e < rhs.e
        };
        let magnitude_gt = if self.e == rhs.e {
            self.m.saturating_abs() > rhs.m.saturating_abs()
        } else {
            self.e > rhs.e
        };
        if sa > 0 {
            magnitude_lt
        } else {
            magnitude_gt
        }
    }
    #[inline]
    fn mul_pow2(self, e: i32) -> Self {
        if self.m == 0 || !self.is_valid() {
            return self;
        }
        Self::make(self.m, self.e.saturating_add(e))
    }
    #[inline]
    fn is_valid(self) -> bool {
        self.e < EXP_LIMIT
    }
    #[inline]
    fn headroom() -> Self {
        // 2^100: as far from the range's ends as f32's 1e30 is from its own
        IntFloat {
            m: MANT_MIN,
            e: 101 - MANT_TOP - 1,
        }
    }
    #[inline]
    fn floor_times(self, k: u32) -> Option<i64> {
        if !self.is_valid() {
            return None;
        }
        // |m k| < 2^57
        let p = i64::from(self.m).checked_mul(i64::from(k))?;
        if self.e >= 0 {
            let scale = 1i64
                .checked_shl(self.e.unsigned_abs())
                .filter(|_| self.e < 63)?;
            p.checked_mul(scale)
        } else {
            // the arithmetic shift floors
            Some(p >> self.e.unsigned_abs().min(63))
        }
    }
    #[inline]
    fn split_pow2(self) -> (Self, i32) {
        if self.m == 0 {
            return (self, 0);
        }
        // m 2^e = (m 2^(1-MANT_BITS)) 2^(e+MANT_BITS-1), the first factor in [1, 2); the
        // exponent is clamped as the defining loop's 64 steps are
        let k = self.e.saturating_add(MANT_TOP).clamp(-64, 64);
        (
            IntFloat {
                m: self.m,
                e: self.e.saturating_sub(k),
            },
            k,
        )
    }
}

/// `2^e` as f64 from its bit pattern, `|e| <= 1000` (reporting only).
#[inline]
fn pow2_f64(e: i32) -> f64 {
    let biased = e.clamp(-1022, 1023).saturating_add(1023) as u64;
    f64::from_bits(biased << 52)
}

#[cfg(test)]
mod tests {
    #![allow(
        clippy::unwrap_used,
        clippy::indexing_slicing,
        clippy::arithmetic_side_effects
    )]
    use super::*;

    /// `v` rounded to 25 significant bits, ties away from zero, by f64 arithmetic (exact for
    /// the operands used: products of two 25-bit mantissas, sums within 53 bits).
    fn oracle(v: f64) -> f64 {
        if v == 0.0 {
            return 0.0;
        }
        let e = v.abs().log2().floor() as i32;
        let mut scale = 2f64.powi(MANT_BITS as i32 - 1 - e);
        // log2 may misplace an exact power of two by one
        if (v.abs() * scale) >= (1u64 << MANT_BITS) as f64 {
            scale *= 0.5;
        }
        if (v.abs() * scale) < (1u64 << (MANT_BITS - 1)) as f64 {
            scale *= 2.0;
        }
        let r = (v.abs() * scale + 0.5).floor();
        v.signum() * r / scale
    }

    fn val(x: IntFloat) -> f64 {
        f64::from(x.m) * 2f64.powi(x.e)
    }

    /// A deterministic stream of awkward operands: mixed signs, magnitudes over 2^-40..2^40,
    /// mantissas at the edges of the range.
    fn operands() -> impl Iterator<Item = f64> {
        let mut s: u64 = 0x9e37_79b9_7f4a_7c15;
        (0..4000).map(move |i| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            let mant = match i % 5 {
                0 => (1 << 24) as f64,
                1 => ((1 << 25) - 1) as f64,
                _ => ((s >> 8) % (1 << 24) + (1 << 24)) as f64,
            };
            let e = ((s >> 40) % 81) as i32 - 40 - 24;
            let sign = if s & 1 == 0 { 1.0 } else { -1.0 };
            sign * mant * 2f64.powi(e)
        })
    }

    fn operand_array() -> [f64; 4000] {
        let mut v = [0.0; 4000];
        for (slot, x) in v.iter_mut().zip(operands()) {
            *slot = x;
        }
        v
    }

    #[test]
    fn conversions_are_exact_for_f32_values() {
        for v in operands() {
            let f = v as f32;
            let x = IntFloat::from_f32(f);
            assert_eq!(val(x), f64::from(f));
            assert_eq!(x.to_f32(), f);
        }
        assert_eq!(IntFloat::from_f32(0.0), IntFloat::ZERO);
        assert_eq!(IntFloat::ONE.to_f32(), 1.0);
        assert_eq!(IntFloat::from_int_pow2(3, -1).to_f32(), 1.5);
        assert!(!IntFloat::from_f32(f32::INFINITY).is_valid());
    }

    #[test]
    fn arithmetic_is_correctly_rounded() {
        let v = operand_array();
        for w in v.windows(2) {
            let (a, b) = (oracle(w[0]), oracle(w[1]));
            let (x, y) = (IntFloat::from_f32(a as f32), IntFloat::from_f32(b as f32));
            let (a, b) = (val(x), val(y));
            assert_eq!(val(x * y), oracle(a * b), "{a} * {b}");
            // the sum is exact in f64 when the exponents differ by < 28
            if (a.abs().log2() - b.abs().log2()).abs() < 27.0 {
                assert_eq!(val(x + y), oracle(a + b), "{a} + {b}");
                assert_eq!(val(x - y), oracle(a - b), "{a} - {b}");
            } else {
                let big = if a.abs() > b.abs() { a } else { b };
                assert!((val(x + y) - (a + b)).abs() <= big.abs() * 2f64.powi(-24));
            }
            let q = val(x.checked_div(y).unwrap());
            let exact = a / b;
            assert!(
                (q - exact).abs() <= exact.abs() * 2f64.powi(-25),
                "{a} / {b}"
            );
            assert_eq!(x.lt(y), a < b);
            assert_eq!(y.lt(x), b < a);
        }
    }

    #[test]
    fn a_floor_instead_of_nearest_is_caught() {
        // The oracle comparison above, run on a product that floors its mantissa instead of
        // rounding it (the planted fault), fails on a fifth of the operand pairs.
        let floored = |x: IntFloat, y: IntFloat| {
            let p = i64::from(x.m) * i64::from(y.m);
            let len = 64 - p.unsigned_abs().leading_zeros() as i32;
            let sh = len - MANT_BITS as i32;
            f64::from((p >> sh) as i32) * 2f64.powi(x.e + y.e + sh)
        };
        let v = operand_array();
        let caught = v
            .windows(2)
            .filter(|w| {
                let (x, y) = (
                    IntFloat::from_f32(w[0] as f32),
                    IntFloat::from_f32(w[1] as f32),
                );
                floored(x, y) != oracle(val(x) * val(y))
            })
            .count();
        assert!(caught > v.len() / 10, "{caught}");
    }

    #[test]
    fn range_ends_saturate_or_flush() {
        let big = IntFloat::ONE.mul_pow2(EXP_LIMIT - 30);
        assert!(big.is_valid());
        assert!(!(big * big).is_valid());
        assert!(!(big * big).lt(big));
        // saturation is sticky: it is never cancelled back into a plausible number
        let sat = big * big;
        assert!(!(sat - sat).is_valid());
        assert!(!(sat * IntFloat::ZERO).is_valid());
        assert_eq!(sat.checked_div(IntFloat::ONE), None);
        let tiny = IntFloat::ONE.mul_pow2(30 - EXP_LIMIT);
        assert_eq!(tiny * tiny, IntFloat::ZERO);
        assert_eq!(IntFloat::ONE.checked_div(IntFloat::ZERO), None);
        assert_eq!(IntFloat::ZERO.split_pow2(), (IntFloat::ZERO, 0));
        let (m, k) = IntFloat::from_f32(-12.0).split_pow2();
        assert_eq!((m.to_f32(), k), (-1.5, 3));
        assert_eq!(IntFloat::from_f32(2.75).floor_times(4), Some(11));
        assert_eq!(IntFloat::from_f32(-2.75).floor_times(1), Some(-3));
    }

    #[test]
    fn split_pow2_matches_the_defining_loop() {
        for v in operands().take(300) {
            let x = IntFloat::from_f32(v as f32);
            let (m, k) = x.split_pow2();
            let (m_loop, k_loop) = crate::scalar::split_pow2_by_steps(x);
            assert_eq!((val(m), k), (val(m_loop), k_loop), "{v}");
        }
    }
}
