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
        })
    }

    /// Takes the command of the newest sample ([`crate::craft::Craft::command`]) and returns
    /// the command acting over the interval that starts at it.
    pub fn push(&mut self, command: [S; COMMAND_LEN]) -> [S; COMMAND_LEN] {
        self.head = self.head.checked_sub(1).unwrap_or(RING - 1);
        if let Some(r) = self.ring.get_mut(self.head) {
            *r = command;
        }
        // `i` samples back: index head + i modulo RING (both below RING, no overflow).
        let at = |i: usize| {
            let k = self.head.saturating_add(i);
            let k = if k >= RING { k.saturating_sub(RING) } else { k };
            self.ring.get(k)
        };
        let zero = [S::ZERO; COMMAND_LEN];
        let late = at(self.whole).unwrap_or(&zero);
        if !S::ZERO.lt(self.fraction) {
            // A whole number of periods: the early command never acts.
            return *late;
        }
        let early = at(self.whole.saturating_add(1)).unwrap_or(&zero);
        core::array::from_fn(|c| {
            let (l, e) = (
                late.get(c).copied().unwrap_or(S::ZERO),
                early.get(c).copied().unwrap_or(S::ZERO),
            );
            l.plus(self.fraction.times(e.minus(l)))
        })
    }
}
