//! A known command-to-thrust delay: the wrench commanded at sample `j` acts from `t_j + L` to
//! `t_(j+1) + L`. With `L = (m + f) T` (nominal period `T`), the interval after sample `k` is
//! covered by command `k - m - 1` for its first fraction `f` and by command `k - m` for the
//! rest; before the first command acts nothing fires. A fixed ring of the last commands, so a
//! delay costs memory in proportion to [`MAX_DELAY_SAMPLES`], never to the flight.
use crate::craft::COMMAND_LEN;
use crate::scalar::Scalar;

/// Longest delay in sample periods.
pub const MAX_DELAY_SAMPLES: usize = 62;
const RING: usize = MAX_DELAY_SAMPLES + 2;

/// The delay line.
#[derive(Clone, Copy, Debug)]
pub struct CommandDelay<S> {
    /// Last commands (zero before the flight's first); the newest at `head`, older ones at
    /// increasing indices modulo the length (a circular buffer: no copying per sample).
    ring: [[S; COMMAND_LEN]; RING],
    head: usize,
    whole: usize,
    fraction: S,
    /// With a fraction of a period: the interpolated commands acting over the newest
    /// interval and the one before, the newest at `acting_newest` (built in place, read by
    /// reference: no copy of a command per sample).
    acting: [[S; COMMAND_LEN]; 2],
    acting_newest: usize,
}

/// Why a delay is refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DelayError {
    /// Negative, not a number, or longer than [`MAX_DELAY_SAMPLES`] periods.
    OutOfRange,
}

impl<S: Scalar> CommandDelay<S> {
    /// A delay of `periods` sample periods (`latency / T`).
    pub fn new(periods: f32) -> Result<Self, DelayError> {
        if !(periods.is_finite() && (0.0..=MAX_DELAY_SAMPLES as f32).contains(&periods)) {
            return Err(DelayError::OutOfRange);
        }
        let whole = periods as usize; // floor: non-negative and at most 62
        let fraction = periods - whole as f32;
        Ok(CommandDelay {
            ring: [[S::ZERO; COMMAND_LEN]; RING],
            head: 0,
            whole,
            fraction: S::from_f32(fraction),
            acting: [[S::ZERO; COMMAND_LEN]; 2],
            acting_newest: 0,
        })
    }

    /// Takes the command of the newest sample ([`crate::craft::Craft::command`]), which
    /// `write` writes in place into the line; [`CommandDelay::acting`] then reads the
    /// commands acting over the intervals around it.
    pub fn push_with(&mut self, write: impl FnOnce(&mut [S; COMMAND_LEN])) {
        self.head = self.head.checked_sub(1).unwrap_or(RING - 1);
        if let Some(r) = self.ring.get_mut(self.head) {
            write(r);
        }
        if !S::ZERO.lt(self.fraction) {
            // A whole number of periods: the acting command is one of the line's.
            return;
        }
        self.acting_newest = 1usize.saturating_sub(self.acting_newest);
        let (late, early) = (
            self.ring.get(ring_index(self.head, self.whole)),
            self.ring
                .get(ring_index(self.head, self.whole.saturating_add(1))),
        );
        let (Some(late), Some(early), Some(out)) =
            (late, early, self.acting.get_mut(self.acting_newest))
        else {
            return;
        };
        for (o, (l, e)) in out.iter_mut().zip(late.iter().zip(early)) {
            *o = l.plus(self.fraction.times(e.minus(*l)));
        }
    }

    /// The command acting over the interval that starts at the newest sample (`back` 0) or
    /// at the one before it (`back` 1: the interval that ends at the newest sample).
    pub fn acting(&self, back: usize) -> &[S; COMMAND_LEN] {
        // The interpolated pair; with a whole delay never written, so all zero.
        let [first, second] = &self.acting;
        if S::ZERO.lt(self.fraction) {
            return if (back == 0) == (self.acting_newest == 0) {
                first
            } else {
                second
            };
        }
        self.ring
            .get(ring_index(
                self.head,
                self.whole.saturating_add(back.min(1)),
            ))
            .unwrap_or(first)
    }
}

/// The ring's index `i` samples back from `head` (`head + i` modulo the length; both below
/// it: no overflow).
fn ring_index(head: usize, i: usize) -> usize {
    let k = head.saturating_add(i);
    if k >= RING {
        k.saturating_sub(RING)
    } else {
        k
    }
}
