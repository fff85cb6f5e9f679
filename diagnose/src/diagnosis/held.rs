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
use crate::select::Settings;

use super::forward::Candidate;

/// The start of `whole`'s smaller form and the words that say so, or `None`: its holdable
/// parameters that its fit moved from "no effect" by less than one parameter's BIC price
/// (z^2 < ln n), held, the others where `whole` put them.
pub(super) fn form(whole: &Candidate, n: &Nominal) -> Option<(Vec<f64>, String)> {
    smaller(whole.kind, &whole.theta, &whole.stderr, n)
}

/// [`form`] for `kind` fitted at `theta` with errors `stderr`.
fn smaller(
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
/// that free refit moves by less than their BIC price held; the lowest BIC is kept.
pub(super) fn run(n: &Nominal, named: &mut Named, settings: &Settings) {
    let _timing = Timing::start("held parameters");
    for e in 0..named.accepted.len() {
        let a = &named.accepted[e];
        if !a.theta.iter().any(|v| v.is_nan()) || a.kind.effect().on_residual() {
            continue;
        }
        let kind = a.kind;
        // free: the held parameters start at their "no effect" values
        let probe: Vec<f64> = a
            .theta
            .iter()
            .map(|v| if v.is_nan() { 0.0 } else { *v })
            .collect();
        let null = kind.effect().no_effect(&probe, &n.context());
        let freed: Option<Vec<f64>> = (0..a.theta.len())
            .map(|i| match a.theta[i].is_nan() {
                true => null.iter().find(|p| p.0 == i).map(|p| p.1),
                false => Some(a.theta[i]),
            })
            .collect();
        let Some(freed) = freed else {
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
        let theta = whole
            .pairs
            .iter()
            .find(|p| p.0 == kind)
            .map(|p| p.1.clone());
        let again = theta.and_then(|th| {
            let se = whole.stderr.get(off..off + th.len())?;
            smaller(kind, &th, se, n)
        });
        let mut trials = vec![(k_with(&whole), whole, None)];
        if let Some((start, words)) = again {
            let pairs = with(&start);
            if let Ok(t) = named.trial(n, &pairs, &tests, settings).without() {
                trials.push((k_with(&t), t, Some(words)));
            }
        }
        let bic = |(k, t, _): &(usize, crate::candidate::Tried, Option<String>)| {
            t.chi2_rigid + *k as f64 * n.ln_n
        };
        let Some(i) = (0..trials.len())
            .filter(|&i| bic(&trials[i]) < bic_now)
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
