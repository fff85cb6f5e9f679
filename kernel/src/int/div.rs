//! Fixed-point division `trunc(a 2^frac / b)` three ways, one per kind of core: restoring
//! long division in 32-bit words (no divide instruction), two 32 / 16-bit digit steps
//! (a hardware 32-bit divide), and one 64-bit division (the host, or a cheap runtime
//! routine). Each returns `(fits, quotient)`: `fits` is false exactly for a zero divisor or
//! a quotient outside `i32`, as the `fixed` crate's `checked_div` defines it.

use super::{Machine, MachineExt};

/// The integer part of `|a| 2^frac / |b|`, taken first by every path.
pub struct QuotientParts<M: Machine> {
    /// `b != 0` and the integer part alone does not already put `|quotient|` above 2^31.
    pub fits: M::Bool,
    /// The quotient is negative.
    pub negative: M::Bool,
    /// `|a|`.
    pub ua: M::W,
    /// `|b|`.
    pub ub: M::W,
    /// `|a| / |b|`.
    pub q_int: M::W,
}

/// Sign, magnitudes and integer part of `a 2^frac / b` (`frac <= 31`).
#[inline(always)]
pub fn quotient_parts<M: Machine>(m: &M, a: &M::W, b: &M::W, frac: u32) -> QuotientParts<M> {
    let (ua, ub) = (m.unsigned_abs(a), m.unsigned_abs(b));
    let q_int = m.udiv(&ua, &ub);
    // |quotient| <= 2^31 needs q_int <= 2^(31 - frac)
    let bound = 1u32 << 31u32.saturating_sub(frac).min(31);
    let fits = m.all(&m.not(&m.eq(&ub, &m.w(0))), &m.ule(&q_int, &m.w(bound)));
    let negative = m.differ(&m.is_negative(a), &m.is_negative(b));
    QuotientParts {
        fits,
        negative,
        ua,
        ub,
        q_int,
    }
}

/// The quotient with magnitude `q` and the given sign, and whether it fits `i32` (2^31
/// only negative).
#[inline(always)]
pub fn signed_quotient<M: Machine>(m: &M, q: &M::W, negative: &M::Bool) -> (M::Bool, M::W) {
    let limit = m.w(1 << 31);
    let fits = m.select_bool(negative, &m.ule(q, &limit), &m.ult(q, &limit));
    // magnitude 2^31 negated is i32::MIN itself
    (fits, m.select(negative, &m.neg(q), q))
}

/// Restoring long division in 32-bit words: one 32-bit divide for the integer part, then one
/// [`restoring_step`] per fractional bit. `frac <= 31`.
#[inline(always)]
pub fn div_by_words<M: Machine>(m: &M, a: &M::W, b: &M::W, frac: u32) -> (M::Bool, M::W) {
    let frac = frac.min(31);
    let parts = quotient_parts(m, a, b, frac);
    let mut r = m.urem(&parts.ua, &parts.ub);
    let mut q = m.shl_k(&parts.q_int, frac);
    let mut bit = frac;
    while bit > 0 {
        bit = bit.saturating_sub(1);
        (r, q) = restoring_step(m, &r, &q, &parts.ub, bit);
    }
    let (sign_fits, v) = signed_quotient(m, &q, &parts.negative);
    (m.all(&parts.fits, &sign_fits), v)
}

/// One digit of restoring division: the remainder doubled, and `ub` taken off (with the
/// quotient's `bit` set) when it fits. `r < ub <= 2^31`, so `2 r < 2^32`.
#[inline(always)]
pub fn restoring_step<M: Machine>(m: &M, r: &M::W, q: &M::W, ub: &M::W, bit: u32) -> (M::W, M::W) {
    let r = m.shl_k(r, 1);
    let take = m.ule(ub, &r);
    (
        m.select(&take, &m.sub(&r, ub), &r),
        m.select(&take, &m.or(q, &m.w(1u32.wrapping_shl(bit))), q),
    )
}

/// Two 32 / 16-bit digit steps of long division (Knuth's algorithm D in base 2^16, as in
/// Hacker's Delight `divlu`): two hardware 32-bit divides and at most two corrections each.
/// `frac <= 31`.
#[inline(always)]
pub fn div_by_digits<M: Machine>(m: &M, a: &M::W, b: &M::W, frac: u32) -> (M::Bool, M::W) {
    let frac = frac.min(31);
    // quotient_parts bounds the quotient by 2^31, so ua 2^frac / ub < 2^32 (divlu's condition).
    let parts = quotient_parts(m, a, b, frac);
    let num = m.shl_dk(&m.zext(&parts.ua), frac); // < 2^63
    let q = divlu(m, &m.lo(&m.lshr_dk(&num, 32)), &m.lo(&num), &parts.ub);
    let (sign_fits, v) = signed_quotient(m, &q, &parts.negative);
    (m.all(&parts.fits, &sign_fits), v)
}

/// `(u1 2^32 + u0) / v` for `u1 < v` (the quotient fits 32 bits), `v != 0`.
#[inline(always)]
pub fn divlu<M: Machine>(m: &M, u1: &M::W, u0: &M::W, v: &M::W) -> M::W {
    let s = m.clz(v); // v != 0 (callers), so s < 32
    let v = m.shl(v, &s); // top bit set
    let (vn1, vn0) = (m.lshr_k(&v, 16), m.and(&v, &m.w(0xffff))); // vn1 >= 2^15
    let un32 = m.select(
        &m.eq(&s, &m.w(0)),
        u1,
        &m.or(&m.shl(u1, &s), &m.lshr(u0, &m.sub(&m.w(32), &s))),
    );
    let un10 = m.shl(u0, &s);
    let (un1, un0) = (m.lshr_k(&un10, 16), m.and(&un10, &m.w(0xffff)));
    let q1 = digit(m, &un32, &un1, &vn1, &vn0);
    // The partial remainder (fits 32 bits after a correct first digit).
    let un21 = m.sub(&m.add(&m.shl_k(&un32, 16), &un1), &m.mul(&q1, &v));
    let q0 = digit(m, &un21, &un0, &vn1, &vn0);
    // q0 < 2^16 (a digit): the sum is the digits side by side
    m.add(&m.shl_k(&q1, 16), &q0)
}

/// One quotient digit of `(top 2^16 + next) / (vn1 2^16 + vn0)`: estimated from the top
/// digits, corrected at most twice (Knuth, TAOCP 4.3.1, Theorem B).
#[inline(always)]
pub fn digit<M: Machine>(m: &M, top: &M::W, next: &M::W, vn1: &M::W, vn0: &M::W) -> M::W {
    let base = m.w(1 << 16);
    // the estimate is too big while it is >= 2^16 or q vn0 > rhat 2^16 + next (`next < 2^16`:
    // the sum is the digits side by side)
    let too_big = |q: &M::W, rhat: &M::W| {
        m.any(
            &m.ule(&base, q),
            &m.ult_d(
                &m.add_d(&m.shl_dk(&m.zext(rhat), 16), &m.zext(next)),
                &m.mul_d(&m.zext(q), &m.zext(vn0)),
            ),
        )
    };
    let q = m.udiv(top, vn1);
    let rhat = m.sub(top, &m.mul(&q, vn1));
    let first = too_big(&q, &rhat);
    let q = m.select(&first, &m.sub(&q, &m.w(1)), &q);
    let rhat = m.select(&first, &m.add(&rhat, vn1), &rhat);
    // a second correction only while rhat still fits a digit
    let again = m.all(&first, &m.ult(&rhat, &base));
    m.select_lazy(
        &again,
        || m.select(&too_big(&q, &rhat), &m.sub(&q, &m.w(1)), &q),
        || q.clone(),
    )
}

/// One signed 64-bit division of `a 2^frac` by `b` (`frac <= 32`).
#[inline(always)]
pub fn div_by_i64<M: Machine>(m: &M, a: &M::W, b: &M::W, frac: u32) -> (M::Bool, M::W) {
    if frac > 32 {
        return (m.b(false), m.w(0));
    }
    let wide_b = m.sext(b);
    let q = m.sdiv_d(&m.shl_dk(&m.sext(a), frac), &wide_b);
    let fits = m.all(&m.not(&m.eq_d(&wide_b, &m.d(0))), &m.fits_w(&q));
    (fits, m.lo(&q))
}
