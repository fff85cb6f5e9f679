//! The widening product and the Q-format rounding product.

use crate::discharge::{Engine, Obligation, PRODUCT_MUTANT_RLIMIT};
use crate::prover::{Prover, ProverExt};
use massid_kernel::int::mul::{
    mul_acc, round_product, unsigned_mul_by_halves, widening_mul_by_halves, widening_mul_direct,
};
use massid_kernel::int::MachineExt;

/// Which widening product the code under proof uses.
#[derive(Clone, Copy, Debug)]
pub enum Widening {
    /// One 64-bit multiply (host, M4F `SMULL`).
    Direct,
    /// Four 16 x 16 -> 32 bit products (Cortex-M0).
    ByHalves,
}

fn widen<P: Prover>(p: &P, how: Widening, a: &P::W, b: &P::W) -> P::D {
    match how {
        Widening::Direct => widening_mul_direct(p, a, b),
        Widening::ByHalves => widening_mul_by_halves(p, a, b),
    }
}

/// `widening_mul_*(a, b)` is the exact product of two signed words, for all of them.
pub struct WideningProduct(pub Widening);

impl Obligation for WideningProduct {
    fn name(&self) -> String {
        format!("widening_mul_{:?}", self.0).to_lowercase()
    }
    fn inputs(&self) -> &'static [&'static str] {
        &["a", "b"]
    }
    fn check<P: Prover>(&self, p: &P, x: &[P::W]) -> (P::Bool, P::Bool) {
        let (a, b) = (&x[0], &x[1]);
        let got = p.under_test(|m| widen(m, self.0, a, b));
        let exact = p.i_mul(&p.sw(a), &p.sw(b));
        (p.b(true), p.i_eq(&p.int_d(&got, true), &exact))
    }
    fn engine(&self) -> Engine {
        engine_for(self.0)
    }
    fn mutant_rlimit(&self) -> u32 {
        PRODUCT_MUTANT_RLIMIT
    }
}

/// Bit-vectors for the 64-bit multiply (the property's own multiply has the same shape);
/// integers for the product by halves (a multiplier built from four smaller ones).
fn engine_for(how: Widening) -> Engine {
    match how {
        Widening::Direct => Engine::BitVector,
        Widening::ByHalves => Engine::Integer,
    }
}

/// `r` is the product of the words `a` and `b` with `frac` fractional bits, rounded to
/// nearest (ties up) and saturated to `i32`: the property of `Fx * Fx`.
pub fn is_rounded_product<P: Prover>(p: &P, a: &P::W, b: &P::W, r: &P::W, frac: u32) -> P::Bool {
    let exact = p.i_mul(&p.sw(a), &p.sw(b));
    is_rounded_value(p, &exact, r, frac)
}

/// `r` is the integer `exact` with `frac` fractional bits, rounded to nearest (ties up) and
/// saturated to `i32`.
pub fn is_rounded_value<P: Prover>(p: &P, exact: &P::I, r: &P::W, frac: u32) -> P::Bool {
    let exact = exact.clone();
    let one = 1i128 << frac;
    let half = one >> 1;
    let r = p.sw(r);
    let scaled = p.i_mul(&r, &p.int(one));
    let nearest = p.all(
        &p.i_le(&p.i_sub(&scaled, &p.int(half)), &exact),
        &p.i_lt(&exact, &p.i_add(&scaled, &p.int(half))),
    );
    let above = p.i_le(&p.int((1i128 << 31) * one - half), &exact);
    let below = p.i_lt(&exact, &p.int(-(1i128 << 31) * one - half));
    p.select_bool(
        &above,
        &p.i_eq(&r, &p.int(i128::from(i32::MAX))),
        &p.select_bool(&below, &p.i_eq(&r, &p.int(i128::from(i32::MIN))), &nearest),
    )
}

/// The fixed-point product with `frac` fractional bits (what `Fx * Fx` runs): the exact
/// product rounded to nearest, ties up, saturated to `i32`, for all pairs of words.
pub struct RoundedProduct {
    /// Fractional bits of the format.
    pub frac: u32,
    /// The widening product inside.
    pub widening: Widening,
}

impl Obligation for RoundedProduct {
    fn name(&self) -> String {
        format!("q{}_{}_mul_{:?}", 32 - self.frac, self.frac, self.widening).to_lowercase()
    }
    fn inputs(&self) -> &'static [&'static str] {
        &["a", "b"]
    }
    fn check<P: Prover>(&self, p: &P, x: &[P::W]) -> (P::Bool, P::Bool) {
        let (a, b) = (&x[0], &x[1]);
        let f = self.frac;
        let r = p.under_test(|m| {
            let wide = widen(m, self.widening, a, b);
            round_product(m, &wide, f)
        });
        let property = is_rounded_product(p, a, b, &r, f);
        (p.b(true), property)
    }
    fn engine(&self) -> Engine {
        engine_for(self.widening)
    }
    fn mutant_rlimit(&self) -> u32 {
        PRODUCT_MUTANT_RLIMIT
    }
}

/// `unsigned_mul_by_halves(ua, ub)` is the exact product of two unsigned words, for all of
/// them: the Cortex-M0 product's four partial products and their sum. (The signed wrapper
/// around it, `widening_mul_by_halves`, is open: see `proofs/README.md`.)
pub struct UnsignedByHalves;

impl Obligation for UnsignedByHalves {
    fn name(&self) -> String {
        "unsigned_mul_by_halves".into()
    }
    fn inputs(&self) -> &'static [&'static str] {
        &["ua", "ub"]
    }
    fn check<P: Prover>(&self, p: &P, x: &[P::W]) -> (P::Bool, P::Bool) {
        let (a, b) = (&x[0], &x[1]);
        let got = p.under_test(|m| unsigned_mul_by_halves(m, a, b));
        let exact = p.i_mul(&p.uw(a), &p.uw(b));
        (p.b(true), p.i_eq(&p.int_d(&got, false), &exact))
    }
    fn engine(&self) -> Engine {
        Engine::Integer
    }
}

/// `mul_acc(acc, a, b) = acc + a b` exactly, and the sum stays within the bound of a full
/// sum, for the envelope of the fixed kernel's exact sums (`massid_kernel::flight_id::exact`):
/// `|a|, |b| < 2^VALUE_BITS` and `|acc|` at most `FOLD_PERIOD - 1` such products. By
/// induction over the products an entry takes between two folds, no sum wraps. The code
/// under proof is the kernel's `mul_acc` as the host compiles it (the 64-bit multiply; the
/// Cortex-M0's product by halves is the open `widening_mul_byhalves`).
pub struct MulAcc;

impl Obligation for MulAcc {
    fn name(&self) -> String {
        "mul_acc".into()
    }
    fn inputs(&self) -> &'static [&'static str] {
        &["acc_hi", "acc_lo", "a", "b"]
    }
    fn check<P: Prover>(&self, p: &P, x: &[P::W]) -> (P::Bool, P::Bool) {
        use massid_kernel::flight_id::exact::FOLD_PERIOD;
        use massid_kernel::flight_id::exact::VALUE_BITS;
        let acc = p.d_of(&x[0], &x[1]);
        let (a, b) = (&x[2], &x[3]);
        let got = p.under_test(|m| mul_acc(m, &acc, a, b));
        let value = (1i128 << VALUE_BITS) - 1;
        let product = value * value;
        let before = product * (FOLD_PERIOD as i128 - 1);
        let acc_i = p.int_d(&acc, true);
        let pre = p.all(
            &p.all(
                &p.i_within(&p.sw(a), -value, value),
                &p.i_within(&p.sw(b), -value, value),
            ),
            &p.i_within(&acc_i, -before, before),
        );
        let exact = p.i_add(&acc_i, &p.i_mul(&p.sw(a), &p.sw(b)));
        let got_i = p.int_d(&got, true);
        let bound = product * FOLD_PERIOD as i128;
        (
            pre,
            p.all(&p.i_eq(&got_i, &exact), &p.i_within(&got_i, -bound, bound)),
        )
    }
    fn mutant_rlimit(&self) -> u32 {
        PRODUCT_MUTANT_RLIMIT
    }
}

/// `round_product(v, frac)` of a 64-bit sum `v` with `|v| <= 2^62` (what the fixed kernel's
/// nominal prediction rounds: a sum of `mul_acc` products, `flight_id::exact`): `v / 2^frac`
/// to nearest, ties up, saturated to `i32`.
pub struct RoundedSum {
    /// Fractional bits dropped.
    pub frac: u32,
}

impl Obligation for RoundedSum {
    fn name(&self) -> String {
        format!("round_sum_{}", self.frac)
    }
    fn inputs(&self) -> &'static [&'static str] {
        &["v_hi", "v_lo"]
    }
    fn check<P: Prover>(&self, p: &P, x: &[P::W]) -> (P::Bool, P::Bool) {
        let v = p.d_of(&x[0], &x[1]);
        let f = self.frac;
        let r = p.under_test(|m| round_product(m, &v, f));
        let vi = p.int_d(&v, true);
        let pre = p.i_within(&vi, -(1i128 << 62), 1i128 << 62);
        (pre, is_rounded_value(p, &vi, &r, f))
    }
}
