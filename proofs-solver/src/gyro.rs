//! The gyro low-pass never overflows: an inductive invariant of the kernel's own
//! `gyro_filter::section`, checked on the interval machine.
//!
//! For a range of sample periods, the coefficients `p`, `g` (Q30) lie in intervals (each
//! end's design, widened by one unit for rounding). If the state of a section is in
//! `[-B, B]` and its inputs are in their box, one step of the code keeps the state in
//! `[-B, B]` with no operation that could wrap: then, since the first sample sets the state
//! to the input itself (inside the box), every reachable state stays there, for any sequence
//! of counts 0..4095 of any length. The second section's input box is the first's invariant.

use crate::interval::{IntervalMachine, Span};
use massid_kernel::gyro_filter::{section, LowPassCoefs, COUNT_FRAC_BITS};

/// The largest filter input: a 12-bit count in Q12.
pub const MAX_INPUT: i128 = 4095 << COUNT_FRAC_BITS;

/// An invariant of both sections over a range of sample periods.
#[derive(Clone, Debug)]
pub struct FilterInvariant {
    /// Sample periods covered, seconds.
    pub dt_s: (f64, f64),
    /// Pole `p` (Q30) over the range.
    pub p: Span,
    /// Gain `g` (Q30) over the range.
    pub g: Span,
    /// First section's state bound (Q12 counts).
    pub first: i128,
    /// Second section's state bound: the filter's output (Q12 counts).
    pub second: i128,
}

fn coefficient_spans(dt_lo: f64, dt_hi: f64, fc_hz: f64) -> (Span, Span) {
    let (a, b) = (
        LowPassCoefs::design(fc_hz, dt_lo),
        LowPassCoefs::design(fc_hz, dt_hi),
    );
    let span = |x: i64, y: i64| Span::new(i128::from(x.min(y)) - 1, i128::from(x.max(y)) + 1);
    (span(a.p_q30, b.p_q30), span(a.g_q30, b.g_q30))
}

/// One step of a section from state box `[-bound, bound]` and input box `input`: the output
/// box, or the operations that may wrap.
fn step(p: Span, g: Span, bound: i128, input: Span) -> Result<Span, Vec<String>> {
    let m = IntervalMachine::default();
    let out = section(&m, &p, &g, &Span::new(-bound, bound), &input, &input);
    let events = m.events.into_inner();
    if events.is_empty() {
        Ok(out)
    } else {
        Err(events)
    }
}

/// The least bound (to 1 part in 2^10, from the contraction's fixed point upward) that one
/// step of the code keeps, or why none was found.
fn invariant(p: Span, g: Span, input: Span) -> Result<i128, String> {
    let one = 1i128 << 30;
    let p_max = p.magnitude();
    if p_max >= one {
        return Err(format!("pole {p_max} / 2^30 is not contracting"));
    }
    // fixed point of B = |p| B + 2 g |x| (+ rounding), then a margin
    let drive = 2 * g.magnitude() * input.magnitude() / one + 2;
    let mut bound = drive * one / (one - p_max) + 1;
    for _ in 0..64 {
        let out = step(p, g, bound, input).map_err(|e| e.join("; "))?;
        if out.magnitude() <= bound && input.magnitude() <= bound {
            return Ok(bound);
        }
        bound += bound / 1024 + 1;
    }
    Err("no invariant within 64 widenings".into())
}

/// The invariant over sample periods `[dt_lo, dt_hi]` at cut-off `fc_hz` for inputs
/// `0..=max_input` (Q12; [`MAX_INPUT`] for the kernel's 12-bit counts).
pub fn filter_invariant(
    dt_lo: f64,
    dt_hi: f64,
    fc_hz: f64,
    max_input: i128,
) -> Result<FilterInvariant, String> {
    let (p, g) = coefficient_spans(dt_lo, dt_hi, fc_hz);
    let first = invariant(p, g, Span::new(0, max_input))?;
    let second = invariant(p, g, Span::new(-first, first))?;
    Ok(FilterInvariant {
        dt_s: (dt_lo, dt_hi),
        p,
        g,
        first,
        second,
    })
}
