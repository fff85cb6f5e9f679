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
    pub fn from_config(sat: &Satellite, cfg: PlantConfig) -> Self {
        Predictor {
            plant: Plant::new(sat, cfg),
            counts_per_rad_s: sat.gyro_counts_per_rad_s,
        }
    }

    pub fn plant(&self) -> &Plant {
        &self.plant
    }

    /// Predicts at `times_ms` for commanded `words` (word k holds until sample k+1), the body
    /// turning at `initial_rate` (rad/s) at the first sample, liquid at rest.
    pub fn run(
        &self,
        times_ms: &[u64],
        words: &[u16],
        initial_rate: [f64; 3],
        opts: PredictOptions,
    ) -> Prediction {
        let n = times_ms.len().min(words.len());
        let mut p = Prediction {
            gyro_rad_s: Vec::with_capacity(n),
            body_rate: Vec::with_capacity(n),
            angular_accel: Vec::with_capacity(n),
            specific_force: Vec::with_capacity(n),
            valves_open: Vec::with_capacity(n),
            edges: Vec::new(),
        };
        let step = StepOptions {
            max_step_ms: opts.max_step_ms,
            full: false,
        };
        p.edges = propagate(
            &self.plant,
            times_ms,
            words,
            State::with_rates(initial_rate),
            step,
            |s| {
                p.body_rate.push(s.state.w.into());
                p.angular_accel.push(s.derivative.w_dot.into());
                p.specific_force.push(s.derivative.specific_force.into());
                p.valves_open.push(s.valves);
            },
        );
        // the sensor sees the ringing as late as the rate (a measurement delay)
        let shocks: Vec<f64> = shock_times_ms(&p.edges)
            .into_iter()
            .map(|t| t + self.plant.cfg.measurement_delay_ms)
            .collect();
        let ringing = ringing_at(&self.plant.cfg, &shocks, &times_ms[..n], |_, _, _| 0.0);
        let cfg = &self.plant.cfg;
        let seen = delayed(
            &times_ms[..n],
            &p.body_rate,
            &p.angular_accel,
            cfg.measurement_delay_ms,
        );
        p.gyro_rad_s = (0..n)
            .map(|k| {
                std::array::from_fn(|a| {
                    cfg.gyro_scale[a] * (seen[k][a] + ringing[k][a])
                        + cfg.gyro_bias_counts[a] / self.counts_per_rad_s[a]
                })
            })
            .collect();
        p
    }
}

/// The body rate `delay_ms` before each sample instant (a `measurement_delay`), by cubic
/// Hermite interpolation between the sample instants from the rates and accelerations there;
/// before the first instant the first rate is held (as the simulator's delay line does).
fn delayed(
    times_ms: &[u64],
    rate: &[[f64; 3]],
    accel: &[[f64; 3]],
    delay_ms: f64,
) -> Vec<[f64; 3]> {
    if delay_ms <= 0.0 || times_ms.is_empty() {
        return rate.to_vec();
    }
    let mut j = 0usize;
    times_ms
        .iter()
        .map(|&t| {
            let tq = t as f64 - delay_ms;
            if tq <= times_ms[0] as f64 {
                return rate[0];
            }
            while j + 1 < times_ms.len() && (times_ms[j + 1] as f64) < tq {
                j += 1;
            }
            let (t0, t1) = (times_ms[j] as f64, times_ms[j + 1] as f64);
            let h = (t1 - t0) * 1e-3;
            let u = (tq - t0) / (t1 - t0);
            let (h00, h10) = (
                1.0 - 3.0 * u * u + 2.0 * u * u * u,
                u - 2.0 * u * u + u * u * u,
            );
            let (h01, h11) = (3.0 * u * u - 2.0 * u * u * u, u * u * u - u * u);
            // the slope at both ends is the one held over the interval (the acceleration
            // recorded at j + 1 is after that sample's command change)
            std::array::from_fn(|a| {
                h00 * rate[j][a]
                    + h10 * h * accel[j][a]
                    + h01 * rate[j + 1][a]
                    + h11 * h * accel[j][a]
            })
        })
        .collect()
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
///
/// Each live tone is kept as the complex number z = exp(-dt/decay) e^{i w dt} and advanced
/// from sample to sample by one complex multiplication (the factor depends only on the
/// sample spacing, shared by all tones), so the cost is a few flops per live tone and sample.
pub fn ringing_at(
    cfg: &PlantConfig,
    shocks_ms: &[f64],
    times_ms: &[u64],
    mut phase: impl FnMut(usize, usize, usize) -> f64,
) -> Vec<[f64; 3]> {
    struct Tone {
        start_ms: f64,
        re: f64,
        im: f64,
        /// amplitude * (cos p, sin p) per axis: sin(wt + p) = sin(wt) cos p + cos(wt) sin p.
        weights: [(f64, f64); 3],
    }
    let mut out = vec![[0.0; 3]; times_ms.len()];
    for (ri, r) in cfg.ringing.iter().enumerate() {
        let omega = 2.0 * std::f64::consts::PI * r.freq_hz;
        let horizon_ms = 8.0 * r.decay_ms;
        let advance = |dt_ms: f64| {
            let env = (-dt_ms / r.decay_ms).exp();
            let (s, c) = (omega * dt_ms * 1e-3).sin_cos();
            (env * c, env * s)
        };
        let mut live: Vec<Tone> = Vec::new();
        let mut next_shock = 0usize;
        let mut last_t: Option<f64> = None;
        let mut step_factor = (0.0, (1.0, 0.0));
        for (k, &t) in times_ms.iter().enumerate() {
            let t = t as f64;
            // Advance the live tones to t.
            if let Some(t0) = last_t {
                let dt = t - t0;
                if dt != step_factor.0 {
                    step_factor = (dt, advance(dt));
                }
                let (fr, fi) = step_factor.1;
                for z in live.iter_mut() {
                    let (re, im) = (z.re * fr - z.im * fi, z.re * fi + z.im * fr);
                    z.re = re;
                    z.im = im;
                }
            }
            live.retain(|z| t - z.start_ms <= horizon_ms);
            while next_shock < shocks_ms.len() && shocks_ms[next_shock] <= t {
                let te = shocks_ms[next_shock];
                if t - te <= horizon_ms {
                    let (re, im) = advance(t - te);
                    let weights = std::array::from_fn(|a| {
                        let p = phase(ri, next_shock, a);
                        (
                            r.amplitude_rad_s[a] * p.cos(),
                            r.amplitude_rad_s[a] * p.sin(),
                        )
                    });
                    live.push(Tone {
                        start_ms: te,
                        re,
                        im,
                        weights,
                    });
                } else {
                    // Still draw its phases so the random sequence does not depend on timing.
                    for a in 0..3 {
                        phase(ri, next_shock, a);
                    }
                }
                next_shock += 1;
            }
            for z in &live {
                for a in 0..3 {
                    let (wc, ws) = z.weights[a];
                    out[k][a] += z.im * wc + z.re * ws;
                }
            }
            last_t = Some(t);
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
    Predictor::new(sat, effects)
        .run(times_ms, words, initial_rate, opts)
        .gyro_rad_s
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::effects::GyroRinging;

    #[test]
    fn ringing_recurrence_equals_the_direct_formula() {
        let sat = Satellite::builtin("sph2").unwrap();
        let r = GyroRinging {
            freq_hz: 338.33,
            decay_ms: 30.0,
            apparent_hz: 38.33,
            amplitude_rad_s: [0.01, 0.02, 0.03],
        };
        let cfg = PlantConfig::new(&sat, &[Effect::GyroRinging(r.clone())]);
        let shocks = [3.0, 7.4, 7.9, 150.0, 400.25];
        // Irregular sampling with a gap, to exercise the factor cache.
        let times: Vec<u64> = (0..300u64)
            .chain(310..700)
            .step_by(1)
            .filter(|t| t % 7 != 3)
            .collect();
        let phase = |_: usize, s: usize, a: usize| 0.3 * s as f64 + a as f64;
        let got = ringing_at(&cfg, &shocks, &times, phase);
        for (k, &t) in times.iter().enumerate() {
            for a in 0..3 {
                let direct: f64 = shocks
                    .iter()
                    .enumerate()
                    .filter(|(_, &te)| t as f64 >= te && t as f64 - te <= 8.0 * r.decay_ms)
                    .map(|(s, &te)| r.response(a, (t as f64 - te) * 1e-3, phase(0, s, a)))
                    .sum();
                assert!(
                    (got[k][a] - direct).abs() < 1e-14,
                    "t {t} axis {a}: {} vs {direct}",
                    got[k][a]
                );
            }
        }
    }
}
