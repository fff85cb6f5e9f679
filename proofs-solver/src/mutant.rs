//! A machine that alters exactly one operation of the code under proof: the mutation check
//! that shows a proof can fail. The code is straight-line over the machine (no data-dependent
//! control flow), so "the n-th operation" names the same operation in the solver's run and
//! in the concrete replay.

use crate::prover::Prover;
use massid_kernel::int::Machine;
use std::cell::Cell;

/// `P` with operation number `site` (counted from 0 while armed) replaced by a sibling:
/// `+` by `-`, `<` by `<=`, a constant by itself plus one, a selection's arms swapped...
pub struct Mutant<P> {
    /// The machine being altered.
    pub inner: P,
    /// The operation to alter.
    pub site: u32,
    count: Cell<u32>,
    armed: Cell<bool>,
}

impl<P> Mutant<P> {
    /// `inner` with operation `site` altered.
    pub fn new(inner: P, site: u32) -> Self {
        Mutant {
            inner,
            site,
            count: Cell::new(0),
            armed: Cell::new(false),
        }
    }
    /// Operations seen while armed.
    pub fn operations(&self) -> u32 {
        self.count.get()
    }
    /// Whether the current operation is the one to alter (and counts it).
    fn hit(&self) -> bool {
        if !self.armed.get() {
            return false;
        }
        let n = self.count.get();
        self.count.set(n + 1);
        n == self.site
    }
}

macro_rules! mutate {
    ($($f:ident($($a:ident: $t:ident),*) -> $r:ident => |$m:ident| $alt:expr;)*) => {
        $(fn $f(&self, $($a: &Self::$t),*) -> Self::$r {
            if self.hit() {
                let $m = &self.inner;
                $alt
            } else {
                self.inner.$f($($a),*)
            }
        })*
    };
}

impl<P: Prover> Machine for Mutant<P> {
    type Bool = P::Bool;
    type W = P::W;
    type D = P::D;
    fn w(&self, v: u32) -> P::W {
        self.inner.w(if self.hit() { v.wrapping_add(1) } else { v })
    }
    fn d(&self, v: u64) -> P::D {
        self.inner.d(if self.hit() { v.wrapping_add(1) } else { v })
    }
    fn b(&self, v: bool) -> P::Bool {
        self.inner.b(if self.hit() { !v } else { v })
    }
    mutate! {
        add(a: W, b: W) -> W => |m| m.sub(a, b);
        sub(a: W, b: W) -> W => |m| m.add(a, b);
        mul(a: W, b: W) -> W => |m| m.add(a, b);
        udiv(a: W, b: W) -> W => |m| m.urem(a, b);
        urem(a: W, b: W) -> W => |m| m.udiv(a, b);
        and(a: W, b: W) -> W => |m| m.or(a, b);
        or(a: W, b: W) -> W => |m| m.and(a, b);
        shl(a: W, s: W) -> W => |m| m.lshr(a, s);
        lshr(a: W, s: W) -> W => |m| m.ashr(a, s);
        ashr(a: W, s: W) -> W => |m| m.lshr(a, s);
        clz(a: W) -> W => |m| m.add(&m.clz(a), &m.w(1));
        eq(a: W, b: W) -> Bool => |m| m.not(&m.eq(a, b));
        ult(a: W, b: W) -> Bool => |m| m.not(&m.ult(b, a));
        slt(a: W, b: W) -> Bool => |m| m.not(&m.slt(b, a));
        add_d(a: D, b: D) -> D => |m| m.sub_d(a, b);
        sub_d(a: D, b: D) -> D => |m| m.add_d(a, b);
        mul_d(a: D, b: D) -> D => |m| m.add_d(a, b);
        or_d(a: D, b: D) -> D => |m| m.add_d(a, &m.add_d(b, &m.d(1)));
        sdiv_d(a: D, b: D) -> D => |m| m.add_d(&m.sdiv_d(a, b), &m.d(1));
        shl_d(a: D, s: W) -> D => |m| m.lshr_d(a, s);
        lshr_d(a: D, s: W) -> D => |m| m.ashr_d(a, s);
        ashr_d(a: D, s: W) -> D => |m| m.lshr_d(a, s);
        clz_d(a: D) -> W => |m| m.add(&m.clz_d(a), &m.w(1));
        eq_d(a: D, b: D) -> Bool => |m| m.not(&m.eq_d(a, b));
        ult_d(a: D, b: D) -> Bool => |m| m.not(&m.ult_d(b, a));
        slt_d(a: D, b: D) -> Bool => |m| m.not(&m.slt_d(b, a));
        zext(a: W) -> D => |m| m.sext(a);
        sext(a: W) -> D => |m| m.zext(a);
        lo(a: D) -> W => |m| m.add(&m.lo(a), &m.w(1));
        all(a: Bool, b: Bool) -> Bool => |m| m.any(a, b);
        any(a: Bool, b: Bool) -> Bool => |m| m.all(a, b);
        not(a: Bool) -> Bool => |_m| a.clone();
    }
    fn select(&self, c: &P::Bool, a: &P::W, b: &P::W) -> P::W {
        if self.hit() {
            self.inner.select(c, b, a)
        } else {
            self.inner.select(c, a, b)
        }
    }
    fn select_d(&self, c: &P::Bool, a: &P::D, b: &P::D) -> P::D {
        if self.hit() {
            self.inner.select_d(c, b, a)
        } else {
            self.inner.select_d(c, a, b)
        }
    }
}

impl<P: Prover> Prover for Mutant<P> {
    type I = P::I;
    fn int(&self, v: i128) -> P::I {
        self.inner.int(v)
    }
    fn int_w(&self, a: &P::W, signed: bool) -> P::I {
        self.inner.int_w(a, signed)
    }
    fn int_d(&self, a: &P::D, signed: bool) -> P::I {
        self.inner.int_d(a, signed)
    }
    fn i_add(&self, a: &P::I, b: &P::I) -> P::I {
        self.inner.i_add(a, b)
    }
    fn i_sub(&self, a: &P::I, b: &P::I) -> P::I {
        self.inner.i_sub(a, b)
    }
    fn i_mul(&self, a: &P::I, b: &P::I) -> P::I {
        self.inner.i_mul(a, b)
    }
    fn i_shl(&self, a: &P::I, s: &P::W) -> P::I {
        self.inner.i_shl(a, s)
    }
    fn i_le(&self, a: &P::I, b: &P::I) -> P::Bool {
        self.inner.i_le(a, b)
    }
    fn i_lt(&self, a: &P::I, b: &P::I) -> P::Bool {
        self.inner.i_lt(a, b)
    }
    fn i_eq(&self, a: &P::I, b: &P::I) -> P::Bool {
        self.inner.i_eq(a, b)
    }
    fn i_select(&self, c: &P::Bool, a: &P::I, b: &P::I) -> P::I {
        self.inner.i_select(c, a, b)
    }
    fn implies(&self, a: &P::Bool, b: &P::Bool) -> P::Bool {
        self.inner.implies(a, b)
    }
    fn d_of(&self, hi: &P::W, lo: &P::W) -> P::D {
        self.inner.d_of(hi, lo)
    }
    fn arm(&self, on: bool) {
        self.armed.set(on);
    }
}
