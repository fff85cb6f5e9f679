//! The exchange step after forward selection. A first choice that stood in for several
//! true effects (a thrust scale for an inertia error and a damping together) would stay
//! named after the true ones join it. Once the set is complete, each named rigid effect is
//! offered a replacement: the unnamed mechanism that fits best in its place (screened, then
//! refitted with the others). The swap is made only if it lowers the BIC by the margin and
//! the newcomer passes every acceptance check on top of the others.

use crate::candidate::{Trial, Tried};
use crate::effects::Kind;
use crate::fit;
use crate::select;
use crate::select::{combinable, wald};

/// A replacement that passed.
pub(crate) struct Swap {
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
pub(crate) fn replacement(
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
    if wald(kind, &th, se, trial.prob) < k_in as f64 * ln_n {
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
