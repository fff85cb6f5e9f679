//! The widening 32 x 32 -> 64 bit product and the rounded, saturated fixed-point product.

use super::{Machine, MachineExt};

/// `a * b` of two signed words as a signed 64-bit word, by the 64-bit multiply (one `SMULL`
/// where the core has it).
#[inline(always)]
pub fn widening_mul_direct<M: Machine>(m: &M, a: &M::W, b: &M::W) -> M::D {
    m.mul_d(&m.sext(a), &m.sext(b))
}

/// `a * b` of two signed words as a signed 64-bit word, from four 16 x 16 -> 32 bit products:
/// exact, and on cores without a 32 x 32 -> 64 multiply (Cortex-M0) much cheaper than the
/// generic 64-bit multiply routine.
#[inline(always)]
pub fn widening_mul_by_halves<M: Machine>(m: &M, a: &M::W, b: &M::W) -> M::D {
    let negative = m.differ(&m.is_negative(a), &m.is_negative(b));
    let mag = unsigned_mul_by_halves(m, &m.unsigned_abs(a), &m.unsigned_abs(b));
    m.select_d(&negative, &m.neg_d(&mag), &mag)
}

/// `ua * ub` of two unsigned words as a 64-bit word, from four 16 x 16 -> 32 bit products.
#[inline(always)]
pub fn unsigned_mul_by_halves<M: Machine>(m: &M, ua: &M::W, ub: &M::W) -> M::D {
    let low_half = m.w(0xffff);
    let (a_lo, a_hi) = (m.and(ua, &low_half), m.lshr_k(ua, 16));
    let (b_lo, b_hi) = (m.and(ub, &low_half), m.lshr_k(ub, 16));
    // each partial product of two 16-bit halves fits in 32 bits
    let lo = m.zext(&m.mul(&a_lo, &b_lo));
    let mid = m.add_d(&m.zext(&m.mul(&a_hi, &b_lo)), &m.zext(&m.mul(&a_lo, &b_hi)));
    let hi = m.zext(&m.mul(&a_hi, &b_hi));
    // ua ub < 2^64: the sum cannot wrap
    m.add_d(&m.add_d(&m.shl_dk(&hi, 32), &m.shl_dk(&mid, 16)), &lo)
}

/// The fixed-point product of two words with `frac` fractional bits from their exact 64-bit
/// product `p`: rounded to nearest (ties toward plus infinity), saturated to 32 bits.
/// Nearest, not the shift's floor: long sums of products (the RLS information) would
/// otherwise drift by half a step per product (proofs finding 7).
#[inline(always)]
pub fn round_product<M: Machine>(m: &M, p: &M::D, frac: u32) -> M::W {
    let frac = frac.min(62);
    let half = if frac == 0 {
        0
    } else {
        1u64 << frac.saturating_sub(1)
    };
    // |p| <= 2^62: adding half cannot wrap
    let r = m.ashr_dk(&m.add_d(p, &m.d(half)), frac);
    m.saturate_to_w(&r)
}

/// `acc + a * b` with the target's widening product: the multiply-accumulate of the fixed
/// kernel's exact sums (`flight_id::exact`), which keep `|a|, |b| < 2^27` and few enough
/// products per sum that it cannot wrap (proved for that envelope: `massid_proofs_solver`,
/// obligation `mul_acc`).
#[inline(always)]
pub fn mul_acc<M: Machine>(m: &M, acc: &M::D, a: &M::W, b: &M::W) -> M::D {
    m.add_d(acc, &widening_mul(m, a, b))
}

/// The widening product this target compiles: by halves on ARM soft-float ABI targets
/// (Cortex-M0/M0+ have no 32 x 32 -> 64 multiply; the ARM core features are not stable
/// `cfg`s, so the soft-float ABI stands in for them), the 64-bit multiply elsewhere.
#[inline(always)]
pub fn widening_mul<M: Machine>(m: &M, a: &M::W, b: &M::W) -> M::D {
    if cfg!(all(target_arch = "arm", target_abi = "eabi")) {
        widening_mul_by_halves(m, a, b)
    } else {
        widening_mul_direct(m, a, b)
    }
}
