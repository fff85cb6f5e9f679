//! Stage 2, forward selection: round by round, every mechanism not yet named is fitted on
//! top of the named ones and scored by its BIC change; the strongest are put through the
//! acceptance checks (`candidate.rs`) and the first that passes is named. When no single
//! one passes, the strongest pairs are tried together (`pairs.rs`). The rigid-body part is
//! refitted jointly after every acceptance; ringing (additive, random phase per edge) lives
//! on the residual.

use super::held;
use super::indistinct::{self, Alternative, Indistinct};
use super::named::{Accepted, Named, Taken};
use super::nominal::Nominal;
use super::{evidence, pairs, Log, Timing, MAX_TRIES};
use crate::candidate::Tried;
use crate::effects::Describe;
use crate::effects::{self, Kind};
use crate::fit;
use crate::locate;
use crate::model::Params;
use crate::ringing::{self, RingingFit};
use crate::select::{self, combinable, wald, Settings};

/// What the ringing search saw, for the report's spectrum plot.
pub(super) struct Tone {
    /// Post-edge residual spectrum of the nominal model (frequency Hz, power).
    pub spectrum_before: Vec<(f64, f64)>,
    /// The statistic a tone must reach to be named.
    pub threshold: f64,
    /// Apparent tone and the true frequencies it could fold from.
    pub alias_marks: (f64, Vec<f64>),
}

/// One mechanism scored in a round.
pub(super) struct Candidate {
    pub delta_bic: f64,
    pub kind: Kind,
    /// Its parameters as fitted on top of the named effects.
    pub theta: Vec<f64>,
    /// Their standard errors (empty for the ringing tone).
    pub stderr: Vec<f64>,
    /// Their covariance (for the Wald test; empty for the ringing tone).
    pub cov: nalgebra::DMatrix<f64>,
    /// Chi-square of the model with it.
    pub chi2: f64,
    /// The ringing fit, for the tone.
    pub ringing: Option<RingingFit>,
    /// Said before the evidence when it is named.
    pub note: String,
    /// The whole model of its fit (none for the ringing tone).
    pub fitted: Option<Params>,
}

/// Runs the forward selection from `named` (the nominal model) until no candidate passes
/// or `settings.max_effects` are named.
pub(super) fn select(n: &Nominal, named: &mut Named, log: &mut Log, settings: &Settings) -> Tone {
    let mut tone = Tone {
        spectrum_before: vec![],
        threshold: f64::NAN,
        alias_marks: (0.0, vec![]),
    };
    // the ringing fit of the current rigid residual (recomputed only when it changes)
    let mut ringing_cache: Option<Option<RingingFit>> = None;
    for round in 0..settings.max_effects {
        let mut ranked = rank(
            n,
            named,
            round,
            log,
            settings,
            &mut ringing_cache,
            &mut tone,
        );
        static_pair_check(n, named, &mut ranked, round, log, settings);
        let _timing = Timing::start("checks");
        let rigid_acc = named.rigid_except(None);
        let tests_prev = named.tests(n);
        let trial = named.trial(n, &rigid_acc, &tests_prev, settings);
        let pool: Vec<(f64, Kind, Vec<f64>)> = ranked
            .iter()
            .filter(|r| r.delta_bic <= -settings.accept_margin && !r.kind.effect().on_residual())
            .take(pairs::PAIR_POOL)
            .map(|r| (r.delta_bic, r.kind, r.theta.clone()))
            .collect();
        // the strong candidates as fitted, for what the named one cannot be told from
        let alternatives: Vec<Alternative> = ranked
            .iter()
            .filter(|r| r.delta_bic <= -settings.accept_margin)
            .filter_map(|r| {
                Some(Alternative {
                    kind: r.kind,
                    theta: r.theta.clone(),
                    fitted: r.fitted.clone()?,
                })
            })
            .collect();
        let mut alike: Vec<Indistinct> = vec![];
        // the strongest candidates by BIC, each tried against the checks that generalise
        // (acceptance.rs); the first that passes is named, the others say why not
        let mut taken: Option<Taken> = None;
        for c in ranked.into_iter().take(MAX_TRIES) {
            if c.delta_bic > -settings.accept_margin {
                break;
            }
            match trial.check(&[(c.kind, c.theta)], c.ringing) {
                Ok(t) => {
                    if let Some(f) = &c.fitted {
                        alike = indistinct::within_noise(n, c.kind, f, &alternatives);
                    }
                    taken = Some((vec![(c.delta_bic, c.kind, c.note)], t));
                    break;
                }
                Err(reason) => log.reject(round, c.kind, c.delta_bic, reason),
            }
        }
        // no single effect generalises: two true effects can each fail alone
        if taken.is_none() && pool.len() >= 2 {
            taken = pairs::try_pairs(n, named, &trial, &pool, round, log, settings);
        }
        let Some((new, t)) = taken else {
            break;
        };
        accept(
            n,
            named,
            new,
            t,
            alike,
            round,
            log,
            &mut ringing_cache,
            &mut tone,
        );
    }
    tone
}

/// Scores every mechanism not yet named: a short fit of each (the ringing tone on the
/// residual), a full fit of the three strongest, then the tests of its own parameters.
/// Returns the candidates that pass, best first.
fn rank(
    n: &Nominal,
    named: &Named,
    round: usize,
    log: &mut Log,
    settings: &Settings,
    ringing_cache: &mut Option<Option<RingingFit>>,
    tone: &mut Tone,
) -> Vec<Candidate> {
    let chi2_cur = named.chi2();
    let ring_gain = named.ring_gain();
    let acc_pairs = named.pairs();
    let ln_n = n.ln_n;
    let mut screened: Vec<Candidate> = vec![];
    for &kind in Kind::ALL.iter() {
        if named.accepted.iter().any(|a| a.kind == kind) {
            continue;
        }
        // mechanisms that share parameters (or give the same rates) cannot be combined
        if !named.accepted.iter().all(|a| combinable(a.kind, kind))
            || !kind.effect().applies(&n.context())
        {
            continue;
        }
        let k_new = effects::n_params(kind, &n.fired);
        if k_new == 0 {
            continue;
        }
        let screen_iter = settings.max_iter.min(3);
        let _timing = Timing::start(kind.name());
        if kind.effect().on_residual() {
            if ringing_cache.is_none() {
                let rf = ringing::fit(
                    n.series,
                    &named.rigid_residual,
                    &n.whitening,
                    settings.ringing_prior_hz,
                    named.latency,
                );
                if tone.spectrum_before.is_empty() {
                    if let Some(r) = &rf {
                        tone.spectrum_before = r.scan.clone();
                        tone.threshold = k_new as f64 * ln_n + settings.accept_margin;
                    }
                }
                *ringing_cache = Some(rf);
            }
            let Some(rf) = ringing_cache.clone().flatten() else {
                continue;
            };
            screened.push(Candidate {
                delta_bic: -rf.gain + k_new as f64 * ln_n,
                kind,
                theta: vec![],
                stderr: vec![],
                cov: nalgebra::DMatrix::zeros(0, 0),
                chi2: chi2_cur - rf.gain,
                note: rf.evidence.clone(),
                ringing: Some(rf),
                fitted: None,
            });
        } else {
            let scored = |(fr, sz): (fit::FitResult, Vec<usize>)| {
                let off: usize = sz[..sz.len() - 1].iter().sum();
                let chi2 = fr.chi2 - ring_gain;
                let k_live = fit::identifiable(&fr.stderr[off..off + k_new]);
                Candidate {
                    delta_bic: chi2 - chi2_cur + k_live as f64 * ln_n,
                    kind,
                    theta: fr.theta[off..off + k_new].to_vec(),
                    stderr: fr.stderr[off..off + k_new].to_vec(),
                    cov: fit::cov_block(&fr.cov, off, k_new),
                    chi2,
                    note: String::new(),
                    ringing: None,
                    fitted: Some(fr.params),
                }
            };
            let whole = select::fit_joint(
                &n.prob,
                &n.fired,
                &acc_pairs,
                Some(kind),
                &named.nuis,
                &n.slosh_hint,
                screen_iter,
            )
            .map(scored);
            // the effect's smaller form, when it has one: the BIC picks between them
            let held = whole
                .as_ref()
                .and_then(|w| held::form(w.kind, &w.theta, &w.stderr, n))
                .and_then(|(start, note)| {
                    let fitted = select::fit_from(
                        &n.prob,
                        &n.fired,
                        &acc_pairs,
                        kind,
                        &start,
                        &named.nuis,
                        &n.slosh_hint,
                        screen_iter,
                    );
                    fitted.map(scored).map(|c| Candidate { note, ..c })
                });
            let best = match (whole, held) {
                (Some(w), Some(h)) => Some(if h.delta_bic < w.delta_bic { h } else { w }),
                (w, h) => w.or(h),
            };
            screened.extend(best);
        }
    }
    // full fits for the best screened candidates
    screened.sort_by(|a, b| a.delta_bic.total_cmp(&b.delta_bic));
    if std::env::var_os("MASSID_DIAG_PROFILE").is_some() {
        for s in &screened {
            let th: Vec<String> = s.theta.iter().take(4).map(|v| format!("{v:.4}")).collect();
            eprintln!(
                "  screened {:>22}: delta BIC {:.0} at [{}]",
                s.kind.name(),
                s.delta_bic,
                th.join(" ")
            );
        }
    }
    let _timing = Timing::start("full fits");
    let mut ranked = vec![];
    for (i, mut c) in screened.into_iter().enumerate() {
        let kind = c.kind;
        let k_new = effects::n_params(kind, &n.fired);
        let k_live = if c.stderr.is_empty() {
            k_new
        } else {
            fit::identifiable(&c.stderr)
        };
        if i < 3 && c.delta_bic < 0.0 && !kind.effect().on_residual() {
            if let Some((fr, sz)) = select::fit_from(
                &n.prob,
                &n.fired,
                &acc_pairs,
                kind,
                &c.theta,
                &named.nuis,
                &n.slosh_hint,
                settings.max_iter,
            ) {
                if fr.chi2 - ring_gain < c.chi2 {
                    let off: usize = sz[..sz.len() - 1].iter().sum();
                    c.delta_bic = fr.chi2 - ring_gain - chi2_cur + k_live as f64 * ln_n;
                    c.theta = fr.theta[off..off + k_new].to_vec();
                    c.stderr = fr.stderr[off..off + k_new].to_vec();
                    c.cov = fit::cov_block(&fr.cov, off, k_new);
                    c.fitted = Some(fr.params.clone());
                }
            }
        }
        log.score(round, kind, c.delta_bic);
        // backing test: the effect's own parameters must differ from "no effect" by
        // more than the BIC penalty in their own (colour-corrected) uncertainty, so a
        // candidate that only helps the others converge is not taken for physics
        let w = if kind.effect().on_residual() {
            f64::INFINITY
        } else {
            wald(kind, &c.theta, &c.stderr, &c.cov, &n.prob)
        };
        let strong = c.delta_bic <= -settings.accept_margin;
        if w < k_live as f64 * ln_n {
            if strong {
                let reason = format!(
                    "its own parameters are within their noise of no effect (Wald {w:.1} < {:.1})",
                    k_live as f64 * ln_n
                );
                log.reject(round, kind, c.delta_bic, reason);
            }
        } else if !observable(kind, &c.theta, n) {
            if strong {
                let reason = "its change time has no firing on one side, so it cannot be told from a constant error".into();
                log.reject(round, kind, c.delta_bic, reason);
            }
        } else {
            ranked.push(c);
        }
    }
    ranked.sort_by(|a, b| a.delta_bic.total_cmp(&b.delta_bic));
    ranked
}

/// A mass-property change can mimic a constant inertia error plus a CoM offset by
/// switching half-way; it is named only if it beats that static pair (else it leaves the
/// ranking, with the reason said).
fn static_pair_check(
    n: &Nominal,
    named: &Named,
    ranked: &mut Vec<Candidate>,
    round: usize,
    log: &mut Log,
    settings: &Settings,
) {
    let first_is_change = ranked
        .first()
        .map(|r| r.kind == Kind::MassPropertyChange)
        .unwrap_or(false);
    if !first_is_change
        || named
            .accepted
            .iter()
            .any(|a| matches!(a.kind, Kind::Inertia | Kind::ComOffset))
    {
        return;
    }
    let mut pairs = named.pairs();
    pairs.push((Kind::Inertia, n.plant.nominal_inertia().to_vec()));
    let Some((fr, sz)) = select::fit_joint(
        &n.prob,
        &n.fired,
        &pairs,
        Some(Kind::ComOffset),
        &named.nuis,
        &n.slosh_hint,
        settings.max_iter,
    ) else {
        return;
    };
    // the inertia and CoM offset terms the data can identify
    let off: usize = sz[..sz.len() - 2].iter().sum();
    let k_static = fit::identifiable(&fr.stderr[off..off + sz[sz.len() - 2] + sz[sz.len() - 1]]);
    let static_bic = fr.chi2 - named.ring_gain() - named.chi2() + k_static as f64 * n.ln_n;
    if static_bic < ranked[0].delta_bic {
        let r = ranked.remove(0);
        // said, so that no later text calls it merely the next best
        log.reject(
            round,
            r.kind,
            r.delta_bic,
            format!(
                "a constant inertia error plus CoM offset, which a change half-way can mimic, fits better (delta BIC {static_bic:.0})"
            ),
        );
    }
}

/// A change in time must have firings on both sides of it to be seen: a mass-property
/// change before the first or after the last firing is a constant inertia / CoM error (or
/// nothing), and a blowdown starting after the last firing cannot be observed.
fn observable(kind: Kind, theta: &[f64], n: &Nominal) -> bool {
    let series = n.series;
    let first =
        series.real_ms(series.word_ms.iter().position(|&w| w != 0).unwrap_or(0) as f64) * 1e-3;
    let last =
        series.real_ms(series.word_ms.iter().rposition(|&w| w != 0).unwrap_or(0) as f64) * 1e-3;
    kind.effect().observable(theta, first, last)
}

/// Names the round's effects: the model `t` becomes the current one and each new effect
/// is recorded with where it acts and the evidence for it.
#[allow(clippy::too_many_arguments)]
fn accept(
    n: &Nominal,
    named: &mut Named,
    new: Vec<(f64, Kind, String)>,
    t: Tried,
    alike: Vec<Indistinct>,
    round: usize,
    log: &Log,
    ringing_cache: &mut Option<Option<RingingFit>>,
    tone: &mut Tone,
) {
    let series = n.series;
    let residual_prev = named.residual.clone();
    let rigid = !new[0].1.effect().on_residual();
    if rigid {
        *ringing_cache = None;
    } else if let Some(rf) = &t.ringing {
        tone.alias_marks = (
            rf.apparent_hz,
            crate::alias::candidates(rf.apparent_hz, series.sample_rate_hz, ringing::F_MAX_HZ),
        );
    }
    let k = named.k
        + new
            .iter()
            .map(|e| t.identifiable(e.1, &n.fired))
            .sum::<usize>();
    named.adopt(&t, rigid, k);
    let delta_bic_total = named.delta_bic(n);
    for (dbic, kind, note) in new {
        let theta = t
            .pairs
            .iter()
            .find(|p| p.0 == kind)
            .map(|p| p.1.clone())
            .unwrap_or_default();
        let windows = locate::top_windows(
            series,
            &residual_prev,
            &named.residual,
            kind.effect().window_ms(),
            3,
        )
        .into_iter()
        .map(|w| w.map(|t| series.real_ms(t as f64).round() as i64))
        .collect();
        // thrust scale names its most-off thruster in the conclusion, from the final fit
        let evidence = evidence::describe(
            kind,
            series,
            &residual_prev,
            &named.residual,
            dbic,
            &note,
            log,
            round,
        );
        named.accepted.push(Accepted {
            kind,
            theta,
            stderr: vec![],
            cov: nalgebra::DMatrix::zeros(0, 0),
            delta_bic: delta_bic_total,
            rms_after: named.rms(n),
            windows,
            evidence,
            alike: alike.clone(),
        });
    }
}
