//! What the identification reads from a recording: sample times, measured rates, the command
//! held from each sample to the next, and what each interval between two samples delivered
//! (per-thruster impulses, shifted by a known command latency; valve-edge rates for the
//! consistency test). Format-independent: v1 (gyro counts) and v2 (rad/s) both land here.
use crate::rate_recording::{Commands, RateRecording};
use crate::recording::Recording;
use crate::satellite::{Satellite, MAX_THRUSTERS};
use nalgebra::Vector3;

/// One sample's command, held until the next sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Command {
    /// Thruster word, bit i = thruster i+1 open.
    Word(u16),
    /// Body force (N) and torque about the model's CoM (N m).
    Wrench { force: [f64; 3], torque: [f64; 3] },
}

/// A flight as the identification sees it.
#[derive(Clone, Debug)]
pub struct Flight {
    /// Sample times, s, strictly increasing.
    pub time_s: Vec<f64>,
    /// Measured rates, rad/s; NaN where missing (or on an unmeasured axis).
    pub rate: Vec<[f64; 3]>,
    /// Which axes are measured.
    pub axes: [bool; 3],
    /// Command of each sample.
    pub commands: Vec<Command>,
    /// Nominal sample period, s (a step over 1.5 of it is a gap).
    pub period_s: f64,
    /// Whether the rates are 12-bit gyro counts converted (v1), which fixes the sensor
    /// response to a point sample.
    pub from_gyro_counts: bool,
}

/// Why a recording cannot be identified (before any fitting).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum FlightError {
    #[error("{0}")]
    Invalid(String),
}

impl Flight {
    /// A v1 recording: counts to rad/s with the model's bias and scale; saturated counts (0 or
    /// 4095) are missing samples.
    pub fn from_v1(rec: &Recording, sat: &Satellite) -> Flight {
        let rate = rec
            .samples
            .iter()
            .map(|s| {
                std::array::from_fn(|a| {
                    let c = s.gyro[a];
                    if c == 0 || c >= crate::recording::MAX_COUNT {
                        f64::NAN
                    } else {
                        sat.gyro_counts_to_rad_s(a, c as f64)
                    }
                })
            })
            .collect();
        Flight {
            time_s: rec
                .samples
                .iter()
                .map(|s| s.time_ms as f64 * 1e-3)
                .collect(),
            rate,
            axes: [true; 3],
            commands: rec
                .samples
                .iter()
                .map(|s| Command::Word(s.thrusters))
                .collect(),
            period_s: rec.sample_period_ms() as f64 * 1e-3,
            from_gyro_counts: true,
        }
    }

    /// A v2 recording (rates in rad/s). A wrench's absent components are zero.
    pub fn from_v2(rec: &RateRecording) -> Flight {
        let commands = match &rec.commands {
            Commands::Thrusters { words, .. } => words.iter().map(|&w| Command::Word(w)).collect(),
            Commands::Wrench { values, .. } => values
                .iter()
                .map(|v| {
                    let z = |x: f64| if x.is_finite() { x } else { 0.0 };
                    Command::Wrench {
                        force: [z(v[0]), z(v[1]), z(v[2])],
                        torque: [z(v[3]), z(v[4]), z(v[5])],
                    }
                })
                .collect(),
        };
        Flight {
            time_s: rec.time_ms.iter().map(|&t| t as f64 * 1e-3).collect(),
            rate: rec.rate.clone(),
            axes: rec.axes,
            commands,
            period_s: 1.0 / rec.sample_rate_hz(),
            from_gyro_counts: false,
        }
    }

    /// Checks the flight against the model: lengths agree, times increase, thruster words
    /// name only the model's thrusters.
    pub fn check(&self, sat: &Satellite) -> Result<(), FlightError> {
        let n = self.time_s.len();
        if self.rate.len() != n || self.commands.len() != n {
            return Err(FlightError::Invalid(format!(
                "{} times, {} rate rows and {} commands: lengths differ",
                n,
                self.rate.len(),
                self.commands.len()
            )));
        }
        if !(self.period_s.is_finite() && self.period_s > 0.0) {
            return Err(FlightError::Invalid(format!(
                "sample period {} s: must be positive",
                self.period_s
            )));
        }
        if let Some(k) = (1..n).find(|&k| self.time_s[k] <= self.time_s[k - 1]) {
            return Err(FlightError::Invalid(format!(
                "sample {k}: time does not increase"
            )));
        }
        let mask = sat.word_mask();
        if let Some((k, w)) = self.commands.iter().enumerate().find_map(|(k, c)| match c {
            Command::Word(w) if w & !mask != 0 => Some((k, *w)),
            _ => None,
        }) {
            return Err(FlightError::Invalid(format!(
                "sample {k}: thruster word {w:#x} names a thruster the {}-thruster model does not have",
                sat.n_thrusters()
            )));
        }
        Ok(())
    }
}

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
}

/// What one interval between consecutive samples delivered, with the latency applied.
#[derive(Clone, Debug)]
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

/// A command's wrench and per-thruster thrusts, computed when first asked for. The intervals
/// read the commands in order, at most three indices around the current one, so a few
/// entries serve them and no per-sample table is held (it was 176 bytes a sample: 1.8 GB at
/// 10^7 samples).
struct CommandCache<'a> {
    flight: &'a Flight,
    sat: &'a Satellite,
    slots: [Option<(usize, (Wrench, [f64; MAX_THRUSTERS]))>; 4],
    oldest: usize,
}

impl CommandCache<'_> {
    fn get(&mut self, i: usize) -> (Wrench, [f64; MAX_THRUSTERS]) {
        if let Some((_, v)) = self.slots.iter().flatten().find(|(k, _)| *k == i) {
            return *v;
        }
        let v = self
            .flight
            .commands
            .get(i)
            .map_or((Wrench::default(), [0.0; MAX_THRUSTERS]), |c| {
                command_wrench(self.sat, c)
            });
        if let Some(slot) = self.slots.get_mut(self.oldest) {
            *slot = Some((i, v));
        }
        self.oldest = (self.oldest + 1) % 4;
        v
    }
}

/// The intervals between consecutive samples. The command of sample `m` acts over
/// `[t_m + latency, t_m+1 + latency)`; before the first command acts nothing fires.
pub fn intervals(flight: &Flight, sat: &Satellite, latency_s: f64) -> Vec<Interval> {
    let n = flight.time_s.len();
    let t = &flight.time_s;
    let mut cmds = CommandCache {
        flight,
        sat,
        slots: [None; 4],
        oldest: 0,
    };
    let zero = (Wrench::default(), [0.0; MAX_THRUSTERS]);
    // Command index acting at time s: m with t_m + L <= s < t_m+1 + L (None before t_0 + L).
    let mut out = Vec::with_capacity(n.saturating_sub(1));
    let mut m: usize = 0;
    for j in 0..n.saturating_sub(1) {
        let (a, b) = (t[j], t[j + 1]);
        let mut iv = Interval {
            dt: b - a,
            impulse: Wrench::default(),
            thruster_impulse: [0.0; MAX_THRUSTERS],
            open_edges: Wrench::default(),
            close_edges: Wrench::default(),
        };
        // Advance m to the last command whose start (shifted) is <= a.
        while m + 1 < n && t[m + 1] + latency_s <= a {
            m += 1;
        }
        let mut s = a;
        let mut cur: Option<usize> = if t[m] + latency_s <= a { Some(m) } else { None };
        let mut next = if cur.is_some() { m + 1 } else { m };
        // An edge exactly at the interval's start belongs to it: a longer delay moves it in.
        if let Some(c) = cur {
            if t[c] + latency_s == a {
                let f_old = if c == 0 { zero.1 } else { cmds.get(c - 1).1 };
                add_edge(&mut iv, sat, &f_old, &cmds.get(c).1);
            }
        }
        loop {
            let end = if next < n {
                (t[next] + latency_s).min(b)
            } else {
                b
            };
            let (w, f) = cur.map_or(zero, |c| cmds.get(c));
            let d = (end - s).max(0.0);
            iv.impulse.add_scaled(&w, d);
            for (acc, fi) in iv.thruster_impulse.iter_mut().zip(&f) {
                *acc += fi * d;
            }
            if next >= n || t[next] + latency_s >= b {
                break;
            }
            // An edge inside the interval: from `cur` to `next`.
            let f_old = cur.map_or(zero.1, |c| cmds.get(c).1);
            add_edge(&mut iv, sat, &f_old, &cmds.get(next).1);
            s = end;
            cur = Some(next);
            next += 1;
        }
        out.push(iv);
    }
    out
}

/// Runs of consecutive samples the fit uses: every measured axis present, steps within 1.5
/// nominal periods, and with `cut_at_changes` no command change inside (an interval whose
/// word changes ends a run; the next starts after it). Each run gets its own initial rate.
/// Runs shorter than `min_len` are dropped.
pub fn windows(flight: &Flight, min_len: usize, cut_at_changes: bool) -> Vec<(usize, usize)> {
    let n = flight.time_s.len();
    let valid = |k: usize| (0..3).all(|a| !flight.axes[a] || flight.rate[k][a].is_finite());
    let joins = |k: usize| {
        flight.time_s[k] - flight.time_s[k - 1] <= 1.5 * flight.period_s
            && !(cut_at_changes && flight.commands[k] != flight.commands[k - 1])
    };
    let mut out = Vec::new();
    let mut start: Option<usize> = None;
    for k in 0..=n {
        let keep = k < n && valid(k) && start.is_none_or(|_| joins(k));
        match (start, keep) {
            (None, true) => start = Some(k),
            (Some(s), false) => {
                if k - s >= min_len {
                    out.push((s, k));
                }
                start = if k < n && valid(k) { Some(k) } else { None };
            }
            _ => {}
        }
    }
    out
}
