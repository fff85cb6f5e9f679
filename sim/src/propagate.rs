//! Runs the plant through a sequence of commanded thruster words, stepping RK4 between the
//! sample instants and splitting steps at every actual valve edge and every mass-property or
//! blowdown breakpoint, so no input changes inside a step. Shared by the fast prediction
//! (rates only) and the full simulation (attitude and translation too).
use crate::dynamics::{derivative, rk4_step, Derivative, Plant, Segment, State};
use crate::valves::{valve_edges, ValveEdge};

/// Time comparisons in ms are made with this slack (edges come from integer ms plus delays).
const EPS_MS: f64 = 1e-9;

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
        StepOptions { max_step_ms: 1.0, full: false }
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

/// Integrates from `x0` at `times_ms[0]` through every sample, calling `on_sample` at each
/// one. Returns the actual valve edges used (for sensor effects excited by them).
pub fn propagate(
    plant: &Plant,
    times_ms: &[u64],
    words: &[u16],
    x0: State,
    opts: StepOptions,
    mut on_sample: impl FnMut(&SampleView),
) -> Vec<ValveEdge> {
    let cfg = &plant.cfg;
    let n = times_ms.len().min(words.len());
    let edges = valve_edges(&times_ms[..n], &words[..n], cfg.open_delay_ms, cfg.close_delay_ms);
    let mut breaks: Vec<f64> = cfg.changes.iter().map(|(at, _)| at * 1e3).collect();
    breaks.extend(cfg.blowdowns.iter().map(|b| b.start_s * 1e3));
    breaks.sort_by(f64::total_cmp);
    let phase_index = |t_ms: f64| breaks_before(&cfg.changes, t_ms);
    let max_step = if opts.max_step_ms > 0.0 { opts.max_step_ms } else { 1.0 };

    let mut x = x0;
    let mut valves: u16 = 0;
    let mut ei = 0usize;
    let mut bi = 0usize;
    let mut cache: Option<(u16, usize, Segment)> = None;
    let segment_for = |valves: u16, t_ms: f64, cache: &mut Option<(u16, usize, Segment)>| -> Segment {
        let p = phase_index(t_ms);
        match cache {
            Some((v, ph, s)) if *v == valves && *ph == p => *s,
            _ => {
                let s = plant.segment(valves, t_ms);
                *cache = Some((valves, p, s));
                s
            }
        }
    };
    let apply_edges = |t: f64, ei: &mut usize, valves: &mut u16| {
        while *ei < edges.len() && edges[*ei].t_ms <= t + EPS_MS {
            let e = edges[*ei];
            if e.opens {
                *valves |= 1 << e.thruster;
            } else {
                *valves &= !(1 << e.thruster);
            }
            *ei += 1;
        }
    };

    for k in 0..n {
        let t_k = times_ms[k] as f64;
        apply_edges(t_k, &mut ei, &mut valves);
        let seg = segment_for(valves, t_k + EPS_MS, &mut cache);
        let d = derivative(&x, t_k, &seg, cfg, opts.full);
        on_sample(&SampleView { index: k, t_ms: t_k, state: &x, derivative: &d, valves });
        if k + 1 == n {
            break;
        }
        let t_end = times_ms[k + 1] as f64;
        let mut t = t_k;
        while t < t_end - EPS_MS {
            apply_edges(t, &mut ei, &mut valves);
            let mut next = t_end.min(t + max_step);
            if ei < edges.len() && edges[ei].t_ms < next {
                next = edges[ei].t_ms;
            }
            while bi < breaks.len() && breaks[bi] <= t + EPS_MS {
                bi += 1;
            }
            if bi < breaks.len() && breaks[bi] < next {
                next = breaks[bi];
            }
            let seg = segment_for(valves, 0.5 * (t + next), &mut cache);
            x = rk4_step(&x, t, next - t, &seg, cfg, opts.full);
            t = next;
        }
    }
    edges
}

/// How many mass-property changes have happened by `t_ms`.
fn breaks_before(changes: &[(f64, crate::effects::MassPhase)], t_ms: f64) -> usize {
    changes.iter().filter(|(at, _)| at * 1e3 <= t_ms).count()
}
