//! The machine as Z3 bit-vectors: every operation is the SMT-LIB operation of the same
//! meaning (with the kernel's conventions for shift amounts and zero divisors spelt out).

use crate::prover::Prover;
use massid_kernel::int::Machine;
use z3::ast::{Ast, Bool, BV};
use z3::Context;

/// The Z3 machine over one context.
pub struct Z3<'ctx> {
    /// The context every term lives in.
    pub ctx: &'ctx Context,
}

impl<'ctx> Z3<'ctx> {
    fn shift_amount(&self, s: &BV<'ctx>, width: u32) -> BV<'ctx> {
        let masked = s.bvand(&BV::from_u64(self.ctx, u64::from(width - 1), 32));
        if width == 32 {
            masked
        } else {
            masked.zero_ext(width - 32)
        }
    }
    fn clz_of(&self, a: &BV<'ctx>, width: u32) -> BV<'ctx> {
        // from the lowest bit up, so the highest set bit decides
        let mut r = BV::from_u64(self.ctx, u64::from(width), 32);
        for i in 0..width {
            let set = a.extract(i, i)._eq(&BV::from_u64(self.ctx, 1, 1));
            r = set.ite(&BV::from_u64(self.ctx, u64::from(width - 1 - i), 32), &r);
        }
        r
    }
    fn zero(&self, width: u32) -> BV<'ctx> {
        BV::from_u64(self.ctx, 0, width)
    }
}

impl<'ctx> Machine for Z3<'ctx> {
    type Bool = Bool<'ctx>;
    type W = BV<'ctx>;
    type D = BV<'ctx>;

    fn w(&self, v: u32) -> BV<'ctx> {
        BV::from_u64(self.ctx, u64::from(v), 32)
    }
    fn d(&self, v: u64) -> BV<'ctx> {
        BV::from_u64(self.ctx, v, 64)
    }
    fn b(&self, v: bool) -> Bool<'ctx> {
        Bool::from_bool(self.ctx, v)
    }
    fn add(&self, a: &BV<'ctx>, b: &BV<'ctx>) -> BV<'ctx> {
        a.bvadd(b)
    }
    fn sub(&self, a: &BV<'ctx>, b: &BV<'ctx>) -> BV<'ctx> {
        a.bvsub(b)
    }
    fn mul(&self, a: &BV<'ctx>, b: &BV<'ctx>) -> BV<'ctx> {
        a.bvmul(b)
    }
    fn udiv(&self, a: &BV<'ctx>, b: &BV<'ctx>) -> BV<'ctx> {
        b._eq(&self.zero(32)).ite(&self.zero(32), &a.bvudiv(b))
    }
    fn urem(&self, a: &BV<'ctx>, b: &BV<'ctx>) -> BV<'ctx> {
        b._eq(&self.zero(32)).ite(&self.zero(32), &a.bvurem(b))
    }
    fn and(&self, a: &BV<'ctx>, b: &BV<'ctx>) -> BV<'ctx> {
        a.bvand(b)
    }
    fn or(&self, a: &BV<'ctx>, b: &BV<'ctx>) -> BV<'ctx> {
        a.bvor(b)
    }
    fn shl(&self, a: &BV<'ctx>, s: &BV<'ctx>) -> BV<'ctx> {
        a.bvshl(&self.shift_amount(s, 32))
    }
    fn lshr(&self, a: &BV<'ctx>, s: &BV<'ctx>) -> BV<'ctx> {
        a.bvlshr(&self.shift_amount(s, 32))
    }
    fn ashr(&self, a: &BV<'ctx>, s: &BV<'ctx>) -> BV<'ctx> {
        a.bvashr(&self.shift_amount(s, 32))
    }
    fn clz(&self, a: &BV<'ctx>) -> BV<'ctx> {
        self.clz_of(a, 32)
    }
    fn eq(&self, a: &BV<'ctx>, b: &BV<'ctx>) -> Bool<'ctx> {
        a._eq(b)
    }
    fn ult(&self, a: &BV<'ctx>, b: &BV<'ctx>) -> Bool<'ctx> {
        a.bvult(b)
    }
    fn slt(&self, a: &BV<'ctx>, b: &BV<'ctx>) -> Bool<'ctx> {
        a.bvslt(b)
    }
    fn select(&self, c: &Bool<'ctx>, a: &BV<'ctx>, b: &BV<'ctx>) -> BV<'ctx> {
        c.ite(a, b)
    }
    fn add_d(&self, a: &BV<'ctx>, b: &BV<'ctx>) -> BV<'ctx> {
        a.bvadd(b)
    }
    fn sub_d(&self, a: &BV<'ctx>, b: &BV<'ctx>) -> BV<'ctx> {
        a.bvsub(b)
    }
    fn mul_d(&self, a: &BV<'ctx>, b: &BV<'ctx>) -> BV<'ctx> {
        a.bvmul(b)
    }
    fn or_d(&self, a: &BV<'ctx>, b: &BV<'ctx>) -> BV<'ctx> {
        a.bvor(b)
    }
    fn sdiv_d(&self, a: &BV<'ctx>, b: &BV<'ctx>) -> BV<'ctx> {
        // SMT-LIB's bvsdiv wraps MIN / -1 to MIN, as the machine does
        b._eq(&self.zero(64)).ite(&self.zero(64), &a.bvsdiv(b))
    }
    fn shl_d(&self, a: &BV<'ctx>, s: &BV<'ctx>) -> BV<'ctx> {
        a.bvshl(&self.shift_amount(s, 64))
    }
    fn lshr_d(&self, a: &BV<'ctx>, s: &BV<'ctx>) -> BV<'ctx> {
        a.bvlshr(&self.shift_amount(s, 64))
    }
    fn ashr_d(&self, a: &BV<'ctx>, s: &BV<'ctx>) -> BV<'ctx> {
        a.bvashr(&self.shift_amount(s, 64))
    }
    fn clz_d(&self, a: &BV<'ctx>) -> BV<'ctx> {
        self.clz_of(a, 64)
    }
    fn eq_d(&self, a: &BV<'ctx>, b: &BV<'ctx>) -> Bool<'ctx> {
        a._eq(b)
    }
    fn ult_d(&self, a: &BV<'ctx>, b: &BV<'ctx>) -> Bool<'ctx> {
        a.bvult(b)
    }
    fn slt_d(&self, a: &BV<'ctx>, b: &BV<'ctx>) -> Bool<'ctx> {
        a.bvslt(b)
    }
    fn select_d(&self, c: &Bool<'ctx>, a: &BV<'ctx>, b: &BV<'ctx>) -> BV<'ctx> {
        c.ite(a, b)
    }
    fn zext(&self, a: &BV<'ctx>) -> BV<'ctx> {
        a.zero_ext(32)
    }
    fn sext(&self, a: &BV<'ctx>) -> BV<'ctx> {
        a.sign_ext(32)
    }
    fn lo(&self, a: &BV<'ctx>) -> BV<'ctx> {
        a.extract(31, 0)
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

impl<'ctx> Prover for Z3<'ctx> {
    type I = BV<'ctx>;
    fn int(&self, v: i128) -> BV<'ctx> {
        let hi = BV::from_u64(self.ctx, ((v as u128) >> 64) as u64, 64);
        let lo = BV::from_u64(self.ctx, v as u64, 64);
        hi.concat(&lo)
    }
    fn int_w(&self, a: &BV<'ctx>, signed: bool) -> BV<'ctx> {
        if signed {
            a.sign_ext(96)
        } else {
            a.zero_ext(96)
        }
    }
    fn int_d(&self, a: &BV<'ctx>, signed: bool) -> BV<'ctx> {
        if signed {
            a.sign_ext(64)
        } else {
            a.zero_ext(64)
        }
    }
    fn i_add(&self, a: &BV<'ctx>, b: &BV<'ctx>) -> BV<'ctx> {
        a.bvadd(b)
    }
    fn i_sub(&self, a: &BV<'ctx>, b: &BV<'ctx>) -> BV<'ctx> {
        a.bvsub(b)
    }
    fn i_mul(&self, a: &BV<'ctx>, b: &BV<'ctx>) -> BV<'ctx> {
        a.bvmul(b)
    }
    fn i_shl(&self, a: &BV<'ctx>, s: &BV<'ctx>) -> BV<'ctx> {
        a.bvshl(&s.zero_ext(96))
    }
    fn i_le(&self, a: &BV<'ctx>, b: &BV<'ctx>) -> Bool<'ctx> {
        a.bvsle(b)
    }
    fn i_lt(&self, a: &BV<'ctx>, b: &BV<'ctx>) -> Bool<'ctx> {
        a.bvslt(b)
    }
    fn i_eq(&self, a: &BV<'ctx>, b: &BV<'ctx>) -> Bool<'ctx> {
        a._eq(b)
    }
    fn i_select(&self, c: &Bool<'ctx>, a: &BV<'ctx>, b: &BV<'ctx>) -> BV<'ctx> {
        c.ite(a, b)
    }
    fn implies(&self, a: &Bool<'ctx>, b: &Bool<'ctx>) -> Bool<'ctx> {
        a.implies(b)
    }
    fn d_of(&self, hi: &BV<'ctx>, lo: &BV<'ctx>) -> BV<'ctx> {
        hi.concat(lo)
    }
}
