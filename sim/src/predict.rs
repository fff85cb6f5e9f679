//! The fast, deterministic (noise-free) prediction the mismatch diagnosis calls hundreds of
//! times per recording: for commanded thruster words at sample instants, what the body does
//! and what a noise-free gyro reads, converted to rad/s with the NOMINAL bias and scale the
//! same way a recording is.
use crate::dynamics::{Plant, State};
use crate::effects::{Effect, PlantConfig};
use crate::propagate::{propagate, StepOptions};
use crate::valves::ValveEdge;
use reference_f64::satellite::Satellite;

/// Prediction settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PredictOptions {
    /// Largest RK4 step, ms; steps are also cut at every actual valve edge, so 1 ms is exact
    /// enough for piecewise-constant thrust (see the crate README for the step study).
    pub max_step_ms: f64,
}

impl Default for PredictOptions {
    fn default() -> Self {
        PredictOptions { max_step_ms: 1.0 }
    }
}

/// Everything predicted at each sample instant.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Prediction {
    /// What a noise-free gyro reads, in rad/s after the nominal conversion: includes gyro bias
    /// and scale errors and ringing sampled at the sample instants.
    pub gyro_rad_s: Vec<[f64; 3]>,
    /// True body rate, rad/s.
    pub body_rate: Vec<[f64; 3]>,
    /// True angular acceleration right after the sample instant, rad/s^2.
    pub angular_accel: Vec<[f64; 3]>,
    /// Specific force at the CoM (thrust / mass), body axes, m/s^2, right after the instant.
    pub specific_force: Vec<[f64; 3]>,
    /// Actual valve state after latency at the instant (bit i = thruster i+1 open).
    pub valves_open: Vec<u16>,
    /// The actual valve edges (after latency), ms.
    pub edges: Vec<ValveEdge>,
}

/// A satellite with effects switched on, reusable for many predictions.
#[derive(Clone, Debug)]
pub struct Predictor {
    plant: Plant,
    counts_per_rad_s: [f64; 3],
}

impl Predictor {
    pub fn new(sat: &Satellite, effects: &[Effect]) -> Self {
        Self::from_config(sat, PlantConfig::new(sat, effects))
    }

    /// From an already-built plant configuration (e.g. one a fitter edits directly).
    pub fn from_config(sat: &Satellite, mut cfg: PlantConfig) -> Self {
        cfg.pressure_drop_n += sat.pressure_drop_n_per_extra;
        Predictor { plant: Plant::new(sat, cfg), counts_per_rad_s: sat.gyro_counts_per_rad_s }
    }

    pub fn plant(&self) -> &Plant {
        &self.plant
    }

    /// Predicts at `times_ms` for commanded `words` (word k holds until sample k+1), the body
    /// turning at `initial_rate` (rad/s) at the first sample, liquid at rest.
    pub fn run(&self, times_ms: &[u64], words: &[u16], initial_rate: [f64; 3], opts: PredictOptions) -> Prediction {
        let n = times_ms.len().min(words.len());
        let mut p = Prediction {
            gyro_rad_s: Vec::with_capacity(n),
            body_rate: Vec::with_capacity(n),
            angular_accel: Vec::with_capacity(n),
            specific_force: Vec::with_capacity(n),
            valves_open: Vec::with_capacity(n),
            edges: Vec::new(),
        };
        let step = StepOptions { max_step_ms: opts.max_step_ms, full: false };
        p.edges = propagate(&self.plant, times_ms, words, State::with_rates(initial_rate), step, |s| {
            p.body_rate.push(s.state.w.into());
            p.angular_accel.push(s.derivative.w_dot.into());
            p.specific_force.push(s.derivative.specific_force.into());
            p.valves_open.push(s.valves);
        });
        let ringing = ringing_at(&self.plant.cfg, &shock_times_ms(&p.edges), &times_ms[..n], |_, _, _| 0.0);
        let cfg = &self.plant.cfg;
        p.gyro_rad_s = (0..n)
            .map(|k| {
                std::array::from_fn(|a| {
                    cfg.gyro_scale[a] * (p.body_rate[k][a] + ringing[k][a])
                        + cfg.gyro_bias_counts[a] / self.counts_per_rad_s[a]
                })
            })
            .collect();
        p
    }
}

/// The distinct instants (ms) at which valves actually open or close: each is one shock.
pub fn shock_times_ms(edges: &[ValveEdge]) -> Vec<f64> {
    let mut t: Vec<f64> = edges.iter().map(|e| e.t_ms).collect();
    t.sort_by(f64::total_cmp);
    t.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
    t
}

/// The gyro ringing (rad/s, per axis) at each sample instant: every shock starts a decaying
/// tone of every ringing effect; `phase(ringing, shock, axis)` gives its phase. Tones are
/// dropped after 8 decay times (below 3.4e-4 of their peak: 0.006 counts at the default
/// amplitude, far below the 12-bit step).
pub fn ringing_at(
    cfg: &PlantConfig,
    shocks_ms: &[f64],
    times_ms: &[u64],
    mut phase: impl FnMut(usize, usize, usize) -> f64,
) -> Vec<[f64; 3]> {
    let mut out = vec![[0.0; 3]; times_ms.len()];
    for (ri, r) in cfg.ringing.iter().enumerate() {
        // sin(wt + p) = sin(wt) cos(p) + cos(wt) sin(p): one exp and one sin_cos per
        // (sample, shock), whatever the number of axes.
        let weights: Vec<[(f64, f64); 3]> = (0..shocks_ms.len())
            .map(|s| {
                std::array::from_fn(|a| {
                    let p = phase(ri, s, a);
                    (r.amplitude_rad_s[a] * p.cos(), r.amplitude_rad_s[a] * p.sin())
                })
            })
            .collect();
        let horizon_ms = 8.0 * r.decay_ms;
        let omega = 2.0 * std::f64::consts::PI * r.freq_hz;
        let mut first = 0usize;
        for (k, &t) in times_ms.iter().enumerate() {
            let t = t as f64;
            while first < shocks_ms.len() && shocks_ms[first] < t - horizon_ms {
                first += 1;
            }
            let mut j = first;
            while j < shocks_ms.len() && shocks_ms[j] <= t {
                let dt_s = (t - shocks_ms[j]) * 1e-3;
                let env = (-dt_s * 1e3 / r.decay_ms).exp();
                let (sn, cs) = (omega * dt_s).sin_cos();
                for a in 0..3 {
                    let (wc, ws) = weights[j][a];
                    out[k][a] += env * (sn * wc + cs * ws);
                }
                j += 1;
            }
        }
    }
    out
}

/// What a noise-free gyro reads (rad/s, nominal conversion) at `times_ms` for commanded
/// `words` with `effects` on. Convenience over [`Predictor`].
pub fn predict_gyro_rates(
    sat: &Satellite,
    effects: &[Effect],
    times_ms: &[u64],
    words: &[u16],
    initial_rate: [f64; 3],
    opts: PredictOptions,
) -> Vec<[f64; 3]> {
    Predictor::new(sat, effects).run(times_ms, words, initial_rate, opts).gyro_rad_s
}

/// The full prediction (rates, accelerations, valve states); see [`Prediction`].
pub fn predict(
    sat: &Satellite,
    effects: &[Effect],
    times_ms: &[u64],
    words: &[u16],
    initial_rate: [f64; 3],
    opts: PredictOptions,
) -> Prediction {
    Predictor::new(sat, effects).run(times_ms, words, initial_rate, opts)
}
