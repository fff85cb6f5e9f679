//! The whole diagnosis: nominal prediction, noise, localisation, forward selection of
//! mechanisms by BIC, and the contract output.

use crate::candidate::{Trial, Tried};
use crate::effects::{self, Kind};
use crate::exchange;
use crate::fit::{self, Problem};
use crate::locate;
use crate::model::{Plant, NT};
use crate::noise::{self, NoiseModel};
use crate::output::{DataIssues, DiagnosisOutput, EffectReport, FORMAT};
use crate::ringing::{self, RingingFit};
use crate::select::{self, combinable, fit_nuisance_with, wald, Settings};
use crate::series::Series;
use crate::stats::{self, ResidualTests};

/// Prints how long a candidate took when MASSID_DIAG_PROFILE is set (development aid).
struct Timing(&'static str, std::time::Instant);

impl Drop for Timing {
    fn drop(&mut self) {
        if std::env::var_os("MASSID_DIAG_PROFILE").is_some() {
            eprintln!("  {:>22}: {:.2} s", self.0, self.1.elapsed().as_secs_f64());
        }
    }
}

/// One candidate's score in one selection round.
#[derive(Clone, Debug)]
pub struct Score {
    pub round: usize,
    pub effect: &'static str,
    pub delta_bic: f64,
}

/// Everything the reports need.
#[derive(Clone, Debug)]
pub struct Analysis {
    pub output: DiagnosisOutput,
    /// The recording as diagnosed (for plots).
    pub series: Series,
    pub residual_before: Vec<[f64; 3]>,
    pub residual_after: Vec<[f64; 3]>,
    pub noise: NoiseModel,
    pub tests_before: ResidualTests,
    pub tests_after: ResidualTests,
    /// Post-edge residual spectrum of the nominal model (frequency Hz, power).
    pub spectrum_before: Vec<(f64, f64)>,
    /// The statistic a tone must reach to be named (its parameters' BIC cost plus the
    /// acceptance margin): the spectrum's significance line.
    pub spectrum_threshold: f64,
    /// Apparent tone and the true frequencies it could fold from.
    pub alias_marks: (f64, Vec<f64>),
    pub scores: Vec<Score>,
    /// Strong candidates that were not named, with the reason.
    pub rejections: Vec<Rejection>,
    pub by_condition_before: Vec<(locate::Condition, usize, [f64; 3])>,
    pub by_condition_after: Vec<(locate::Condition, usize, [f64; 3])>,
    /// The named effects' parameters in the model's layout, in acceptance order (what
    /// a held-out prediction runs with, `holdout.rs`).
    pub fitted: Vec<(Kind, Vec<f64>)>,
}

struct Accepted {
    kind: Kind,
    theta: Vec<f64>,
    stderr: Vec<f64>,
    delta_bic: f64,
    rms_after: [f64; 3],
    windows: Vec<[i64; 2]>,
    evidence: String,
}

/// Fits the nuisances (initial rate, rate jumps at gaps) of the nominal model.
fn fit_nuisance(prob: &Problem, nuis: &[f64]) -> Option<fit::FitResult> {
    fit_nuisance_with(prob, &[], nuis)
}

/// Mean of the first usable samples per axis as the starting initial rate.
pub(crate) fn initial_rate(series: &Series) -> [f64; 3] {
    std::array::from_fn(|a| {
        let first: Vec<f64> = (0..series.len())
            .filter(|&i| series.valid[i][a])
            .take(5)
            .map(|i| series.rate[i][a])
            .collect();
        if first.is_empty() {
            0.0
        } else {
            first.iter().sum::<f64>() / first.len() as f64
        }
    })
}

/// Low-frequency peaks of the nominal residual (slosh starting points), Hz.
fn slosh_hints(series: &Series, r: &[[f64; 3]]) -> Vec<f64> {
    let mask = noise::coasting_mask(series, 100);
    let step = (series.sample_rate_hz / 20.0).max(1.0) as usize;
    let mut t = vec![];
    let mut y: [Vec<f64>; 3] = Default::default();
    for i in (0..series.len()).step_by(step) {
        if mask[i] && series.valid[i].iter().all(|&v| v) {
            t.push(series.t_ms[i] as f64 * 1e-3);
            for a in 0..3 {
                y[a].push(r[i][a]);
            }
        }
    }
    if t.len() < 50 {
        return vec![0.4];
    }
    let freqs = crate::spectrum::grid(0.05, 5.0, 400);
    let mut tot = vec![0.0; freqs.len()];
    for a in 0..3 {
        // remove a linear trend per axis so drift does not dominate
        let p = crate::spectrum::lomb_scargle(&t, &detrend(&t, &y[a]), &freqs);
        for (x, v) in tot.iter_mut().zip(p) {
            *x += v;
        }
    }
    let mut idx: Vec<usize> = (1..freqs.len() - 1)
        .filter(|&i| tot[i] >= tot[i - 1] && tot[i] >= tot[i + 1])
        .collect();
    idx.sort_by(|&a, &b| tot[b].total_cmp(&tot[a]));
    let mut out: Vec<f64> = idx.iter().take(2).map(|&i| freqs[i]).collect();
    if out.is_empty() {
        out.push(0.4);
    }
    out
}

fn detrend(t: &[f64], y: &[f64]) -> Vec<f64> {
    let n = t.len() as f64;
    let mt = t.iter().sum::<f64>() / n;
    let my = y.iter().sum::<f64>() / n;
    let sxy: f64 = t.iter().zip(y).map(|(a, b)| (a - mt) * (b - my)).sum();
    let sxx: f64 = t.iter().map(|a| (a - mt).powi(2)).sum();
    let b = if sxx > 0.0 { sxy / sxx } else { 0.0 };
    t.iter()
        .zip(y)
        .map(|(a, v)| v - my - b * (a - mt))
        .collect()
}

/// A change in time must have firings on both sides of it to be seen: a mass-property
/// change before the first or after the last firing is a constant inertia / CoM error (or
/// nothing), and a blowdown starting after the last firing cannot be observed.
fn observable(kind: Kind, theta: &[f64], series: &Series) -> bool {
    let first =
        series.real_ms(series.word_ms.iter().position(|&w| w != 0).unwrap_or(0) as f64) * 1e-3;
    let last =
        series.real_ms(series.word_ms.iter().rposition(|&w| w != 0).unwrap_or(0) as f64) * 1e-3;
    kind.effect().observable(theta, first, last)
}

/// Runs the diagnosis of `series` against the satellite `plant`; `None` when the nominal
/// model does not predict the recording (a non-finite prediction).
pub fn diagnose(
    series: &Series,
    plant: &Plant,
    recording: &str,
    model: &str,
    issues: DataIssues,
    settings: &Settings,
) -> Option<Analysis> {
    let fired = effects::fired_thrusters(series);
    // 1. nominal prediction with the initial rate fitted, noise from its residual
    let provisional = NoiseModel::white([1e-6; 3]);
    let prob0 = Problem::new(plant, series, &provisional);
    let mut start = initial_rate(series).to_vec();
    start.extend(std::iter::repeat_n(0.0, 3 * series.gap_resets.len()));
    let w0 = fit_nuisance(&prob0, &start)
        .map(|f| f.theta)
        .unwrap_or(start);
    // no prediction (an extreme model can make it non-finite): nothing to diagnose
    // against, which the caller reports as an error rather than a residual of zero
    let r0 = prob0.residual(&select::nuisance_params(&w0))?;
    let noise = noise::estimate(series, &r0);
    let mut prob = Problem::new(plant, series, &noise);
    prob.stride = (series.sample_rate_hz / 200.0).round().max(1.0) as usize;
    let nominal = fit_nuisance(&prob, &w0);
    let mut omega0: Vec<f64> = nominal.as_ref().map(|f| f.theta.clone()).unwrap_or(w0);
    let nominal_params = select::nuisance_params(&omega0);
    let residual_before = prob.residual(&nominal_params)?;
    let chi2_nominal = prob.chi2(&nominal_params).unwrap_or(f64::INFINITY);
    let n_obs = prob.n_obs() as f64;
    let ln_n = n_obs.max(2.0).ln();
    let slosh_hint = slosh_hints(series, &residual_before);

    // 2. forward selection. The rigid-body part is refitted jointly after every
    // acceptance; ringing (additive, random phase per edge) lives on the residual.
    let mut accepted: Vec<Accepted> = vec![];
    let mut chi2_rigid = chi2_nominal;
    let mut ringing_fit: Option<RingingFit> = None;
    let mut k_cur = 0usize;
    let mut scores = vec![];
    let mut rejections: Vec<Rejection> = vec![];
    let mut rigid_residual = residual_before.clone();
    let mut residual_cur = residual_before.clone();
    let mut alias_marks = (0.0, vec![]);
    let mut joint_stderr: Vec<f64> = vec![];
    let mut sizes: Vec<usize> = vec![];
    let whitening = noise.ar(4);
    let mut spectrum_before: Vec<(f64, f64)> = vec![];
    let mut spectrum_threshold = f64::NAN;
    // the ringing fit of the current rigid residual (recomputed only when it changes)
    let mut ringing_cache: Option<Option<RingingFit>> = None;
    // valve latency of the accepted effects: ringing is excited at the actual valve motion
    let mut latency = (0.0, 0.0);
    for round in 0..settings.max_effects {
        let ring_gain = ringing_fit.as_ref().map(|r| r.gain).unwrap_or(0.0);
        let chi2_cur = chi2_rigid - ring_gain;
        let acc_pairs: Vec<(Kind, Vec<f64>)> =
            accepted.iter().map(|a| (a.kind, a.theta.clone())).collect();
        let mut ranked: Vec<(f64, Kind, Vec<f64>, String, Option<RingingFit>)> = vec![];
        let mut screened: Vec<(
            f64,
            Kind,
            Vec<f64>,
            f64,
            String,
            Option<RingingFit>,
            Vec<f64>,
        )> = vec![];
        for &kind in Kind::ALL.iter() {
            if accepted.iter().any(|a| a.kind == kind) {
                continue;
            }
            // mechanisms that share parameters (or give the same rates) cannot be combined
            if !accepted.iter().all(|a| combinable(a.kind, kind))
                || !kind
                    .effect()
                    .applies(&select::context(&prob, &fired, &slosh_hint))
            {
                continue;
            }
            let k_new = effects::n_params(kind, &fired);
            if k_new == 0 {
                continue;
            }
            let screen_iter = settings.max_iter.min(3);
            let t_cand = std::time::Instant::now();
            let _timing = Timing(kind.name(), t_cand);
            if kind.effect().on_residual() {
                if ringing_cache.is_none() {
                    let rf = ringing::fit(
                        series,
                        &rigid_residual,
                        &whitening,
                        settings.ringing_prior_hz,
                        latency,
                    );
                    if spectrum_before.is_empty() {
                        if let Some(r) = &rf {
                            spectrum_before = r.scan.clone();
                            spectrum_threshold = k_new as f64 * ln_n + settings.accept_margin;
                        }
                    }
                    ringing_cache = Some(rf);
                }
                let Some(rf) = ringing_cache.clone().flatten() else {
                    continue;
                };
                let dbic = -rf.gain + k_new as f64 * ln_n;
                screened.push((
                    dbic,
                    kind,
                    vec![],
                    chi2_cur - rf.gain,
                    rf.evidence.clone(),
                    Some(rf),
                    vec![],
                ));
            } else {
                let Some((fr, sz)) = select::fit_joint(
                    &prob,
                    &fired,
                    &acc_pairs,
                    Some(kind),
                    &omega0,
                    &slosh_hint,
                    screen_iter,
                ) else {
                    continue;
                };
                let off: usize = sz[..sz.len() - 1].iter().sum();
                let chi2 = fr.chi2 - ring_gain;
                let k_live = fit::identifiable(&fr.stderr[off..off + k_new]);
                screened.push((
                    chi2 - chi2_cur + k_live as f64 * ln_n,
                    kind,
                    fr.theta[off..off + k_new].to_vec(),
                    chi2,
                    String::new(),
                    None,
                    fr.stderr[off..off + k_new].to_vec(),
                ));
            }
        }
        // full fits for the best screened candidates
        screened.sort_by(|a, b| a.0.total_cmp(&b.0));
        if std::env::var_os("MASSID_DIAG_PROFILE").is_some() {
            for s in &screened {
                let th: Vec<String> = s.2.iter().take(4).map(|v| format!("{v:.4}")).collect();
                eprintln!(
                    "  screened {:>22}: delta BIC {:.0} at [{}]",
                    s.1.name(),
                    s.0,
                    th.join(" ")
                );
            }
        }
        for (i, (dbic, kind, theta, chi2, note, rf, se)) in screened.into_iter().enumerate() {
            let k_new = effects::n_params(kind, &fired);
            let k_live = if se.is_empty() {
                k_new
            } else {
                fit::identifiable(&se)
            };
            let (dbic, theta, se) = if i < 3 && dbic < 0.0 && !kind.effect().on_residual() {
                match select::fit_from(
                    &prob,
                    &fired,
                    &acc_pairs,
                    kind,
                    &theta,
                    &omega0,
                    &slosh_hint,
                    settings.max_iter,
                ) {
                    Some((fr, sz)) if fr.chi2 - ring_gain < chi2 => {
                        let off: usize = sz[..sz.len() - 1].iter().sum();
                        (
                            fr.chi2 - ring_gain - chi2_cur + k_live as f64 * ln_n,
                            fr.theta[off..off + k_new].to_vec(),
                            fr.stderr[off..off + k_new].to_vec(),
                        )
                    }
                    _ => (dbic, theta, se),
                }
            } else {
                (dbic, theta, se)
            };
            scores.push(Score {
                round,
                effect: kind.name(),
                delta_bic: dbic,
            });
            // backing test: the effect's own parameters must differ from "no effect" by
            // more than the BIC penalty in their own (colour-corrected) uncertainty, so a
            // candidate that only helps the others converge is not taken for physics
            let w = if kind.effect().on_residual() {
                f64::INFINITY
            } else {
                wald(kind, &theta, &se, &prob)
            };
            if w < k_live as f64 * ln_n {
                if dbic <= -settings.accept_margin {
                    let reason = format!("its own parameters are within their noise of no effect (Wald {w:.1} < {:.1})", k_live as f64 * ln_n);
                    rejections.push(Rejection {
                        round,
                        effect: kind.name(),
                        delta_bic: dbic,
                        reason,
                    });
                }
            } else if !observable(kind, &theta, series) {
                if dbic <= -settings.accept_margin {
                    let reason = "its change time has no firing on one side, so it cannot be told from a constant error".into();
                    rejections.push(Rejection {
                        round,
                        effect: kind.name(),
                        delta_bic: dbic,
                        reason,
                    });
                }
            } else {
                ranked.push((dbic, kind, theta, note, rf));
            }
        }
        ranked.sort_by(|a, b| a.0.total_cmp(&b.0));
        // a mass-property change can mimic a constant inertia error plus a CoM offset by
        // switching half-way; it is named only if it beats that static pair
        if ranked
            .first()
            .map(|r| r.1 == Kind::MassPropertyChange)
            .unwrap_or(false)
            && !accepted
                .iter()
                .any(|a| matches!(a.kind, Kind::Inertia | Kind::ComOffset))
        {
            let mut pairs = acc_pairs.clone();
            pairs.push((Kind::Inertia, prob.plant.nominal_inertia().to_vec()));
            if let Some((fr, sz)) = select::fit_joint(
                &prob,
                &fired,
                &pairs,
                Some(Kind::ComOffset),
                &omega0,
                &slosh_hint,
                settings.max_iter,
            ) {
                // the inertia and CoM offset terms the data can identify
                let off: usize = sz[..sz.len() - 2].iter().sum();
                let k_static =
                    fit::identifiable(&fr.stderr[off..off + sz[sz.len() - 2] + sz[sz.len() - 1]]);
                let static_bic = fr.chi2 - ring_gain - chi2_cur + k_static as f64 * ln_n;
                if static_bic < ranked[0].0 {
                    let r = ranked.remove(0);
                    // said, so that no later text calls it merely the next best
                    rejections.push(Rejection {
                        round,
                        effect: r.1.name(),
                        delta_bic: r.0,
                        reason: format!(
                            "a constant inertia error plus CoM offset, which a change half-way can mimic, fits better (delta BIC {static_bic:.0})"
                        ),
                    });
                }
            }
        }
        // the strongest candidates by BIC, each tried against the checks that generalise
        // (acceptance.rs); the first that passes is named, the others say why not
        let sigma = noise.var.map(f64::sqrt);
        let rms_prev = locate::rms(&residual_cur, &series.valid);
        let tests_prev = stats::residual_tests(series, &residual_cur);
        let rigid_acc: Vec<(Kind, Vec<f64>)> = acc_pairs
            .iter()
            .filter(|p| !p.0.effect().on_residual())
            .cloned()
            .collect();
        // one verdict for a single effect and for a set named together
        let trial = Trial {
            prob: &prob,
            fired: &fired,
            rigid_acc: &rigid_acc,
            nuis: &omega0,
            hint: &slosh_hint,
            settings,
            rigid_residual: &rigid_residual,
            whitening: &whitening,
            ringing_on: ringing_fit.is_some(),
            sigma,
            rms_prev,
            tests_prev: &tests_prev,
        };
        let pool: Vec<(f64, Kind, Vec<f64>)> = ranked
            .iter()
            .filter(|r| r.0 <= -settings.accept_margin && !r.1.effect().on_residual())
            .take(PAIR_POOL)
            .map(|r| (r.0, r.1, r.2.clone()))
            .collect();
        let mut taken: Option<(Vec<(f64, Kind, String)>, Tried)> = None;
        for (dbic, kind, theta, note, rf) in ranked.into_iter().take(MAX_TRIES) {
            if dbic > -settings.accept_margin {
                break;
            }
            match trial.check(&[(kind, theta)], rf) {
                Ok(t) => {
                    taken = Some((vec![(dbic, kind, note)], t));
                    break;
                }
                Err(reason) => rejections.push(Rejection {
                    round,
                    effect: kind.name(),
                    delta_bic: dbic,
                    reason,
                }),
            }
        }
        // no single effect generalises: two true effects can each fail alone (each fit
        // alone is a compromise that predicts some held-out block worse), so the
        // strongest pairs are fitted jointly and put through the same checks
        if taken.is_none() && pool.len() >= 2 {
            let _timing = Timing("pairs", std::time::Instant::now());
            let mut pairs = vec![];
            for a in 0..pool.len() {
                for b in a + 1..pool.len() {
                    let (ka, kb) = (pool[a].1, pool[b].1);
                    if !combinable(ka, kb) {
                        continue;
                    }
                    let new = [(ka, pool[a].2.clone()), (kb, pool[b].2.clone())];
                    let mut start = rigid_acc.clone();
                    start.extend_from_slice(&new);
                    let Some((fr, sz)) = select::fit_joint(
                        &prob,
                        &fired,
                        &start,
                        None,
                        &omega0,
                        &slosh_hint,
                        settings.max_iter * 2,
                    ) else {
                        continue;
                    };
                    let off_a: usize = sz[..sz.len() - 2].iter().sum();
                    let off_b = off_a + sz[sz.len() - 2];
                    let end = off_b + sz[sz.len() - 1];
                    let k_pair = fit::identifiable(&fr.stderr[off_a..end]);
                    let dbic = fr.chi2 - ring_gain - chi2_cur + k_pair as f64 * ln_n;
                    // each must earn its place beside the other
                    if dbic > pool[a].0.min(pool[b].0) - settings.accept_margin {
                        continue;
                    }
                    let own = |kind: Kind, from: usize, to: usize| {
                        let se = &fr.stderr[from..to];
                        wald(kind, &fr.theta[from..to], se, &prob)
                            >= fit::identifiable(se) as f64 * ln_n
                    };
                    if !own(ka, off_a, off_b) || !own(kb, off_b, end) {
                        continue;
                    }
                    let fitted = [
                        (ka, fr.theta[off_a..off_b].to_vec()),
                        (kb, fr.theta[off_b..end].to_vec()),
                    ];
                    pairs.push((dbic, fitted));
                }
            }
            pairs.sort_by(|x, y| x.0.total_cmp(&y.0));
            for (dbic, new) in pairs.into_iter().take(MAX_TRIES) {
                match trial.check(&new, None) {
                    Ok(t) => {
                        let together = |other: Kind| {
                            format!("named together with {}: alone neither generalised, together they predict held-out blocks better (delta BIC {dbic:.0} for both)", other.name())
                        };
                        taken = Some((
                            vec![
                                (dbic, new[0].0, together(new[1].0)),
                                (dbic, new[1].0, together(new[0].0)),
                            ],
                            t,
                        ));
                        break;
                    }
                    Err(reason) => rejections.push(Rejection {
                        round,
                        effect: new[0].0.name(),
                        delta_bic: dbic,
                        reason: format!("together with {}: {reason}", new[1].0.name()),
                    }),
                }
            }
        }
        let Some((named, t)) = taken else {
            break;
        };
        let residual_prev = residual_cur.clone();
        if named[0].1.effect().on_residual() {
            if let Some(rf) = &t.ringing {
                alias_marks = (
                    rf.apparent_hz,
                    crate::alias::candidates(
                        rf.apparent_hz,
                        series.sample_rate_hz,
                        ringing::F_MAX_HZ,
                    ),
                );
            }
        } else {
            omega0 = t.nuis.clone();
            chi2_rigid = t.chi2_rigid;
            rigid_residual = t.rigid_residual.clone();
            joint_stderr = t.stderr.clone();
            sizes = t.sizes.clone();
            ringing_cache = None;
            latency = t.latency;
        }
        for a in accepted.iter_mut() {
            if let Some((_, th)) = t.pairs.iter().find(|p| p.0 == a.kind) {
                a.theta = th.clone();
            }
        }
        ringing_fit = t.ringing.clone();
        residual_cur = t.residual.clone();
        k_cur += named
            .iter()
            .map(|n| t.identifiable(n.1, &fired))
            .sum::<usize>();
        let chi2_total = chi2_rigid - ringing_fit.as_ref().map(|r| r.gain).unwrap_or(0.0);
        let delta_bic_total = chi2_total - chi2_nominal + k_cur as f64 * ln_n;
        for (dbic, kind, note) in named {
            let theta = t
                .pairs
                .iter()
                .find(|p| p.0 == kind)
                .map(|p| p.1.clone())
                .unwrap_or_default();
            let width = kind.effect().window_ms();
            let windows = locate::top_windows(series, &residual_prev, &residual_cur, width, 3)
                .into_iter()
                .map(|w| w.map(|t| series.real_ms(t as f64).round() as i64))
                .collect();
            // thrust scale names its most-off thruster below, from the final fit
            let evidence = describe(
                kind,
                series,
                &residual_prev,
                &residual_cur,
                dbic,
                &note,
                &scores,
                &rejections,
                round,
            );
            accepted.push(Accepted {
                kind,
                theta,
                stderr: vec![],
                delta_bic: delta_bic_total,
                rms_after: locate::rms(&residual_cur, &series.valid),
                windows,
                evidence,
            });
        }
    }
    // 3. exchange (`exchange.rs`): each named rigid effect in turn is offered the unnamed
    // mechanism that fits best in its place; a swap keeps the joint fit's order (the
    // newcomer goes last) and updates the state as an acceptance does
    if accepted
        .iter()
        .filter(|a| !a.kind.effect().on_residual())
        .count()
        >= 2
    {
        let _timing = Timing("exchange", std::time::Instant::now());
        let sigma = noise.var.map(f64::sqrt);
        let mut e = 0;
        let mut swaps = 0;
        while e < accepted.len() {
            let out = accepted[e].kind;
            if out.effect().on_residual() {
                e += 1;
                continue;
            }
            let rest: Vec<(Kind, Vec<f64>)> = accepted
                .iter()
                .filter(|a| a.kind != out && !a.kind.effect().on_residual())
                .map(|a| (a.kind, a.theta.clone()))
                .collect();
            let k_out = joint_identifiable(&accepted, &sizes, &joint_stderr, out, &fired);
            let k_rest = k_cur - k_out;
            let bic_now = chi2_rigid + k_cur as f64 * ln_n;
            if swaps == MAX_SWAPS {
                break;
            }
            let rms_prev = locate::rms(&residual_cur, &series.valid);
            let tests_prev = stats::residual_tests(series, &residual_cur);
            let trial = Trial {
                prob: &prob,
                fired: &fired,
                rigid_acc: &rest,
                nuis: &omega0,
                hint: &slosh_hint,
                settings,
                rigid_residual: &rigid_residual,
                whitening: &whitening,
                ringing_on: ringing_fit.is_some(),
                sigma,
                rms_prev,
                tests_prev: &tests_prev,
            };
            // backward step: an effect the others now stand in for (two names for one
            // thing, e.g. a uniform thrust scale beside an inertia) is dropped when the
            // model without it has the lower BIC
            if let Ok(t) = trial.without() {
                let bic_without = t.chi2_rigid + k_rest as f64 * ln_n;
                // the others refitted without it must still be physics
                let cx = select::context(&prob, &fired, &slosh_hint);
                let still_plausible = t.pairs.iter().all(|(k, th)| {
                    let sp = select::spec(*k, &prob, &fired, &slosh_hint);
                    crate::acceptance::implausible(*k, th, &cx, &sp.lo, &sp.hi).is_none()
                });
                if bic_without < bic_now && still_plausible {
                    let gone = accepted.remove(e);
                    rejections.push(Rejection {
                        round: settings.max_effects,
                        effect: gone.kind.name(),
                        delta_bic: gone.delta_bic,
                        reason: format!(
                            "named, then dropped: the other named effects stand in for it (without it the BIC is lower by {:.0})",
                            bic_now - bic_without
                        ),
                    });
                    for a in accepted.iter_mut() {
                        if let Some((_, th)) = t.pairs.iter().find(|p| p.0 == a.kind) {
                            a.theta = th.clone();
                        }
                    }
                    omega0 = t.nuis.clone();
                    chi2_rigid = t.chi2_rigid;
                    rigid_residual = t.rigid_residual.clone();
                    joint_stderr = t.stderr.clone();
                    sizes = t.sizes.clone();
                    latency = t.latency;
                    ringing_fit = t.ringing.clone();
                    residual_cur = t.residual.clone();
                    k_cur = k_rest;
                    // the last entry is the whole model again
                    if let Some(a) = accepted.last_mut() {
                        a.rms_after = locate::rms(&residual_cur, &series.valid);
                        a.delta_bic = chi2_rigid
                            - ringing_fit.as_ref().map(|r| r.gain).unwrap_or(0.0)
                            - chi2_nominal
                            + k_cur as f64 * ln_n;
                    }
                    swaps += 1;
                    continue;
                }
            }
            let named: Vec<Kind> = accepted.iter().map(|a| a.kind).collect();
            let verdict = exchange::replacement(&trial, out, &named, k_rest, bic_now, ln_n);
            match verdict {
                Ok(None) => e += 1,
                Ok(Some(exchange::Swap {
                    kind,
                    tried: t,
                    k_in,
                    delta_bic: dbic,
                })) => {
                    swaps += 1;
                    let gone = accepted.remove(e);
                    rejections.push(Rejection {
                        round: settings.max_effects,
                        effect: gone.kind.name(),
                        delta_bic: gone.delta_bic,
                        reason: format!(
                            "named first, then replaced by {}: with the other named effects refitted it fits better (delta BIC {dbic:.0})",
                            kind.name()
                        ),
                    });
                    for a in accepted.iter_mut() {
                        if let Some((_, th)) = t.pairs.iter().find(|p| p.0 == a.kind) {
                            a.theta = th.clone();
                        }
                    }
                    let residual_prev = residual_cur.clone();
                    omega0 = t.nuis.clone();
                    chi2_rigid = t.chi2_rigid;
                    rigid_residual = t.rigid_residual.clone();
                    joint_stderr = t.stderr.clone();
                    sizes = t.sizes.clone();
                    latency = t.latency;
                    ringing_fit = t.ringing.clone();
                    residual_cur = t.residual.clone();
                    k_cur = k_rest + k_in;
                    let chi2_total =
                        chi2_rigid - ringing_fit.as_ref().map(|r| r.gain).unwrap_or(0.0);
                    let windows = locate::top_windows(
                        series,
                        &residual_prev,
                        &residual_cur,
                        kind.effect().window_ms(),
                        3,
                    )
                    .into_iter()
                    .map(|w| w.map(|t| series.real_ms(t as f64).round() as i64))
                    .collect();
                    // the rigid effects keep the joint fit's order: the newcomer goes last
                    accepted.push(Accepted {
                        kind,
                        theta: t.pairs.last().map(|p| p.1.clone()).unwrap_or_default(),
                        stderr: vec![],
                        delta_bic: chi2_total - chi2_nominal + k_cur as f64 * ln_n,
                        rms_after: locate::rms(&residual_cur, &series.valid),
                        windows,
                        evidence: format!(
                            "{}; named in place of {}, which the forward selection chose first and which stood in for it: with the other named effects refitted, it fits better (delta BIC {dbic:.0}) and passes every check",
                            kind.effect().signature(),
                            out.name()
                        ),
                    });
                    // the effect now at position e has not been tried yet
                }
                Err((kind, delta_bic, reason)) => {
                    rejections.push(Rejection {
                        round: settings.max_effects,
                        effect: kind.name(),
                        delta_bic,
                        reason: format!("in place of {}: {reason}", out.name()),
                    });
                    e += 1;
                }
            }
        }
    }
    // standard errors of the rigid effects come from the last joint fit
    let mut off = 0;
    let rigid_idx: Vec<usize> = (0..accepted.len())
        .filter(|&i| !accepted[i].kind.effect().on_residual())
        .collect();
    for (j, &i) in rigid_idx.iter().enumerate() {
        let n = sizes.get(j).copied().unwrap_or(0);
        accepted[i].stderr = joint_stderr
            .get(off..off + n)
            .map(|s| s.to_vec())
            .unwrap_or_default();
        off += n;
    }
    for a in accepted
        .iter_mut()
        .filter(|a| a.kind.effect().on_residual())
    {
        if let Some(rf) = &ringing_fit {
            a.theta = vec![
                rf.freq_hz,
                rf.decay_ms,
                rf.amplitude[0],
                rf.amplitude[1],
                rf.amplitude[2],
            ];
            a.stderr = vec![rf.freq_stderr, rf.decay_stderr];
        }
    }

    for a in accepted.iter_mut().filter(|a| a.kind == Kind::ThrustScale) {
        // name the thruster that is most off nominal, as finally fitted, with its uncertainty
        let fired_idx: Vec<usize> = (0..NT).filter(|&i| fired[i]).collect();
        if let Some((j, v)) = a
            .theta
            .iter()
            .enumerate()
            .max_by(|x, y| (x.1 - 1.0).abs().total_cmp(&(y.1 - 1.0).abs()))
        {
            let se = a.stderr.get(j).copied().unwrap_or(f64::INFINITY);
            a.evidence = format!(
                "thruster {} delivers {} % of its nominal force; {}",
                fired_idx.get(j).map(|i| i + 1).unwrap_or(0),
                crate::numfmt::value_pm(100.0 * v, 100.0 * se),
                a.evidence
            );
        }
    }
    let effects_out: Vec<EffectReport> = accepted
        .iter()
        .map(|a| {
            let others: Vec<Kind> = accepted
                .iter()
                .map(|o| o.kind)
                .filter(|&k| k != a.kind)
                .collect();
            report_effect(a, &others, &select::context(&prob, &fired, &[]), plant)
        })
        .collect();
    // a named ringing accounts for its post-edge windows as a random tone
    let mut ringing_windows = vec![false; series.len()];
    if let Some(rf) = &ringing_fit {
        // every sample within five decay times of the last valve shock (however short the
        // pulse, so not only the windows long enough to fit the tone in)
        let edges = series.edges();
        let mut e = 0;
        for (i, m) in ringing_windows.iter_mut().enumerate() {
            let t = series.t_ms[i] as f64;
            while e < edges.len() && (edges[e].0 as f64) + latency.0.min(latency.1) <= t {
                e += 1;
            }
            *m = e > 0 && t - edges[e - 1].0 as f64 <= 5.0 * rf.decay_ms + latency.0.max(latency.1);
        }
    }
    let unexplained = crate::unexplained::verdict(series, &residual_cur, &noise, &ringing_windows);
    let output = DiagnosisOutput {
        format: FORMAT.into(),
        recording: recording.into(),
        model: model.into(),
        samples: series.len() as u64,
        residual_rms_before: locate::rms(&residual_before, &series.valid),
        residual_rms_after: locate::rms(&residual_cur, &series.valid),
        effects: effects_out,
        unexplained,
        data_issues: issues,
        noise: Some(noise.report()),
    };
    Some(Analysis {
        fitted: accepted.iter().map(|a| (a.kind, a.theta.clone())).collect(),
        output,
        series: series.clone(),
        tests_before: stats::residual_tests_for(series, &residual_before, &noise),
        tests_after: stats::residual_tests_for(series, &residual_cur, &noise),
        by_condition_before: locate::by_condition(series, &residual_before),
        by_condition_after: locate::by_condition(series, &residual_cur),
        residual_before,
        residual_after: residual_cur,
        noise,
        spectrum_before,
        spectrum_threshold,
        alias_marks,
        scores,
        rejections,
    })
}

/// How many of a round's strongest candidates (or pairs) are tried against the acceptance
/// checks.
const MAX_TRIES: usize = 3;
/// At most this many exchanges after the forward selection (each lowers the BIC by the
/// margin, so the step ends anyway; this bounds its cost).
const MAX_SWAPS: usize = 3;
/// When no single candidate passes, pairs are formed from this many of the strongest.
const PAIR_POOL: usize = 5;

/// How many of the named `kind`'s parameters the last joint fit identified.
fn joint_identifiable(
    accepted: &[Accepted],
    sizes: &[usize],
    stderr: &[f64],
    kind: Kind,
    fired: &[bool; NT],
) -> usize {
    let rigid = accepted.iter().filter(|a| !a.kind.effect().on_residual());
    let mut off = 0;
    for (a, &n) in rigid.zip(sizes) {
        if a.kind == kind {
            return stderr.get(off..off + n).map(fit::identifiable).unwrap_or(n);
        }
        off += n;
    }
    effects::n_params(kind, fired)
}

/// A candidate the diagnosis did not name, and why.
#[derive(Clone, Debug)]
pub struct Rejection {
    pub round: usize,
    pub effect: &'static str,
    pub delta_bic: f64,
    pub reason: String,
}

fn axes_label(gain: [f64; 3]) -> String {
    let tot: f64 = gain.iter().map(|g| g.max(0.0)).sum();
    if tot <= 0.0 {
        return "no axis".into();
    }
    let names = ["x", "y", "z"];
    let mut v: Vec<String> = (0..3)
        .filter(|&a| gain[a] > 0.15 * tot)
        .map(|a| format!("{} ({:.0} %)", names[a], 100.0 * gain[a] / tot))
        .collect();
    if v.is_empty() {
        v.push("spread over axes".into());
    }
    v.join(", ")
}

/// Evidence sentence: what structure the effect explains, where, and what it beat.
#[allow(clippy::too_many_arguments)]
fn describe(
    kind: Kind,
    series: &Series,
    before: &[[f64; 3]],
    after: &[[f64; 3]],
    dbic: f64,
    note: &str,
    scores: &[Score],
    rejections: &[Rejection],
    round: usize,
) -> String {
    // where the explained error is created: the residual's change over 20 ms, by condition
    let lag = (20.0f64).max(1000.0 / series.sample_rate_hz).round() as i64;
    let cb = locate::by_condition(series, &locate::differenced(series, before, lag));
    let ca = locate::by_condition(series, &locate::differenced(series, after, lag));
    let mut gain_axis = [0.0; 3];
    let mut best_cond = (f64::MIN, String::new());
    for (b, a) in cb.iter().zip(ca.iter()) {
        let g: f64 = (0..3).map(|x| (b.2[x] - a.2[x]) * b.1 as f64).sum();
        for x in 0..3 {
            gain_axis[x] += (b.2[x] - a.2[x]) * b.1 as f64;
        }
        let per_sample = g / b.1.max(1) as f64;
        if per_sample > best_cond.0 {
            best_cond = (per_sample, b.0.label());
        }
    }
    let alt = alternatives(kind.name(), dbic, scores, rejections, round);
    let what = kind.effect().signature();
    let mut s = format!(
        "{what}; the explained error arises on {}, most per sample {}; delta BIC {:.0} when added{alt}",
        axes_label(gain_axis),
        best_cond.1,
        dbic
    );
    if !note.is_empty() {
        s = format!("{note}; {s}");
    }
    s
}

/// What the named effect beat in its round: every candidate that scored better, with the
/// reason it was not named, then the best one that scored worse as the "next best". A
/// candidate that scored better is never called the next best; one that scored better
/// without a recorded reason (none is expected: every such path records one) is said to
/// be "not named" rather than passed over.
fn alternatives(
    effect: &str,
    dbic: f64,
    scores: &[Score],
    rejections: &[Rejection],
    round: usize,
) -> String {
    let rejected: Vec<&Rejection> = rejections
        .iter()
        .filter(|r| r.round == round && r.effect != effect)
        .collect();
    let mut alt = String::new();
    let mut better: Vec<&Rejection> = rejected
        .iter()
        .copied()
        .filter(|r| r.delta_bic < dbic)
        .collect();
    better.sort_by(|a, b| a.delta_bic.total_cmp(&b.delta_bic));
    for r in better {
        alt.push_str(&format!(
            "; {} scored better (delta BIC {:.0}) but was not named: {}",
            r.effect, r.delta_bic, r.reason
        ));
    }
    let mut others: Vec<&Score> = scores
        .iter()
        .filter(|s| {
            s.round == round && s.effect != effect && !rejected.iter().any(|r| r.effect == s.effect)
        })
        .collect();
    others.sort_by(|a, b| a.delta_bic.total_cmp(&b.delta_bic));
    for s in others.iter().filter(|s| s.delta_bic < dbic) {
        alt.push_str(&format!(
            "; {} scored better (delta BIC {:.0}) but was not named",
            s.effect, s.delta_bic
        ));
    }
    if let Some(s) = others.iter().find(|s| s.delta_bic >= dbic) {
        alt.push_str(&format!(
            "; next best mechanism {} at delta BIC {:.0}",
            s.effect, s.delta_bic
        ));
    }
    alt
}

fn report_effect(
    a: &Accepted,
    others: &[Kind],
    cx: &effects::Context,
    plant: &Plant,
) -> EffectReport {
    let se = |i: usize| a.stderr.get(i).copied().unwrap_or(f64::INFINITY);
    let (p, s) = a.kind.effect().report(&a.theta, &se, cx);
    EffectReport {
        equivalent_to: crate::equivalence::equivalents(a.kind, &a.theta, &se, others, plant, cx),
        effect: a.kind.name().into(),
        params: p,
        stderr: s,
        evidence: a.evidence.clone(),
        windows_ms: a.windows.clone(),
        rms_after: a.rms_after,
        delta_bic: a.delta_bic,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn score(effect: &'static str, delta_bic: f64) -> Score {
        Score {
            round: 0,
            effect,
            delta_bic,
        }
    }

    /// p04's first round: a candidate that scored better than the named one and was set
    /// aside is given with its reason, never as "next best".
    #[test]
    fn a_better_rejected_candidate_is_never_the_next_best() {
        let scores = [
            score("mass_property_change", -18_103_378.0),
            score("gyro_bias", -13_611_189.0),
            score("com_offset", -13_414_902.0),
            score("thruster_latency", -90_678.0),
        ];
        let rej = [Rejection {
            round: 0,
            effect: "mass_property_change",
            delta_bic: -18_103_378.0,
            reason: "REASON".into(),
        }];
        let t = alternatives("gyro_bias", -13_611_189.0, &scores, &rej, 0);
        assert!(t.contains("mass_property_change scored better (delta BIC -18103378) but was not named: REASON"), "{t}");
        assert!(t.contains("next best mechanism com_offset"), "{t}");
        assert!(
            !t.contains("next best mechanism mass_property_change"),
            "{t}"
        );
        // a better candidate without a recorded reason is still not the next best
        let t = alternatives("gyro_bias", -13_611_189.0, &scores, &[], 0);
        assert!(
            !t.contains("next best mechanism mass_property_change"),
            "{t}"
        );
        assert!(t.contains("mass_property_change scored better"), "{t}");
        // worse rejected candidates are not repeated in the sentence
        let rej = [Rejection {
            round: 0,
            effect: "com_offset",
            delta_bic: -13_414_902.0,
            reason: "R2".into(),
        }];
        let t = alternatives("mass_property_change", -18_103_378.0, &scores, &rej, 0);
        assert_eq!(t, "; next best mechanism gyro_bias at delta BIC -13611189");
    }
}
