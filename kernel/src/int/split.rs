//! Block-floating-point normalisation: a signed word, or a 64-bit integer sum, split into a
//! mantissa and a power-of-two exponent from its bit length.

use super::{Machine, MachineExt};

/// `(m, k)` with `b = m * 2^k` (up to the floor of the right shift) and
/// `2^frac <= |m| < 2^(frac + 1)`; zero stays `(0, 0)`. The fixed-point mantissa of
/// `frac` fractional bits is then in [1, 2) in magnitude. `frac <= 29`.
#[inline(always)]
pub fn split_word<M: Machine>(m: &M, b: &M::W, frac: u32) -> (M::W, M::W) {
    let frac = frac.min(29);
    let mag = m.unsigned_abs(b);
    // bit length of |b|: |b| in [2^(len-1), 2^len)
    let len = m.sub(&m.w(32), &m.clz(&mag));
    let top = m.w(frac.saturating_add(1));
    let down = m.ult(&top, &len);
    let up = m.all(&m.ult(&len, &top), &m.not(&m.eq(&mag, &m.w(0))));
    // Down: the floor halvings of the defining loop compose to one arithmetic shift by k;
    // for a negative value the floor may leave |b >> k| = 2^(frac+1): one more step then.
    // `len <= 32`, so k <= 31 - frac.
    let k_down = || {
        let k0 = m.sub(&len, &top);
        let two = m.w(1 << frac.saturating_add(1));
        let one_more = m.ule(&two, &m.unsigned_abs(&m.ashr(b, &k0)));
        m.select(&one_more, &m.add(&k0, &m.w(1)), &k0)
    };
    // Up: exact doublings until |b| >= 2^frac (|b| < 2^frac, so no overflow).
    let k_up = || m.sub(&top, &len);
    let exponent = m.select_lazy(&down, k_down, || {
        m.select_lazy(&up, || m.neg(&k_up()), || m.w(0))
    });
    let mantissa = m.select_lazy(
        &down,
        || m.ashr(b, &exponent),
        || m.select_lazy(&up, || m.shl(b, &m.neg(&exponent)), || b.clone()),
    );
    (mantissa, exponent)
}

/// The top `bits` bits of a signed 64-bit sum: `(m, sh, len)` with `len` the bit length of
/// `|v|`, `sh = max(len - bits, 0)` and `m = v >> sh` (floor), so `|m| <= 2^bits` (equal only for a
/// negative `v` whose floor carries into the next power).
/// `bits <= 31`.
#[inline(always)]
pub fn top_bits<M: Machine>(m: &M, v: &M::D, bits: u32) -> (M::W, M::W, M::W) {
    let bits = m.w(bits.min(31));
    let len = m.sub(&m.w(64), &m.clz_d(&m.unsigned_abs_d(v)));
    let sh = m.select(&m.ult(&bits, &len), &m.sub(&len, &bits), &m.w(0));
    (m.lo(&m.ashr_d(v, &sh)), sh, len)
}
