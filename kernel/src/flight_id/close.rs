//! A window's initial-rate term, added to the flight's sums a few entries per sample.
//!
//! Closing a window eliminates its initial rate: `s s^T / n` (`s` the window's sum of the
//! samples, `n` their count) joins the flight's `czz`, `czy` and `cyy` ([`FlightSums`]), up to
//! 18 x 18 + 3 x 18 + 3 = 381 multiply-adds. In the integer float that was 30,000
//! instructions on the M4F in the tick that closed the window, 3.6 times the 8,400 budget,
//! where a sample costs 14,000. The fit reads these sums only outside the tick
//! ([`super::FlightId::solve`]), so nothing needs them at once: a closed window's means and
//! sums wait here, and each later sample adds [`DRAIN_ALONE`] of its entries while one window
//! waits, [`DRAIN_PER_SAMPLE`] while more do ([`PendingCloses::drain_tick`]: the fewer a
//! tick adds, the cheaper the ticks that add them, 960 instructions on the M4F at 8). Each
//! entry takes the same operation as before, and the windows are taken in the order they
//! closed, so the sums are bit for bit those of the close done at once.
//!
//! Up to [`PENDING`] closed windows wait. A dense window (381 entries) is done in 96 samples
//! alone, in 48 once the next has closed, so the queue fills only if windows shorter than
//! about 50 samples close one after the other (a rate sensor failing every few samples); then
//! the oldest is finished in the tick that closes the next (the close done at once, as
//! before).

use super::components::NZ;
use super::sums::{Active, FlightSums, Sample};
use crate::scalar::Scalar;

/// Closed windows that can wait for their term.
pub const PENDING: usize = 4;
/// Entries of the waiting terms added per sample while two or more windows wait.
pub const DRAIN_PER_SAMPLE: usize = 8;
/// Entries of the waiting term added per sample while it is the only one.
pub const DRAIN_ALONE: usize = 4;

/// A closed window's term: its means and sums over the components it moved.
#[derive(Clone, Copy, Debug)]
struct Closed<S> {
    mean: Sample<S>,
    sum: Sample<S>,
    /// The drive components in the term (those the flight had moved when the window closed;
    /// the others' sums are zero), increasing.
    comps: [u8; NZ],
    len: u8,
}

impl<S: Scalar> Closed<S> {
    /// Entries of the term: the `z` block, `z` by each axis' `y`, each axis' `y`.
    fn entries(&self) -> usize {
        let n = usize::from(self.len);
        n.saturating_mul(n)
            .saturating_add(n.saturating_mul(3))
            .saturating_add(3)
    }

    fn comp(&self, k: usize) -> usize {
        usize::from(self.comps.get(k).copied().unwrap_or(0))
    }

    /// Adds entry `k` of the term to `flight` (row by row: `czz`, then `czy`, then `cyy`).
    fn add_entry(&self, flight: &mut FlightSums<S>, k: usize) {
        let len = usize::from(self.len);
        // The divisor of the splits below (never zero; with no component there is no `z`
        // entry to split).
        let n = len.max(1);
        let zz = len.saturating_mul(len);
        let zy = len.saturating_mul(3);
        let (mz, sz, my, sy) = (&self.mean.z, &self.sum.z, &self.mean.y, &self.sum.y);
        let at = |v: &[S], i: usize| v.get(i).copied().unwrap_or(S::ZERO);
        let split = |k: usize| (k.checked_div(n).unwrap_or(0), k.checked_rem(n).unwrap_or(0));
        if k < zz {
            let (r, c) = split(k);
            let (i, j) = (self.comp(r), self.comp(c));
            if let Some(c) = flight.czz.get_mut(i).and_then(|row| row.get_mut(j)) {
                *c = c.mul_add(at(mz, i), at(sz, j));
            }
        } else if let Some(r) = k.checked_sub(zz).filter(|r| *r < zy) {
            let (a, c) = split(r);
            let j = self.comp(c);
            if let Some(c) = flight.czy.get_mut(a).and_then(|row| row.get_mut(j)) {
                *c = c.mul_add(at(my, a), at(sz, j));
            }
        } else {
            let a = k.saturating_sub(zz.saturating_add(zy));
            if let Some(c) = flight.cyy.get_mut(a) {
                *c = c.mul_add(at(my, a), at(sy, a));
            }
        }
    }
}

/// Closed windows whose term is not yet in the flight's sums, oldest first.
#[derive(Clone, Copy, Debug)]
pub struct PendingCloses<S> {
    queue: [Option<Closed<S>>; PENDING],
    /// The oldest window's slot.
    head: usize,
    /// Entries of the oldest window's term already added.
    done: usize,
}

impl<S: Scalar> Default for PendingCloses<S> {
    fn default() -> Self {
        PendingCloses {
            queue: [None; PENDING],
            head: 0,
            done: 0,
        }
    }
}

impl<S: Scalar> PendingCloses<S> {
    /// Queues the term of a closed window of `n` samples whose sums are `sum`
    /// ([`super::sums::WindowSums::close`]), over the drive components `active` (all when it
    /// is not sparse). Nothing for an empty window. When the
    /// queue is full its oldest term is finished first.
    pub fn close(&mut self, flight: &mut FlightSums<S>, sum: Sample<S>, n: u32, active: &Active) {
        if n == 0 {
            return;
        }
        if self.waiting() >= PENDING {
            // The oldest term's remaining entries, at once.
            let left = self
                .queue
                .get(self.head)
                .and_then(Option::as_ref)
                .map_or(0, |c| c.entries().saturating_sub(self.done));
            self.drain(flight, left);
        }
        let count = S::from_int_pow2(i32::try_from(n).unwrap_or(i32::MAX), 0);
        let mean = |v: S| v.checked_div(count).unwrap_or(S::ZERO);
        let mut closed = Closed {
            mean: Sample {
                z: [S::ZERO; NZ],
                y: sum.y.map(mean),
            },
            sum,
            comps: [0; NZ],
            len: 0,
        };
        let dense: [u8; NZ] = core::array::from_fn(|i| u8::try_from(i).unwrap_or(0));
        let comps = if active.sparse() {
            active.components()
        } else {
            &dense[..]
        };
        for (slot, c) in closed.comps.iter_mut().zip(comps) {
            *slot = *c;
            let i = usize::from(*c);
            if let (Some(m), Some(s)) = (closed.mean.z.get_mut(i), sum.z.get(i)) {
                *m = mean(*s);
            }
        }
        closed.len = u8::try_from(comps.len().min(NZ)).unwrap_or(0);
        let tail = self
            .head
            .saturating_add(self.waiting())
            .checked_rem(PENDING)
            .unwrap_or(0);
        if let Some(slot) = self.queue.get_mut(tail) {
            *slot = Some(closed);
        }
    }

    /// Closed windows waiting.
    pub fn waiting(&self) -> usize {
        self.queue.iter().filter(|q| q.is_some()).count()
    }

    /// Adds up to `budget` entries of the waiting terms to `flight`, oldest first; a window
    /// counts in `flight.windows` once its whole term is in.
    pub fn drain(&mut self, flight: &mut FlightSums<S>, budget: usize) {
        let mut left = budget;
        while left > 0 {
            // Borrowed, not copied: a term is hundreds of bytes and this runs every sample.
            let Some(Some(closed)) = self.queue.get(self.head) else {
                return;
            };
            let entries = closed.entries();
            let take = left.min(entries.saturating_sub(self.done));
            for k in self.done..self.done.saturating_add(take) {
                closed.add_entry(flight, k);
            }
            self.done = self.done.saturating_add(take);
            left = left.saturating_sub(take);
            if self.done >= entries {
                if let Some(slot) = self.queue.get_mut(self.head) {
                    *slot = None;
                }
                self.head = self
                    .head
                    .saturating_add(1)
                    .checked_rem(PENDING)
                    .unwrap_or(0);
                self.done = 0;
                flight.windows = flight.windows.saturating_add(1);
            }
        }
    }

    /// A tick's share: [`DRAIN_ALONE`] entries while one window waits, [`DRAIN_PER_SAMPLE`]
    /// while more do.
    pub fn drain_tick(&mut self, flight: &mut FlightSums<S>) {
        let budget = if self.waiting() > 1 {
            DRAIN_PER_SAMPLE
        } else {
            DRAIN_ALONE
        };
        self.drain(flight, budget);
    }

    /// Adds every waiting term (before a fit, and at the end of the flight: not a tick's work).
    pub fn drain_all(&mut self, flight: &mut FlightSums<S>) {
        self.drain(flight, usize::MAX);
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
    use crate::flight_id::sums::tests::text_hash;
    use crate::IntFloat;

    /// Closed windows: sums, sample counts and the components moved by then. Window 0 closes
    /// before any component has moved (a coast, then a missing sample: only its `y` term),
    /// window 1 is sparse (a planar craft's components), the others dense; windows 2-6 are
    /// short, so they close faster than their terms drain and the queue fills.
    fn windows<S: Scalar>() -> [(Sample<S>, u32, Active, u32); 7] {
        let v = |w: usize, c: usize| {
            S::from_f32(((w * 11 + c * 7) % 13) as f32 / 4.0 - 1.3 + c as f32 / 32.0)
        };
        let mut planar = Active::NONE;
        planar.note(|i| [2, 3, 4, 14, 17].contains(&i));
        core::array::from_fn(|w| {
            let active = match w {
                0 => Active::NONE,
                1 => planar,
                _ => Active::full(),
            };
            let sum = Sample {
                z: core::array::from_fn(|c| {
                    if active.sparse() && !active.contains(c) {
                        S::ZERO
                    } else {
                        v(w, c)
                    }
                }),
                y: core::array::from_fn(|a| v(w, NZ + a)),
            };
            // Samples in the window, and the samples between its close and the next.
            let (n, gap) = if (2..=6).contains(&w) {
                (3, 2)
            } else {
                (40, 60)
            };
            (sum, n + w as u32, active, gap)
        })
    }

    /// Every window's term added at once, in `order`: the close as it was done in its tick.
    fn at_once<S: Scalar + core::fmt::Debug>(order: [usize; 7]) -> u64 {
        let ws = windows::<S>();
        let mut f = FlightSums::<S>::default();
        for w in order {
            let (sum, n, active, _) = ws[w];
            let count = S::from_int_pow2(n as i32, 0);
            let comps = |i: usize| !active.sparse() || active.contains(i);
            let mz: [S; NZ] = core::array::from_fn(|i| sum.z[i].checked_div(count).unwrap());
            let my: [S; 3] = core::array::from_fn(|a| sum.y[a].checked_div(count).unwrap());
            for i in (0..NZ).filter(|i| comps(*i)) {
                for j in (0..NZ).filter(|j| comps(*j)) {
                    f.czz[i][j] = f.czz[i][j].mul_add(mz[i], sum.z[j]);
                }
            }
            for a in 0..3 {
                for j in (0..NZ).filter(|j| comps(*j)) {
                    f.czy[a][j] = f.czy[a][j].mul_add(my[a], sum.z[j]);
                }
                f.cyy[a] = f.cyy[a].mul_add(my[a], sum.y[a]);
            }
            f.windows += 1;
        }
        text_hash(&f)
    }

    /// The terms through the queue, a few entries per sample.
    fn queued<S: Scalar + core::fmt::Debug>() -> (u64, usize) {
        let mut f = FlightSums::<S>::default();
        let mut q = PendingCloses::<S>::default();
        let mut most = 0;
        for (sum, n, active, gap) in windows::<S>() {
            q.close(&mut f, sum, n, &active);
            most = most.max(q.waiting());
            for _ in 0..gap {
                q.drain_tick(&mut f);
            }
        }
        // An empty window queues nothing.
        q.close(&mut f, windows::<S>()[0].0, 0, &Active::full());
        q.drain_all(&mut f);
        assert_eq!(q.waiting(), 0);
        (text_hash(&f), most)
    }

    fn spread_equals_at_once<S: Scalar + core::fmt::Debug>() {
        let (got, most) = queued::<S>();
        assert_eq!(most, PENDING, "the short windows fill the queue");
        assert_eq!(got, at_once::<S>([0, 1, 2, 3, 4, 5, 6]));
        // Planted: the same terms in another order are other bits; the comparison sees it.
        assert_ne!(got, at_once::<S>([0, 1, 3, 2, 4, 5, 6]));
    }

    /// The queued terms, drained a few entries per sample (4 alone, 8 while more wait, and at
    /// once when the queue is full), are bit for bit the terms added at once in the order the
    /// windows closed.
    #[test]
    fn a_spread_close_equals_the_close_at_once_bit_for_bit() {
        spread_equals_at_once::<f32>();
        spread_equals_at_once::<IntFloat>();
    }
}
