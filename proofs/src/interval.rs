//! A sound interval scalar for the range analysis.
//!
//! `Interval` encloses every value a kernel variable can take. Each operation rounds its
//! f64 endpoints outward (one ulp each way, so the IEEE round-to-nearest error is covered)
//! and then widens by the *target format's* own rounding slack ([`set_slack`]): an absolute
//! step for a fixed-point format (its resolution) and a relative step for f32. So an interval
//! run encloses the real-number result *and* the f32 or fixed result of the same code, as
//! long as that format does not overflow, which is exactly what the analysis checks.
//!
//! A thread-local [`Watch`] records, over every operation, the largest magnitude produced
//! (intermediates included: a product can overflow even when the state it feeds fits),
//! divisions by an interval containing zero, square roots of possibly negative intervals
//! and comparisons the intervals could not decide. Undecided comparisons and conversions
//! to integers are *enumerated*: they draw from the [`crate::engine`], so running the
//! analysis under [`crate::engine::Mode::Exhaustive`] follows every branch.

use core::cell::RefCell;
use core::ops::{Add, Div, Mul, Neg, Sub};

/// A closed interval `[lo, hi]` of reals (`lo <= hi`, both finite unless the watch reports
/// a blow-up).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Interval {
    lo: f64,
    hi: f64,
}

/// What the watch saw since the last [`reset_watch`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Watch {
    /// Largest |endpoint| of any operation's result.
    pub max_abs: f64,
    /// Divisions whose divisor interval contained zero (result unbounded).
    pub div_by_zero: u64,
    /// Square roots of intervals reaching below zero.
    pub sqrt_negative: u64,
    /// Comparisons left to the engine because the intervals overlapped.
    pub undecided: u64,
    /// Operations executed.
    pub ops: u64,
}

/// Rounding slack of the format the interval stands in for.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Slack {
    /// Absolute widening per operation (fixed point: one step of the format, 2^-frac).
    pub abs: f64,
    /// Relative widening per operation (f32: 2^-24).
    pub rel: f64,
}

/// The format an interval run stands in for: its largest magnitude and rounding slack.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Format {
    pub name: &'static str,
    /// Largest representable magnitude (fixed: 2^(int bits - 1)).
    pub max: f64,
    pub slack: Slack,
}

impl Format {
    /// A signed fixed format with `int` integer bits (sign included) and `frac` fractional bits.
    pub const fn fixed(name: &'static str, int: i32, frac: i32) -> Format {
        Format {
            name,
            max: pow2(int - 1),
            slack: Slack {
                abs: pow2(-frac),
                rel: 0.0,
            },
        }
    }
    /// IEEE binary32 (round to nearest: relative error 2^-24; subnormals: 2^-149 absolute).
    pub const F32: Format = Format {
        name: "f32",
        max: f32::MAX as f64,
        slack: Slack {
            abs: 1.4e-45,
            rel: 5.960464477539063e-8,
        },
    };
    /// The kernel's fixed scalar `Q8_24` (I8F24).
    pub const Q8_24: Format = Format::fixed("Q8.24", 8, 24);
    /// `Q16_16` (I16F16).
    pub const Q16_16: Format = Format::fixed("Q16.16", 16, 16);
    /// A deliberately too narrow 16-bit format (I8F8): the checks must flag it.
    pub const Q8_8: Format = Format::fixed("Q8.8", 8, 8);
    /// A deliberately too narrow 32-bit format (I4F28).
    pub const Q4_28: Format = Format::fixed("Q4.28", 4, 28);
    /// Exact real arithmetic (no format slack, no limit): for enclosing the f64 reference.
    pub const REAL: Format = Format {
        name: "real",
        max: f64::MAX,
        slack: Slack { abs: 0.0, rel: 0.0 },
    };
}

const fn pow2(e: i32) -> f64 {
    let mut v = 1.0;
    let mut i = 0;
    while i < e.unsigned_abs() {
        v = if e > 0 { v * 2.0 } else { v * 0.5 };
        i += 1;
    }
    v
}

std::thread_local! {
    static FORMAT: RefCell<Format> = const { RefCell::new(Format::REAL) };
    static WATCH: RefCell<Watch> = const { RefCell::new(Watch { max_abs: 0.0, div_by_zero: 0, sqrt_negative: 0, undecided: 0, ops: 0 }) };
    static SLACK: RefCell<Slack> = const { RefCell::new(Slack { abs: 0.0, rel: 0.0 }) };
}

/// Clear the watch; returns what it held.
pub fn reset_watch() -> Watch {
    WATCH.with(|w| core::mem::take(&mut *w.borrow_mut()))
}
/// What the watch holds now.
pub fn watch() -> Watch {
    WATCH.with(|w| *w.borrow())
}
/// Set the per-operation rounding slack (thread-local).
pub fn set_slack(s: Slack) {
    SLACK.with(|x| *x.borrow_mut() = s);
}
/// Make interval runs on this thread stand for `f`: its slack on every operation, its limit
/// for [`massid_kernel::Scalar::is_valid`], `headroom` and `checked_div`.
pub fn set_format(f: Format) {
    set_slack(f.slack);
    FORMAT.with(|x| *x.borrow_mut() = f);
}
/// The format interval runs currently stand for.
pub fn format() -> Format {
    FORMAT.with(|x| *x.borrow())
}

fn next_up(x: f64) -> f64 {
    if x.is_nan() || x == f64::INFINITY {
        return x;
    }
    if x == 0.0 {
        return f64::from_bits(1);
    }
    let b = x.to_bits();
    f64::from_bits(if x > 0.0 { b + 1 } else { b - 1 })
}
fn next_down(x: f64) -> f64 {
    -next_up(-x)
}

impl Interval {
    /// The interval `[lo, hi]`; `None` when `lo > hi` or either is NaN.
    pub fn new(lo: f64, hi: f64) -> Option<Self> {
        (lo <= hi).then_some(Interval { lo, hi })
    }
    /// The interval of a range tuple, e.g. from [`crate::envelope`].
    pub fn of(r: (f64, f64)) -> Self {
        Interval::new(r.0, r.1).expect("envelope range with lo > hi")
    }
    /// The single point `x`.
    pub fn point(x: f64) -> Self {
        Interval { lo: x, hi: x }
    }
    pub fn lo(self) -> f64 {
        self.lo
    }
    pub fn hi(self) -> f64 {
        self.hi
    }
    /// Largest magnitude in the interval.
    pub fn mag(self) -> f64 {
        self.lo.abs().max(self.hi.abs())
    }
    pub fn width(self) -> f64 {
        self.hi - self.lo
    }
    pub fn contains(self, x: f64) -> bool {
        self.lo <= x && x <= self.hi
    }
    /// Smallest interval holding both (for joining states across iterations).
    pub fn hull(self, o: Self) -> Self {
        Interval {
            lo: self.lo.min(o.lo),
            hi: self.hi.max(o.hi),
        }
    }
    /// True when `self` lies inside `o`.
    pub fn within(self, o: Self) -> bool {
        o.lo <= self.lo && self.hi <= o.hi
    }

    /// Round outward, apply the format slack, and record the result in the watch.
    fn finish(lo: f64, hi: f64) -> Self {
        let s = SLACK.with(|s| *s.borrow());
        let (mut lo, mut hi) = (next_down(lo), next_up(hi));
        if s.abs > 0.0 || s.rel > 0.0 {
            lo = next_down(lo - s.abs - lo.abs() * s.rel);
            hi = next_up(hi + s.abs + hi.abs() * s.rel);
        }
        if lo.is_nan() || hi.is_nan() {
            lo = f64::NEG_INFINITY;
            hi = f64::INFINITY;
        }
        WATCH.with(|w| {
            let mut w = w.borrow_mut();
            w.ops += 1;
            w.max_abs = w.max_abs.max(lo.abs()).max(hi.abs());
        });
        Interval { lo, hi }
    }

    /// Square root; an interval reaching below zero is clipped at zero and counted.
    pub fn sqrt(self) -> Self {
        if self.lo < 0.0 {
            WATCH.with(|w| w.borrow_mut().sqrt_negative += 1);
        }
        Interval::finish(self.lo.max(0.0).sqrt(), self.hi.max(0.0).sqrt())
    }
    pub fn abs(self) -> Self {
        if self.lo >= 0.0 {
            self
        } else if self.hi <= 0.0 {
            -self
        } else {
            Interval {
                lo: 0.0,
                hi: self.mag(),
            }
        }
    }
    pub fn min(self, o: Self) -> Self {
        Interval {
            lo: self.lo.min(o.lo),
            hi: self.hi.min(o.hi),
        }
    }
    pub fn max(self, o: Self) -> Self {
        Interval {
            lo: self.lo.max(o.lo),
            hi: self.hi.max(o.hi),
        }
    }

    /// Decide `self < o`; when the intervals overlap the answer is left to the engine (both
    /// outcomes are explored under exhaustive mode) and counted as undecided.
    pub fn lt(self, o: Self) -> bool {
        if self.hi < o.lo {
            true
        } else if self.lo >= o.hi {
            false
        } else {
            undecided()
        }
    }
    /// Decide `self <= o` (see [`Interval::lt`]).
    pub fn le(self, o: Self) -> bool {
        if self.hi <= o.lo {
            true
        } else if self.lo > o.hi {
            false
        } else {
            undecided()
        }
    }
    /// Decide `self == 0`-style equality tests (see [`Interval::lt`]).
    pub fn eq_val(self, o: Self) -> bool {
        if self.lo == self.hi && o.lo == o.hi && self.lo == o.lo {
            true
        } else if self.hi < o.lo || o.hi < self.lo {
            false
        } else {
            undecided()
        }
    }
    /// The integer `floor(x)` for some `x` in the interval, enumerated by the engine when the
    /// interval spans several integers. `None` when not finite or beyond i64.
    pub fn floor_i64(self) -> Option<i64> {
        let (a, b) = (self.lo.floor(), self.hi.floor());
        if !(a.is_finite() && b.is_finite()) || a < i64::MIN as f64 || b > i64::MAX as f64 {
            return None;
        }
        if a == b {
            Some(a as i64)
        } else {
            WATCH.with(|w| w.borrow_mut().undecided += 1);
            // Inside the engine every integer in range is explored; outside, the kernel
            // contract's "not decided" answer.
            crate::engine::active().then(|| crate::engine::any_in(a as i64, b as i64))
        }
    }
}

/// An undecided comparison: inside the engine both outcomes are explored; outside it the
/// kernel contract's conservative answer (`false`, "not certainly") is given.
fn undecided() -> bool {
    WATCH.with(|w| w.borrow_mut().undecided += 1);
    crate::engine::active() && crate::engine::any_bool()
}

impl Add for Interval {
    type Output = Interval;
    fn add(self, o: Self) -> Self {
        Interval::finish(self.lo + o.lo, self.hi + o.hi)
    }
}
impl Sub for Interval {
    type Output = Interval;
    fn sub(self, o: Self) -> Self {
        Interval::finish(self.lo - o.hi, self.hi - o.lo)
    }
}
impl Neg for Interval {
    type Output = Interval;
    fn neg(self) -> Self {
        Interval {
            lo: -self.hi,
            hi: -self.lo,
        }
    }
}
impl Mul for Interval {
    type Output = Interval;
    fn mul(self, o: Self) -> Self {
        let p = [
            self.lo * o.lo,
            self.lo * o.hi,
            self.hi * o.lo,
            self.hi * o.hi,
        ];
        // 0 * inf is NaN: such a product is unbounded anyway, `finish` maps it to entire.
        let lo = p.iter().cloned().fold(f64::INFINITY, f64::min);
        let hi = p.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        if p.iter().any(|x| x.is_nan()) {
            return Interval::finish(f64::NAN, f64::NAN);
        }
        Interval::finish(lo, hi)
    }
}
impl Div for Interval {
    type Output = Interval;
    fn div(self, o: Self) -> Self {
        if o.lo <= 0.0 && 0.0 <= o.hi {
            WATCH.with(|w| w.borrow_mut().div_by_zero += 1);
            return Interval::finish(f64::NAN, f64::NAN);
        }
        let p = [
            self.lo / o.lo,
            self.lo / o.hi,
            self.hi / o.lo,
            self.hi / o.hi,
        ];
        let lo = p.iter().cloned().fold(f64::INFINITY, f64::min);
        let hi = p.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        Interval::finish(lo, hi)
    }
}

/// The kernel's number trait, with the meaning the range analysis needs: arithmetic
/// encloses the format's own results (slack), comparisons are decided when the intervals
/// allow and otherwise both outcomes are explored through the engine (sound path
/// enumeration, not the "false when unsure" shortcut, which would drop paths).
impl massid_kernel::Scalar for Interval {
    const ZERO: Self = Interval { lo: 0.0, hi: 0.0 };
    const ONE: Self = Interval { lo: 1.0, hi: 1.0 };
    fn from_int_pow2(m: i32, e: i32) -> Self {
        let v = m as f64 * pow2_f64(e);
        Interval::finish(v, v)
    }
    fn from_f32(v: f32) -> Self {
        let v = if v.is_nan() { 0.0 } else { v as f64 };
        Interval::finish(v, v)
    }
    fn to_f32(self) -> f32 {
        (0.5 * self.lo + 0.5 * self.hi) as f32
    }
    fn checked_div(self, rhs: Self) -> Option<Self> {
        if rhs.lo <= 0.0 && 0.0 <= rhs.hi {
            // The concrete divisor may be zero: the kernel's None branch is one possible
            // path; the quotient for a nonzero divisor is unbounded, so only that branch is
            // explored, and the watch records it.
            WATCH.with(|w| w.borrow_mut().div_by_zero += 1);
            return None;
        }
        Some(self / rhs)
    }
    fn abs(self) -> Self {
        Interval::abs(self)
    }
    fn lt(self, rhs: Self) -> bool {
        Interval::lt(self, rhs)
    }
    fn mul_pow2(self, e: i32) -> Self {
        let f = pow2_f64(e);
        Interval::finish(self.lo * f, self.hi * f)
    }
    fn is_valid(self) -> bool {
        let max = format().max;
        if self.hi < max && self.lo > -max {
            true
        } else if self.lo >= max || self.hi <= -max {
            false
        } else {
            undecided()
        }
    }
    fn floor_times(self, k: u32) -> Option<i64> {
        // The impls compute this in a wider integer type (not in the format), so the product
        // is not a format value: it is formed here without the watch or the format slack.
        let k = k as f64;
        let (a, b) = (self.lo * k, self.hi * k);
        Interval {
            lo: next_down(a.min(b)),
            hi: next_up(a.max(b)),
        }
        .floor_i64()
    }
    fn headroom() -> Self {
        let f = format();
        let v = if f.max >= 1e30 { 1e30 } else { f.max / 4.0 };
        Interval::point(v)
    }
}

fn pow2_f64(e: i32) -> f64 {
    let e = e.clamp(-1074, 1023);
    if e >= -1022 {
        f64::from_bits(((e + 1023) as u64) << 52)
    } else {
        f64::from_bits(1u64 << (e + 1074))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    fn random_interval(rng: &mut impl Rng) -> Interval {
        let a: f64 = rng.gen_range(-100.0..100.0);
        let b: f64 = rng.gen_range(-100.0..100.0);
        Interval::new(a.min(b), a.max(b)).unwrap()
    }
    fn sample(rng: &mut impl Rng, i: Interval) -> f64 {
        match rng.gen_range(0..4) {
            0 => i.lo(),
            1 => i.hi(),
            _ => rng.gen_range(i.lo()..=i.hi()),
        }
    }

    /// The containment property: for x in X and y in Y, x op y is in X op Y.
    #[test]
    fn every_operation_encloses_its_point_results() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(42);
        for _ in 0..20_000 {
            let (x, y) = (random_interval(&mut rng), random_interval(&mut rng));
            let (a, b) = (sample(&mut rng, x), sample(&mut rng, y));
            assert!((x + y).contains(a + b));
            assert!((x - y).contains(a - b));
            assert!((x * y).contains(a * b));
            assert!((-x).contains(-a));
            assert!(x.abs().contains(a.abs()));
            if !(y.lo() <= 0.0 && 0.0 <= y.hi()) {
                assert!((x / y).contains(a / b), "{x:?}/{y:?} {a}/{b}");
            }
            if x.lo() >= 0.0 {
                assert!(x.sqrt().contains(a.sqrt()));
            }
        }
    }

    #[test]
    fn rounding_is_outward_even_where_f64_rounds() {
        // 0.1 + 0.2 rounds up in f64; the exact sum 0.3000000000000000166.. must be inside.
        let s = Interval::point(0.1) + Interval::point(0.2);
        assert!(s.lo() < 0.1 + 0.2 && 0.1 + 0.2 < s.hi());
        assert!(s.width() > 0.0);
    }

    #[test]
    fn slack_encloses_fixed_point_rounding() {
        use fixed::types::I16F16;
        set_slack(Slack {
            abs: 1.0 / 65536.0,
            rel: 0.0,
        });
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        for _ in 0..20_000 {
            let a = I16F16::from_bits(rng.gen_range(-(1 << 22)..(1 << 22)));
            let b = I16F16::from_bits(rng.gen_range(-(1 << 22)..(1 << 22)));
            let (ia, ib) = (Interval::point(a.to_num()), Interval::point(b.to_num()));
            assert!((ia * ib).contains((a * b).to_num()));
            if b != 0 {
                if let Some(q) = a.checked_div(b) {
                    assert!((ia / ib).contains(q.to_num()));
                }
            }
        }
        set_slack(Slack::default());
    }

    #[test]
    fn watch_sees_intermediates_and_division_by_zero() {
        reset_watch();
        let big = Interval::point(300.0) * Interval::point(300.0);
        let _ = big - big;
        let _ = Interval::point(1.0) / Interval::new(-1.0, 1.0).unwrap();
        let w = reset_watch();
        assert!(w.max_abs >= 90_000.0);
        assert_eq!(w.div_by_zero, 1);
    }

    #[test]
    fn decided_comparisons_do_not_consult_the_engine() {
        let (a, b) = (
            Interval::new(0.0, 1.0).unwrap(),
            Interval::new(2.0, 3.0).unwrap(),
        );
        assert!(a.lt(b));
        assert!(!b.lt(a));
        assert!(a.le(b));
        assert!(!a.eq_val(b));
        assert_eq!(Interval::new(2.2, 2.9).unwrap().floor_i64(), Some(2));
    }
}
