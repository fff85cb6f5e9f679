//! The machine as integer intervals (signed reading of every word): a sound bound on every
//! value the code can produce, and a record of every operation that could wrap. For
//! compound routines whose overflow freedom would take the solver minutes (products of
//! symbolic words), this proves it in microseconds on the same source.
//!
//! Only the operations the bounded routines use are precise; any other operation returns the
//! whole range of its width and is recorded as imprecise, so a proof never silently rests
//! on it.

use massid_kernel::int::Machine;
use std::cell::RefCell;

/// A closed interval of exact integers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Span {
    /// Least value.
    pub lo: i128,
    /// Greatest value.
    pub hi: i128,
}

impl Span {
    /// `[lo, hi]`.
    pub fn new(lo: i128, hi: i128) -> Self {
        Span { lo, hi }
    }
    fn hull(self, o: Span) -> Span {
        Span::new(self.lo.min(o.lo), self.hi.max(o.hi))
    }
    /// Largest magnitude.
    pub fn magnitude(self) -> i128 {
        self.lo.abs().max(self.hi.abs())
    }
}

/// A truth value that may be undecided.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Tri {
    /// Holds for every value.
    True,
    /// Fails for every value.
    False,
    /// Depends on the value.
    Either,
}

/// The interval machine. `events` records each operation whose exact result may leave its
/// word (a possible wrap) and each imprecise operation.
#[derive(Default)]
pub struct IntervalMachine {
    /// Possible wraps and imprecise operations, in order.
    pub events: RefCell<Vec<String>>,
}

const W_RANGE: Span = Span {
    lo: i32::MIN as i128,
    hi: i32::MAX as i128,
};
const D_RANGE: Span = Span {
    lo: i64::MIN as i128,
    hi: i64::MAX as i128,
};

impl IntervalMachine {
    fn within(&self, what: &str, s: Span, range: Span) -> Span {
        if s.lo < range.lo || s.hi > range.hi {
            self.events
                .borrow_mut()
                .push(format!("{what} may wrap: [{}, {}]", s.lo, s.hi));
            range
        } else {
            s
        }
    }
    fn imprecise(&self, what: &str, range: Span) -> Span {
        self.events.borrow_mut().push(format!("{what}: imprecise"));
        range
    }
    fn product(a: Span, b: Span) -> Span {
        let c = [a.lo * b.lo, a.lo * b.hi, a.hi * b.lo, a.hi * b.hi];
        Span::new(
            c.iter().copied().min().unwrap_or(0),
            c.iter().copied().max().unwrap_or(0),
        )
    }
    fn compare(a: Span, b: Span) -> Tri {
        if a.hi < b.lo {
            Tri::True
        } else if a.lo >= b.hi {
            Tri::False
        } else {
            Tri::Either
        }
    }
    fn equal(a: Span, b: Span) -> Tri {
        if a.lo == a.hi && b.lo == b.hi && a.lo == b.lo {
            Tri::True
        } else if a.hi < b.lo || b.hi < a.lo {
            Tri::False
        } else {
            Tri::Either
        }
    }
    fn choose(c: Tri, a: Span, b: Span) -> Span {
        match c {
            Tri::True => a,
            Tri::False => b,
            Tri::Either => a.hull(b),
        }
    }
    fn shift_amount(s: Span) -> Option<u32> {
        (s.lo == s.hi && (0..64).contains(&s.lo)).then_some(s.lo as u32)
    }
}

impl Machine for IntervalMachine {
    type Bool = Tri;
    type W = Span;
    type D = Span;

    fn w(&self, v: u32) -> Span {
        let v = i128::from(v as i32);
        Span::new(v, v)
    }
    fn d(&self, v: u64) -> Span {
        let v = i128::from(v as i64);
        Span::new(v, v)
    }
    fn b(&self, v: bool) -> Tri {
        if v {
            Tri::True
        } else {
            Tri::False
        }
    }
    fn add(&self, a: &Span, b: &Span) -> Span {
        self.within("add", Span::new(a.lo + b.lo, a.hi + b.hi), W_RANGE)
    }
    fn sub(&self, a: &Span, b: &Span) -> Span {
        self.within("sub", Span::new(a.lo - b.hi, a.hi - b.lo), W_RANGE)
    }
    fn mul(&self, a: &Span, b: &Span) -> Span {
        self.within("mul", Self::product(*a, *b), W_RANGE)
    }
    fn udiv(&self, _: &Span, _: &Span) -> Span {
        self.imprecise("udiv", W_RANGE)
    }
    fn urem(&self, _: &Span, _: &Span) -> Span {
        self.imprecise("urem", W_RANGE)
    }
    fn and(&self, _: &Span, _: &Span) -> Span {
        self.imprecise("and", W_RANGE)
    }
    fn or(&self, _: &Span, _: &Span) -> Span {
        self.imprecise("or", W_RANGE)
    }
    fn shl(&self, a: &Span, s: &Span) -> Span {
        match Self::shift_amount(*s).filter(|k| *k < 32) {
            Some(k) => self.within("shl", Span::new(a.lo << k, a.hi << k), W_RANGE),
            None => self.imprecise("shl by a varying amount", W_RANGE),
        }
    }
    fn lshr(&self, _: &Span, _: &Span) -> Span {
        self.imprecise("lshr", W_RANGE)
    }
    fn ashr(&self, a: &Span, s: &Span) -> Span {
        match Self::shift_amount(*s).filter(|k| *k < 32) {
            Some(k) => Span::new(a.lo >> k, a.hi >> k),
            None => self.imprecise("ashr by a varying amount", W_RANGE),
        }
    }
    fn clz(&self, _: &Span) -> Span {
        self.imprecise("clz", Span::new(0, 32))
    }
    fn eq(&self, a: &Span, b: &Span) -> Tri {
        Self::equal(*a, *b)
    }
    fn ult(&self, _: &Span, _: &Span) -> Tri {
        self.imprecise("ult", W_RANGE);
        Tri::Either
    }
    fn slt(&self, a: &Span, b: &Span) -> Tri {
        Self::compare(*a, *b)
    }
    fn select(&self, c: &Tri, a: &Span, b: &Span) -> Span {
        Self::choose(*c, *a, *b)
    }
    fn add_d(&self, a: &Span, b: &Span) -> Span {
        self.within("add_d", Span::new(a.lo + b.lo, a.hi + b.hi), D_RANGE)
    }
    fn sub_d(&self, a: &Span, b: &Span) -> Span {
        self.within("sub_d", Span::new(a.lo - b.hi, a.hi - b.lo), D_RANGE)
    }
    fn mul_d(&self, a: &Span, b: &Span) -> Span {
        self.within("mul_d", Self::product(*a, *b), D_RANGE)
    }
    fn or_d(&self, _: &Span, _: &Span) -> Span {
        self.imprecise("or_d", D_RANGE)
    }
    fn sdiv_d(&self, _: &Span, _: &Span) -> Span {
        self.imprecise("sdiv_d", D_RANGE)
    }
    fn shl_d(&self, a: &Span, s: &Span) -> Span {
        match Self::shift_amount(*s) {
            Some(k) => self.within("shl_d", Span::new(a.lo << k, a.hi << k), D_RANGE),
            None => self.imprecise("shl_d by a varying amount", D_RANGE),
        }
    }
    fn lshr_d(&self, _: &Span, _: &Span) -> Span {
        self.imprecise("lshr_d", D_RANGE)
    }
    fn ashr_d(&self, a: &Span, s: &Span) -> Span {
        match Self::shift_amount(*s) {
            Some(k) => Span::new(a.lo >> k, a.hi >> k),
            None => self.imprecise("ashr_d by a varying amount", D_RANGE),
        }
    }
    fn clz_d(&self, _: &Span) -> Span {
        self.imprecise("clz_d", Span::new(0, 64))
    }
    fn eq_d(&self, a: &Span, b: &Span) -> Tri {
        Self::equal(*a, *b)
    }
    fn ult_d(&self, _: &Span, _: &Span) -> Tri {
        self.imprecise("ult_d", D_RANGE);
        Tri::Either
    }
    fn slt_d(&self, a: &Span, b: &Span) -> Tri {
        Self::compare(*a, *b)
    }
    fn select_d(&self, c: &Tri, a: &Span, b: &Span) -> Span {
        Self::choose(*c, *a, *b)
    }
    fn zext(&self, a: &Span) -> Span {
        if a.lo >= 0 {
            *a
        } else {
            self.imprecise(
                "zext of a possibly negative word",
                Span::new(0, u32::MAX.into()),
            )
        }
    }
    fn sext(&self, a: &Span) -> Span {
        *a
    }
    fn lo(&self, a: &Span) -> Span {
        // the low word equals the value exactly when it fits; otherwise it wraps
        self.within("lo", *a, W_RANGE)
    }
    fn all(&self, a: &Tri, b: &Tri) -> Tri {
        match (a, b) {
            (Tri::False, _) | (_, Tri::False) => Tri::False,
            (Tri::True, Tri::True) => Tri::True,
            _ => Tri::Either,
        }
    }
    fn any(&self, a: &Tri, b: &Tri) -> Tri {
        match (a, b) {
            (Tri::True, _) | (_, Tri::True) => Tri::True,
            (Tri::False, Tri::False) => Tri::False,
            _ => Tri::Either,
        }
    }
    fn not(&self, a: &Tri) -> Tri {
        match a {
            Tri::True => Tri::False,
            Tri::False => Tri::True,
            Tri::Either => Tri::Either,
        }
    }
}
