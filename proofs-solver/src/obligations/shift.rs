//! Saturating and rounding power-of-two scaling (`mul_pow2`, `from_int_pow2`,
//! `mul_pow2_nearest`).

use crate::discharge::Obligation;
use crate::prover::{Prover, ProverExt};
use massid_kernel::int::shift::{shift_nearest, shift_saturating};
use massid_kernel::int::MachineExt;

/// `min(|e|, cap)` of a signed word, computed outside the code under proof.
fn magnitude_capped<P: Prover>(p: &P, e: &P::W, cap: u32) -> P::W {
    let a = p.unsigned_abs(e);
    p.select(&p.ult(&a, &p.w(cap)), &a, &p.w(cap))
}

/// `v 2^sh` exact when it fits, saturated when not; right shifts floor.
fn scaled_by_floor<P: Prover>(p: &P, v: &P::W, sh: &P::W, r: &P::I) -> P::Bool {
    let k = magnitude_capped(p, sh, 64);
    let vi = p.sw(v);
    // right: r 2^k <= v < (r + 1) 2^k
    let low = p.i_shl(r, &k);
    let floor = p.all(
        &p.i_le(&low, &vi),
        &p.i_lt(&vi, &p.i_add(&low, &p.i_shl(&p.int(1), &k))),
    );
    // left: |v| < 2^31 and k <= 64, exact in 128 bits (beyond 64 it saturates all the same)
    let exact = p.i_shl(&vi, &k);
    let max = p.int(i128::from(i32::MAX));
    let min = p.int(i128::from(i32::MIN));
    let left = p.select_bool(
        &p.i_lt(&max, &exact),
        &p.i_eq(r, &max),
        &p.select_bool(&p.i_lt(&exact, &min), &p.i_eq(r, &min), &p.i_eq(r, &exact)),
    );
    p.select_bool(&p.is_negative(sh), &floor, &left)
}

/// `shift_saturating(v, sh)` for every word `v` and every exponent `sh`.
pub struct ShiftSaturating;

impl Obligation for ShiftSaturating {
    fn name(&self) -> String {
        "shift_saturating".into()
    }
    fn inputs(&self) -> &'static [&'static str] {
        &["v", "sh"]
    }
    fn check<P: Prover>(&self, p: &P, x: &[P::W]) -> (P::Bool, P::Bool) {
        let (v, sh) = (&x[0], &x[1]);
        let r = p.under_test(|m| shift_saturating(m, v, sh));
        (p.b(true), scaled_by_floor(p, v, sh, &p.sw(&r)))
    }
}

/// `shift_nearest(v, e)`: for `e < 0` the nearest integer to `v 2^e` (ties up), for
/// `e >= 0` as [`ShiftSaturating`]; every word and exponent.
pub struct ShiftNearest;

impl Obligation for ShiftNearest {
    fn name(&self) -> String {
        "shift_nearest".into()
    }
    fn inputs(&self) -> &'static [&'static str] {
        &["v", "e"]
    }
    fn check<P: Prover>(&self, p: &P, x: &[P::W]) -> (P::Bool, P::Bool) {
        let (v, e) = (&x[0], &x[1]);
        let r = p.sw(&p.under_test(|m| shift_nearest(m, v, e)));
        let k = magnitude_capped(p, e, 64);
        let vi = p.sw(v);
        // r 2^k - 2^(k-1) <= v < r 2^k + 2^(k-1), doubled to stay in integers
        let twice_v = p.i_add(&vi, &vi);
        let twice_low = p.i_shl(&r, &p.add(&k, &p.w(1)));
        let unit = p.i_shl(&p.int(1), &k);
        let nearest = p.all(
            &p.i_le(&p.i_sub(&twice_low, &unit), &twice_v),
            &p.i_lt(&twice_v, &p.i_add(&twice_low, &unit)),
        );
        let property = p.select_bool(&p.is_negative(e), &nearest, &scaled_by_floor(p, v, e, &r));
        (p.b(true), property)
    }
}
