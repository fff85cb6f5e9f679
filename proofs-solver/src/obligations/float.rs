//! The integer float's own primitives (`massid_kernel::int::float`): rounding a 64-bit
//! integer to a 25-bit mantissa, and the aligned sum of two mantissas. Its product and
//! quotient are the widening product and the fixed-point quotient, proved in `mul` and `div`.

use crate::discharge::Obligation;
use crate::prover::{Prover, ProverExt};
use massid_kernel::int::float::{aligned_sum, round_to_mantissa, MANT_BITS, MAX_ALIGN};
use massid_kernel::int::MachineExt;

/// `round_to_mantissa(v)`: zero gives (0, 0); otherwise `2^24 <= |m| < 2^25`, `m` has `v`'s
/// sign, `-24 <= k <= 39`, `v = m 2^k` exactly for `k <= 0`, and for `k > 0` `m 2^k` is a
/// nearest value: `2 |v - m 2^k| <= 2^k`. Every 64-bit `v`.
///
/// The slowest obligation here (Z3 about 7.5 minutes, 0.95e9 of its resource count on this
/// machine; split into one question per bit length of `v`, with every shift in the statement
/// by a constant, the questions took longer in all, 15-30 s each). Its mutants would each
/// cost up to that, so the mutation check of `solver_proofs` leaves it out; a flooring
/// variant is refuted there instead (`wrong_variants_are_refuted...`).
pub struct RoundToMantissa;

impl Obligation for RoundToMantissa {
    fn name(&self) -> String {
        format!("round_to_mantissa_{MANT_BITS}")
    }
    fn inputs(&self) -> &'static [&'static str] {
        &["v_hi", "v_lo"]
    }
    fn check<P: Prover>(&self, p: &P, x: &[P::W]) -> (P::Bool, P::Bool) {
        let v = p.d_of(&x[0], &x[1]);
        let (mant, k) = p.under_test(|m| round_to_mantissa(m, &v));
        (p.b(true), is_rounded_mantissa(p, &v, &mant, &k))
    }
}

/// The property of [`RoundToMantissa`] for `(m, k)` computed from `v`.
pub fn is_rounded_mantissa<P: Prover>(p: &P, v: &P::D, mant: &P::W, k: &P::W) -> P::Bool {
    let (vi, mi, ki) = (p.int_d(v, true), p.sw(mant), p.sw(k));
    let zero = p.int(0);
    let is_zero = p.i_eq(&vi, &zero);
    let normal = p.i_within(
        &p.i_abs(&mi),
        1i128 << (MANT_BITS - 1),
        (1i128 << MANT_BITS) - 1,
    );
    let same_sign = p.i_eq(
        &p.i_select(&p.i_lt(&vi, &zero), &p.int(1), &zero),
        &p.i_select(&p.i_lt(&mi, &zero), &p.int(1), &zero),
    );
    let k_range = p.i_within(&ki, 1 - i128::from(MANT_BITS), 64 - i128::from(MANT_BITS));
    let up = p.not(&p.i_lt(&zero, &ki));
    let exact_up = p.i_eq(&p.i_shl(&vi, &p.neg(k)), &mi);
    let diff = p.i_sub(&vi, &p.i_shl(&mi, k));
    let nearest = p.i_le(&p.i_shl(&p.i_abs(&diff), &p.w(1)), &p.i_shl(&p.int(1), k));
    let nonzero = p.all(
        &p.all(&normal, &k_range),
        &p.all(&same_sign, &p.select_bool(&up, &exact_up, &nearest)),
    );
    p.select_bool(
        &is_zero,
        &p.all(&p.i_eq(&mi, &zero), &p.i_eq(&ki, &zero)),
        &nonzero,
    )
}

/// `aligned_sum(a, b, d) = a 2^d + b` exactly, for mantissas `|a|, |b| < 2^25` and
/// `d <= MAX_ALIGN` (the caller's range: it returns the larger operand past it).
pub struct AlignedSum;

impl Obligation for AlignedSum {
    fn name(&self) -> String {
        format!("aligned_sum_{MANT_BITS}")
    }
    fn inputs(&self) -> &'static [&'static str] {
        &["a", "b", "d"]
    }
    fn check<P: Prover>(&self, p: &P, x: &[P::W]) -> (P::Bool, P::Bool) {
        let (a, b, d) = (&x[0], &x[1], &x[2]);
        let s = p.under_test(|m| aligned_sum(m, a, b, d));
        let limit = (1i128 << MANT_BITS) - 1;
        let (ai, bi) = (p.sw(a), p.sw(b));
        let pre = p.all(
            &p.all(
                &p.i_within(&ai, -limit, limit),
                &p.i_within(&bi, -limit, limit),
            ),
            &p.i_within(&p.uw(d), 0, i128::from(MAX_ALIGN)),
        );
        let exact = p.i_eq(&p.int_d(&s, true), &p.i_add(&p.i_shl(&ai, d), &bi));
        (pre, exact)
    }
}
