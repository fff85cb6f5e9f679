//! The kernel's integer primitives, written once over a model of the machine word.
//!
//! Every routine in this module is generic over [`Machine`]: a 32-bit word `W`, a 64-bit
//! word `D` and a truth value, with wrapping operations whose meaning is fixed bit for bit
//! (Rust's `wrapping_*`, shifts masked to the width, a zero divisor giving 0). The kernel
//! instantiates them with [`Native`] (plain `u32`/`u64`/`bool`, every method
//! `#[inline(always)]`, so the compiled code is what it would be written by hand), and
//! `proofs/` instantiates the *same source* with Z3 bit-vectors and with integer intervals,
//! to prove each routine exact (or overflow-free) for every input of its envelope.
//!
//! Data-dependent choices are [`Machine::select`], not `if`: a solver sees both arms, and the
//! compiled code keeps a branch or a conditional move as the optimiser likes. Loops run a
//! fixed number of times (the format's fractional bits, a proven bound on corrections).
//! Signedness is in the operation (`slt`, `ashr`, `sext`), never in the type, as in the
//! machine's own instruction set.

pub mod div;
pub mod float;
pub mod mul;
pub mod shift;
pub mod split;

/// A machine with 32- and 64-bit words. See the module docs for the semantics every
/// implementation must give these operations.
pub trait Machine {
    /// A truth value.
    type Bool: Clone;
    /// A 32-bit word.
    type W: Clone;
    /// A 64-bit word.
    type D: Clone;

    /// A 32-bit constant.
    fn w(&self, v: u32) -> Self::W;
    /// A 64-bit constant.
    fn d(&self, v: u64) -> Self::D;
    /// A truth constant.
    fn b(&self, v: bool) -> Self::Bool;

    /// Wrapping sum.
    fn add(&self, a: &Self::W, b: &Self::W) -> Self::W;
    /// Wrapping difference.
    fn sub(&self, a: &Self::W, b: &Self::W) -> Self::W;
    /// Low 32 bits of the product.
    fn mul(&self, a: &Self::W, b: &Self::W) -> Self::W;
    /// Unsigned quotient; 0 for a zero divisor.
    fn udiv(&self, a: &Self::W, b: &Self::W) -> Self::W;
    /// Unsigned remainder; 0 for a zero divisor.
    fn urem(&self, a: &Self::W, b: &Self::W) -> Self::W;
    /// Bitwise and.
    fn and(&self, a: &Self::W, b: &Self::W) -> Self::W;
    /// Bitwise or.
    fn or(&self, a: &Self::W, b: &Self::W) -> Self::W;
    /// Left shift by `s & 31`.
    fn shl(&self, a: &Self::W, s: &Self::W) -> Self::W;
    /// Logical right shift by `s & 31`.
    fn lshr(&self, a: &Self::W, s: &Self::W) -> Self::W;
    /// Arithmetic right shift by `s & 31`.
    fn ashr(&self, a: &Self::W, s: &Self::W) -> Self::W;
    /// Count of leading zero bits (32 for zero).
    fn clz(&self, a: &Self::W) -> Self::W;
    /// Equality.
    fn eq(&self, a: &Self::W, b: &Self::W) -> Self::Bool;
    /// Unsigned `a < b`.
    fn ult(&self, a: &Self::W, b: &Self::W) -> Self::Bool;
    /// Signed `a < b`.
    fn slt(&self, a: &Self::W, b: &Self::W) -> Self::Bool;
    /// `if c { a } else { b }`.
    fn select(&self, c: &Self::Bool, a: &Self::W, b: &Self::W) -> Self::W;
    /// [`Machine::select`] of two computations: the native machine runs only the chosen
    /// one (the branch the hand-written code had); every other machine runs both, in order,
    /// so that a proof, a bound or a mutant sees every operation of either arm.
    #[inline(always)]
    fn select_lazy(
        &self,
        c: &Self::Bool,
        a: impl FnOnce() -> Self::W,
        b: impl FnOnce() -> Self::W,
    ) -> Self::W {
        let (a, b) = (a(), b());
        self.select(c, &a, &b)
    }

    /// Wrapping sum.
    fn add_d(&self, a: &Self::D, b: &Self::D) -> Self::D;
    /// Wrapping difference.
    fn sub_d(&self, a: &Self::D, b: &Self::D) -> Self::D;
    /// Low 64 bits of the product.
    fn mul_d(&self, a: &Self::D, b: &Self::D) -> Self::D;
    /// Bitwise or.
    fn or_d(&self, a: &Self::D, b: &Self::D) -> Self::D;
    /// Signed quotient truncated toward zero; 0 for a zero divisor, `a` for `MIN / -1`.
    fn sdiv_d(&self, a: &Self::D, b: &Self::D) -> Self::D;
    /// Left shift by `s & 63`.
    fn shl_d(&self, a: &Self::D, s: &Self::W) -> Self::D;
    /// Logical right shift by `s & 63`.
    fn lshr_d(&self, a: &Self::D, s: &Self::W) -> Self::D;
    /// Arithmetic right shift by `s & 63`.
    fn ashr_d(&self, a: &Self::D, s: &Self::W) -> Self::D;
    /// Count of leading zero bits (64 for zero), as a 32-bit word.
    fn clz_d(&self, a: &Self::D) -> Self::W;
    /// Equality.
    fn eq_d(&self, a: &Self::D, b: &Self::D) -> Self::Bool;
    /// Unsigned `a < b`.
    fn ult_d(&self, a: &Self::D, b: &Self::D) -> Self::Bool;
    /// Signed `a < b`.
    fn slt_d(&self, a: &Self::D, b: &Self::D) -> Self::Bool;
    /// `if c { a } else { b }`.
    fn select_d(&self, c: &Self::Bool, a: &Self::D, b: &Self::D) -> Self::D;

    /// Zero extension.
    fn zext(&self, a: &Self::W) -> Self::D;
    /// Sign extension.
    fn sext(&self, a: &Self::W) -> Self::D;
    /// Low 32 bits.
    fn lo(&self, a: &Self::D) -> Self::W;

    /// Conjunction.
    fn all(&self, a: &Self::Bool, b: &Self::Bool) -> Self::Bool;
    /// Disjunction.
    fn any(&self, a: &Self::Bool, b: &Self::Bool) -> Self::Bool;
    /// Negation.
    fn not(&self, a: &Self::Bool) -> Self::Bool;
}

/// Derived operations, written once from the primitives above.
pub trait MachineExt: Machine {
    /// Unsigned `a <= b`.
    fn ule(&self, a: &Self::W, b: &Self::W) -> Self::Bool {
        self.not(&self.ult(b, a))
    }
    /// Signed `a <= b`.
    fn sle(&self, a: &Self::W, b: &Self::W) -> Self::Bool {
        self.not(&self.slt(b, a))
    }
    /// Signed `a <= b`.
    fn sle_d(&self, a: &Self::D, b: &Self::D) -> Self::Bool {
        self.not(&self.slt_d(b, a))
    }
    /// Unsigned `a <= b`.
    fn ule_d(&self, a: &Self::D, b: &Self::D) -> Self::Bool {
        self.not(&self.ult_d(b, a))
    }
    /// Wrapping negation.
    fn neg(&self, a: &Self::W) -> Self::W {
        self.sub(&self.w(0), a)
    }
    /// Wrapping negation.
    fn neg_d(&self, a: &Self::D) -> Self::D {
        self.sub_d(&self.d(0), a)
    }
    /// `a < 0` as a signed word.
    fn is_negative(&self, a: &Self::W) -> Self::Bool {
        self.slt(a, &self.w(0))
    }
    /// `a < 0` as a signed word.
    fn is_negative_d(&self, a: &Self::D) -> Self::Bool {
        self.slt_d(a, &self.d(0))
    }
    /// `|a|` of a signed word as an unsigned word (`i32::unsigned_abs`).
    fn unsigned_abs(&self, a: &Self::W) -> Self::W {
        self.select(&self.is_negative(a), &self.neg(a), a)
    }
    /// `|a|` of a signed word as an unsigned word (`i64::unsigned_abs`).
    fn unsigned_abs_d(&self, a: &Self::D) -> Self::D {
        self.select_d(&self.is_negative_d(a), &self.neg_d(a), a)
    }
    /// Left shift by a constant.
    fn shl_k(&self, a: &Self::W, s: u32) -> Self::W {
        self.shl(a, &self.w(s))
    }
    /// Logical right shift by a constant.
    fn lshr_k(&self, a: &Self::W, s: u32) -> Self::W {
        self.lshr(a, &self.w(s))
    }
    /// Left shift by a constant.
    fn shl_dk(&self, a: &Self::D, s: u32) -> Self::D {
        self.shl_d(a, &self.w(s))
    }
    /// Arithmetic right shift by a constant.
    fn ashr_dk(&self, a: &Self::D, s: u32) -> Self::D {
        self.ashr_d(a, &self.w(s))
    }
    /// Logical right shift by a constant.
    fn lshr_dk(&self, a: &Self::D, s: u32) -> Self::D {
        self.lshr_d(a, &self.w(s))
    }
    /// `if c { a } else { b }` for truth values.
    fn select_bool(&self, c: &Self::Bool, a: &Self::Bool, b: &Self::Bool) -> Self::Bool {
        self.any(&self.all(c, a), &self.all(&self.not(c), b))
    }
    /// Exclusive or of truth values.
    fn differ(&self, a: &Self::Bool, b: &Self::Bool) -> Self::Bool {
        self.any(&self.all(a, &self.not(b)), &self.all(&self.not(a), b))
    }
    /// `a` saturated to a signed 32-bit word.
    fn saturate_to_w(&self, a: &Self::D) -> Self::W {
        let max = self.d(i32::MAX as u64);
        let min = self.d(i64::from(i32::MIN) as u64);
        let high = self.slt_d(&max, a);
        let low = self.slt_d(a, &min);
        let sat = self.select(&high, &self.w(i32::MAX as u32), &self.w(i32::MIN as u32));
        self.select(&self.any(&high, &low), &sat, &self.lo(a))
    }
    /// Whether `a` fits a signed 32-bit word.
    fn fits_w(&self, a: &Self::D) -> Self::Bool {
        self.eq_d(&self.sext(&self.lo(a)), a)
    }
}

impl<M: Machine + ?Sized> MachineExt for M {}

/// The machine the kernel runs on: Rust's own integers. Zero-sized; every method inlines
/// to the one instruction (or runtime routine) it names.
#[derive(Clone, Copy, Debug, Default)]
pub struct Native;

impl Machine for Native {
    type Bool = bool;
    type W = u32;
    type D = u64;

    #[inline(always)]
    fn w(&self, v: u32) -> u32 {
        v
    }
    #[inline(always)]
    fn d(&self, v: u64) -> u64 {
        v
    }
    #[inline(always)]
    fn b(&self, v: bool) -> bool {
        v
    }
    #[inline(always)]
    fn add(&self, a: &u32, b: &u32) -> u32 {
        a.wrapping_add(*b)
    }
    #[inline(always)]
    fn sub(&self, a: &u32, b: &u32) -> u32 {
        a.wrapping_sub(*b)
    }
    #[inline(always)]
    fn mul(&self, a: &u32, b: &u32) -> u32 {
        a.wrapping_mul(*b)
    }
    #[inline(always)]
    fn udiv(&self, a: &u32, b: &u32) -> u32 {
        a.checked_div(*b).unwrap_or(0)
    }
    #[inline(always)]
    fn urem(&self, a: &u32, b: &u32) -> u32 {
        a.checked_rem(*b).unwrap_or(0)
    }
    #[inline(always)]
    fn and(&self, a: &u32, b: &u32) -> u32 {
        a & b
    }
    #[inline(always)]
    fn or(&self, a: &u32, b: &u32) -> u32 {
        a | b
    }
    #[inline(always)]
    fn shl(&self, a: &u32, s: &u32) -> u32 {
        a.wrapping_shl(*s)
    }
    #[inline(always)]
    fn lshr(&self, a: &u32, s: &u32) -> u32 {
        a.wrapping_shr(*s)
    }
    #[inline(always)]
    fn ashr(&self, a: &u32, s: &u32) -> u32 {
        (*a as i32).wrapping_shr(*s) as u32
    }
    #[inline(always)]
    fn clz(&self, a: &u32) -> u32 {
        a.leading_zeros()
    }
    #[inline(always)]
    fn eq(&self, a: &u32, b: &u32) -> bool {
        a == b
    }
    #[inline(always)]
    fn ult(&self, a: &u32, b: &u32) -> bool {
        a < b
    }
    #[inline(always)]
    fn slt(&self, a: &u32, b: &u32) -> bool {
        (*a as i32) < (*b as i32)
    }
    #[inline(always)]
    fn select(&self, c: &bool, a: &u32, b: &u32) -> u32 {
        if *c {
            *a
        } else {
            *b
        }
    }
    #[inline(always)]
    fn select_lazy(&self, c: &bool, a: impl FnOnce() -> u32, b: impl FnOnce() -> u32) -> u32 {
        if *c {
            a()
        } else {
            b()
        }
    }
    #[inline(always)]
    fn add_d(&self, a: &u64, b: &u64) -> u64 {
        a.wrapping_add(*b)
    }
    #[inline(always)]
    fn sub_d(&self, a: &u64, b: &u64) -> u64 {
        a.wrapping_sub(*b)
    }
    #[inline(always)]
    fn mul_d(&self, a: &u64, b: &u64) -> u64 {
        a.wrapping_mul(*b)
    }
    #[inline(always)]
    fn or_d(&self, a: &u64, b: &u64) -> u64 {
        a | b
    }
    #[inline(always)]
    fn sdiv_d(&self, a: &u64, b: &u64) -> u64 {
        let (a, b) = (*a as i64, *b as i64);
        // `checked_div` is `None` for a zero divisor and for `MIN / -1`, whose wrapped
        // quotient is `MIN` itself
        a.checked_div(b).unwrap_or(if b == 0 { 0 } else { a }) as u64
    }
    #[inline(always)]
    fn shl_d(&self, a: &u64, s: &u32) -> u64 {
        a.wrapping_shl(*s)
    }
    #[inline(always)]
    fn lshr_d(&self, a: &u64, s: &u32) -> u64 {
        a.wrapping_shr(*s)
    }
    #[inline(always)]
    fn ashr_d(&self, a: &u64, s: &u32) -> u64 {
        (*a as i64).wrapping_shr(*s) as u64
    }
    #[inline(always)]
    fn clz_d(&self, a: &u64) -> u32 {
        a.leading_zeros()
    }
    #[inline(always)]
    fn eq_d(&self, a: &u64, b: &u64) -> bool {
        a == b
    }
    #[inline(always)]
    fn ult_d(&self, a: &u64, b: &u64) -> bool {
        a < b
    }
    #[inline(always)]
    fn slt_d(&self, a: &u64, b: &u64) -> bool {
        (*a as i64) < (*b as i64)
    }
    #[inline(always)]
    fn select_d(&self, c: &bool, a: &u64, b: &u64) -> u64 {
        if *c {
            *a
        } else {
            *b
        }
    }
    #[inline(always)]
    fn zext(&self, a: &u32) -> u64 {
        u64::from(*a)
    }
    #[inline(always)]
    fn sext(&self, a: &u32) -> u64 {
        i64::from(*a as i32) as u64
    }
    #[inline(always)]
    fn lo(&self, a: &u64) -> u32 {
        *a as u32
    }
    #[inline(always)]
    fn all(&self, a: &bool, b: &bool) -> bool {
        *a && *b
    }
    #[inline(always)]
    fn any(&self, a: &bool, b: &bool) -> bool {
        *a || *b
    }
    #[inline(always)]
    fn not(&self, a: &bool) -> bool {
        !*a
    }
}
