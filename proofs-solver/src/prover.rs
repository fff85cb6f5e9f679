//! What an obligation needs beyond the machine: exact 128-bit integers to state the property
//! (never mutated, never wrapped within the ranges used), and a way to build inputs.

use massid_kernel::int::{Machine, MachineExt};

/// A machine on which properties can be stated. Implemented by the Z3 machine (the proof)
/// and the concrete machine (the replay of a counterexample).
pub trait Prover: Machine {
    /// An exact integer (128 bits: every product of two 64-bit words fits).
    type I: Clone;
    /// An exact integer constant.
    fn int(&self, v: i128) -> Self::I;
    /// A 32-bit word read as signed (`true`) or unsigned.
    fn int_w(&self, a: &Self::W, signed: bool) -> Self::I;
    /// A 64-bit word read as signed (`true`) or unsigned.
    fn int_d(&self, a: &Self::D, signed: bool) -> Self::I;
    /// Sum.
    fn i_add(&self, a: &Self::I, b: &Self::I) -> Self::I;
    /// Difference.
    fn i_sub(&self, a: &Self::I, b: &Self::I) -> Self::I;
    /// Product.
    fn i_mul(&self, a: &Self::I, b: &Self::I) -> Self::I;
    /// `a * 2^s` for a word `s` (below 128).
    fn i_shl(&self, a: &Self::I, s: &Self::W) -> Self::I;
    /// `a <= b`.
    fn i_le(&self, a: &Self::I, b: &Self::I) -> Self::Bool;
    /// `a < b`.
    fn i_lt(&self, a: &Self::I, b: &Self::I) -> Self::Bool;
    /// `a == b`.
    fn i_eq(&self, a: &Self::I, b: &Self::I) -> Self::Bool;
    /// `if c { a } else { b }`.
    fn i_select(&self, c: &Self::Bool, a: &Self::I, b: &Self::I) -> Self::I;
    /// `a => b`.
    fn implies(&self, a: &Self::Bool, b: &Self::Bool) -> Self::Bool;
    /// The 64-bit word `hi 2^32 + lo`, built outside the code under proof.
    fn d_of(&self, hi: &Self::W, lo: &Self::W) -> Self::D;
    /// Marks the start (`true`) and end of the code under proof (a mutant alters only
    /// operations inside; the property around it is never altered).
    fn arm(&self, _on: bool) {}
}

/// Property helpers written once over [`Prover`].
pub trait ProverExt: Prover {
    /// Runs the code under proof (see [`Prover::arm`]).
    fn under_test<R>(&self, f: impl FnOnce(&Self) -> R) -> R {
        self.arm(true);
        let r = f(self);
        self.arm(false);
        r
    }
    /// `lo <= a <= hi`.
    fn i_within(&self, a: &Self::I, lo: i128, hi: i128) -> Self::Bool {
        self.all(&self.i_le(&self.int(lo), a), &self.i_le(a, &self.int(hi)))
    }
    /// A signed 32-bit word as an exact integer.
    fn sw(&self, a: &Self::W) -> Self::I {
        self.int_w(a, true)
    }
    /// An unsigned 32-bit word as an exact integer.
    fn uw(&self, a: &Self::W) -> Self::I {
        self.int_w(a, false)
    }
    /// `|a|`.
    fn i_abs(&self, a: &Self::I) -> Self::I {
        let neg = self.i_lt(a, &self.int(0));
        self.i_select(&neg, &self.i_sub(&self.int(0), a), a)
    }
    /// `q = trunc(n / d)` for `d != 0`, stated without division:
    /// `|q| |d| <= |n| < (|q| + 1) |d|`, and `q`'s sign is that of `n d` (or `q = 0`).
    fn is_trunc_quotient(&self, q: &Self::I, n: &Self::I, d: &Self::I) -> Self::Bool {
        let (aq, an, ad) = (self.i_abs(q), self.i_abs(n), self.i_abs(d));
        let low = self.i_mul(&aq, &ad);
        let magnitude = self.all(
            &self.i_le(&low, &an),
            &self.i_lt(&an, &self.i_add(&low, &ad)),
        );
        let zero = self.int(0);
        let same = self.differ(&self.i_lt(n, &zero), &self.i_lt(d, &zero));
        let sign_ok = self.any(
            &self.i_eq(q, &zero),
            &self.select_bool(&same, &self.i_lt(q, &zero), &self.i_lt(&zero, q)),
        );
        self.all(&magnitude, &sign_ok)
    }
}

impl<P: Prover + ?Sized> ProverExt for P {}
