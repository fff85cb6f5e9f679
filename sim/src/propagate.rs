//! Runs the plant through commanded thruster words, stepping RK4 between instants and
//! splitting steps at every actual valve edge and every mass-property or blowdown
//! breakpoint, so no input changes inside a step. [`Propagator`] takes commands one instant
//! at a time (closed loop needs that); [`propagate`] runs a whole command sequence. Shared
//! by the fast prediction (rates only) and the full simulation (attitude and translation).
//!
//! With a thrust rise (`effects/thrust_rise.rs`) thrust is no longer constant between edges:
//! at every actual valve edge each thruster's lagged force is re-referenced (its value at the
//! edge, relaxing towards the steady force of the new valve set), the step's [`Segment`]
//! carries the decaying excess, and steps are at most tau/8 long for the first 12 tau after
//! an edge so RK4 resolves the exponential for any tau (1 ms steps stay exact for slow rises).
use crate::dynamics::{derivative, rk4_step, Derivative, Plant, Segment, State};
use crate::valves::ValveEdge;
use reference_f64::satellite::MAX_THRUSTERS;

/// Time comparisons in ms are made with this slack (edges come from integer ms plus delays).
const EPS_MS: f64 = 1e-9;
/// Thrust rise: steps are at most tau / RISE_STEPS_PER_TAU long for RISE_FINE_TAUS * tau
/// after an edge (exp(-12) = 6e-6 of the transient is left), never shorter than
/// RISE_MIN_STEP_MS (for tau below 8e-4 ms the transient's whole area, tau * force, is
/// below 8e-4 ms of thrust).
const RISE_STEPS_PER_TAU: f64 = 8.0;
const RISE_FINE_TAUS: f64 = 12.0;
const RISE_MIN_STEP_MS: f64 = 1e-4;

/// How to integrate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepOptions {
    /// Largest RK4 step, ms (steps are also cut at every valve edge).
    pub max_step_ms: f64,
    /// Also integrate attitude, position and velocity.
    pub full: bool,
}

impl Default for StepOptions {
    fn default() -> Self {
        StepOptions {
            max_step_ms: 1.0,
            full: false,
        }
    }
}

/// What is known at one sample instant (right after any valve edge at that instant).
pub struct SampleView<'a> {
    pub index: usize,
    pub t_ms: f64,
    pub state: &'a State,
    pub derivative: &'a Derivative,
    /// Actual valve state (bit i = thruster i+1 open).
    pub valves: u16,
}

/// The plant moving through time under streamed commands.
pub struct Propagator<'a> {
    plant: &'a Plant,
    opts: StepOptions,
    x: State,
    t_ms: f64,
    /// Commanded word in force.
    command: u16,
    /// Actual valve state.
    valves: u16,
    /// Scheduled edges not yet reached, sorted by time.
    pending: Vec<ValveEdge>,
    /// Edges already applied, in time order.
    applied: Vec<ValveEdge>,
    breaks: Vec<f64>,
    next_break: usize,
    cache: Option<(u16, usize, Segment)>,
    /// Thrust rise: each thruster's force (N, before blowdown) at `rise_t0_ms`, the last
    /// valve edge; `rise_live` = some force still differs from its steady value there.
    rise_level: [f64; MAX_THRUSTERS],
    rise_t0_ms: f64,
    rise_live: bool,
}

impl<'a> Propagator<'a> {
    /// Starts at `t0_ms` in state `x0`, every valve closed.
    pub fn new(plant: &'a Plant, x0: State, t0_ms: f64, opts: StepOptions) -> Self {
        let mut breaks: Vec<f64> = plant.cfg.changes.iter().map(|(at, _)| at * 1e3).collect();
        breaks.extend(plant.cfg.blowdowns.iter().map(|b| b.start_s * 1e3));
        breaks.sort_by(f64::total_cmp);
        let opts = StepOptions {
            max_step_ms: if opts.max_step_ms > 0.0 {
                opts.max_step_ms
            } else {
                1.0
            },
            ..opts
        };
        Propagator {
            plant,
            opts,
            x: x0,
            t_ms: t0_ms,
            command: 0,
            valves: 0,
            pending: Vec::new(),
            applied: Vec::new(),
            breaks,
            next_break: 0,
            cache: None,
            rise_level: [0.0; MAX_THRUSTERS],
            rise_t0_ms: t0_ms,
            rise_live: false,
        }
    }

    pub fn state(&self) -> &State {
        &self.x
    }
    pub fn time_ms(&self) -> f64 {
        self.t_ms
    }
    pub fn valves(&self) -> u16 {
        self.valves
    }
    /// Actual valve edges so far.
    pub fn edges(&self) -> &[ValveEdge] {
        &self.applied
    }
    /// Takes the actual valve edges so far (in time order) out of the propagator, so a long
    /// flight does not hold them all; [`Propagator::edges`] then starts empty again.
    pub fn take_edges(&mut self) -> std::vec::Drain<'_, ValveEdge> {
        self.applied.drain(..)
    }
    pub fn into_edges(mut self) -> Vec<ValveEdge> {
        self.applied.append(&mut self.pending);
        self.applied
    }

    /// Commands `word` from now on: schedules the valve edges its changes cause (a valve
    /// opens `open_delay_ms` after a commanded rising edge and closes `close_delay_ms` after
    /// a falling one; a close that would come before its pending open cancels that open).
    pub fn command(&mut self, word: u16) {
        // Every bit of the 16-bit word (a 0x0fff mask here kept thrusters 13-16 of a
        // 16-thruster craft shut: its flights came out 35 % "heavier" and inconsistent).
        let changed = word ^ self.command;
        if changed != 0 {
            let cfg = &self.plant.cfg;
            for th in 0..MAX_THRUSTERS {
                let bit = 1u16 << th;
                if changed & bit == 0 {
                    continue;
                }
                let opens = word & bit != 0;
                let t = self.t_ms
                    + if opens {
                        cfg.open_delay_ms
                    } else {
                        cfg.close_delay_ms
                    };
                if !opens {
                    if let Some(i) = self
                        .pending
                        .iter()
                        .position(|e| e.thruster == th as u8 && e.opens && e.t_ms >= t)
                    {
                        self.pending.remove(i);
                        continue;
                    }
                }
                let e = ValveEdge {
                    t_ms: t,
                    thruster: th as u8,
                    opens,
                };
                let at = self.pending.partition_point(|p| p.t_ms <= t);
                self.pending.insert(at, e);
            }
            self.command = word;
        }
        self.apply_due_edges();
    }

    fn apply_due_edges(&mut self) {
        let before = self.valves;
        let mut n = 0;
        for e in &self.pending {
            if e.t_ms > self.t_ms + EPS_MS {
                break;
            }
            if e.opens {
                self.valves |= 1 << e.thruster;
            } else {
                self.valves &= !(1 << e.thruster);
            }
            n += 1;
        }
        self.applied.extend(self.pending.drain(..n));
        if self.valves != before {
            self.rise_rereference(before);
        }
    }

    /// Thrust rise: the valves just changed from `before`; every thruster's lagged force
    /// now (it was relaxing towards the steady force of `before`) becomes the new start.
    fn rise_rereference(&mut self, before: u16) {
        let tau = self.plant.cfg.thrust_rise_tau_ms;
        if tau <= 0.0 {
            return;
        }
        let old = self.plant.thrusts(before);
        let new = self.plant.thrusts(self.valves);
        let decay = (-(self.t_ms - self.rise_t0_ms) / tau).exp();
        for i in 0..MAX_THRUSTERS {
            self.rise_level[i] = old[i] + (self.rise_level[i] - old[i]) * decay;
        }
        self.rise_t0_ms = self.t_ms;
        self.rise_live = (0..MAX_THRUSTERS).any(|i| self.rise_level[i] != new[i]);
        self.cache = None;
    }

    fn segment(&mut self, t_ms: f64) -> Segment {
        let phase = self
            .plant
            .cfg
            .changes
            .iter()
            .filter(|(at, _)| at * 1e3 <= t_ms)
            .count();
        match self.cache {
            Some((v, ph, s)) if v == self.valves && ph == phase => s,
            _ => {
                let s = if self.rise_live {
                    let steady = self.plant.thrusts(self.valves);
                    let excess = std::array::from_fn(|i| self.rise_level[i] - steady[i]);
                    self.plant
                        .segment_with_rise(self.valves, t_ms, &excess, self.rise_t0_ms)
                } else {
                    self.plant.segment(self.valves, t_ms)
                };
                self.cache = Some((self.valves, phase, s));
                s
            }
        }
    }

    /// The state derivative now (inputs right after any edge at this instant).
    pub fn derivative_now(&mut self) -> Derivative {
        let seg = self.segment(self.t_ms + EPS_MS);
        derivative(&self.x, self.t_ms, &seg, &self.plant.cfg, self.opts.full)
    }

    /// Integrates to `t_end_ms` under the current command.
    pub fn advance_to(&mut self, t_end_ms: f64) {
        while self.t_ms < t_end_ms - EPS_MS {
            self.apply_due_edges();
            let t = self.t_ms;
            let mut h_max = self.opts.max_step_ms;
            if self.rise_live {
                let tau = self.plant.cfg.thrust_rise_tau_ms;
                if t - self.rise_t0_ms < RISE_FINE_TAUS * tau {
                    h_max = h_max.min((tau / RISE_STEPS_PER_TAU).max(RISE_MIN_STEP_MS));
                }
            }
            let mut next = t_end_ms.min(t + h_max);
            if let Some(e) = self.pending.first() {
                if e.t_ms < next {
                    next = e.t_ms;
                }
            }
            while self.next_break < self.breaks.len() && self.breaks[self.next_break] <= t + EPS_MS
            {
                self.next_break += 1;
            }
            if let Some(&b) = self.breaks.get(self.next_break) {
                if b < next {
                    next = b;
                }
            }
            let seg = self.segment(0.5 * (t + next));
            self.x = rk4_step(&self.x, t, next - t, &seg, &self.plant.cfg, self.opts.full);
            self.t_ms = next;
        }
        self.t_ms = self.t_ms.max(t_end_ms);
        self.apply_due_edges();
    }
}

/// Integrates from `x0` at `times_ms[0]` through every sample (word k commanded at
/// `times_ms[k]` and held until the next sample), calling `on_sample` at each one.
/// Returns every actual valve edge (for sensor effects they excite).
pub fn propagate(
    plant: &Plant,
    times_ms: &[u64],
    words: &[u16],
    x0: State,
    opts: StepOptions,
    mut on_sample: impl FnMut(&SampleView),
) -> Vec<ValveEdge> {
    let n = times_ms.len().min(words.len());
    if n == 0 {
        return Vec::new();
    }
    let mut p = Propagator::new(plant, x0, times_ms[0] as f64, opts);
    for k in 0..n {
        let t_k = times_ms[k] as f64;
        p.advance_to(t_k);
        p.command(words[k]);
        let d = p.derivative_now();
        on_sample(&SampleView {
            index: k,
            t_ms: t_k,
            state: &p.x,
            derivative: &d,
            valves: p.valves,
        });
    }
    p.into_edges()
}
