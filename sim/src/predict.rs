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
/// [`RingingStream`] computes the same numbers one sample at a time.
pub fn ringing_at(
    cfg: &PlantConfig,
    shocks_ms: &[f64],
    times_ms: &[u64],
    mut phase: impl FnMut(usize, usize, usize) -> f64,
) -> Vec<[f64; 3]> {
    let mut stream = RingingStream::new(cfg);
    for &t in shocks_ms {
        stream.push_shock(t);
    }
    // `ringing_at` asks for every phase of ringing 0 before any of ringing 1 (its order
    // before the stream existed): with several ringings, run them one at a time.
    let n = cfg.ringing.len();
    if n <= 1 {
        return times_ms.iter().map(|&t| stream.at(t, &mut phase)).collect();
    }
    let mut out = vec![[0.0; 3]; times_ms.len()];
    for ri in 0..n {
        let mut one = stream.clone().only(ri);
        for (k, &t) in times_ms.iter().enumerate() {
            one.add_at(t, &mut out[k], |_, s, a| phase(ri, s, a));
        }
    }
    out
}

/// A live tone of one ringing effect.
#[derive(Clone, Debug)]
struct Tone {
    start_ms: f64,
    re: f64,
    im: f64,
    /// amplitude * (cos p, sin p) per axis: sin(wt + p) = sin(wt) cos p + cos(wt) sin p.
    weights: [(f64, f64); 3],
}

/// One ringing effect's live tones.
#[derive(Clone, Debug)]
struct Tones {
    /// Index in the plant configuration's ringing list.
    ri: usize,
    ringing: crate::effects::GyroRinging,
    live: Vec<Tone>,
    /// The last sample spacing (ms) and its advance factor.
    step_factor: (f64, (f64, f64)),
}

impl Tones {
    fn advance(&self, dt_ms: f64) -> (f64, f64) {
        let r = &self.ringing;
        let omega = 2.0 * std::f64::consts::PI * r.freq_hz;
        let env = (-dt_ms / r.decay_ms).exp();
        let (s, c) = (omega * dt_ms * 1e-3).sin_cos();
        (env * c, env * s)
    }
}

/// [`ringing_at`] one sample at a time, holding only the live tones and the shocks not yet
/// reached: shocks are pushed as they become known (in time order), samples asked for in
/// time order. Each sample's value is bit for bit the one [`ringing_at`] gives; the phases
/// are asked for shock by shock, all ringings of a shock before the next shock.
#[derive(Clone, Debug)]
pub struct RingingStream {
    tones: Vec<Tones>,
    /// Shocks pushed and not yet reached by a sample, ms.
    pending: std::collections::VecDeque<f64>,
    /// Index of the first pending shock among all shocks pushed.
    next_shock: usize,
    last_t: Option<f64>,
    /// Shocks reached this sample (kept to reuse its allocation).
    reached: Vec<f64>,
}

impl RingingStream {
    /// The ringing effects of `cfg`, no shock yet.
    pub fn new(cfg: &PlantConfig) -> Self {
        RingingStream {
            tones: cfg
                .ringing
                .iter()
                .enumerate()
                .map(|(ri, r)| Tones {
                    ri,
                    ringing: r.clone(),
                    live: Vec::new(),
                    step_factor: (0.0, (1.0, 0.0)),
                })
                .collect(),
            pending: std::collections::VecDeque::new(),
            next_shock: 0,
            last_t: None,
            reached: Vec::new(),
        }
    }

    /// Keeps only ringing `ri` (its index in the configuration still names it to `phase`).
    fn only(mut self, ri: usize) -> Self {
        self.tones.retain(|t| t.ri == ri);
        self
    }

    /// A shock at `t_ms`; shocks must come in time order, before the samples they reach.
    pub fn push_shock(&mut self, t_ms: f64) {
        self.pending.push_back(t_ms);
    }

    /// How many shocks samples have reached so far (each asked `3 x ringings` phases).
    pub fn shocks_reached(&self) -> usize {
        self.next_shock
    }

    /// The ringing at the sample instant `t_ms` (instants must not decrease).
    pub fn at(&mut self, t_ms: u64, phase: impl FnMut(usize, usize, usize) -> f64) -> [f64; 3] {
        let mut out = [0.0; 3];
        self.add_at(t_ms, &mut out, phase);
        out
    }

    /// Adds the ringing at `t_ms` to `out`, tone by tone (the order of the sums of
    /// [`ringing_at`]).
    fn add_at(
        &mut self,
        t_ms: u64,
        out: &mut [f64; 3],
        mut phase: impl FnMut(usize, usize, usize) -> f64,
    ) {
        let t = t_ms as f64;
        self.reached.clear();
        while let Some(&te) = self.pending.front() {
            if te > t {
                break;
            }
            self.reached.push(te);
            self.pending.pop_front();
        }
        let first = self.next_shock;
        for tones in &mut self.tones {
            let r = &tones.ringing;
            let horizon_ms = 8.0 * r.decay_ms;
            // Advance the live tones to t.
            if let Some(t0) = self.last_t {
                let dt = t - t0;
                if dt != tones.step_factor.0 {
                    tones.step_factor = (dt, tones.advance(dt));
                }
                let (fr, fi) = tones.step_factor.1;
                for z in tones.live.iter_mut() {
                    let (re, im) = (z.re * fr - z.im * fi, z.re * fi + z.im * fr);
                    z.re = re;
                    z.im = im;
                }
            }
            tones.live.retain(|z| t - z.start_ms <= horizon_ms);
            for (j, &te) in self.reached.iter().enumerate() {
                let s = first + j;
                if t - te <= horizon_ms {
                    let (re, im) = tones.advance(t - te);
                    let r = &tones.ringing;
                    let weights = std::array::from_fn(|a| {
                        let p = phase(tones.ri, s, a);
                        (
                            r.amplitude_rad_s[a] * p.cos(),
                            r.amplitude_rad_s[a] * p.sin(),
                        )
                    });
                    tones.live.push(Tone {
                        start_ms: te,
                        re,
                        im,
                        weights,
                    });
                } else {
                    // Still draw its phases so the random sequence does not depend on timing.
                    for a in 0..3 {
                        phase(tones.ri, s, a);
                    }
                }
            }
            for z in &tones.live {
                for a in 0..3 {
                    let (wc, ws) = z.weights[a];
                    out[a] += z.im * wc + z.re * ws;
                }
            }
        }
        self.next_shock += self.reached.len();
        self.last_t = Some(t);
    }
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
    /// Two ringing effects: `ringing_at` sums both, and the stream gives the same bits
    /// sample by sample when asked the same phases.
    #[test]
    fn two_ringings_streamed_equal_the_whole() {
        let sat = Satellite::builtin("sph2").unwrap();
        let r = |f: f64, d: f64, amp: f64| {
            Effect::GyroRinging(GyroRinging {
                freq_hz: f,
                decay_ms: d,
                apparent_hz: 0.0,
                amplitude_rad_s: [amp, 2.0 * amp, 3.0 * amp],
            })
        };
        let cfg = PlantConfig::new(&sat, &[r(338.33, 30.0, 0.01), r(211.0, 9.0, 0.02)]);
        let shocks = [3.0, 7.4, 7.9, 150.0, 400.25];
        let times: Vec<u64> = (0..700u64).filter(|t| t % 5 != 2).collect();
        let phase = |ri: usize, s: usize, a: usize| 0.3 * s as f64 + a as f64 + 1.7 * ri as f64;
        let whole = ringing_at(&cfg, &shocks, &times, phase);
        let mut stream = RingingStream::new(&cfg);
        for &s in &shocks {
            stream.push_shock(s);
        }
        for (k, &t) in times.iter().enumerate() {
            let direct: [f64; 3] = std::array::from_fn(|a| {
                cfg.ringing
                    .iter()
                    .enumerate()
                    .flat_map(|(ri, g)| {
                        shocks
                            .iter()
                            .enumerate()
                            .filter(|(_, &te)| t as f64 >= te && t as f64 - te <= 8.0 * g.decay_ms)
                            .map(move |(s, &te)| {
                                g.response(a, (t as f64 - te) * 1e-3, phase(ri, s, a))
                            })
                    })
                    .sum()
            });
            let one = stream.at(t, phase);
            for a in 0..3 {
                assert!((whole[k][a] - direct[a]).abs() < 1e-14, "t {t} axis {a}");
                assert_eq!(one[a].to_bits(), whole[k][a].to_bits(), "t {t} axis {a}");
            }
        }
        assert_eq!(stream.shocks_reached(), shocks.len());
    }
}
