//! A known command-to-thrust delay: the wrench commanded at sample `j` acts from `t_j + L` to
//! `t_(j+1) + L`. With `L = (m + f) T` (nominal period `T`), the interval after sample `k` is
//! covered by command `k - m - 1` for its first fraction `f` and by command `k - m` for the
//! rest; before the first command acts nothing fires. A fixed ring of the last commands, so a
//! delay costs memory in proportion to [`MAX_DELAY_SAMPLES`], never to the flight.
use crate::craft::{Craft, COMMAND_LEN};
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
    /// The thruster word the newest command was made of ([`CommandDelay::push_word`]); None
    /// for a command written by [`CommandDelay::push_with`].
    word: Option<u16>,
    /// Per slot, which command it holds: equal numbers, the same command (a repeated word's
    /// copy); a new command takes the next number ([`CommandDelay::acting_key`]).
    generation: [u32; RING],
    next_generation: u32,
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
            word: None,
            generation: [0; RING],
            next_generation: 1,
        })
    }

    /// Takes the command of the newest sample ([`crate::craft::Craft::command`]), which
    /// `write` writes in place into the line; [`CommandDelay::acting`] then reads the
    /// commands acting over the intervals around it.
    pub fn push_with(&mut self, write: impl FnOnce(&mut [S; COMMAND_LEN])) {
        self.word = None;
        self.head = self.head.checked_sub(1).unwrap_or(RING - 1);
        if let Some(r) = self.ring.get_mut(self.head) {
            write(r);
        }
        self.number(self.head, None);
        self.interpolate();
    }

    /// Takes the newest sample's thruster word of `craft` (the same table on every call): its
    /// command ([`Craft::command`]) is made only when the word differs from the previous
    /// sample's, and otherwise copied (a
    /// thruster word holds for many samples: the command of 16 thrusters costs the integer
    /// float some 1,200 instructions, the copy under a hundred).
    pub fn push_word(&mut self, craft: &Craft<S>, word: u16) {
        let (old, new) = (self.head, self.head.checked_sub(1).unwrap_or(RING - 1));
        self.head = new;
        if self.word == Some(word) {
            // The two slots are next to each other (or the ring's ends): one split (checked:
            // no panic path in the tick).
            if let Some((low, high)) = self.ring.split_at_mut_checked(old.max(new)) {
                let (src, dst) = if new < old {
                    (high.first(), low.get_mut(new))
                } else {
                    (low.get(old), high.first_mut())
                };
                if let (Some(src), Some(dst)) = (src, dst) {
                    *dst = *src;
                }
            }
            self.number(new, Some(old));
        } else {
            if let Some(r) = self.ring.get_mut(new) {
                craft.command_into(word, r);
            }
            self.number(new, None);
        }
        self.word = Some(word);
        self.interpolate();
    }

    /// Numbers slot `slot`: as slot `same` (a copy of its command), or anew.
    fn number(&mut self, slot: usize, same: Option<usize>) {
        let n = match same.and_then(|k| self.generation.get(k)) {
            Some(n) => *n,
            None => {
                let n = self.next_generation;
                self.next_generation = n.wrapping_add(1);
                n
            }
        };
        if let Some(g) = self.generation.get_mut(slot) {
            *g = n;
        }
    }

    /// Which commands [`CommandDelay::acting`]`(back)` is made of: equal keys, the same
    /// acting command (numbers wrap after 2^32 new commands: a key is only to be compared
    /// with one taken a few samples before).
    pub fn acting_key(&self, back: usize) -> (u32, u32) {
        let late = ring_index(self.head, self.whole.saturating_add(back.min(1)));
        let early = if S::ZERO.lt(self.fraction) {
            ring_index(
                self.head,
                self.whole.saturating_add(back.min(1)).saturating_add(1),
            )
        } else {
            late
        };
        let at = |k: usize| self.generation.get(k).copied().unwrap_or(0);
        (at(late), at(early))
    }

    /// With a fractional delay, the acting command of the newest interval, interpolated in
    /// place.
    fn interpolate(&mut self) {
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

#[cfg(test)]
mod tests {
    #![allow(
        clippy::unwrap_used,
        clippy::indexing_slicing,
        clippy::arithmetic_side_effects
    )]
    use super::*;
    use crate::flight_id::test_flights::{five_thrusters, words};
    use crate::IntFloat;

    /// The word path (the command made once per run of a word, else copied) acts exactly as
    /// the command path, and both as the delay's definition: command `k - m` and `k - m - 1`
    /// weighted by the fraction. Planted (checked by hand, 2026-11-30): a word path that
    /// never remakes the command fails at the first change.
    fn the_word_path_acts_as_the_commands<S: Scalar + PartialEq + core::fmt::Debug>() {
        let craft = five_thrusters::<S>();
        for periods in [0.0f32, 1.0, 2.5, 61.75] {
            let mut by_word = CommandDelay::<S>::new(periods).unwrap();
            let mut by_command = CommandDelay::<S>::new(periods).unwrap();
            let mut history: [[S; COMMAND_LEN]; 256] = [[S::ZERO; COMMAND_LEN]; 256];
            let mut previous = ((0, 0), [S::ZERO; COMMAND_LEN]);
            let mut reused = 0;
            // 200 samples: three times round the ring.
            for (k, word) in words(200).enumerate() {
                by_word.push_word(&craft, word);
                by_command.push_with(|slot| craft.command_into(word, slot));
                history[k] = craft.command(word);
                let (whole, fraction) = (periods as usize, S::from_f32(periods.fract()));
                let back = |i: usize| {
                    k.checked_sub(i)
                        .map_or([S::ZERO; COMMAND_LEN], |j| history[j])
                };
                for b in 0..2 {
                    let (late, early) = (back(whole + b), back(whole + b + 1));
                    let want: [S; COMMAND_LEN] = core::array::from_fn(|c| {
                        if S::ZERO.lt(fraction) {
                            late[c].plus(fraction.times(early[c].minus(late[c])))
                        } else {
                            late[c]
                        }
                    });
                    let (w, c) = (by_word.acting(b), by_command.acting(b));
                    // Equal keys (a step reused by the identification), equal commands.
                    if b == 1 && by_word.acting_key(1) == previous.0 {
                        assert_eq!(w, &previous.1, "{periods} periods, sample {k}: key");
                    }
                    assert_eq!(w, c, "{periods} periods, sample {k}");
                    assert_eq!(w, &want, "{periods} periods, sample {k}, back {b}");
                }
                let key = by_word.acting_key(1);
                reused += usize::from(key == previous.0);
                previous = (key, *by_word.acting(1));
            }
            // Runs of a word: keys reused (and checked above) dozens of times.
            assert!(reused > 10, "{periods} periods: {reused} keys reused");
        }
    }

    #[test]
    fn the_word_path_acts_as_the_commands_f32_and_fixed() {
        the_word_path_acts_as_the_commands::<f32>();
        the_word_path_acts_as_the_commands::<IntFloat>();
    }
}
