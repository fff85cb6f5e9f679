//! The integer core of the kernel's integer floating point ([`crate::int_float::IntFloat`]):
//! a 64-bit integer rounded to a 25-bit mantissa and a power-of-two exponent, and the exact
//! sum of two mantissas aligned to the smaller exponent. Products and quotients need nothing
//! new: the widening product ([`super::mul`]) and the fixed-point quotient ([`super::div`])
//! are already proved.

use super::{Machine, MachineExt};

/// Bits of a normalised mantissa: `2^(MANT_BITS - 1) <= |m| < 2^MANT_BITS` (one more than
/// `f32`'s significand, so the kernel's integer float is at least as fine as `f32`).
pub const MANT_BITS: u32 = 25;

/// Largest exponent difference [`aligned_sum`] takes: a mantissa shifted up by it stays
/// below 2^63. A smaller operand further down is below a 2^-13 fraction of the larger's last
/// bit and rounds away (the caller returns the larger operand).
pub const MAX_ALIGN: u32 = 63 - MANT_BITS;

/// `(m, k)` with `v` rounded to nearest (ties away from zero) at `MANT_BITS` significant bits:
/// `v ~ m 2^k` with `2^(MANT_BITS-1) <= |m| < 2^MANT_BITS`, exactly `v = m 2^k` when `k <= 0`,
/// and `|v - m 2^k| <= 2^(k-1)` otherwise; zero gives `(0, 0)`. Every 64-bit `v`.
/// Nearest, not the shift's floor: the identification sums hundreds of thousands of products,
/// and a floor would bias them by half a step each (as it did the RLS, proofs finding 7).
#[inline(always)]
pub fn round_to_mantissa<M: Machine>(m: &M, v: &M::D) -> (M::W, M::W) {
    let mag = m.unsigned_abs_d(v);
    // bit length of |v|: |v| in [2^(len-1), 2^len)
    let len = m.sub(&m.w(64), &m.clz_d(&mag));
    let top = m.w(MANT_BITS);
    // the exponent: len - MANT_BITS, negative (a left shift) for short values
    let k0 = m.sub(&len, &top);
    let down = m.ult(&top, &len);
    let (mant, k) = {
        // Down: add half of the last kept bit and shift (|v| <= 2^63, so no wrap); a carry out
        // to 2^MANT_BITS is a power of two, halved exactly.
        let half = m.shl_d(&m.d(1), &m.sub(&k0, &m.w(1)));
        let rounded = m.lo(&m.lshr_d(&m.add_d(&mag, &half), &k0));
        let carry = m.eq(&rounded, &m.w(1 << MANT_BITS));
        let r_down = m.select(&carry, &m.w(1 << (MANT_BITS - 1)), &rounded);
        let k_down = m.select(&carry, &m.add(&k0, &m.w(1)), &k0);
        // Up: exact doubling (|v| < 2^MANT_BITS).
        let r_up = m.shl(&m.lo(&mag), &m.neg(&k0));
        (
            m.select(&down, &r_down, &r_up),
            m.select(&down, &k_down, &k0),
        )
    };
    let zero = m.eq(&len, &m.w(0));
    let signed = m.select(&m.is_negative_d(v), &m.neg(&mant), &mant);
    (
        m.select(&zero, &m.w(0), &signed),
        m.select(&zero, &m.w(0), &k),
    )
}

/// `a 2^d + b` exactly, as a signed 64-bit word: two signed mantissas (`|a|, |b| <
/// 2^MANT_BITS`) brought to the exponent of `b`, `d <= MAX_ALIGN` (no wrap: `|a| 2^d < 2^63`).
#[inline(always)]
pub fn aligned_sum<M: Machine>(m: &M, a: &M::W, b: &M::W, d: &M::W) -> M::D {
    m.add_d(&m.shl_d(&m.sext(a), d), &m.sext(b))
}
