//! Mechanisms this recording cannot tell apart from the one named. The contract's classes
//! (`equivalence.rs`) give the same rates on every recording; two other mechanisms can still
//! give rates equal within the noise on a given one. A 20 ms first-order thrust rise and a
//! 20 ms valve latency sampled at 100 Hz deliver the same impulse with the same centroid and
//! differ only within a few ms of each edge. On random 3-D craft a planted rise was named a
//! latency, the rise scoring better but missing the materiality check by 0.01 of the noise,
//! with nothing listed (`diagnose_random_craft`): a confident answer the data do not back.
//!
//! So a strong candidate of the same round whose fitted prediction lies within one
//! parameter's BIC penalty (`ln n`) of the named one's, in the chi-square the selection
//! scores by (every sample, each axis weighted by its noise: `Problem::chi2_between`), is
//! listed with it under `equivalent_to`. `ln n` is the price the selection itself puts on
//! one parameter: a difference below it is not worth a choice.
//!
//! The judgement is made once, in the round the effect is named alone by the forward
//! selection, against that round's model; effects named as a pair, or swapped in by the
//! exchange, list none of their own.

use super::nominal::Nominal;
use crate::effects::Kind;
use crate::model::Params;

/// A candidate of the round as fitted on top of the named effects.
pub(super) struct Alternative {
    pub kind: Kind,
    pub theta: Vec<f64>,
    /// The whole model of its fit (the named effects refitted with it).
    pub fitted: Params,
}

/// One mechanism the recording cannot tell from the named one.
#[derive(Clone, Debug)]
pub(super) struct Indistinct {
    pub kind: Kind,
    pub theta: Vec<f64>,
    /// Chi-square between the two fitted predictions.
    pub distance: f64,
}

/// The `alternatives` (other kinds than `named`) whose predictions lie within `ln n` of
/// `fitted`, the named effect's model, closest first.
pub(super) fn within_noise(
    n: &Nominal,
    named: Kind,
    fitted: &Params,
    alternatives: &[Alternative],
) -> Vec<Indistinct> {
    let mut out: Vec<Indistinct> = alternatives
        .iter()
        .filter(|a| a.kind != named)
        .filter_map(|a| {
            let distance = n.prob.chi2_between(fitted, &a.fitted)?;
            if std::env::var_os("MASSID_DIAG_PROFILE").is_some() {
                eprintln!(
                    "  {} against {}: chi-square {distance:.1} (ln n {:.1})",
                    a.kind.name(),
                    named.name(),
                    n.ln_n
                );
            }
            (distance.is_finite() && distance < n.ln_n).then(|| Indistinct {
                kind: a.kind,
                theta: a.theta.clone(),
                distance,
            })
        })
        .collect();
    out.sort_by(|a, b| a.distance.total_cmp(&b.distance));
    out
}

/// The sentence the named effect's evidence ends with.
pub(super) fn sentence(list: &[Indistinct], ln_n: f64) -> String {
    let names: Vec<String> = list
        .iter()
        .map(|i| format!("{} (chi-square {:.1})", i.kind.name(), i.distance))
        .collect();
    format!(
        "this recording cannot tell it from {}: their fitted rates differ by less than one parameter's BIC penalty ({ln_n:.1}), so they are listed as equivalent here",
        names.join(", ")
    )
}
