//! What each interval between two samples delivered: the commanded wrench's impulse, each
//! thruster's impulse, and the valve-edge rates of the consistency test, with a known command
//! latency applied. Computed when the fit asks, so that no per-sample table is held.
use super::flight::{Command, Flight};
use crate::satellite::{Satellite, MAX_THRUSTERS};
use nalgebra::Vector3;
use std::cell::{Cell, RefCell};
use std::collections::HashMap;

/// A body wrench: torque about the model's CoM (N m) and force (N), or their time integrals.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Wrench {
    pub torque: Vector3<f64>,
    pub force: Vector3<f64>,
}

impl Wrench {
    fn add_scaled(&mut self, other: &Wrench, s: f64) {
        self.torque += other.torque * s;
        self.force += other.force * s;
    }

    fn scaled(&self, s: f64) -> Wrench {
        Wrench {
            torque: self.torque * s,
            force: self.force * s,
        }
    }
}

/// What one interval between consecutive samples delivered, with the latency applied.
#[derive(Clone, Debug, Default)]
pub struct Interval {
    /// Length, s.
    pub dt: f64,
    /// Integral of the commanded wrench over the interval (N m s, N s).
    pub impulse: Wrench,
    /// Per thruster, the integral of its thrust magnitude (N s); all zero for wrench commands.
    pub thruster_impulse: [f64; MAX_THRUSTERS],
    /// Rate at which the integral changes when every valve opens later (d impulse / d open
    /// delay, N m, N): minus the opening thrusters' wrench, summed over the interval's edges.
    pub open_edges: Wrench,
    /// The same for closing edges (plus the closing thrusters' wrench).
    pub close_edges: Wrench,
}

impl Interval {
    /// One of `m` equal parts of the interval, the wrench spread evenly over it (for substeps
    /// of the integration; the parts add up to the interval's integrals).
    pub fn part(&self, m: usize) -> Interval {
        let s = 1.0 / m as f64;
        Interval {
            dt: self.dt * s,
            impulse: self.impulse.scaled(s),
            thruster_impulse: self.thruster_impulse.map(|v| v * s),
            open_edges: self.open_edges.scaled(s),
            close_edges: self.close_edges.scaled(s),
        }
    }
}

/// A thruster's wrench per newton of its thrust: `(lever x dir, dir)`.
pub fn unit_wrench(sat: &Satellite, i: usize) -> Wrench {
    Wrench {
        torque: sat.lever_arm_m(i).cross(&sat.dir(i)),
        force: sat.dir(i),
    }
}

fn command_wrench(sat: &Satellite, c: &Command) -> (Wrench, [f64; MAX_THRUSTERS]) {
    match c {
        Command::Word(w) => {
            let f = sat.thrusts_for_word(*w);
            let mut out = Wrench::default();
            for (i, &fi) in f.iter().enumerate().take(sat.n_thrusters()) {
                if fi != 0.0 {
                    out.add_scaled(&unit_wrench(sat, i), fi);
                }
            }
            (out, f)
        }
        Command::Wrench { force, torque } => (
            Wrench {
                torque: Vector3::from(*torque),
                force: Vector3::from(*force),
            },
            [0.0; MAX_THRUSTERS],
        ),
    }
}

/// d impulse / d delay of one valve edge from thrusts `f_old` to `f_new`: the old thrust acts
/// longer, the new one shorter.
fn add_edge(
    iv: &mut Interval,
    sat: &Satellite,
    f_old: &[f64; MAX_THRUSTERS],
    f_new: &[f64; MAX_THRUSTERS],
) {
    for i in 0..sat.n_thrusters() {
        let (o, nw) = (f_old[i], f_new[i]);
        if nw > 0.0 && o == 0.0 {
            iv.open_edges.add_scaled(&unit_wrench(sat, i), -nw);
        } else if o > 0.0 && nw == 0.0 {
            iv.close_edges.add_scaled(&unit_wrench(sat, i), o);
        }
    }
}

/// The intervals between consecutive samples, each computed when the fit asks for it. The
/// command of sample `m` acts over `[t_m + latency, t_m+1 + latency)`; before the first
/// command acts nothing fires. No per-sample table is held: a table of intervals was 280
/// bytes a sample (2.8 GB at 10^7 samples), and before 891f350 a table of the commands'
/// wrenches another 176. A thruster word's wrench and thrusts are computed once per distinct
/// word (at most 2^16 of them); a wrench command needs no work.
pub struct Intervals<'a> {
    flight: &'a Flight,
    sat: &'a Satellite,
    latency_s: f64,
    words: RefCell<HashMap<u16, Delivered>>,
    /// The command run last read, and the command index last found acting: the fit reads the
    /// intervals in order, so both searches usually end where they start.
    run_hint: Cell<usize>,
    acting_hint: Cell<usize>,
}

/// A command's wrench and per-thruster thrusts.
type Delivered = (Wrench, [f64; MAX_THRUSTERS]);

impl<'a> Intervals<'a> {
    pub fn new(flight: &'a Flight, sat: &'a Satellite, latency_s: f64) -> Self {
        Intervals {
            flight,
            sat,
            latency_s,
            words: RefCell::new(HashMap::new()),
            run_hint: Cell::new(0),
            acting_hint: Cell::new(0),
        }
    }

    /// Intervals: one fewer than the samples.
    pub fn len(&self) -> usize {
        self.flight.time_s.len().saturating_sub(1)
    }

    /// True if the flight has fewer than two samples.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Every interval, in order.
    pub fn iter(&self) -> impl Iterator<Item = Interval> + '_ {
        (0..self.len()).map(|j| self.at(j))
    }

    /// Command `i`'s wrench and thrusts (nothing before the first or past the last).
    fn command(&self, i: usize) -> Delivered {
        match self.flight.commands.get_near(i, &self.run_hint) {
            None => (Wrench::default(), [0.0; MAX_THRUSTERS]),
            Some(Command::Word(w)) => *self
                .words
                .borrow_mut()
                .entry(*w)
                .or_insert_with(|| command_wrench(self.sat, &Command::Word(*w))),
            Some(c) => command_wrench(self.sat, c),
        }
    }

    /// The interval from sample `j` to sample `j + 1` (`j < len()`; past it, an empty one).
    pub fn at(&self, j: usize) -> Interval {
        let t = &self.flight.time_s;
        let (n, latency_s, sat) = (t.len(), self.latency_s, self.sat);
        let zero = (Wrench::default(), [0.0; MAX_THRUSTERS]);
        let (Some(&a), Some(&b)) = (t.get(j), t.get(j + 1)) else {
            return Interval::default();
        };
        let mut iv = Interval {
            dt: b - a,
            ..Interval::default()
        };
        // The last command whose start (shifted) is <= a, or 0 if none is (then nothing acts
        // yet); the shifted starts are non-decreasing, so a binary search finds it.
        let starts_by = |k: usize| t.get(k).is_some_and(|&tk| tk + latency_s <= a);
        let is_last = |k: usize| starts_by(k) && !starts_by(k + 1);
        let h = self.acting_hint.get();
        let m = if is_last(h) {
            h
        } else if is_last(h + 1) {
            h + 1
        } else {
            t.partition_point(|&tm| tm + latency_s <= a)
                .saturating_sub(1)
        };
        self.acting_hint.set(m);
        let mut s = a;
        let mut cur: Option<usize> = if t[m] + latency_s <= a { Some(m) } else { None };
        let mut next = if cur.is_some() { m + 1 } else { m };
        // An edge exactly at the interval's start belongs to it: a longer delay moves it in.
        if let Some(c) = cur {
            if t[c] + latency_s == a {
                let f_old = if c == 0 {
                    zero.1
                } else {
                    self.command(c - 1).1
                };
                add_edge(&mut iv, sat, &f_old, &self.command(c).1);
            }
        }
        loop {
            let end = if next < n {
                (t[next] + latency_s).min(b)
            } else {
                b
            };
            let (w, f) = cur.map_or(zero, |c| self.command(c));
            let d = (end - s).max(0.0);
            iv.impulse.add_scaled(&w, d);
            for (acc, fi) in iv.thruster_impulse.iter_mut().zip(&f) {
                *acc += fi * d;
            }
            if next >= n || t[next] + latency_s >= b {
                break;
            }
            // An edge inside the interval: from `cur` to `next`.
            let f_old = cur.map_or(zero.1, |c| self.command(c).1);
            add_edge(&mut iv, sat, &f_old, &self.command(next).1);
            s = end;
            cur = Some(next);
            next += 1;
        }
        iv
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::flight_id::flight::samples::flight;

    fn bits(iv: &Interval) -> Vec<u64> {
        let w = |w: &Wrench| {
            w.torque
                .iter()
                .chain(w.force.iter())
                .map(|v| v.to_bits())
                .collect::<Vec<_>>()
        };
        let mut out = vec![iv.dt.to_bits()];
        out.extend(w(&iv.impulse));
        out.extend(iv.thruster_impulse.iter().map(|v| v.to_bits()));
        out.extend(w(&iv.open_edges));
        out.extend(w(&iv.close_edges));
        out
    }

    /// An interval is the same whatever was asked for before it (the searches' hints), at any
    /// latency: in order, backwards, and by a stride that jumps over runs.
    #[test]
    fn an_interval_does_not_depend_on_the_order_of_asking() {
        let sat = Satellite::builtin("sph2").unwrap();
        for wrench in [false, true] {
            let f = flight(1500, wrench);
            for latency in [0.0, 1e-3, 0.0065, 0.2] {
                let ivs = Intervals::new(&f, &sat, latency);
                let ordered: Vec<Vec<u64>> = ivs.iter().map(|iv| bits(&iv)).collect();
                let fresh = Intervals::new(&f, &sat, latency);
                for j in (0..ivs.len()).rev() {
                    assert_eq!(
                        bits(&fresh.at(j)),
                        ordered[j],
                        "latency {latency}, interval {j}"
                    );
                }
                let fresh = Intervals::new(&f, &sat, latency);
                for j in (0..ivs.len()).map(|k| (k * 397) % ivs.len()) {
                    assert_eq!(
                        bits(&fresh.at(j)),
                        ordered[j],
                        "latency {latency}, interval {j}"
                    );
                }
                // Something fires once the latency has passed.
                assert!(ordered.iter().any(|b| b[1..].iter().any(|v| *v != 0)));
            }
        }
    }
}
