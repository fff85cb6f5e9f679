//! Two independent simulators should agree: feed a recording's commands and its truth
//! file's effects to this simulator and compare the body rates it predicts with the
//! recorded ones. Only what the truth file leaves open is fitted:
//! - the initial body rate (mean residual over the rest period before the first command);
//! - when a telemetry gap hides a command change, the instant of the change (searched
//!   millisecond by millisecond inside the gap);
//! - `fuel_slosh`: the liquid inertia fraction (extra key, one value for all axes);
//! - `gyro_ringing`: each shock's amplitude and phase per axis (linear least squares on a
//!   sine and a cosine at `freq_hz` decaying with `decay_ms`), since the phase at which a
//!   valve shock catches the tuning fork is not a parameter of the vocabulary.
//!
//! The noise floor is the recorded rates' standard deviation over that same rest period.
use crate::effects::{Effect, Truth};
use crate::predict::{shock_times_ms, PredictOptions, Predictor};
use reference_f64::recording::Recording;
use reference_f64::satellite::Satellite;

/// The outcome for one recording.
#[derive(Clone, Debug)]
pub struct Reproduction {
    pub samples: usize,
    /// RMS of recorded minus predicted rate, rad/s, after the fits.
    pub residual_rms: [f64; 3],
    /// The same with the nominal model (no effect, no fit).
    pub nominal_rms: [f64; 3],
    /// Gyro noise: standard deviation of the recorded rate at rest, rad/s.
    pub noise_floor: [f64; 3],
    /// What was fitted, human-readable.
    pub fitted: Vec<String>,
}

struct Case<'a> {
    sat: &'a Satellite,
    times: Vec<u64>,
    words: Vec<u16>,
    /// Index of each measured sample in `times` (extra command instants are not samples).
    measured_at: Vec<usize>,
    meas: Vec<[f64; 3]>,
}

impl Case<'_> {
    fn residuals(&self, effects: &[Effect], w0: [f64; 3]) -> (Vec<[f64; 3]>, Vec<f64>) {
        let p = Predictor::new(self.sat, effects).run(
            &self.times,
            &self.words,
            w0,
            PredictOptions::default(),
        );
        let r = self
            .measured_at
            .iter()
            .zip(&self.meas)
            .map(|(&i, m)| std::array::from_fn(|a| m[a] - p.gyro_rad_s[i][a]))
            .collect();
        (r, shock_times_ms(&p.edges))
    }
}

fn sse(r: &[[f64; 3]]) -> f64 {
    r.iter().map(|x| x.iter().map(|v| v * v).sum::<f64>()).sum()
}

fn rms(r: &[[f64; 3]]) -> [f64; 3] {
    let n = r.len().max(1) as f64;
    std::array::from_fn(|a| (r.iter().map(|x| x[a] * x[a]).sum::<f64>() / n).sqrt())
}

/// Reproduces `rec` with the effects of `truth`.
pub fn reproduce(rec: &Recording, truth: &Truth) -> Result<Reproduction, String> {
    let sat = Satellite::builtin(&truth.satellite)
        .ok_or_else(|| format!("unknown satellite {}", truth.satellite))?;
    let samples = &rec.samples;
    let rest = samples.iter().take_while(|s| s.thrusters == 0).count();
    if rest < 20 {
        return Err(format!(
            "{}: needs a rest period before the first command (has {rest} samples)",
            rec.source
        ));
    }
    let meas: Vec<[f64; 3]> = samples
        .iter()
        .map(|s| std::array::from_fn(|a| sat.gyro_counts_to_rad_s(a, s.gyro[a] as f64)))
        .collect();
    let noise_floor: [f64; 3] = std::array::from_fn(|a| {
        let m = meas[..rest].iter().map(|x| x[a]).sum::<f64>() / rest as f64;
        (meas[..rest].iter().map(|x| (x[a] - m).powi(2)).sum::<f64>() / (rest - 1) as f64).sqrt()
    });
    let mut case = Case {
        sat: &sat,
        times: samples.iter().map(|s| s.time_ms).collect(),
        words: samples.iter().map(|s| s.thrusters).collect(),
        measured_at: (0..samples.len()).collect(),
        meas,
    };
    let nominal_rms = rms(&case.residuals(&[], [0.0; 3]).0);
    let mut fitted = Vec::new();
    let mut effects = truth.effects.clone();
    // Ringing is fitted shock by shock at the end: predict without it meanwhile.
    let ringing: Vec<Effect> = effects
        .iter()
        .filter(|e| matches!(e, Effect::GyroRinging(_)))
        .cloned()
        .collect();
    effects.retain(|e| !matches!(e, Effect::GyroRinging(_)));

    fit_gap_commands(&mut case, &effects, rec.sample_period_ms(), &mut fitted);
    fit_slosh_fraction(&case, &mut effects, &mut fitted);

    // Initial rate.
    let (r, _) = case.residuals(&effects, [0.0; 3]);
    let w0: [f64; 3] =
        std::array::from_fn(|a| r[..rest].iter().map(|x| x[a]).sum::<f64>() / rest as f64);
    fitted.push(format!(
        "initial rate [{:.1e}, {:.1e}, {:.1e}] rad/s",
        w0[0], w0[1], w0[2]
    ));
    let (mut r, shocks) = case.residuals(&effects, w0);

    for e in &ringing {
        if let Effect::GyroRinging(g) = e {
            let amp = fit_ringing_per_shock(&case, &mut r, &shocks, g.freq_hz, g.decay_ms);
            fitted.push(format!(
                "ringing amplitude and phase per shock ({} shocks, mean amplitude {amp:.4} rad/s)",
                shocks.len()
            ));
        }
    }
    Ok(Reproduction {
        samples: samples.len(),
        residual_rms: rms(&r),
        nominal_rms,
        noise_floor,
        fitted,
    })
}

/// A gap that hides a command change: try every millisecond of the gap for the change and
/// keep the best (judged over the 300 ms after the gap).
fn fit_gap_commands(case: &mut Case, effects: &[Effect], period_ms: u64, fitted: &mut Vec<String>) {
    let gaps: Vec<usize> = (1..case.times.len())
        .filter(|&k| {
            case.times[k] - case.times[k - 1] > period_ms && case.words[k] != case.words[k - 1]
        })
        .collect();
    // Insert from the last gap backwards so earlier indices stay valid.
    let mut inserted = Vec::new();
    for &k in gaps.iter().rev() {
        let (t0, t1, new_word) = (case.times[k - 1], case.times[k], case.words[k]);
        case.times.insert(k, t0 + 1);
        case.words.insert(k, new_word);
        inserted.push((k, t0, t1));
    }
    // Positions shift: recompute which entries are measured samples.
    let extra: std::collections::BTreeSet<usize> = {
        let mut sorted: Vec<usize> = inserted.iter().map(|x| x.0).collect();
        sorted.sort();
        sorted
            .into_iter()
            .enumerate()
            .map(|(shift, k)| k + shift)
            .collect()
    };
    case.measured_at = (0..case.times.len())
        .filter(|i| !extra.contains(i))
        .collect();
    for &idx in &extra {
        let (t0, t1) = (case.times[idx - 1], case.times[idx + 1]);
        let window: Vec<usize> = case
            .measured_at
            .iter()
            .enumerate()
            .filter(|(_, &i)| case.times[i] >= t1 && case.times[i] < t1 + 300)
            .map(|(j, _)| j)
            .collect();
        let mut best = (f64::INFINITY, t0 + 1);
        for ts in t0 + 1..=t1 {
            case.times[idx] = ts;
            let (r, _) = case.residuals(effects, [0.0; 3]);
            let e: f64 = window
                .iter()
                .map(|&j| r[j].iter().map(|v| v * v).sum::<f64>())
                .sum();
            if e < best.0 {
                best = (e, ts);
            }
        }
        case.times[idx] = best.1;
        fitted.push(format!(
            "command change hidden in the gap {t0}..{t1} ms placed at {} ms",
            best.1
        ));
    }
}

/// Golden-section search of the slosh liquid fraction (all axes alike) in [0.005, 0.2].
fn fit_slosh_fraction(case: &Case, effects: &mut [Effect], fitted: &mut Vec<String>) {
    let Some(i) = effects
        .iter()
        .position(|e| matches!(e, Effect::FuelSlosh(_)))
    else {
        return;
    };
    let with = |f: f64, effects: &mut [Effect]| {
        effects[i] = effects[i]
            .with_params(&[
                ("inertia_fraction[0]", f),
                ("inertia_fraction[1]", f),
                ("inertia_fraction[2]", f),
            ])
            .expect("fuel_slosh has inertia_fraction");
    };
    let cost = |f: f64, effects: &mut [Effect]| {
        with(f, effects);
        sse(&case.residuals(effects, [0.0; 3]).0)
    };
    let g = (5f64.sqrt() - 1.0) / 2.0;
    let (mut a, mut b) = (0.005, 0.2);
    let mut c = b - g * (b - a);
    let mut d = a + g * (b - a);
    let (mut fc, mut fd) = (cost(c, effects), cost(d, effects));
    for _ in 0..25 {
        if fc < fd {
            b = d;
            d = c;
            fd = fc;
            c = b - g * (b - a);
            fc = cost(c, effects);
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + g * (b - a);
            fd = cost(d, effects);
        }
    }
    let f = 0.5 * (a + b);
    with(f, effects);
    fitted.push(format!("slosh liquid inertia fraction {f:.4}"));
}

/// Removes from `r` the best sine+cosine tone after each shock, per axis; returns the mean
/// fitted amplitude.
fn fit_ringing_per_shock(
    case: &Case,
    r: &mut [[f64; 3]],
    shocks: &[f64],
    freq_hz: f64,
    decay_ms: f64,
) -> f64 {
    let times: Vec<f64> = case
        .measured_at
        .iter()
        .map(|&i| case.times[i] as f64)
        .collect();
    let mut amps = Vec::new();
    for (s, &te) in shocks.iter().enumerate() {
        let end = shocks
            .get(s + 1)
            .copied()
            .unwrap_or(f64::INFINITY)
            .min(te + 8.0 * decay_ms);
        let lo = times.partition_point(|&t| t < te);
        let hi = times.partition_point(|&t| t < end);
        if hi <= lo + 2 {
            continue;
        }
        let basis = |t: f64| {
            let dt = (t - te) * 1e-3;
            let env = (-dt * 1e3 / decay_ms).exp();
            let ph = 2.0 * std::f64::consts::PI * freq_hz * dt;
            (env * ph.sin(), env * ph.cos())
        };
        for a in 0..3 {
            let (mut ss, mut sc, mut cc, mut rs, mut rc) = (0.0, 0.0, 0.0, 0.0, 0.0);
            for j in lo..hi {
                let (bs, bc) = basis(times[j]);
                ss += bs * bs;
                sc += bs * bc;
                cc += bc * bc;
                rs += r[j][a] * bs;
                rc += r[j][a] * bc;
            }
            let det = ss * cc - sc * sc;
            if det.abs() < 1e-12 {
                continue;
            }
            let (a_s, a_c) = ((rs * cc - rc * sc) / det, (rc * ss - rs * sc) / det);
            amps.push(a_s.hypot(a_c));
            for j in lo..hi {
                let (bs, bc) = basis(times[j]);
                r[j][a] -= a_s * bs + a_c * bc;
            }
        }
    }
    amps.iter().sum::<f64>() / amps.len().max(1) as f64
}
