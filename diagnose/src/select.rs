//! Forward selection: starting from the nominal model (initial rate fitted), fit every
//! mechanism of the vocabulary on top of the accepted ones, take the one with the lowest
//! BIC, refit all accepted jointly, and stop when no candidate lowers BIC by more than
//! the acceptance margin.

use crate::effects::Describe;
use crate::effects::{self, Context, Kind};
use crate::fit::{self, Family, FitResult, Problem};
use crate::model::{Params, NT};

/// An accepted (or candidate) effect with its fitted parameter vector.
#[derive(Clone, Debug)]
pub struct Fitted {
    pub kind: Kind,
    pub theta: Vec<f64>,
    pub stderr: Vec<f64>,
    /// Chi-square of the model with this and all earlier effects.
    pub chi2: f64,
    /// BIC change against the model before this effect.
    pub delta_bic: f64,
    /// Free-text notes from the fit (alias choice, ...).
    pub note: String,
}

/// Settings of the selection.
#[derive(Clone, Debug)]
pub struct Settings {
    /// A candidate is accepted only if it lowers BIC by more than this (beyond the
    /// k ln N penalty already in BIC), calibrated on nominal simulated recordings.
    pub accept_margin: f64,
    pub max_effects: usize,
    pub max_iter: usize,
    /// Prior for the true gyro ringing frequency, Hz (seed App. A: 338 Hz).
    pub ringing_prior_hz: f64,
    /// Re-estimate the body rate every this many seconds (None: only after telemetry
    /// gaps). A long closed-loop recording of a craft whose model is off is not predicted
    /// open loop from its first sample (every torque error integrates for minutes);
    /// re-anchoring the rate compares the model with the craft over this horizon instead.
    pub horizon_s: Option<f64>,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            accept_margin: 25.0,
            max_effects: 3,
            max_iter: 12,
            ringing_prior_hz: 338.0,
            horizon_s: None,
        }
    }
}

/// Points of the change-time scan around a fitted mass-property change.
const CHANGE_SCAN_POINTS: usize = 40;
/// Scans of the change time, each on a grid 10 times finer than the one before (a 30 s
/// flight: 94 ms, then 9.4 ms); the first also tries the command edges ([`change_probes`]).
const CHANGE_SCAN_PASSES: usize = 2;
/// Command edges a change-time scan tries, at most (evenly thinned beyond): 256 (about
/// 190 a scan on the 60 s, 1 kHz random-PWM bench) gave the same open-set answers and
/// `mass_change_mc` figures on seeds 90400-90459 as 64, for 10-20 % more predictions.
const MAX_EDGE_PROBES: usize = 64;

/// The recording's length on its own clock (s) and the half-width of a first change-time
/// scan: the spacing of the starts ([`effects::MASS_CHANGE_STARTS`] over the run).
pub(crate) fn change_window(series: &crate::series::Series) -> (f64, f64) {
    let dur = series.real_ms(series.duration_s() * 1e3) * 1e-3;
    (dur, dur / effects::MASS_CHANGE_STARTS as f64)
}

/// The change times the first scan tries within `at +- half` s (the recording's clock,
/// within `0..=dur`): an even grid of `CHANGE_SCAN_POINTS + 1`, and the command edges, at most
/// [`MAX_EDGE_PROBES`]. Why the edges: a change during a firing is a minimum as narrow as
/// the firing, which a grid steps over (the random flight 90150 of `mass_change_mc`: the
/// truth 17 ms into a firing, the grid's best a coast away), and the cost of a change in a
/// coast turns at the coast's ends.
pub(crate) fn change_probes(
    series: &crate::series::Series,
    at: f64,
    half: f64,
    dur: f64,
) -> Vec<f64> {
    let grid = (0..=CHANGE_SCAN_POINTS)
        .map(|k| (at - half + 2.0 * half * k as f64 / CHANGE_SCAN_POINTS as f64).clamp(0.0, dur));
    let from = series.model_ms((at - half) * 1e3).max(1.0) as usize;
    let to = (series.model_ms((at + half) * 1e3).max(0.0) as usize).min(series.word_ms.len());
    let edges: Vec<f64> = (from..to)
        .filter(|&k| series.word_ms[k] != series.word_ms[k - 1])
        .map(|k| series.real_ms(k as f64) * 1e-3)
        .filter(|t| (at - half..=at + half).contains(t))
        .collect();
    let every = edges.len().div_ceil(MAX_EDGE_PROBES).max(1);
    let mut probes: Vec<f64> = grid.chain(edges.into_iter().step_by(every)).collect();
    probes.sort_by(f64::total_cmp);
    probes.dedup();
    probes
}
/// LM iterations that rank starts which all predict the same (a new effect at "no effect").
const RANKING_ITERATIONS: usize = 2;

/// Parameters of a model made of `accepted` effects and the nuisances `nuis` (initial
/// rate, then 3 per gap reset).
pub fn build(fired: &[bool; NT], accepted: &[(Kind, Vec<f64>)], nuis: &[f64]) -> Params {
    let mut p = nuisance_params(nuis);
    for (k, th) in accepted {
        // ringing is additive with a random phase per edge: handled on the residual
        if !k.effect().on_residual() {
            effects::apply(*k, th, fired, &mut p);
        }
    }
    p
}

/// The nominal model with nuisances `nuis`: initial rate, then one rate jump per gap.
pub fn nuisance_params(nuis: &[f64]) -> Params {
    Params {
        omega0: [nuis[0], nuis[1], nuis[2]],
        resets: nuis[3..].chunks(3).map(|c| [c[0], c[1], c[2]]).collect(),
        ..Params::default()
    }
}

pub use crate::effects::Spec;

/// What the effects may look at about this recording and its model.
pub fn context<'a>(
    prob: &Problem<'a>,
    fired: &'a [bool; NT],
    slosh_hint_hz: &'a [f64],
) -> Context<'a> {
    Context {
        // times of a change are on the recording's clock
        duration_s: prob.series.real_ms(prob.series.duration_s() * 1e3) * 1e-3,
        nominal_inertia: prob.plant.nominal_inertia(),
        min_thrust_n: (0..prob.plant.n_thrusters)
            .map(|i| prob.plant.thrust_n(i))
            .fold(f64::MAX, f64::min),
        n_thrusters: prob.plant.n_thrusters,
        fired,
        slosh_hint_hz,
        sample_rate_hz: prob.series.sample_rate_hz,
        command_step_ms: command_step_ms(&prob.series.word_ms),
        plant: prob.plant,
        inertia_start: *prob
            .inertia_start
            .get_or_init(|| crate::equation_error::inertia(prob)),
    }
}

/// Median time one thruster word holds, ms (runs of the 1 ms command grid; 1000 when the
/// words never change).
fn command_step_ms(word_ms: &[u16]) -> f64 {
    let mut runs = vec![];
    let mut start = 0usize;
    for k in 1..word_ms.len() {
        if word_ms[k] != word_ms[k - 1] {
            runs.push(k - start);
            start = k;
        }
    }
    if runs.is_empty() {
        return 1000.0;
    }
    runs.sort_unstable();
    runs[runs.len() / 2] as f64
}

/// Parameter space of `kind` for this recording.
pub fn spec(kind: Kind, prob: &Problem, fired: &[bool; NT], slosh_hint_hz: &[f64]) -> Spec {
    kind.effect().spec(&context(prob, fired, slosh_hint_hz))
}

/// Fits the effects `kinds` (new one last) jointly with the initial rate, starting from
/// `fixed` (earlier effects' current values) and each start of the new effect.
pub fn fit_joint(
    prob: &Problem,
    fired: &[bool; NT],
    accepted: &[(Kind, Vec<f64>)],
    new: Option<Kind>,
    nuis: &[f64],
    slosh_hint: &[f64],
    max_iter: usize,
) -> Option<(FitResult, Vec<usize>)> {
    fit_with_starts(prob, fired, accepted, new, None, nuis, slosh_hint, max_iter)
}

/// Continues the fit of `new` from `theta_new` (e.g. after a short screening fit).
#[allow(clippy::too_many_arguments)]
pub fn fit_from(
    prob: &Problem,
    fired: &[bool; NT],
    accepted: &[(Kind, Vec<f64>)],
    new: Kind,
    theta_new: &[f64],
    nuis: &[f64],
    slosh_hint: &[f64],
    max_iter: usize,
) -> Option<(FitResult, Vec<usize>)> {
    fit_with_starts(
        prob,
        fired,
        accepted,
        Some(new),
        Some(vec![theta_new.to_vec()]),
        nuis,
        slosh_hint,
        max_iter,
    )
}

#[allow(clippy::too_many_arguments)]
fn fit_with_starts(
    prob: &Problem,
    fired: &[bool; NT],
    accepted: &[(Kind, Vec<f64>)],
    new: Option<Kind>,
    starts: Option<Vec<Vec<f64>>>,
    nuis: &[f64],
    slosh_hint: &[f64],
    max_iter: usize,
) -> Option<(FitResult, Vec<usize>)> {
    // assemble the parameter layout: each accepted effect, then the new one, then omega0
    let mut kinds: Vec<Kind> = accepted.iter().map(|a| a.0).collect();
    if let Some(k) = new {
        kinds.push(k);
    }
    kinds.retain(|k| !k.effect().on_residual());
    let mut lo = vec![];
    let mut hi = vec![];
    let mut step = vec![];
    let mut base = vec![];
    let mut sizes = vec![];
    let mut two_sided = vec![];
    let mut new_starts = vec![vec![]];
    for (idx, k) in kinds.iter().enumerate() {
        let s = spec(*k, prob, fired, slosh_hint);
        two_sided.extend(std::iter::repeat_n(k.effect().kinked(), s.lo.len()));
        lo.extend(s.lo);
        hi.extend(s.hi);
        step.extend(s.step);
        // an effect with no start has nothing to fit on this recording
        sizes.push(s.starts.first()?.len());
        let is_new = new == Some(*k) && idx == kinds.len() - 1;
        if is_new {
            new_starts = starts.clone().unwrap_or(s.starts);
        } else {
            let th = &accepted.iter().find(|a| a.0 == *k).unwrap().1;
            base.extend(th.iter().cloned());
        }
    }
    let frozen_from = lo.len();
    lo.extend(std::iter::repeat_n(-3.0, nuis.len()));
    hi.extend(std::iter::repeat_n(3.0, nuis.len()));
    step.extend(std::iter::repeat_n(1e-5, nuis.len()));
    let kinds2 = kinds.clone();
    let sizes2 = sizes.clone();
    let fired2 = *fired;
    // what no fit steps (a mass-property change's time): a new effect's is searched by its
    // starts (and the change time's scan at the end), a named one's stays where that put it
    let mut held = vec![false; lo.len()];
    let mut off = 0;
    for (k, n) in kinds.iter().zip(&sizes) {
        for &j in k.effect().held() {
            held[off + j] = true;
        }
        off += n;
    }
    let change_at = (new == Some(Kind::MassPropertyChange)).then_some(base.len());
    // the nuisances' columns are taken once per fit
    let frozen: Vec<bool> = (0..lo.len()).map(|j| j >= frozen_from).collect();
    let fam = Family {
        apply: Box::new(move |th: &[f64]| {
            let mut acc: Vec<(Kind, Vec<f64>)> = vec![];
            let mut off = 0;
            for (k, &n) in kinds2.iter().zip(sizes2.iter()) {
                acc.push((*k, th[off..off + n].to_vec()));
                off += n;
            }
            Some(build(&fired2, &acc, &th[off..]))
        }),
        step,
        lo,
        hi,
        frozen,
        nuisance_from: frozen_from,
        two_sided,
        held,
    };
    // many starts: keep the two with the lowest cost before iterating; when every
    // start predicts the same (the new effect starts at "no effect"), after a short fit
    if new_starts.len() > 2 {
        // each start where the fit would start it
        let start_of = |st: &Vec<f64>| {
            let mut th0 = base.clone();
            th0.extend(st.iter().cloned());
            th0.extend_from_slice(nuis);
            fam.clamp(&mut th0);
            th0
        };
        let mut scored: Vec<(f64, Vec<f64>)> = new_starts
            .iter()
            .filter_map(|st| {
                Some((
                    (fam.apply)(&start_of(st)).and_then(|p| prob.cost(&p))?,
                    st.clone(),
                ))
            })
            .collect();
        let (lo_c, hi_c) = scored
            .iter()
            .fold((f64::MAX, f64::MIN), |(a, b), s| (a.min(s.0), b.max(s.0)));
        if hi_c - lo_c <= 1e-9 * lo_c.abs() {
            let off = base.len();
            let k_new = new_starts[0].len();
            scored = new_starts
                .iter()
                .filter_map(|st| {
                    let r = fit::fit(prob, &fam, &start_of(st), RANKING_ITERATIONS.min(max_iter))?;
                    Some((r.chi2, r.theta[off..off + k_new].to_vec()))
                })
                .collect();
        }
        scored.sort_by(|a, b| a.0.total_cmp(&b.0));
        new_starts = scored.into_iter().take(2).map(|s| s.1).collect();
    }
    let mut best: Option<FitResult> = None;
    // the model without the new effect, the yardstick of its starts (once per call)
    let without = new.and_then(|_| prob.cost(&build(fired, accepted, nuis)));
    for st in &new_starts {
        let mut th0 = base.clone();
        th0.extend(st.iter().cloned());
        th0.extend_from_slice(nuis);
        // scored where the fit will start
        fam.clamp(&mut th0);
        // a start that fits far worse than the model without the new effect, at the
        // nuisances that model was fitted with, has moved the whole trajectory: it gets
        // nuisances of its own first (the prediction at `th0` is the fit's first, so it
        // is a repeat the cache answers while the recording fits in it)
        if let Some(k) = new {
            let at_start = (fam.apply)(&th0).and_then(|p| prob.cost(&p));
            if let (Some(a), Some(w)) = (at_start, without) {
                if a > OWN_NUISANCE_ABOVE * w {
                    let mut with = accepted.to_vec();
                    with.push((k, th0[base.len()..base.len() + st.len()].to_vec()));
                    if let Some(f) = fit_nuisance_with(prob, &with, nuis) {
                        th0.truncate(th0.len() - nuis.len());
                        th0.extend_from_slice(&f.theta);
                    }
                }
            }
        }
        if let Some(r) = fit::fit(prob, &fam, &th0, max_iter) {
            if best.as_ref().map(|b| r.chi2 < b.chi2).unwrap_or(true) {
                best = Some(r);
            }
        }
    }
    // a change time only moves the prediction when it crosses a firing, so LM cannot walk
    // it: scan it around the best start's with the other parameters re-fitted to first order
    // (`profile`), then let LM settle the rest at the best point, from that re-fit; then
    // again around that point on a grid 10 times finer (a change during a firing moves the
    // fit continuously)
    if let Some(i) = change_at {
        let (dur, mut half) = change_window(prob.series);
        for pass in 0..CHANGE_SCAN_PASSES {
            let Some(b) = best.as_ref() else {
                break;
            };
            let profiled = |th: &[f64]| -> Option<(f64, Vec<f64>)> {
                let r = prob.weighted(&(fam.apply)(th)?)?;
                let Some(lin) = &b.linearised else {
                    return Some((r.norm_squared(), th.to_vec()));
                };
                let (cost, step) = lin.refit(&r)?;
                let mut start = th.to_vec();
                for (j, d) in step {
                    start[j] += d;
                }
                fam.clamp(&mut start);
                Some((cost, start))
            };
            let at_best = profiled(&b.theta).map(|p| p.0).unwrap_or(f64::INFINITY);
            let mut top = (at_best, b.theta.clone());
            let probes = if pass == 0 {
                change_probes(prob.series, b.theta[i], half, dur)
            } else {
                (0..=CHANGE_SCAN_POINTS)
                    .map(|k| {
                        (b.theta[i] - half + 2.0 * half * k as f64 / CHANGE_SCAN_POINTS as f64)
                            .clamp(0.0, dur)
                    })
                    .collect()
            };
            for at in probes {
                let mut th = b.theta.clone();
                th[i] = at;
                if let Some((c, start)) = profiled(&th) {
                    if c < top.0 {
                        top = (c, start);
                    }
                }
            }
            if top.0 < at_best {
                if let Some(r) = fit::fit(prob, &fam, &top.1, max_iter) {
                    if r.chi2 < b.chi2 {
                        best = Some(r);
                    }
                }
            }
            // the next pass spans two points of this one's grid each side
            half *= 4.0 / CHANGE_SCAN_POINTS as f64;
        }
    }
    best.map(|b| (b, sizes))
}

/// A new effect's start whose chi-square is above this many times the model's without it
/// gets nuisances of its own before it is fitted (`fit_with_starts`). The recording's own
/// inertia estimate on a 40 s tumble (`diagnose_random_craft` seed 86022) started at 28
/// times the model's with the model's nuisances and 0.003 times with its own; at any start
/// worse than the model (factor 1) the open sets' answers were the same for 13 % more
/// predictions (refits of starts a few percent worse), at 2 see the README.
const OWN_NUISANCE_ABOVE: f64 = 2.0;

/// Fits the nuisances (initial rate, rate jumps at gaps) of the model with `effects` held
/// at the given parameters.
pub(crate) fn fit_nuisance_with(
    prob: &Problem,
    effects: &[(Kind, Vec<f64>)],
    nuis: &[f64],
) -> Option<fit::FitResult> {
    let n = nuis.len();
    let fired = effects::fired_thrusters(prob.series);
    let fam = Family {
        apply: Box::new(move |th: &[f64]| Some(build(&fired, effects, th))),
        step: vec![1e-5; n],
        lo: vec![-3.0; n],
        hi: vec![3.0; n],
        frozen: vec![false; n],
        nuisance_from: 0,
        two_sided: vec![],
        held: vec![],
    };
    fit::fit(prob, &fam, nuis, 10)
}

/// Wald statistic of an effect's parameters against their "no effect" values, with their
/// covariance `cov` (the effect's own block): `d' C^-1 d` over the parameters with a finite
/// error. Correlated parameters are tested jointly: a valve's open and close latencies move
/// together when a slow sensor sees only their sum, and the sum of squared z-scores then
/// called a 40 ms / 20 ms latency noise (Wald 10 against a likelihood gain of 2,300) and a
/// thrust scale was named in its place. Without a usable covariance (an empty or singular
/// block), the sum of squared z-scores.
pub(crate) fn wald(
    kind: Kind,
    theta: &[f64],
    se: &[f64],
    cov: &nalgebra::DMatrix<f64>,
    prob: &Problem,
) -> f64 {
    let fired = effects::fired_thrusters(prob.series);
    let null = kind.effect().no_effect(theta, &context(prob, &fired, &[]));
    let live: Vec<(usize, f64, f64)> = null
        .iter()
        .filter_map(|&(i, v)| {
            let e = se.get(i).copied().unwrap_or(f64::INFINITY);
            (e > 0.0 && e.is_finite()).then(|| (i, (theta[i] - v) / e, e))
        })
        .collect();
    let diagonal: f64 = live.iter().map(|(_, z, _)| z * z).sum();
    let m = live.len();
    if m == 0 || cov.nrows() != theta.len() || cov.ncols() != theta.len() {
        return diagonal;
    }
    // the correlation matrix of the live parameters and their z-scores: `z' R^-1 z`
    let z = nalgebra::DVector::from_iterator(m, live.iter().map(|l| l.1));
    let r = nalgebra::DMatrix::from_fn(m, m, |a, b| {
        let (ia, _, ea) = live[a];
        let (ib, _, eb) = live[b];
        cov[(ia, ib)] / (ea * eb)
    });
    if !r.iter().all(|v| v.is_finite()) {
        return diagonal;
    }
    match r.cholesky() {
        Some(c) => {
            let w = z.dot(&c.solve(&z));
            if w.is_finite() {
                w
            } else {
                diagonal
            }
        }
        _ => diagonal,
    }
}

/// The valve latency (open, close ms) among `pairs`, zero when none.
/// A measurement delay counts as a latency on both edges (it shifts every edge as the rate
/// sensor sees it).
pub(crate) fn latency_of(pairs: &[(Kind, Vec<f64>)]) -> (f64, f64) {
    let (open, close) = pairs
        .iter()
        .find(|a| a.0 == Kind::ThrusterLatency)
        .map(|a| (a.1[0], a.1[1]))
        .unwrap_or((0.0, 0.0));
    let delay = pairs
        .iter()
        .find(|a| a.0 == Kind::MeasurementDelay)
        .map(|a| a.1[0])
        .unwrap_or(0.0);
    (open + delay, close + delay)
}

/// Mechanisms that share parameters cannot be fitted together.
pub(crate) fn combinable(a: Kind, b: Kind) -> bool {
    let mass = |k: Kind| {
        matches!(
            k,
            Kind::MassPropertyChange | Kind::Inertia | Kind::ComOffset
        )
    };
    let timing = |k: Kind| matches!(k, Kind::ThrusterLatency | Kind::MeasurementDelay);
    !(mass(a) && mass(b) && (a == Kind::MassPropertyChange || b == Kind::MassPropertyChange))
        && !(timing(a) && timing(b) && a != b)
}

#[cfg(test)]
mod tests {
    use super::*;
    use reference_f64::satellite::Satellite;

    /// Open and close latencies of 40 and 20 ms with errors of 14.2 ms each, correlated
    /// 0.98 (a slow sensor sees mostly their sum): each is within 3 sigma of 0, but their
    /// difference is 20 ms against an error of 2.8 ms. The joint statistic says so; the sum
    /// of squared z-scores (the planted fault: no covariance) said 10, under the 2 ln N
    /// penalty, and a thrust scale was named instead.
    #[test]
    fn the_wald_test_uses_the_parameters_correlation() {
        let sat = Satellite::builtin("sph2").unwrap();
        let plant = crate::model::Plant::new(&sat);
        let words: Vec<u16> = (0..3000)
            .map(|k| if k % 300 < 80 { 0b101 } else { 0 })
            .collect();
        let series = crate::model::tests::commanded(&sat, &words);
        let noise = crate::noise::NoiseModel::white([1e-6; 3]);
        let prob = Problem::new(&plant, &series, &noise);
        let theta = [40.0, 20.0];
        let se = [14.2, 14.2];
        let v = 14.2f64 * 14.2;
        let cov = nalgebra::DMatrix::from_row_slice(2, 2, &[v, 0.98 * v, 0.98 * v, v]);
        let joint = wald(Kind::ThrusterLatency, &theta, &se, &cov, &prob);
        // (40, 20) in the correlation's coordinates: sum 60 (error 28.1), difference 20 (2.84)
        let want = (60.0f64 / (2.0 * 1.98 * v).sqrt()).powi(2)
            + (20.0f64 / (2.0 * 0.02 * v).sqrt()).powi(2);
        assert!((joint - want).abs() < 1e-9 * want, "{joint} {want}");
        assert!(joint > 2.0 * 12.0, "{joint}");
        let none = nalgebra::DMatrix::zeros(0, 0);
        let diagonal = wald(Kind::ThrusterLatency, &theta, &se, &none, &prob);
        assert!((diagonal - (40.0f64.powi(2) + 20.0f64.powi(2)) / v).abs() < 1e-9);
        assert!(diagonal < 2.0 * 9.4, "{diagonal}");
        // uncorrelated: the two agree
        let independent = nalgebra::DMatrix::from_row_slice(2, 2, &[v, 0.0, 0.0, v]);
        let w = wald(Kind::ThrusterLatency, &theta, &se, &independent, &prob);
        assert!((w - diagonal).abs() < 1e-9 * diagonal);
    }

    /// Noiseless rates of a SPHERES spinning at (0.3, -0.2, 0.4) rad/s, commanded `words`
    /// (one a ms), whose Ixx grows 40 % and whose CoM moves 3 mm along x at `at_s`: its
    /// plant, the recording, a white noise model, and the inertia after the change.
    fn changed_flight(
        words: &[u16],
        at_s: f64,
    ) -> (
        crate::model::Plant,
        crate::series::Series,
        crate::noise::NoiseModel,
        [f64; 6],
    ) {
        let sat = Satellite::builtin("sph2").unwrap();
        let plant = crate::model::Plant::new(&sat);
        let mut series = crate::model::tests::commanded(&sat, words);
        let mut after = sat.inertia_kgm2;
        after[0] *= 1.4;
        let truth = Params {
            omega0: [0.3, -0.2, 0.4],
            mass_change: Some((at_s, [3.0, 0.0, 0.0], after)),
            ..Params::default()
        };
        let noise = crate::noise::NoiseModel::white([1e-6; 3]);
        series.rate = Problem::new(&plant, &series, &noise)
            .predict(&truth)
            .unwrap();
        (plant, series, noise, after)
    }

    /// A mass-property change's time is searched, never stepped: a named change refitted
    /// with the others stays at its time (with an error), and a new one is found in the
    /// coast that holds the true change. Noiseless rates of a spinning SPHERES whose Ixx
    /// grows 40 % and whose CoM moves 3 mm at 1.70 s, between the firings of 1.50-1.58
    /// and 1.80-1.88 s. The planted fault, the time stepped by the fit like the other
    /// parameters (`held` all false), moves the named change's time off 1.2 s.
    #[test]
    fn a_change_time_is_searched_not_stepped() {
        let words: Vec<u16> = (0..3000)
            .map(|k| if k % 300 < 80 { 0b101 } else { 0 })
            .collect();
        let (plant, series, noise, after) = changed_flight(&words, 1.7);
        let prob = Problem::new(&plant, &series, &noise);
        let fired = effects::fired_thrusters(&series);
        let nuis = [0.3, -0.2, 0.4];
        // named at a wrong time: refitted, the time stays and has an error
        let mut named = vec![1.2, 3.0, 0.0, 0.0];
        named.extend_from_slice(&after);
        let accepted = [(Kind::MassPropertyChange, named)];
        let (refit, _) = fit_joint(&prob, &fired, &accepted, None, &nuis, &[], 6).unwrap();
        assert_eq!(refit.theta[0], 1.2, "the named change's time was stepped");
        assert!(refit.stderr[0].is_finite() && refit.stderr[0] > 0.0);
        // new: the search finds the coast of the true change
        let (new, _) = fit_joint(
            &prob,
            &fired,
            &[],
            Some(Kind::MassPropertyChange),
            &nuis,
            &[],
            12,
        )
        .unwrap();
        assert!(new.theta[0] > 1.58 && new.theta[0] < 1.8, "{:?}", new.theta);
    }

    /// A new change's time is scanned with the other parameters re-fitted (`profile`):
    /// started in the wrong coast, its CoM and inertia fitted there, the scan finds the
    /// coast of the true change. Noiseless rates of a spinning SPHERES pulsed 30 ms every
    /// 100 ms, whose Ixx grows 40 % and whose CoM moves 3 mm at 1.75 s (coast 1.73-1.80 s).
    /// From starts at 1.62, 1.66 and 1.86 s the fit ends at 1.72-1.79 s; the planted fault,
    /// the scan with the others where they were fitted (`linearised` ignored), ends at 1.65,
    /// 1.67 and 1.85 s, in the coast it started in.
    #[test]
    fn a_change_time_is_scanned_with_the_rest_refitted() {
        let sat = Satellite::builtin("sph2").unwrap();
        let pattern = [
            0b1,
            0b100_0000,
            0b1_0000_0000,
            0b10,
            0b1000_0000,
            0b10_0000_0000,
        ];
        let words: Vec<u16> = (0..3000)
            .map(|k| {
                if k % 100 < 30 {
                    pattern[(k / 100) % 6]
                } else {
                    0
                }
            })
            .collect();
        let (plant, series, noise, _) = changed_flight(&words, 1.75);
        let prob = Problem::new(&plant, &series, &noise);
        let fired = effects::fired_thrusters(&series);
        let nuis = [0.3, -0.2, 0.4];
        for wrong in [1.62, 1.66, 1.86] {
            let mut start = vec![wrong, 0.0, 0.0, 0.0];
            start.extend_from_slice(&sat.inertia_kgm2);
            let (fr, _) = fit_from(
                &prob,
                &fired,
                &[],
                Kind::MassPropertyChange,
                &start,
                &nuis,
                &[],
                12,
            )
            .unwrap();
            assert!(
                fr.theta[0] > 1.70 && fr.theta[0] < 1.80,
                "{wrong}: {:?}",
                fr.theta
            );
        }
    }

    /// The first scan's probes: the 41-point grid and the command edges within the window
    /// (and the run), sorted, at most [`MAX_EDGE_PROBES`] edges (thinned evenly). A flight
    /// with an edge every 10 ms: 200 edges in a +-1 s window, 50 kept; near the start the
    /// window is clipped to the run. Planted fault: no thinning (all 200 kept).
    #[test]
    fn change_probes_are_the_grid_and_the_edges_in_the_window() {
        let sat = Satellite::builtin("sph2").unwrap();
        let words: Vec<u16> = (0..3000)
            .map(|k| if k % 20 < 10 { 0b101 } else { 0 })
            .collect();
        let series = crate::model::tests::commanded(&sat, &words);
        let (dur, _) = change_window(&series);
        let probes = change_probes(&series, 1.5, 1.0, dur);
        assert!(probes.windows(2).all(|p| p[0] < p[1]), "sorted, no repeats");
        assert!(
            probes.iter().all(|&t| (0.5..=2.5).contains(&t)),
            "{probes:?}"
        );
        // every 4th of the 200 edges (50), less those on the 50 ms grid
        let edges = probes.len() - (CHANGE_SCAN_POINTS + 1);
        assert!((30..=MAX_EDGE_PROBES).contains(&edges), "{edges}");
        // the grid's ends are there
        assert!(probes.contains(&0.5) && probes.contains(&2.5));
        // clipped to the run
        let near = change_probes(&series, 0.2, 1.0, dur);
        assert!(near.iter().all(|&t| (0.0..=1.2).contains(&t)) && near.contains(&0.0));
        // a window with no edge: the grid alone
        let quiet = crate::model::tests::commanded(&sat, &vec![0u16; 3000]);
        assert_eq!(
            change_probes(&quiet, 1.5, 1.0, dur).len(),
            CHANGE_SCAN_POINTS + 1
        );
    }
}
