//! The three fixed-point division paths.
//!
//! The paths with a symbolic divisor inside a long computation are proved in parts, because
//! a SAT solver cannot relate a divider circuit to a multiplier in reasonable time (a 32-bit
//! `a == (a / b) b + a % b` alone did not finish in 5 minutes here). Each part is a solver
//! obligation on the kernel's own function; the parts compose by the induction written on
//! [`RestoringStep`] and [`Digit`]:
//!
//! * restoring division (`div_by_words`): [`IntegerPart`], then `frac` times
//!   [`RestoringStep`], then [`SignedQuotient`];
//! * digit division (`div_by_digits`): [`IntegerPart`], [`Normalise`], two [`Digit`]s,
//!   then [`SignedQuotient`];
//! * one 64-bit division (`div_by_i64`): [`ByI64`], whole.

use crate::discharge::{Engine, Obligation};
use crate::prover::{Prover, ProverExt};
use massid_kernel::int::div::{digit, div_by_i64, quotient_parts, restoring_step, signed_quotient};
use massid_kernel::int::MachineExt;

/// `quotient_parts(a, b, frac)`: the magnitudes are `|a|`, `|b|`; the integer part is
/// `floor(|a| / |b|)` (the hardware divide's definition); `fits` is false for `b = 0` and
/// when the integer part alone puts `|a| 2^frac / |b|` above 2^31, and when `fits`, the
/// integer part shifted by `frac` does not wrap: `q_int 2^frac <= 2^31`.
pub struct IntegerPart {
    /// Fractional bits of the format.
    pub frac: u32,
}

impl Obligation for IntegerPart {
    fn name(&self) -> String {
        format!("div_integer_part_q{}_{}", 32 - self.frac, self.frac)
    }
    fn inputs(&self) -> &'static [&'static str] {
        &["a", "b"]
    }
    fn check<P: Prover>(&self, p: &P, x: &[P::W]) -> (P::Bool, P::Bool) {
        let (a, b) = (&x[0], &x[1]);
        let parts = p.under_test(|m| quotient_parts(m, a, b, self.frac));
        let (ai, bi) = (p.sw(a), p.sw(b));
        let (ua, ub, qi) = (p.uw(&parts.ua), p.uw(&parts.ub), p.uw(&parts.q_int));
        let zero = p.int(0);
        let mags = p.all(&p.i_eq(&ua, &p.i_abs(&ai)), &p.i_eq(&ub, &p.i_abs(&bi)));
        let sign = p.all(
            &p.implies(
                &parts.negative,
                &p.differ(&p.i_lt(&ai, &zero), &p.i_lt(&bi, &zero)),
            ),
            &p.implies(
                &p.differ(&p.i_lt(&ai, &zero), &p.i_lt(&bi, &zero)),
                &parts.negative,
            ),
        );
        // q_int is the hardware's floor(ua / ub): fits <=> b != 0 and q_int <= 2^(31-frac),
        // and (q_int > 2^(31-frac) => |a| 2^frac / |b| >= q_int 2^frac > 2^31).
        let bound = p.int(1i128 << (31 - self.frac));
        let fits_exact = p.all(
            &p.implies(&parts.fits, &p.not(&p.i_eq(&ub, &zero))),
            &p.implies(
                &p.not(&p.i_eq(&ub, &zero)),
                &p.any(
                    &p.all(&parts.fits, &p.i_le(&qi, &bound)),
                    &p.all(&p.not(&parts.fits), &p.i_lt(&bound, &qi)),
                ),
            ),
        );
        let no_wrap = p.implies(
            &parts.fits,
            &p.i_le(&p.i_shl(&qi, &p.w(self.frac)), &p.int(1i128 << 31)),
        );
        (
            p.b(true),
            p.all(&p.all(&mags, &sign), &p.all(&fits_exact, &no_wrap)),
        )
    }
}

/// `restoring_step(r, q, ub, bit)`: for `0 < ub <= 2^31`, `r < ub` and `q`'s `bit` clear,
/// the new remainder is below `ub` and either `2 r = r'` with `q' = q`, or
/// `2 r = r' + ub` with `q' = q + 2^bit`.
///
/// Induction: `|a| = q_int |b| + r_0` with `r_0 < |b|` ([`IntegerPart`], the divide's
/// definition). Write `N_i = |a| 2^i` and `Q_i = q_int 2^i + (digits so far)` for the
/// quotient after `i` steps; `N_i = Q_i |b| + r_i` with `r_i < |b|` holds at `i = 0`, and
/// one step maps it to `N_{i+1} = 2 N_i = (2 Q_i + c) |b| + r_{i+1}` with `r_{i+1} < |b|`,
/// which is this obligation (the word `q` holds `Q_i` scaled to its final weight: the step
/// adds `2^bit` for the digit `c = 1`). After `frac` steps `|a| 2^frac = q |b| + r`,
/// `r < |b|`: `q` is the truncated quotient's magnitude.
pub struct RestoringStep {
    /// The quotient bit this step decides.
    pub bit: u32,
}

impl Obligation for RestoringStep {
    fn name(&self) -> String {
        format!("restoring_step_bit{}", self.bit)
    }
    fn inputs(&self) -> &'static [&'static str] {
        &["r", "q", "ub"]
    }
    fn check<P: Prover>(&self, p: &P, x: &[P::W]) -> (P::Bool, P::Bool) {
        let (r, q, ub) = (&x[0], &x[1], &x[2]);
        let (r2, q2) = p.under_test(|m| restoring_step(m, r, q, ub, self.bit));
        is_restoring_step(p, (r, q, ub), (&r2, &q2), self.bit)
    }
}

/// `(envelope, property)` of one restoring step from `(r, q, ub)` to `(r2, q2)` deciding
/// quotient bit `bit` (see [`RestoringStep`]).
pub fn is_restoring_step<P: Prover>(
    p: &P,
    (r, q, ub): (&P::W, &P::W, &P::W),
    (r2, q2): (&P::W, &P::W),
    bit: u32,
) -> (P::Bool, P::Bool) {
    let weight = 1u32 << bit;
    let envelope = p.all(
        &p.all(&p.not(&p.eq(ub, &p.w(0))), &p.ule(ub, &p.w(1 << 31))),
        &p.all(&p.ult(r, ub), &p.eq(&p.and(q, &p.w(weight)), &p.w(0))),
    );
    let (ri, qi, ubi, r2i, q2i) = (p.uw(r), p.uw(q), p.uw(ub), p.uw(r2), p.uw(q2));
    let twice = p.i_add(&ri, &ri);
    let kept = p.all(&p.i_eq(&q2i, &qi), &p.i_eq(&twice, &r2i));
    let taken = p.all(
        &p.i_eq(&q2i, &p.i_add(&qi, &p.int(i128::from(weight)))),
        &p.i_eq(&twice, &p.i_add(&r2i, &ubi)),
    );
    (envelope, p.all(&p.any(&kept, &taken), &p.i_lt(&r2i, &ubi)))
}

/// `signed_quotient(q, negative)`: `fits` exactly when `±q` is an `i32`, and then the word
/// is `±q`. Every magnitude and sign.
pub struct SignedQuotient;

impl Obligation for SignedQuotient {
    fn name(&self) -> String {
        "div_signed_quotient".into()
    }
    fn inputs(&self) -> &'static [&'static str] {
        &["q", "negative"]
    }
    fn check<P: Prover>(&self, p: &P, x: &[P::W]) -> (P::Bool, P::Bool) {
        let (q, flag) = (&x[0], &x[1]);
        let negative = p.not(&p.eq(flag, &p.w(0)));
        let (fits, v) = p.under_test(|m| signed_quotient(m, q, &negative));
        let qi = p.uw(q);
        let want = p.i_select(&negative, &p.i_sub(&p.int(0), &qi), &qi);
        let representable = p.i_within(&want, i128::from(i32::MIN), i128::from(i32::MAX));
        let property = p.all(
            &p.all(
                &p.implies(&fits, &representable),
                &p.implies(&representable, &fits),
            ),
            &p.implies(&fits, &p.i_eq(&p.sw(&v), &want)),
        );
        (p.b(true), property)
    }
}

/// `divlu`'s normalisation: for `u1 < v`, `v != 0`, shifting `v` by `s = clz(v)` sets its
/// top bit and the dividend `(u1:u0) 2^s` loses no bit: `un32 2^32 + un10 = (u1 2^32 + u0)
/// 2^s` (the quotient is unchanged), and `un32 < v 2^s`: the first digit's precondition.
pub struct Normalise;

impl Obligation for Normalise {
    fn name(&self) -> String {
        "divlu_normalise".into()
    }
    fn inputs(&self) -> &'static [&'static str] {
        &["u1", "u0", "v"]
    }
    fn check<P: Prover>(&self, p: &P, x: &[P::W]) -> (P::Bool, P::Bool) {
        let (u1, u0, v) = (&x[0], &x[1], &x[2]);
        let envelope = p.all(&p.not(&p.eq(v, &p.w(0))), &p.ult(u1, v));
        // the same operations as the head of `divlu`
        let (s, vn, un32, un10) = p.under_test(|m| {
            let s = m.clz(v);
            let vn = m.shl(v, &s);
            let un32 = m.select(
                &m.eq(&s, &m.w(0)),
                u1,
                &m.or(&m.shl(u1, &s), &m.lshr(u0, &m.sub(&m.w(32), &s))),
            );
            (s.clone(), vn, un32, m.shl(u0, &s))
        });
        let dividend = p.i_add(&p.i_shl(&p.uw(u1), &p.w(32)), &p.uw(u0));
        let shifted = p.i_add(&p.i_shl(&p.uw(&un32), &p.w(32)), &p.uw(&un10));
        let property = p.all(
            &p.all(
                &p.i_eq(&shifted, &p.i_shl(&dividend, &s)),
                &p.i_eq(&p.uw(&vn), &p.i_shl(&p.uw(v), &s)),
            ),
            &p.all(&p.ule(&p.w(1 << 31), &vn), &p.ult(&un32, &vn)),
        );
        (envelope, property)
    }
}

/// One digit of `divlu` (Knuth's algorithm D, base 2^16): for a normalised divisor `v`
/// (top bit set), `top < v` and `next < 2^16`, `digit` returns `q < 2^16` with
/// `q v <= top 2^16 + next < (q + 1) v`, and the partial remainder `top 2^16 + next - q v`
/// computed in 32 bits is exact. `divlu` is two such digits (high, then low with the first
/// remainder as `top`), so its quotient is `q1 2^16 + q0`.
pub struct Digit;

impl Obligation for Digit {
    fn name(&self) -> String {
        "divlu_digit".into()
    }
    fn inputs(&self) -> &'static [&'static str] {
        &["top", "next", "v"]
    }
    fn check<P: Prover>(&self, p: &P, x: &[P::W]) -> (P::Bool, P::Bool) {
        let (top, next, v) = (&x[0], &x[1], &x[2]);
        let envelope = p.all(
            &p.all(&p.ule(&p.w(1 << 31), v), &p.ult(top, v)),
            &p.ult(next, &p.w(1 << 16)),
        );
        let (q, rem) = p.under_test(|m| {
            let (vn1, vn0) = (m.lshr_k(v, 16), m.and(v, &m.w(0xffff)));
            let q = digit(m, top, next, &vn1, &vn0);
            let rem = m.sub(&m.add(&m.shl_k(top, 16), next), &m.mul(&q, v));
            (q, rem)
        });
        let dividend = p.i_add(&p.i_shl(&p.uw(top), &p.w(16)), &p.uw(next));
        let (qi, vi) = (p.uw(&q), p.uw(v));
        let low = p.i_mul(&qi, &vi);
        let property = p.all(
            &p.all(
                &p.i_le(&low, &dividend),
                &p.i_lt(&dividend, &p.i_add(&low, &vi)),
            ),
            &p.all(
                &p.i_lt(&qi, &p.int(1 << 16)),
                &p.i_eq(&p.uw(&rem), &p.i_sub(&dividend, &low)),
            ),
        );
        (envelope, property)
    }
    fn engine(&self) -> Engine {
        Engine::Integer
    }
}

/// `div_by_i64(a, b, frac)`, whole: `fits` exactly when `b != 0` and the truncated
/// quotient of `a 2^frac / b` is an `i32`, and then the word is that quotient. The
/// quotient itself is the 64-bit signed division's, so this is the one obligation with a
/// symbolic 64-bit divisor (slow: behind a flag).
pub struct ByI64 {
    /// Fractional bits of the format.
    pub frac: u32,
}

impl Obligation for ByI64 {
    fn name(&self) -> String {
        format!("div_by_i64_q{}_{}", 32 - self.frac, self.frac)
    }
    fn inputs(&self) -> &'static [&'static str] {
        &["a", "b"]
    }
    fn check<P: Prover>(&self, p: &P, x: &[P::W]) -> (P::Bool, P::Bool) {
        let (a, b) = (&x[0], &x[1]);
        let (fits, q) = p.under_test(|m| div_by_i64(m, a, b, self.frac));
        let n = p.i_shl(&p.sw(a), &p.w(self.frac));
        let bi = p.sw(b);
        let nonzero = p.not(&p.i_eq(&bi, &p.int(0)));
        // with b != 0 the true quotient fits i32 iff some i32 is the truncated quotient:
        // |n| < (2^31 + 1) |b| for negative quotients, < 2^31 |b| for positive ones
        let an = p.i_abs(&n);
        let ab = p.i_abs(&bi);
        let negative = p.differ(&p.i_lt(&n, &p.int(0)), &p.i_lt(&bi, &p.int(0)));
        let limit = p.i_select(&negative, &p.int((1i128 << 31) + 1), &p.int(1i128 << 31));
        let representable = p.all(&nonzero, &p.i_lt(&an, &p.i_mul(&limit, &ab)));
        let property = p.all(
            &p.all(
                &p.implies(&fits, &representable),
                &p.implies(&representable, &fits),
            ),
            &p.implies(&fits, &p.is_trunc_quotient(&p.sw(&q), &n, &bi)),
        );
        (p.b(true), property)
    }
    fn engine(&self) -> Engine {
        Engine::Integer
    }
}
