//! Stage 3, exchange, after the forward selection. A first choice that stood in for
//! several true effects (a thrust scale for an inertia error and a damping together) would
//! stay named after the true ones join it. Once the set is complete, each named rigid
//! effect in turn is first offered a way out (the backward step: dropped when the others,
//! refitted, now stand in for it and the BIC without it is lower), then a replacement: the
//! unnamed mechanism that fits best in its place (screened, then refitted with the others).
//! The swap is made only if it lowers the BIC by the margin and the newcomer passes every
//! acceptance check on top of the others.

use super::named::{Accepted, Named};
use super::nominal::Nominal;
use super::{Log, Timing};
use crate::candidate::{Trial, Tried};
use crate::effects::Describe;
use crate::effects::Kind;
use crate::fit;
use crate::locate;
use crate::select::{self, combinable, wald, Settings};

/// At most this many exchanges (drops and swaps) after the forward selection (each lowers
/// the BIC by the margin, so the step ends anyway; this bounds its cost).
const MAX_SWAPS: usize = 3;

/// Runs the exchange over the named effects (when at least two rigid ones are named).
pub(super) fn run(n: &Nominal, named: &mut Named, log: &mut Log, settings: &Settings) {
    let rigid = named
        .accepted
        .iter()
        .filter(|a| !a.kind.effect().on_residual())
        .count();
    if rigid < 2 {
        return;
    }
    let _timing = Timing::start("exchange");
    // the exchanges are logged after every round of the forward selection
    let round = settings.max_effects;
    let mut e = 0;
    let mut swaps = 0;
    while e < named.accepted.len() {
        let out = named.accepted[e].kind;
        if out.effect().on_residual() {
            e += 1;
            continue;
        }
        let rest = named.rigid_except(Some(out));
        let k_rest = named.k - named.identifiable(out, n);
        let bic_now = named.chi2_rigid + named.k as f64 * n.ln_n;
        if swaps == MAX_SWAPS {
            break;
        }
        let tests_prev = named.tests(n);
        let trial = named.trial(n, &rest, &tests_prev, settings);
        // backward step: an effect the others now stand in for (two names for one
        // thing, e.g. a uniform thrust scale beside an inertia) is dropped when the
        // model without it has the lower BIC
        if let Some((t, bic_without)) = without(n, &trial, k_rest, bic_now) {
            let gone = named.accepted.remove(e);
            log.reject(
                round,
                gone.kind,
                gone.delta_bic,
                format!(
                    "named, then dropped: the other named effects stand in for it (without it the BIC is lower by {:.0})",
                    bic_now - bic_without
                ),
            );
            named.adopt(&t, true, k_rest);
            // the last entry is the whole model again
            let (rms, delta_bic) = (named.rms(n), named.delta_bic(n));
            if let Some(a) = named.accepted.last_mut() {
                a.rms_after = rms;
                a.delta_bic = delta_bic;
            }
            swaps += 1;
            continue;
        }
        let kinds: Vec<Kind> = named.accepted.iter().map(|a| a.kind).collect();
        match replacement(&trial, out, &kinds, k_rest, bic_now, n.ln_n) {
            Ok(None) => e += 1,
            Ok(Some(swap)) => {
                swaps += 1;
                let gone = named.accepted.remove(e);
                log.reject(
                    round,
                    gone.kind,
                    gone.delta_bic,
                    format!(
                        "named first, then replaced by {}: with the other named effects refitted it fits better (delta BIC {:.0})",
                        swap.kind.name(),
                        swap.delta_bic
                    ),
                );
                swap_in(n, named, swap, out, k_rest);
                // the effect now at position e has not been tried yet
            }
            Err((kind, delta_bic, reason)) => {
                log.reject(
                    round,
                    kind,
                    delta_bic,
                    format!("in place of {}: {reason}", out.name()),
                );
                e += 1;
            }
        }
    }
}

/// The model without the effect `trial` leaves out, and its BIC, when that BIC is lower
/// than `bic_now` and the others refitted without it are still physics (a delay must not
/// slide below the valve range to stand in for it).
fn without(n: &Nominal, trial: &Trial, k_rest: usize, bic_now: f64) -> Option<(Tried, f64)> {
    let t = trial.without().ok()?;
    let bic_without = t.chi2_rigid + k_rest as f64 * n.ln_n;
    let cx = n.context();
    let still_plausible = t.pairs.iter().all(|(k, th)| {
        let sp = select::spec(*k, &n.prob, &n.fired, &n.slosh_hint);
        crate::acceptance::implausible(*k, th, &cx, &sp.lo, &sp.hi).is_none()
    });
    (bic_without < bic_now && still_plausible).then_some((t, bic_without))
}

/// Names `swap.kind` in place of `out` (already removed): the rigid effects keep the joint
/// fit's order, so the newcomer goes last.
fn swap_in(n: &Nominal, named: &mut Named, swap: Swap, out: Kind, k_rest: usize) {
    let series = n.series;
    let t = swap.tried;
    let residual_prev = named.residual.clone();
    named.adopt(&t, true, k_rest + swap.k_in);
    let windows = locate::top_windows(
        series,
        &residual_prev,
        &named.residual,
        swap.kind.effect().window_ms(),
        3,
    )
    .into_iter()
    .map(|w| w.map(|t| series.real_ms(t as f64).round() as i64))
    .collect();
    named.accepted.push(Accepted {
        kind: swap.kind,
        theta: t.pairs.last().map(|p| p.1.clone()).unwrap_or_default(),
        stderr: vec![],
        cov: nalgebra::DMatrix::zeros(0, 0),
        delta_bic: named.delta_bic(n),
        rms_after: named.rms(n),
        windows,
        evidence: format!(
            "{}; named in place of {}, which the forward selection chose first and which stood in for it: with the other named effects refitted, it fits better (delta BIC {:.0}) and passes every check",
            swap.kind.effect().signature(),
            out.name(),
            swap.delta_bic
        ),
        alike: vec![],
    });
}

/// A replacement that passed.
struct Swap {
    pub kind: Kind,
    /// The model with the others and the newcomer, refitted jointly.
    pub tried: Tried,
    /// The newcomer's identifiable parameters (its BIC penalty).
    pub k_in: usize,
    /// BIC after the swap minus before.
    pub delta_bic: f64,
}

/// The best replacement for the named effect `out`, given the others (`trial.rigid_acc`,
/// with `k_rest` identifiable parameters) and the current BIC `bic_now`. `Ok(None)` when no
/// mechanism can take its place; `Err` with the best one, its screened BIC change and why
/// it failed.
fn replacement(
    trial: &Trial,
    out: Kind,
    named: &[Kind],
    k_rest: usize,
    bic_now: f64,
    ln_n: f64,
) -> Result<Option<Swap>, (Kind, f64, String)> {
    let settings = trial.settings;
    let mut best: Option<(f64, Kind, Vec<f64>)> = None;
    for &kind in Kind::ALL.iter() {
        if kind == out
            || kind.effect().on_residual()
            || named.contains(&kind)
            || !trial.rigid_acc.iter().all(|r| combinable(r.0, kind))
            || !kind
                .effect()
                .applies(&select::context(trial.prob, trial.fired, trial.hint))
        {
            continue;
        }
        let Some((fr, sz)) = select::fit_joint(
            trial.prob,
            trial.fired,
            trial.rigid_acc,
            Some(kind),
            trial.nuis,
            trial.hint,
            settings.max_iter.min(3),
        ) else {
            continue;
        };
        let off: usize = sz[..sz.len() - 1].iter().sum();
        let n = sz[sz.len() - 1];
        let k = fit::identifiable(&fr.stderr[off..off + n]);
        let bic = fr.chi2 + (k_rest + k) as f64 * ln_n;
        if best.as_ref().map(|b| bic < b.0).unwrap_or(true) {
            best = Some((bic, kind, fr.theta[off..off + n].to_vec()));
        }
    }
    let Some((bic_screen, kind, theta)) = best else {
        return Ok(None);
    };
    let fail = |why: String| (kind, bic_screen - bic_now, why);
    let t = trial.check(&[(kind, theta)], None).map_err(fail)?;
    let k_in = t.identifiable(kind, trial.fired);
    let bic = t.chi2_rigid + (k_rest + k_in) as f64 * ln_n;
    if bic > bic_now - settings.accept_margin {
        return Err(fail(format!(
            "it does not fit better (delta BIC {:+.0})",
            bic - bic_now
        )));
    }
    let th = t.pairs.last().map(|p| p.1.clone()).unwrap_or_default();
    let off: usize = t.sizes.iter().take(t.sizes.len().saturating_sub(1)).sum();
    let se = t.stderr.get(off..off + th.len()).unwrap_or(&[]);
    let cov = fit::cov_block(&t.cov, off, th.len());
    if wald(kind, &th, se, &cov, trial.prob) < k_in as f64 * ln_n {
        return Err(fail(
            "its own parameters are within their noise of no effect".into(),
        ));
    }
    Ok(Some(Swap {
        kind,
        tried: t,
        k_in,
        delta_bic: bic - bic_now,
    }))
}
