//! The machine the kernel runs on ([`Native`]) with exact `i128` properties: where a
//! counterexample found by the solver is replayed on the compiled code.

use crate::prover::Prover;
use massid_kernel::int::{Machine, Native};

/// [`Native`] plus `i128` property arithmetic.
#[derive(Clone, Copy, Debug, Default)]
pub struct Concrete;

macro_rules! delegate {
    ($($f:ident($($a:ident: $t:ty),*) -> $r:ty;)*) => {
        $(fn $f(&self, $($a: $t),*) -> $r { Native.$f($($a),*) })*
    };
}

impl Machine for Concrete {
    type Bool = bool;
    type W = u32;
    type D = u64;
    delegate! {
        w(v: u32) -> u32; d(v: u64) -> u64; b(v: bool) -> bool;
        add(a: &u32, b: &u32) -> u32; sub(a: &u32, b: &u32) -> u32; mul(a: &u32, b: &u32) -> u32;
        udiv(a: &u32, b: &u32) -> u32; urem(a: &u32, b: &u32) -> u32;
        and(a: &u32, b: &u32) -> u32; or(a: &u32, b: &u32) -> u32;
        shl(a: &u32, s: &u32) -> u32; lshr(a: &u32, s: &u32) -> u32; ashr(a: &u32, s: &u32) -> u32;
        clz(a: &u32) -> u32; eq(a: &u32, b: &u32) -> bool; ult(a: &u32, b: &u32) -> bool;
        slt(a: &u32, b: &u32) -> bool; select(c: &bool, a: &u32, b: &u32) -> u32;
        add_d(a: &u64, b: &u64) -> u64; sub_d(a: &u64, b: &u64) -> u64; mul_d(a: &u64, b: &u64) -> u64;
        or_d(a: &u64, b: &u64) -> u64; sdiv_d(a: &u64, b: &u64) -> u64;
        shl_d(a: &u64, s: &u32) -> u64; lshr_d(a: &u64, s: &u32) -> u64; ashr_d(a: &u64, s: &u32) -> u64;
        clz_d(a: &u64) -> u32; eq_d(a: &u64, b: &u64) -> bool; ult_d(a: &u64, b: &u64) -> bool;
        slt_d(a: &u64, b: &u64) -> bool; select_d(c: &bool, a: &u64, b: &u64) -> u64;
        zext(a: &u32) -> u64; sext(a: &u32) -> u64; lo(a: &u64) -> u32;
        all(a: &bool, b: &bool) -> bool; any(a: &bool, b: &bool) -> bool; not(a: &bool) -> bool;
    }
}

impl Prover for Concrete {
    type I = i128;
    fn int(&self, v: i128) -> i128 {
        v
    }
    fn int_w(&self, a: &u32, signed: bool) -> i128 {
        if signed {
            i128::from(*a as i32)
        } else {
            i128::from(*a)
        }
    }
    fn int_d(&self, a: &u64, signed: bool) -> i128 {
        if signed {
            i128::from(*a as i64)
        } else {
            i128::from(*a)
        }
    }
    fn i_add(&self, a: &i128, b: &i128) -> i128 {
        a.wrapping_add(*b)
    }
    fn i_sub(&self, a: &i128, b: &i128) -> i128 {
        a.wrapping_sub(*b)
    }
    fn i_mul(&self, a: &i128, b: &i128) -> i128 {
        a.wrapping_mul(*b)
    }
    fn i_shl(&self, a: &i128, s: &u32) -> i128 {
        a.checked_shl(*s).unwrap_or(0)
    }
    fn i_le(&self, a: &i128, b: &i128) -> bool {
        a <= b
    }
    fn i_lt(&self, a: &i128, b: &i128) -> bool {
        a < b
    }
    fn i_eq(&self, a: &i128, b: &i128) -> bool {
        a == b
    }
    fn i_select(&self, c: &bool, a: &i128, b: &i128) -> i128 {
        if *c {
            *a
        } else {
            *b
        }
    }
    fn implies(&self, a: &bool, b: &bool) -> bool {
        !*a || *b
    }
    fn d_of(&self, hi: &u32, lo: &u32) -> u64 {
        (u64::from(*hi) << 32) | u64::from(*lo)
    }
}
