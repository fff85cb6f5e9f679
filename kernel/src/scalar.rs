//! The number type the kernel is generic over, with an `f32` and a `fixed`-crate impl.
//!
//! # Contract (what generic kernel code may assume, and what an impl must provide)
//!
//! * `+ - *` and unary `-` never panic. Fixed impls **saturate** at the format's limits
//!   (a saturated value is caught by the range analysis and the status checks, it is never
//!   wrapped into a plausible-looking wrong number). `f32` follows IEEE.
//! * Division only through [`Scalar::checked_div`], which returns `None` for a zero divisor
//!   or a quotient that does not fit: the kernel turns that into a status.
//! * Every comparison or branch condition goes through a trait method ([`Scalar::lt`],
//!   [`Scalar::is_valid`], [`Scalar::abs`]), never `PartialOrd`, so that an interval type can
//!   give them a conservative meaning: `lt(a, b)` must return `true` only if `a < b` holds
//!   for every value the operands may stand for. Kernel code is written so that the
//!   `false` branch of `lt` is always the safe one (e.g. "pivot not known to be large
//!   enough" => singular status).
//! * Constants enter only through [`Scalar::from_f32`] (model parameters at
//!   initialisation) and [`Scalar::from_int_pow2`] (integer accumulators scaled by a power of
//!   two). There is no other hidden conversion; [`Scalar::to_f32`] is for reporting only and
//!   never feeds back into the computation.
//! * [`Scalar::mul_pow2`] scales by `2^e` exactly (a shift for fixed, exact for `f32` in
//!   range); the kernel uses it for block-floating-point normalisation of the RLS
//!   information and the Kalman-filter accumulators (see `kernel/README.md`).
//!
//! Implement this trait outside the crate for an interval/affine type to run the same
//! generic code as a range analysis (task `proofs/`).

use crate::int::{self, Native};
use core::ops::{Add, Mul, Neg, Sub};
use fixed::types::extra::LeEqU32;
use fixed::FixedI32;

/// The number type of the kernel. See the module docs for the contract.
pub trait Scalar:
    Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Neg<Output = Self>
{
    /// Additive identity.
    const ZERO: Self;
    /// Multiplicative identity.
    const ONE: Self;
    /// `m * 2^e`, saturating if it does not fit (rounding toward zero below resolution).
    fn from_int_pow2(m: i32, e: i32) -> Self;
    /// A model constant (called at initialisation, not per tick). Saturates; NaN maps to zero
    /// and makes [`Scalar::is_valid`] of derived values meaningful only through the status checks.
    fn from_f32(v: f32) -> Self;
    /// For reporting only (never fed back into the kernel's arithmetic).
    fn to_f32(self) -> f32;
    /// `self / rhs`, or `None` if `rhs` may be zero or the quotient does not fit.
    fn checked_div(self, rhs: Self) -> Option<Self>;
    /// Absolute value (saturating for the most negative fixed value).
    fn abs(self) -> Self;
    /// `true` only if `self < rhs` certainly holds (interval impls: for all represented values).
    fn lt(self, rhs: Self) -> bool;
    /// `self * 2^e`, exact when representable; saturates on overflow, truncates toward zero below resolution.
    fn mul_pow2(self, e: i32) -> Self;
    /// `true` if the value is a finite number that did not hit a saturation limit.
    fn is_valid(self) -> bool;
    /// The largest `v` such that `v` and `-v` are safely representable, as a bound for
    /// normalisation (`f32`: a large power of two; fixed: a quarter of the format's range).
    fn headroom() -> Self;
    /// `floor(self * k)` computed exactly (wider integer or f64 arithmetic inside the impl),
    /// or `None` if it does not fit or is not decided (an interval straddling an integer).
    /// The mixer's integer-millisecond rounding rests on this.
    fn floor_times(self, k: u32) -> Option<i64>;
    /// `true` only if the value is certainly exactly zero: a shortcut for skipping work whose
    /// result would be zero anyway. The default, `false`, never skips (right for intervals).
    #[inline]
    fn is_certainly_zero(self) -> bool {
        false
    }

    /// `self + rhs` (the contract makes the operators panic-free: saturating for fixed,
    /// IEEE for f32). Generic kernel code calls these named forms so that the crate-wide
    /// `clippy::arithmetic_side_effects` lint stays on for every integer operation.
    #[inline]
    #[allow(clippy::arithmetic_side_effects)]
    fn plus(self, rhs: Self) -> Self {
        self + rhs
    }
    /// `self - rhs` (see [`Scalar::plus`]).
    #[inline]
    #[allow(clippy::arithmetic_side_effects)]
    fn minus(self, rhs: Self) -> Self {
        self - rhs
    }
    /// `self * rhs` (see [`Scalar::plus`]).
    #[inline]
    #[allow(clippy::arithmetic_side_effects)]
    fn times(self, rhs: Self) -> Self {
        self * rhs
    }
    /// `-self` (see [`Scalar::plus`]).
    #[inline]
    #[allow(clippy::arithmetic_side_effects)]
    fn negate(self) -> Self {
        -self
    }
    /// `self + a * b`.
    #[inline]
    fn mul_add(self, a: Self, b: Self) -> Self {
        self.plus(a.times(b))
    }

    /// [`Scalar::mul_pow2`] rounding to nearest instead of truncating below resolution: for
    /// rescaling stored sums (the RLS information is shifted down once per merge; a
    /// truncating shift drifts by half a step each time). Default: `mul_pow2` (exact for
    /// `f32` in range).
    #[inline]
    fn mul_pow2_nearest(self, e: i32) -> Self {
        self.mul_pow2(e)
    }

    /// `(m, k)` with `self = m * 2^k` (up to the floor rounding of the down shifts) and
    /// `|m|` in `[1, 2)`: the block-floating-point normalisation. At most 64 steps each way;
    /// zero stays `(0, 0)`. The default is the defining loop, one exact halving or doubling
    /// per step through the trait's own comparisons (so an interval type keeps its meaning);
    /// the `f32` and fixed impls compute the same result in O(1) from the bit pattern
    /// (tested against the loop).
    #[inline]
    fn split_pow2(self) -> (Self, i32) {
        split_pow2_by_steps(self)
    }
}

/// The defining loop of [`Scalar::split_pow2`].
pub fn split_pow2_by_steps<S: Scalar>(v: S) -> (S, i32) {
    let one = S::ONE;
    let two = S::from_int_pow2(2, 0);
    let mut m = v;
    let mut e = 0i32;
    for _ in 0..64 {
        if m.abs().lt(two) {
            break;
        }
        m = m.mul_pow2(-1);
        e = e.saturating_add(1);
    }
    for _ in 0..64 {
        if !m.abs().lt(one) || !S::ZERO.lt(m.abs()) {
            break;
        }
        m = m.mul_pow2(1);
        e = e.saturating_sub(1);
    }
    (m, e)
}

/// The larger of two magnitudes, through the trait's comparison.
#[inline]
pub fn max_abs<S: Scalar>(a: S, b: S) -> S {
    let (a, b) = (a.abs(), b.abs());
    if a.lt(b) {
        b
    } else {
        a
    }
}

/// The operations the IEEE impls ([`f32`], [`f64`]) share, written once.
macro_rules! ieee_float_ops {
    () => {
        #[inline]
        fn checked_div(self, rhs: Self) -> Option<Self> {
            if rhs == 0.0 {
                return None;
            }
            let q = self / rhs;
            q.is_finite().then_some(q)
        }
        #[inline]
        fn abs(self) -> Self {
            if self < 0.0 {
                -self
            } else {
                self
            }
        }
        #[inline]
        fn lt(self, rhs: Self) -> bool {
            self < rhs
        }
        #[inline]
        fn is_valid(self) -> bool {
            self.is_finite()
        }
        #[inline]
        fn is_certainly_zero(self) -> bool {
            self == 0.0
        }
        #[inline]
        fn floor_times(self, k: u32) -> Option<i64> {
            // An f32 or f64 value times a u32 is exact in f64 for f32, and rounded once for
            // f64; the floor is then taken exactly.
            let x = f64::from(self) * f64::from(k);
            if !x.is_finite() || x.abs() >= 9.0e15 {
                return None;
            }
            let t = x as i64; // truncation toward zero, exact below 2^53
            Some(if (t as f64) > x {
                t.saturating_sub(1)
            } else {
                t
            })
        }
    };
}

impl Scalar for f32 {
    const ZERO: Self = 0.0;
    const ONE: Self = 1.0;
    #[inline]
    fn from_int_pow2(m: i32, e: i32) -> Self {
        (m as f32) * pow2_f32(e)
    }
    #[inline]
    fn from_f32(v: f32) -> Self {
        if v.is_nan() {
            0.0
        } else {
            v
        }
    }
    #[inline]
    fn to_f32(self) -> f32 {
        self
    }
    ieee_float_ops!();
    #[inline]
    fn mul_pow2(self, e: i32) -> Self {
        // A single power of two only spans 2^-126..2^127; the shift is applied in up to three
        // exact steps so a larger one still saturates / flushes as the contract says (proofs
        // finding 11). Beyond +-300 every finite nonzero f32 overflows or flushes anyway.
        let e = e.clamp(-300, 300);
        let first = e.clamp(-126, 127);
        let rest = e.saturating_sub(first);
        let second = rest.clamp(-126, 127);
        let third = rest.saturating_sub(second);
        self * pow2_f32(first) * pow2_f32(second) * pow2_f32(third)
    }
    #[inline]
    fn headroom() -> Self {
        1.0e30
    }
    #[inline]
    fn split_pow2(self) -> (Self, i32) {
        let biased = ((self.to_bits() >> 23) & 0xff) as i32;
        if biased == 0 || biased == 0xff {
            // zero, subnormal, infinite, NaN: rare, the defining loop
            return split_pow2_by_steps(self);
        }
        // A normal number is 1.f * 2^(biased - 127); the loop stops after 64 steps.
        let k = biased.saturating_sub(127).clamp(-64, 64);
        // exact: the result is normal (|k| <= 64 keeps it far inside the range)
        (self * pow2_f32(k.saturating_neg()), k)
    }
}

/// Doubles: what a core with a double-precision FPU (Cortex-M7) flies, and on the ground the
/// kernel's algorithms without their f32 rounding (how the identification's rounding budget
/// is measured: `kernel-host`'s `identify::<f64>` against `identify::<f32>`).
impl Scalar for f64 {
    const ZERO: Self = 0.0;
    const ONE: Self = 1.0;
    #[inline]
    fn from_int_pow2(m: i32, e: i32) -> Self {
        f64::from(m) * f64::from(pow2_f32(e.clamp(-126, 127))) * pow2_rest(e)
    }
    #[inline]
    fn from_f32(v: f32) -> Self {
        if v.is_nan() {
            0.0
        } else {
            f64::from(v)
        }
    }
    #[inline]
    fn to_f32(self) -> f32 {
        self as f32
    }
    ieee_float_ops!();
    #[inline]
    fn mul_pow2(self, e: i32) -> Self {
        let e = e.clamp(-2000, 2000);
        let first = e.clamp(-1000, 1000);
        let second = e.saturating_sub(first);
        self * pow2_f64(first) * pow2_f64(second)
    }
    #[inline]
    fn headroom() -> Self {
        1.0e200
    }
}

/// `2^(e - clamp(e, -126, 127))` for [`Scalar::from_int_pow2`] of f64.
#[inline]
fn pow2_rest(e: i32) -> f64 {
    pow2_f64(e.saturating_sub(e.clamp(-126, 127)))
}

/// `2^e` as f64 from its bit pattern; clamps to the normal range.
#[inline]
fn pow2_f64(e: i32) -> f64 {
    let e = e.clamp(-1022, 1023);
    let biased = e.saturating_add(1023) as u64;
    f64::from_bits(biased << 52)
}

/// `2^e` as f32 built from its bit pattern (no libm in `no_std`); clamps to the normal range.
#[inline]
fn pow2_f32(e: i32) -> f32 {
    let e = e.clamp(-126, 127);
    // e + 127 is in 1..=254, so the cast and shift are exact.
    let biased = e.saturating_add(127) as u32;
    f32::from_bits(biased << 23)
}

/// A `fixed`-crate 32-bit signed number with `FRAC` fractional bits and saturating arithmetic.
///
/// The kernel's fixed instantiation is [`Q8_24`] (range +-128, resolution 6e-8): every
/// quantity is expressed in units that make it O(1) (see `kernel/README.md`, range analysis),
/// and the quantities whose dynamic range is too wide for any 32-bit format (Kalman
/// information, RLS information) are carried as integer accumulators or as block floating
/// point (a `Fx` mantissa plus a shared `i32` exponent).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Default)]
#[repr(transparent)]
pub struct Fx<Frac: LeEqU32>(pub FixedI32<Frac>);

/// The kernel's fixed-point scalar: 8 integer bits (sign included), 24 fractional bits.
pub type Q8_24 = Fx<fixed::types::extra::U24>;
/// A 16.16 scalar (too coarse for the CoM terms: kept for the range-analysis comparison).
pub type Q16_16 = Fx<fixed::types::extra::U16>;

impl<Frac: LeEqU32> Add for Fx<Frac> {
    type Output = Self;
    #[inline]
    fn add(self, rhs: Self) -> Self {
        Fx(self.0.saturating_add(rhs.0))
    }
}
impl<Frac: LeEqU32> Sub for Fx<Frac> {
    type Output = Self;
    #[inline]
    fn sub(self, rhs: Self) -> Self {
        Fx(self.0.saturating_sub(rhs.0))
    }
}
impl<Frac: LeEqU32> Mul for Fx<Frac> {
    type Output = Self;
    /// Full 64-bit product rounded to nearest (ties toward plus infinity), saturated
    /// ([`int::mul::round_product`]).
    #[inline]
    fn mul(self, rhs: Self) -> Self {
        let (a, b) = (self.0.to_bits() as u32, rhs.0.to_bits() as u32);
        let p = int::mul::widening_mul(&Native, &a, &b);
        Fx(FixedI32::from_bits(
            int::mul::round_product(&Native, &p, Frac::U32) as i32,
        ))
    }
}

/// `a * b` as i64 from four 16 x 16 -> 32 bit products ([`int::mul::widening_mul_by_halves`]).
#[inline]
pub fn mul_32x32_by_halves(a: i32, b: i32) -> i64 {
    int::mul::widening_mul_by_halves(&Native, &(a as u32), &(b as u32)) as i64
}

/// A `(fits, bits)` pair of the word primitives as an `Option<i32>`.
#[inline(always)]
fn fitting((fits, q): (bool, u32)) -> Option<i32> {
    fits.then_some(q as i32)
}

/// `trunc(a 2^frac / b)` as the `fixed` crate's `checked_div` defines it (`None` for a zero
/// divisor or a quotient outside `i32`), by restoring long division in 32-bit words
/// ([`int::div::div_by_words`]): for cores without a hardware divide (Cortex-M0), which
/// otherwise call the 64-bit division routine, several hundred instructions per quotient.
#[inline]
pub fn fixed_div_by_words(a: i32, b: i32, frac: u32) -> Option<i32> {
    if frac > 31 {
        return fixed_div_by_i64(a, b, frac);
    }
    fitting(int::div::div_by_words(
        &Native,
        &(a as u32),
        &(b as u32),
        frac,
    ))
}

/// `trunc(a 2^frac / b)` by one 64-bit division ([`int::div::div_by_i64`]), where the core
/// divides in hardware or the runtime's routine is cheap enough.
#[inline]
pub fn fixed_div_by_i64(a: i32, b: i32, frac: u32) -> Option<i32> {
    fitting(int::div::div_by_i64(
        &Native,
        &(a as u32),
        &(b as u32),
        frac,
    ))
}

/// `trunc(a 2^frac / b)` with two 32 / 16-bit digit steps of long division
/// ([`int::div::div_by_digits`]): two hardware 32-bit divides and at most four corrections,
/// where the 64-bit division routine would take ~150 instructions (Cortex-M4F).
#[inline]
pub fn fixed_div_by_digits(a: i32, b: i32, frac: u32) -> Option<i32> {
    if frac > 31 {
        return fixed_div_by_i64(a, b, frac);
    }
    fitting(int::div::div_by_digits(
        &Native,
        &(a as u32),
        &(b as u32),
        frac,
    ))
}

// Soft-division ARM (Cortex-M0/M0+): shift-subtract, no divide instruction to build on.
#[cfg(all(target_arch = "arm", target_abi = "eabi"))]
#[inline]
pub(crate) fn fixed_div(a: i32, b: i32, frac: u32) -> Option<i32> {
    fixed_div_by_words(a, b, frac)
}

// Hard-float ARM (Cortex-M4F/M7): hardware 32-bit divide.
#[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
#[inline]
pub(crate) fn fixed_div(a: i32, b: i32, frac: u32) -> Option<i32> {
    fixed_div_by_digits(a, b, frac)
}

#[cfg(not(all(target_arch = "arm", any(target_abi = "eabi", target_abi = "eabihf"))))]
#[inline]
pub(crate) fn fixed_div(a: i32, b: i32, frac: u32) -> Option<i32> {
    fixed_div_by_i64(a, b, frac)
}

impl<Frac: LeEqU32> Neg for Fx<Frac> {
    type Output = Self;
    #[inline]
    fn neg(self) -> Self {
        Fx(self.0.saturating_neg())
    }
}

impl<Frac: LeEqU32> Scalar for Fx<Frac> {
    const ZERO: Self = Fx(FixedI32::ZERO);
    // Valid for FRAC <= 30 (the shift is checked at compile time when instantiated).
    const ONE: Self = Fx(FixedI32::from_bits(1 << Frac::U32));
    #[inline]
    fn from_int_pow2(m: i32, e: i32) -> Self {
        // value = m * 2^e; bits = m * 2^(e + FRAC)
        let sh = e.saturating_add(Frac::I32);
        Fx(FixedI32::from_bits(shift_sat_i32(m, sh)))
    }
    #[inline]
    fn from_f32(v: f32) -> Self {
        // Round to nearest (ties away from zero) and saturate, without the `fixed` crate's
        // conversion (which keeps a formatting panic path in the binary). f32 * 2^FRAC is
        // exact in f64; `f64 as i64` saturates.
        if v.is_nan() {
            return Fx(FixedI32::ZERO);
        }
        let x = f64::from(v) * f64::from(1u32 << Frac::U32.min(31));
        let r = if x >= 0.0 {
            (x + 0.5) as i64
        } else {
            (x - 0.5) as i64
        };
        let bits = r.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32;
        Fx(FixedI32::from_bits(bits))
    }
    #[inline]
    fn to_f32(self) -> f32 {
        self.0.to_num::<f32>()
    }
    #[inline]
    fn checked_div(self, rhs: Self) -> Option<Self> {
        fixed_div(self.0.to_bits(), rhs.0.to_bits(), Frac::U32).map(|b| Fx(FixedI32::from_bits(b)))
    }
    #[inline]
    fn abs(self) -> Self {
        Fx(self.0.saturating_abs())
    }
    #[inline]
    fn lt(self, rhs: Self) -> bool {
        self.0 < rhs.0
    }
    #[inline]
    fn mul_pow2(self, e: i32) -> Self {
        Fx(FixedI32::from_bits(shift_sat_i32(self.0.to_bits(), e)))
    }
    #[inline]
    fn mul_pow2_nearest(self, e: i32) -> Self {
        let v = self.0.to_bits() as u32;
        Fx(FixedI32::from_bits(
            int::shift::shift_nearest(&Native, &v, &(e as u32)) as i32,
        ))
    }
    #[inline]
    fn is_valid(self) -> bool {
        self.0 != FixedI32::<Frac>::MAX && self.0 != FixedI32::<Frac>::MIN
    }
    #[inline]
    fn headroom() -> Self {
        Fx(FixedI32::from_bits(i32::MAX >> 2))
    }
    #[inline]
    fn floor_times(self, k: u32) -> Option<i64> {
        // bits * k fits in i64 (32 + 32 bits); the arithmetic shift floors.
        let prod = i64::from(self.0.to_bits()).checked_mul(i64::from(k))?;
        Some(prod >> Frac::U32.min(63))
    }
    #[inline]
    fn split_pow2(self) -> (Self, i32) {
        if Frac::U32 > 29 {
            return split_pow2_by_steps(self);
        }
        let b = self.0.to_bits() as u32;
        let (m, k) = int::split::split_word(&Native, &b, Frac::U32);
        (Fx(FixedI32::from_bits(m as i32)), k as i32)
    }
}

/// `v * 2^sh` saturated to i32, flooring right shifts ([`int::shift::shift_saturating`]).
#[inline]
fn shift_sat_i32(v: i32, sh: i32) -> i32 {
    int::shift::shift_saturating(&Native, &(v as u32), &(sh as u32)) as i32
}

/// A block-floating-point value `m * 2^e`: an O(1) [`Scalar`] mantissa with an integer
/// exponent. Used for the quantities whose dynamic range no 32-bit fixed format holds
/// (Kalman information ~ 3e9, its covariance ~ 3e-10, RLS weights).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scaled<S> {
    /// Mantissa (kept O(1) by the code that builds it).
    pub m: S,
    /// Power-of-two exponent.
    pub e: i32,
}

impl<S: Scalar> Scaled<S> {
    /// Zero.
    pub fn zero() -> Self {
        Scaled { m: S::ZERO, e: 0 }
    }
    /// The value re-expressed with exponent `e` (the mantissa shifted accordingly).
    #[inline]
    pub fn mantissa_at(self, e: i32) -> S {
        self.m.mul_pow2(self.e.saturating_sub(e))
    }
    /// For reporting: the value as f64 (`m * 2^e`).
    pub fn to_f64(self) -> f64 {
        let mut v = f64::from(self.m.to_f32());
        let mut e = self.e.clamp(-1100, 1100);
        while e > 0 {
            v *= 2.0;
            e = e.saturating_sub(1);
        }
        while e < 0 {
            v *= 0.5;
            e = e.saturating_add(1);
        }
        v
    }
}

impl<S: Scalar> Scaled<S> {
    /// A constant given in f64 at initialisation, with its mantissa in [1, 2).
    pub fn from_f64(v: f64) -> Self {
        if !v.is_finite() || v == 0.0 {
            return Scaled::zero();
        }
        let mut m = v;
        let mut e = 0i32;
        let mut guard = 0u32;
        while (m >= 2.0 || m <= -2.0) && guard < 2100 {
            m *= 0.5;
            e = e.saturating_add(1);
            guard = guard.saturating_add(1);
        }
        while m < 1.0 && m > -1.0 && guard < 2100 {
            m *= 2.0;
            e = e.saturating_sub(1);
            guard = guard.saturating_add(1);
        }
        Scaled {
            m: S::from_f32(m as f32),
            e,
        }
    }

    /// Brings the mantissa into [1, 2) in magnitude (at most 64 steps each way; zero stays
    /// zero): [`Scalar::split_pow2`].
    #[inline]
    pub fn normalized(self) -> Self {
        let (m, k) = self.m.split_pow2();
        Scaled {
            m,
            e: self.e.saturating_add(k),
        }
    }
}

/// `true` for a zero (a NaN or saturated value is not one, so it still propagates).
fn is_exact_zero<S: Scalar>(m: S) -> bool {
    m.is_valid() && !S::ZERO.lt(m.abs())
}

impl<S: Scalar> Scaled<S> {
    /// Product (mantissas multiplied, exponents added; the result is renormalised).
    pub fn times(self, rhs: Self) -> Self {
        let a = self.normalized();
        let b = rhs.normalized();
        Scaled {
            m: a.m.times(b.m),
            e: a.e.saturating_add(b.e),
        }
        .normalized()
    }
    /// Quotient, `None` for a zero divisor.
    pub fn over(self, rhs: Self) -> Option<Self> {
        let a = self.normalized();
        let b = rhs.normalized();
        Some(
            Scaled {
                m: a.m.checked_div(b.m)?,
                e: a.e.saturating_sub(b.e),
            }
            .normalized(),
        )
    }
    /// Sum (aligned to the larger exponent).
    pub fn plus(self, rhs: Self) -> Self {
        // A zero's exponent carries no information: aligning to it would flush the other
        // operand below its resolution (proofs finding 12).
        if is_exact_zero(self.m) {
            return rhs.normalized();
        }
        if is_exact_zero(rhs.m) {
            return self.normalized();
        }
        let a = self.normalized();
        let b = rhs.normalized();
        let e = a.e.max(b.e).saturating_add(1);
        Scaled {
            m: a.mantissa_at(e).plus(b.mantissa_at(e)),
            e,
        }
        .normalized()
    }
    /// The value at exponent 0 (saturating), e.g. to compare with a plain threshold.
    pub fn value(self) -> S {
        self.mantissa_at(0)
    }
}

impl<S: Scalar> Scaled<S> {
    /// An exact-integer accumulator as block floating point: mantissa in [0.5, 1] in
    /// magnitude (1 only for a negative sum whose floor carries, `proofs-solver`'s
    /// `top_bits_i64_30`) carrying its top 30 bits.
    pub fn from_i64(v: i64) -> Self {
        let (m, sh, len) = int::split::top_bits(&Native, &(v as u64), 30);
        let (m, sh, len) = (m as i32, sh as i32, len as i32); // |m| <= 2^30 (proved), sh, len <= 64
        Scaled {
            m: S::from_int_pow2(m, sh.saturating_sub(len)),
            e: len,
        }
    }
    /// [`Scaled::from_i64`] for a 128-bit accumulator.
    pub fn from_i128(v: i128) -> Self {
        let len = 128u32.saturating_sub(v.unsigned_abs().leading_zeros());
        let sh = len.saturating_sub(30).min(127);
        let m = (v >> sh) as i32; // |v >> sh| <= 2^30
        let len = len as i32;
        Scaled {
            m: S::from_int_pow2(m, (sh as i32).saturating_sub(len)),
            e: len,
        }
    }
    /// Product with a plain scalar.
    pub fn scale(self, k: S) -> Self {
        // Both factors normalised first (as in `times`), so a raw mantissa times `k` cannot
        // saturate the mantissa format.
        self.times(Scaled { m: k, e: 0 })
    }
    /// Difference.
    pub fn minus(self, rhs: Self) -> Self {
        self.plus(Scaled {
            m: rhs.m.negate(),
            e: rhs.e,
        })
    }
}
