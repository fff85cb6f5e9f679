//! Stage 4, the conclusion: standard errors of the named effects from the last joint fit,
//! each effect's report in the contract's names (with its equivalents), the verdict on what
//! is left unexplained, and everything the human report plots.

use super::forward::Tone;
use super::indistinct;
use super::named::{Accepted, Named};
use super::nominal::Nominal;
use super::{Analysis, Log};
use crate::effects::Describe;
use crate::effects::{self, Kind};
use crate::locate;
use crate::model::{Plant, NT};
use crate::output::{DataIssues, DiagnosisOutput, EffectReport, FORMAT};
use crate::stats;

/// Where the analysis ends: the contract output and what the report needs.
pub(super) fn conclude(
    n: Nominal,
    mut named: Named,
    log: Log,
    tone: Tone,
    recording: &str,
    model: &str,
    issues: DataIssues,
) -> Analysis {
    let series = n.series;
    attach_stderr(&mut named);
    held_errors(&n, &mut named);
    name_thrust_scale(&mut named.accepted, &n.fired);
    let cx = crate::select::context(&n.prob, &n.fired, &[]);
    let effects_out: Vec<EffectReport> = named
        .accepted
        .iter()
        .map(|a| {
            let others: Vec<Kind> = named
                .accepted
                .iter()
                .map(|o| o.kind)
                .filter(|&k| k != a.kind)
                .collect();
            report_effect(a, &others, &cx, n.plant, n.ln_n)
        })
        .collect();
    let ringing_windows = ringing_windows(&n, &named);
    let unexplained =
        crate::unexplained::verdict(series, &named.residual, &n.noise, &ringing_windows);
    let output = DiagnosisOutput {
        format: FORMAT.into(),
        recording: recording.into(),
        model: model.into(),
        samples: series.len() as u64,
        residual_rms_before: locate::rms(&n.residual, &series.valid),
        residual_rms_after: named.rms(&n),
        effects: effects_out,
        unexplained,
        data_issues: issues,
        noise: Some(n.noise.report()),
    };
    Analysis {
        fitted: named.pairs(),
        output,
        series: series.clone(),
        tests_before: stats::residual_tests_for(series, &n.residual, &n.noise),
        tests_after: stats::residual_tests_for(series, &named.residual, &n.noise),
        by_condition_before: locate::by_condition(series, &n.residual),
        by_condition_after: locate::by_condition(series, &named.residual),
        residual_before: n.residual,
        residual_after: named.residual,
        noise: n.noise,
        spectrum_before: tone.spectrum_before,
        spectrum_threshold: tone.threshold,
        alias_marks: tone.alias_marks,
        scores: log.scores,
        rejections: log.rejections,
    }
}

/// Standard errors of the rigid effects from the last joint fit; the ringing tone's
/// parameters and errors from its own fit.
fn attach_stderr(named: &mut Named) {
    let mut off = 0;
    let mut sizes = named.sizes.iter();
    for a in named
        .accepted
        .iter_mut()
        .filter(|a| !a.kind.effect().on_residual())
    {
        let k = sizes.next().copied().unwrap_or(0);
        a.stderr = named
            .stderr
            .get(off..off + k)
            .map(|s| s.to_vec())
            .unwrap_or_default();
        a.cov = crate::fit::cov_block(&named.cov, off, k);
        off += k;
    }
    if let Some(rf) = &named.ringing {
        for a in named
            .accepted
            .iter_mut()
            .filter(|a| a.kind.effect().on_residual())
        {
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
}

/// The errors of the parameters no fit steps (a mass-property change's time) from the
/// final model's profile ([`crate::profile::held_error`]) instead of the covariance's
/// difference column; that parameter's covariance row and column are rescaled to the new
/// error (its correlations kept).
fn held_errors(n: &Nominal, named: &mut Named) {
    let Some(lin) = named.linearised.clone() else {
        return;
    };
    let rigid = named.rigid_except(None);
    let mut errors = vec![];
    for (r, (kind, theta)) in rigid.iter().enumerate() {
        let spec = crate::select::spec(*kind, &n.prob, &n.fired, &n.slosh_hint);
        for &j in kind.effect().held() {
            let (Some(&at), Some(&lo), Some(&hi), Some(&step)) = (
                theta.get(j),
                spec.lo.get(j),
                spec.hi.get(j),
                spec.step.get(j),
            ) else {
                continue;
            };
            let cost = |x: f64| {
                let mut pairs = rigid.clone();
                pairs[r].1[j] = x;
                let w = n
                    .prob
                    .weighted(&crate::select::build(&n.fired, &pairs, &named.nuis))?;
                Some(lin.refit(&w)?.0)
            };
            let se = crate::profile::held_error(&cost, at, (lo, hi), step, lin.rise);
            errors.push((*kind, j, se));
        }
    }
    for (kind, j, se) in errors {
        let Some(a) = named.accepted.iter_mut().find(|a| a.kind == kind) else {
            continue;
        };
        let Some(old) = a.stderr.get_mut(j) else {
            continue;
        };
        let ratio = se / *old;
        *old = se;
        if j < a.cov.nrows() && ratio.is_finite() {
            a.cov.row_mut(j).scale_mut(ratio);
            a.cov.column_mut(j).scale_mut(ratio);
        }
    }
}

/// A thrust scale's evidence starts with the thruster most off nominal, as finally fitted,
/// with its uncertainty.
fn name_thrust_scale(accepted: &mut [Accepted], fired: &[bool; NT]) {
    let fired_idx: Vec<usize> = (0..NT).filter(|&i| fired[i]).collect();
    for a in accepted.iter_mut().filter(|a| a.kind == Kind::ThrustScale) {
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
}

/// The samples a named ringing accounts for as a random tone: every sample within five
/// decay times of the last valve shock (however short the pulse, so not only the windows
/// long enough to fit the tone in).
fn ringing_windows(n: &Nominal, named: &Named) -> Vec<bool> {
    let series = n.series;
    let mut windows = vec![false; series.len()];
    let Some(rf) = &named.ringing else {
        return windows;
    };
    let latency = named.latency;
    let edges = series.edges();
    let mut e = 0;
    for (i, m) in windows.iter_mut().enumerate() {
        let t = series.t_ms[i] as f64;
        while e < edges.len() && (edges[e].0 as f64) + latency.0.min(latency.1) <= t {
            e += 1;
        }
        *m = e > 0 && t - edges[e - 1].0 as f64 <= 5.0 * rf.decay_ms + latency.0.max(latency.1);
    }
    windows
}

/// One named effect in the contract's form.
fn report_effect(
    a: &Accepted,
    others: &[Kind],
    cx: &effects::Context,
    plant: &Plant,
    ln_n: f64,
) -> EffectReport {
    let se = |i: usize| a.stderr.get(i).copied().unwrap_or(f64::INFINITY);
    let cov = |i: usize, j: usize| a.cov.get((i, j)).copied().unwrap_or(f64::NAN);
    let reported = a.kind.effect().report(&a.theta, &se, cx);
    let (p, s) = reported.maps();
    let mut equivalent_to =
        crate::equivalence::equivalents(a.kind, &a.theta, &se, &cov, others, plant, cx);
    // then what this recording cannot tell it from, unless named or listed already
    let mut alike = vec![];
    for alt in &a.alike {
        let listed = equivalent_to
            .iter()
            .any(|v| v["effect"].as_str() == Some(alt.kind.name()));
        if !listed && !others.contains(&alt.kind) {
            let unknown = |_: usize| f64::INFINITY;
            let reported = alt.kind.effect().report(&alt.theta, &unknown, cx);
            equivalent_to.push(effects::contract_json(&reported.params));
            alike.push(alt.clone());
        }
    }
    let evidence = if alike.is_empty() {
        a.evidence.clone()
    } else {
        format!("{}; {}", a.evidence, indistinct::sentence(&alike, ln_n))
    };
    EffectReport {
        equivalent_to,
        held: reported.held_json(),
        effect: a.kind.name().into(),
        params: p,
        stderr: s,
        evidence,
        windows_ms: a.windows.clone(),
        rms_after: a.rms_after,
        delta_bic: a.delta_bic,
    }
}
