//! The evidence sentence of a named effect: what structure it explains, on which axes and
//! in which input condition, and what it beat in its round (with the reason each stronger
//! candidate was not named).

use super::{Log, Rejection, Score};
use crate::effects::Describe;
use crate::effects::Kind;
use crate::locate;
use crate::series::Series;

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
pub(super) fn describe(
    kind: Kind,
    series: &Series,
    before: &[[f64; 3]],
    after: &[[f64; 3]],
    dbic: f64,
    note: &str,
    log: &Log,
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
    let alt = alternatives(kind.name(), dbic, &log.scores, &log.rejections, round);
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
