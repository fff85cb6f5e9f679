//! The machine as Z3 integers: a word is its unsigned value, every operation its exact
//! arithmetic meaning reduced modulo 2^32 or 2^64. Z3's nonlinear integer reasoning proves
//! what bit-level solving cannot in reasonable time: that a multiplier or a divider built from
//! smaller ones equals the exact product or quotient (the 16-bit-halves product, a Knuth
//! digit). Bitwise `and` with a non-mask, `or` and shifts by a varying amount are
//! over-approximated (a fresh value within sound bounds, or a case split), never assumed.

use crate::prover::Prover;
use massid_kernel::int::Machine;
use std::cell::RefCell;
use z3::ast::{Ast, Bool, Int};
use z3::Context;

/// The integer machine over one context. `facts` are the bounds of the fresh values it
/// introduced; the solver assumes them (they hold for the machine's real results).
pub struct Z3Int<'ctx> {
    /// The context every term lives in.
    pub ctx: &'ctx Context,
    /// Facts about over-approximated results, to assume.
    pub facts: RefCell<Vec<Bool<'ctx>>>,
}

impl<'ctx> Z3Int<'ctx> {
    /// A machine with no facts yet.
    pub fn new(ctx: &'ctx Context) -> Self {
        Z3Int {
            ctx,
            facts: RefCell::new(Vec::new()),
        }
    }
    /// An exact constant.
    pub fn num(&self, v: i128) -> Int<'ctx> {
        Int::from_str(self.ctx, &v.to_string()).unwrap_or_else(|| Int::from_i64(self.ctx, 0))
    }
    fn pow2(&self, k: u32) -> Int<'ctx> {
        self.num(1i128 << k)
    }
    fn wrap(&self, a: &Int<'ctx>, bits: u32) -> Int<'ctx> {
        a.modulo(&self.pow2(bits))
    }
    fn signed(&self, a: &Int<'ctx>, bits: u32) -> Int<'ctx> {
        let half = self.pow2(bits - 1);
        a.ge(&half)
            .ite(&Int::sub(self.ctx, &[a, &self.pow2(bits)]), a)
    }
    fn constant(a: &Int<'ctx>) -> Option<i128> {
        a.simplify()
            .as_i64()
            .map(i128::from)
            .or_else(|| a.simplify().as_u64().map(i128::from))
    }
    fn sum(&self, a: &Int<'ctx>, b: &Int<'ctx>) -> Int<'ctx> {
        Int::add(self.ctx, &[a, b])
    }
    fn difference(&self, a: &Int<'ctx>, b: &Int<'ctx>) -> Int<'ctx> {
        Int::sub(self.ctx, &[a, b])
    }
    fn product(&self, a: &Int<'ctx>, b: &Int<'ctx>) -> Int<'ctx> {
        Int::mul(self.ctx, &[a, b])
    }
    /// `a 2^s` by cases on `s & (bits - 1)`.
    fn shift_left(&self, a: &Int<'ctx>, s: &Int<'ctx>, bits: u32) -> Int<'ctx> {
        let s = s.modulo(&self.num(i128::from(bits)));
        if let Some(k) = Self::constant(&s) {
            return self.wrap(&self.product(a, &self.pow2(k as u32)), bits);
        }
        let mut r = self.num(0);
        for k in 0..bits {
            let v = self.wrap(&self.product(a, &self.pow2(k)), bits);
            r = s._eq(&self.num(i128::from(k))).ite(&v, &r);
        }
        r
    }
    /// `floor(a / 2^s)` by cases on `s & (bits - 1)` (for `a` read as the caller wants).
    fn shift_right(&self, a: &Int<'ctx>, s: &Int<'ctx>, bits: u32) -> Int<'ctx> {
        let s = s.modulo(&self.num(i128::from(bits)));
        if let Some(k) = Self::constant(&s) {
            return a.div(&self.pow2(k as u32));
        }
        let mut r = self.num(0);
        for k in 0..bits {
            r = s
                ._eq(&self.num(i128::from(k)))
                .ite(&a.div(&self.pow2(k)), &r);
        }
        r
    }
    fn leading_zeros(&self, a: &Int<'ctx>, bits: u32) -> Int<'ctx> {
        let mut r = self.num(i128::from(bits));
        for i in 0..bits {
            // from the lowest power up, so the highest one reached decides
            r = a
                .ge(&self.pow2(i))
                .ite(&self.num(i128::from(bits - 1 - i)), &r);
        }
        r
    }
    fn mask_width(v: i128) -> Option<u32> {
        (v > 0 && (v + 1) & v == 0).then(|| (v + 1).trailing_zeros())
    }
    fn bit_and(&self, a: &Int<'ctx>, b: &Int<'ctx>, bits: u32) -> Int<'ctx> {
        for (x, y) in [(a, b), (b, a)] {
            if let Some(k) = Self::constant(y).and_then(Self::mask_width) {
                return x.modulo(&self.pow2(k));
            }
        }
        // sound bounds: 0 <= a & b <= min(a, b)
        let r = Int::fresh_const(self.ctx, "and");
        let f = Bool::and(self.ctx, &[&r.ge(&self.num(0)), &r.le(a), &r.le(b)]);
        self.facts.borrow_mut().push(f);
        let _ = bits;
        r
    }
    fn bit_or(&self, a: &Int<'ctx>, b: &Int<'ctx>, bits: u32) -> Int<'ctx> {
        if Self::constant(a) == Some(0) {
            return b.clone();
        }
        if Self::constant(b) == Some(0) {
            return a.clone();
        }
        // sound bounds: max(a, b) <= a | b <= min(a + b, 2^bits - 1)
        let r = Int::fresh_const(self.ctx, "or");
        let f = Bool::and(
            self.ctx,
            &[
                &r.ge(a),
                &r.ge(b),
                &r.le(&self.sum(a, b)),
                &r.lt(&self.pow2(bits)),
            ],
        );
        self.facts.borrow_mut().push(f);
        r
    }
}

impl<'ctx> Machine for Z3Int<'ctx> {
    type Bool = Bool<'ctx>;
    type W = Int<'ctx>;
    type D = Int<'ctx>;

    fn w(&self, v: u32) -> Int<'ctx> {
        self.num(i128::from(v))
    }
    fn d(&self, v: u64) -> Int<'ctx> {
        self.num(i128::from(v))
    }
    fn b(&self, v: bool) -> Bool<'ctx> {
        Bool::from_bool(self.ctx, v)
    }
    fn add(&self, a: &Int<'ctx>, b: &Int<'ctx>) -> Int<'ctx> {
        self.wrap(&self.sum(a, b), 32)
    }
    fn sub(&self, a: &Int<'ctx>, b: &Int<'ctx>) -> Int<'ctx> {
        self.wrap(&self.difference(a, b), 32)
    }
    fn mul(&self, a: &Int<'ctx>, b: &Int<'ctx>) -> Int<'ctx> {
        self.wrap(&self.product(a, b), 32)
    }
    fn udiv(&self, a: &Int<'ctx>, b: &Int<'ctx>) -> Int<'ctx> {
        b._eq(&self.num(0)).ite(&self.num(0), &a.div(b))
    }
    fn urem(&self, a: &Int<'ctx>, b: &Int<'ctx>) -> Int<'ctx> {
        b._eq(&self.num(0)).ite(&self.num(0), &a.modulo(b))
    }
    fn and(&self, a: &Int<'ctx>, b: &Int<'ctx>) -> Int<'ctx> {
        self.bit_and(a, b, 32)
    }
    fn or(&self, a: &Int<'ctx>, b: &Int<'ctx>) -> Int<'ctx> {
        self.bit_or(a, b, 32)
    }
    fn shl(&self, a: &Int<'ctx>, s: &Int<'ctx>) -> Int<'ctx> {
        self.shift_left(a, s, 32)
    }
    fn lshr(&self, a: &Int<'ctx>, s: &Int<'ctx>) -> Int<'ctx> {
        self.shift_right(a, s, 32)
    }
    fn ashr(&self, a: &Int<'ctx>, s: &Int<'ctx>) -> Int<'ctx> {
        self.wrap(&self.shift_right(&self.signed(a, 32), s, 32), 32)
    }
    fn clz(&self, a: &Int<'ctx>) -> Int<'ctx> {
        self.leading_zeros(a, 32)
    }
    fn eq(&self, a: &Int<'ctx>, b: &Int<'ctx>) -> Bool<'ctx> {
        a._eq(b)
    }
    fn ult(&self, a: &Int<'ctx>, b: &Int<'ctx>) -> Bool<'ctx> {
        a.lt(b)
    }
    fn slt(&self, a: &Int<'ctx>, b: &Int<'ctx>) -> Bool<'ctx> {
        self.signed(a, 32).lt(&self.signed(b, 32))
    }
    fn select(&self, c: &Bool<'ctx>, a: &Int<'ctx>, b: &Int<'ctx>) -> Int<'ctx> {
        c.ite(a, b)
    }
    fn add_d(&self, a: &Int<'ctx>, b: &Int<'ctx>) -> Int<'ctx> {
        self.wrap(&self.sum(a, b), 64)
    }
    fn sub_d(&self, a: &Int<'ctx>, b: &Int<'ctx>) -> Int<'ctx> {
        self.wrap(&self.difference(a, b), 64)
    }
    fn mul_d(&self, a: &Int<'ctx>, b: &Int<'ctx>) -> Int<'ctx> {
        self.wrap(&self.product(a, b), 64)
    }
    fn or_d(&self, a: &Int<'ctx>, b: &Int<'ctx>) -> Int<'ctx> {
        self.bit_or(a, b, 64)
    }
    fn sdiv_d(&self, a: &Int<'ctx>, b: &Int<'ctx>) -> Int<'ctx> {
        let (n, d) = (self.signed(a, 64), self.signed(b, 64));
        let zero = self.num(0);
        let neg = |x: &Int<'ctx>| self.difference(&zero, x);
        let (an, ad) = (n.ge(&zero).ite(&n, &neg(&n)), d.ge(&zero).ite(&d, &neg(&d)));
        let mag = an.div(&ad);
        let q = n.ge(&zero)._eq(&d.ge(&zero)).ite(&mag, &neg(&mag));
        d._eq(&zero).ite(&zero, &self.wrap(&q, 64))
    }
    fn shl_d(&self, a: &Int<'ctx>, s: &Int<'ctx>) -> Int<'ctx> {
        self.shift_left(a, s, 64)
    }
    fn lshr_d(&self, a: &Int<'ctx>, s: &Int<'ctx>) -> Int<'ctx> {
        self.shift_right(a, s, 64)
    }
    fn ashr_d(&self, a: &Int<'ctx>, s: &Int<'ctx>) -> Int<'ctx> {
        self.wrap(&self.shift_right(&self.signed(a, 64), s, 64), 64)
    }
    fn clz_d(&self, a: &Int<'ctx>) -> Int<'ctx> {
        self.leading_zeros(a, 64)
    }
    fn eq_d(&self, a: &Int<'ctx>, b: &Int<'ctx>) -> Bool<'ctx> {
        a._eq(b)
    }
    fn ult_d(&self, a: &Int<'ctx>, b: &Int<'ctx>) -> Bool<'ctx> {
        a.lt(b)
    }
    fn slt_d(&self, a: &Int<'ctx>, b: &Int<'ctx>) -> Bool<'ctx> {
        self.signed(a, 64).lt(&self.signed(b, 64))
    }
    fn select_d(&self, c: &Bool<'ctx>, a: &Int<'ctx>, b: &Int<'ctx>) -> Int<'ctx> {
        c.ite(a, b)
    }
    fn zext(&self, a: &Int<'ctx>) -> Int<'ctx> {
        a.clone()
    }
    fn sext(&self, a: &Int<'ctx>) -> Int<'ctx> {
        self.wrap(&self.signed(a, 32), 64)
    }
    fn lo(&self, a: &Int<'ctx>) -> Int<'ctx> {
        self.wrap(a, 32)
    }
    fn all(&self, a: &Bool<'ctx>, b: &Bool<'ctx>) -> Bool<'ctx> {
        Bool::and(self.ctx, &[a, b])
    }
    fn any(&self, a: &Bool<'ctx>, b: &Bool<'ctx>) -> Bool<'ctx> {
        Bool::or(self.ctx, &[a, b])
    }
    fn not(&self, a: &Bool<'ctx>) -> Bool<'ctx> {
        a.not()
    }
}

impl<'ctx> Prover for Z3Int<'ctx> {
    type I = Int<'ctx>;
    fn int(&self, v: i128) -> Int<'ctx> {
        self.num(v)
    }
    fn int_w(&self, a: &Int<'ctx>, signed: bool) -> Int<'ctx> {
        if signed {
            self.signed(a, 32)
        } else {
            a.clone()
        }
    }
    fn int_d(&self, a: &Int<'ctx>, signed: bool) -> Int<'ctx> {
        if signed {
            self.signed(a, 64)
        } else {
            a.clone()
        }
    }
    fn i_add(&self, a: &Int<'ctx>, b: &Int<'ctx>) -> Int<'ctx> {
        self.sum(a, b)
    }
    fn i_sub(&self, a: &Int<'ctx>, b: &Int<'ctx>) -> Int<'ctx> {
        self.difference(a, b)
    }
    fn i_mul(&self, a: &Int<'ctx>, b: &Int<'ctx>) -> Int<'ctx> {
        self.product(a, b)
    }
    fn i_shl(&self, a: &Int<'ctx>, s: &Int<'ctx>) -> Int<'ctx> {
        if let Some(k) = Self::constant(s) {
            return self.product(a, &self.pow2(k as u32));
        }
        let mut r = self.num(0);
        for k in 0..128u32 {
            r = s
                ._eq(&self.num(i128::from(k)))
                .ite(&self.product(a, &self.pow2(k.min(126))), &r);
        }
        r
    }
    fn i_le(&self, a: &Int<'ctx>, b: &Int<'ctx>) -> Bool<'ctx> {
        a.le(b)
    }
    fn i_lt(&self, a: &Int<'ctx>, b: &Int<'ctx>) -> Bool<'ctx> {
        a.lt(b)
    }
    fn i_eq(&self, a: &Int<'ctx>, b: &Int<'ctx>) -> Bool<'ctx> {
        a._eq(b)
    }
    fn i_select(&self, c: &Bool<'ctx>, a: &Int<'ctx>, b: &Int<'ctx>) -> Int<'ctx> {
        c.ite(a, b)
    }
    fn implies(&self, a: &Bool<'ctx>, b: &Bool<'ctx>) -> Bool<'ctx> {
        a.implies(b)
    }
    fn d_of(&self, hi: &Int<'ctx>, lo: &Int<'ctx>) -> Int<'ctx> {
        self.sum(&self.product(hi, &self.pow2(32)), lo)
    }
}
