//! Saturating power-of-two scaling of a signed word: the fixed-point `mul_pow2`,
//! `from_int_pow2` and the rounding `mul_pow2_nearest`.

use super::{Machine, MachineExt};

/// `v * 2^sh` for signed `v` and signed `sh`, saturated to `i32`; right shifts round toward
/// minus infinity (31 and beyond leave the sign: 0 or -1).
#[inline(always)]
pub fn shift_saturating<M: Machine>(m: &M, v: &M::W, sh: &M::W) -> M::W {
    let amount = m.unsigned_abs(sh);
    m.select_lazy(
        &m.is_negative(sh),
        || {
            let max_right = m.w(31);
            m.ashr(
                v,
                &m.select(&m.ult(&amount, &max_right), &amount, &max_right),
            )
        },
        || shift_left_saturating(m, v, &amount),
    )
}

/// `v * 2^s` for signed `v` and unsigned `s`, saturated to `i32`.
#[inline(always)]
fn shift_left_saturating<M: Machine>(m: &M, v: &M::W, s: &M::W) -> M::W {
    // v fits after a left shift by s iff it has more than s redundant sign bits
    let negative = m.is_negative(v);
    let redundant = m.clz(&m.select(&negative, &m.sub(&m.w(u32::MAX), v), v));
    let saturated = m.select(&negative, &m.w(i32::MIN as u32), &m.w(i32::MAX as u32));
    let shifted = m.select(&m.ult(s, &redundant), &m.shl(v, s), &saturated);
    m.select(&m.eq(v, &m.w(0)), &m.w(0), &shifted)
}

/// `v * 2^e` rounded to nearest (ties toward plus infinity) for `e < 0`, saturated to `i32`;
/// [`shift_saturating`] for `e >= 0`. For rescaling stored sums: a truncating shift drifts
/// by half a step each time.
#[inline(always)]
pub fn shift_nearest<M: Machine>(m: &M, v: &M::W, e: &M::W) -> M::W {
    let amount = m.unsigned_abs(e);
    m.select_lazy(
        &m.is_negative(e),
        || {
            let cap = m.w(40);
            let r = m.select(&m.ult(&amount, &cap), &amount, &cap);
            let half = m.shl_d(&m.d(1), &m.sub(&r, &m.w(1)));
            // |v| < 2^31 and 1 <= r <= 40: v + 2^(r-1) fits i64, and the shifted value fits
            // i32 except for the one carry above i32::MAX
            let rounded = m.ashr_d(&m.add_d(&m.sext(v), &half), &r);
            m.select(&m.fits_w(&rounded), &m.lo(&rounded), &m.w(i32::MAX as u32))
        },
        || shift_left_saturating(m, v, &amount),
    )
}
