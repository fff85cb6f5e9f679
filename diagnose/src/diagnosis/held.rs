//! Parameters an effect holds at their "no effect" values ([`effects::HELD`]): an inertia's
//! products that the data do not move. When a candidate is screened, its holdable
//! parameters that its whole fit moves by less than one parameter's BIC price are held in a
//! second, smaller form ([`form`]); the BIC picks between the two. That choice is made
//! against the effects named in its round, and one of them may be dropped later, so after
//! the exchange each held effect is decided again against the final set ([`run`]).

use super::named::Named;
use super::nominal::Nominal;
use super::Timing;
use crate::effects::{self, Describe};
use crate::fit;
use crate::select::Settings;

/// The start of the smaller form of `kind` fitted whole at `theta` (errors `stderr`) and
/// the words that say so, or `None`: its holdable parameters that the fit moved from "no
/// effect" by less than one parameter's BIC price (z^2 < ln n), held, the others where the
/// fit put them.
pub(super) fn form(
    kind: effects::Kind,
    theta: &[f64],
    stderr: &[f64],
    n: &Nominal,
) -> Option<(Vec<f64>, String)> {
    let effect = kind.effect();
    let cx = n.context();
    let null = effect.no_effect(theta, &cx);
    let held: Vec<(usize, &str)> = effect
        .holdable(&cx)
        .into_iter()
        .filter(|&(i, _)| {
            let (Some(&(_, v)), Some(&se)) = (null.iter().find(|p| p.0 == i), stderr.get(i)) else {
                return false;
            };
            ((theta[i] - v) / se).powi(2) < n.ln_n
        })
        .collect();
    if held.is_empty() {
        return None;
    }
    let mut start = theta.to_vec();
    for &(i, _) in &held {
        start[i] = effects::HELD;
    }
    let names: Vec<&str> = held.iter().map(|h| h.1).collect();
    Some((start, note(&names)))
}

/// What follows the held parameters' names in the evidence's first clause.
const HELD_CLAUSE: &str =
    " held at the model's (each within its BIC price of it; a lower BIC than fitting them); ";

/// The evidence's first clause for an effect with `names` held (the evidence adds "; ").
fn note(names: &[&str]) -> String {
    format!("{}{}", names.join(", "), HELD_CLAUSE.trim_end_matches("; "))
}

/// Decides each named effect's held parameters again against the final set of effects:
/// the model as it is, refitted with them free, and refitted with the holdable parameters
/// that free refit moves by less than their BIC price held; the lowest BIC is kept, except
/// that a free refit which is another effect's exact equal is kept whatever its BIC.
pub(super) fn run(n: &Nominal, named: &mut Named, settings: &Settings) {
    let _timing = Timing::start("held parameters");
    for e in 0..named.accepted.len() {
        let a = &named.accepted[e];
        if !a.theta.iter().any(|v| v.is_nan()) || a.kind.effect().on_residual() {
            continue;
        }
        let kind = a.kind;
        let Some(freed) = released(kind, &a.theta, n) else {
            continue;
        };
        let with = |theta: &[f64]| {
            let mut pairs = named.rigid_except(None);
            for p in pairs.iter_mut().filter(|p| p.0 == kind) {
                p.1 = theta.to_vec();
            }
            pairs
        };
        let bic_now = named.chi2_rigid + named.k as f64 * n.ln_n;
        let tests = named.tests(n);
        let pairs = with(&freed);
        let Ok(whole) = named.trial(n, &pairs, &tests, settings).without() else {
            continue;
        };
        // the model's parameter count with `t`'s fit of this effect
        let k_with = |t: &crate::candidate::Tried| {
            named.k - named.identifiable(kind, n) + t.identifiable(kind, &n.fired)
        };
        // the whole refit's own smaller form
        let off: usize = whole
            .pairs
            .iter()
            .zip(&whole.sizes)
            .take_while(|(p, _)| p.0 != kind)
            .map(|(_, s)| s)
            .sum();
        let theta_whole = whole
            .pairs
            .iter()
            .find(|p| p.0 == kind)
            .map(|p| p.1.clone());
        let again = theta_whole.as_ref().and_then(|th| {
            let se = whole.stderr.get(off..off + th.len())?;
            form(kind, th, se, n)
        });
        let exact = theta_whole
            .as_ref()
            .is_some_and(|th| exact_equal(kind, th, &whole, off, named, n));
        let mut trials = vec![(k_with(&whole), whole, None)];
        if let (Some((start, words)), false) = (again, exact) {
            let pairs = with(&start);
            if let Ok(t) = named.trial(n, &pairs, &tests, settings).without() {
                trials.push((k_with(&t), t, Some(words)));
            }
        }
        let bic = |(k, t, _): &(usize, crate::candidate::Tried, Option<String>)| {
            t.chi2_rigid + *k as f64 * n.ln_n
        };
        let Some(i) = (0..trials.len())
            .filter(|&i| exact || bic(&trials[i]) < bic_now)
            .min_by(|&i, &j| bic(&trials[i]).total_cmp(&bic(&trials[j])))
        else {
            continue;
        };
        let (k, t, words) = trials.swap_remove(i);
        named.adopt(&t, true, k);
        // the last entry is the whole model again
        let (rms, delta_bic) = (named.rms(n), named.delta_bic(n));
        if let Some(last) = named.accepted.last_mut() {
            last.rms_after = rms;
            last.delta_bic = delta_bic;
        }
        let a = &mut named.accepted[e];
        // the evidence's held clause, if any, says what is held now
        if let Some((_, rest)) = a.evidence.split_once(HELD_CLAUSE) {
            a.evidence = match words {
                Some(w) => format!("{w}; {rest}"),
                None => rest.to_string(),
            };
        }
    }
}

/// `theta` with its held parameters at their "no effect" values (where the fit starts them
/// when they are free again).
fn released(kind: effects::Kind, theta: &[f64], n: &Nominal) -> Option<Vec<f64>> {
    let probe: Vec<f64> = theta
        .iter()
        .map(|v| if v.is_nan() { 0.0 } else { *v })
        .collect();
    let null = kind.effect().no_effect(&probe, &n.context());
    (0..theta.len())
        .map(|i| match theta[i].is_nan() {
            true => null.iter().find(|p| p.0 == i).map(|p| p.1),
            false => Some(theta[i]),
        })
        .collect()
}

/// Whether `kind` fitted whole at `theta` (its errors at `off` in `whole`'s) gives another
/// effect's rates exactly (`equivalence.rs`): an inertia r times the model's, products too,
/// is a uniform thrust scale. Holding its products would hide that alternative: a thrust
/// error was named an inertia with nothing listed (`diagnose_random_craft`, seed 84001).
fn exact_equal(
    kind: effects::Kind,
    theta: &[f64],
    whole: &crate::candidate::Tried,
    off: usize,
    named: &Named,
    n: &Nominal,
) -> bool {
    let others: Vec<effects::Kind> = named
        .accepted
        .iter()
        .map(|a| a.kind)
        .filter(|&o| o != kind)
        .collect();
    let se = |i: usize| whole.stderr.get(off + i).copied().unwrap_or(f64::INFINITY);
    let cov = fit::cov_block(&whole.cov, off, theta.len());
    let cov = |i: usize, j: usize| cov.get((i, j)).copied().unwrap_or(f64::NAN);
    let cx = n.context();
    !crate::equivalence::equivalents(kind, theta, &se, &cov, &others, n.plant, &cx).is_empty()
}
