//! Stage 4, the conclusion: standard errors of the named effects from the last joint fit
//! (with a held change time, from its profile: `crate::profile`),
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
use crate::noise::NoiseReport;
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
    held_errors(&n, &mut named);
    attach_stderr(&mut named);
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
        noise: Some(NoiseReport {
            response: n.prob.response.name().map(|(key, _)| key.to_string()),
            ..n.noise.report()
        }),
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
        response: n.prob.response,
        spectrum_before: tone.spectrum_before,
        spectrum_threshold: tone.threshold,
        alias_marks: tone.alias_marks,
        scores: log.scores,
        rejections: log.rejections,
    }
}

/// Standard errors of the rigid effects from the last joint fit (as [`held_errors`] left
/// them); the ringing tone's
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

/// How finely a held change time's error is found: the model's step (a change takes effect
/// at a 1 ms step).
const CHANGE_RESOLUTION_S: f64 = 1e-3;

/// The named effects' errors when the last joint fit held a parameter (a mass-property
/// change's time), instead of the covariance of the fit's difference columns, whose column
/// for a change time is steep or zero depending on whether 10 ms crosses a firing edge:
/// - the held parameter's error from its profile ([`crate::profile::held_error`]);
/// - the others' covariance with it where it is (the stepped parameters' own normal
///   matrix), plus what moving it by its error moves them by (the profile's re-fit at
///   `at +- error`, the delta method), so their errors include the change time's.
fn held_errors(n: &Nominal, named: &mut Named) {
    let Some(lin) = named.linearised.clone() else {
        return;
    };
    let rigid = named.rigid_except(None);
    let total: usize = named.sizes.iter().sum();
    // (the fit's errors and covariance go on with the nuisances, which are left as they are)
    if named.sizes.len() != rigid.len()
        || named.stderr.len() < total
        || named.cov.nrows() < total
        || named.cov.ncols() < total
    {
        return;
    }
    let stepped = lin.stepped();
    let cond = lin.covariance();
    let mut cov = nalgebra::DMatrix::from_element(total, total, f64::NAN);
    for (a, &i) in stepped.iter().enumerate().filter(|x| *x.1 < total) {
        for (b, &j) in stepped.iter().enumerate().filter(|x| *x.1 < total) {
            cov[(i, j)] = cond[(a, b)];
        }
    }
    let mut off = 0;
    for (r, ((kind, theta), &size)) in rigid.iter().zip(&named.sizes).enumerate() {
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
            let refit = |x: f64| {
                let mut pairs = rigid.clone();
                pairs[r].1[j] = x;
                let w = n
                    .prob
                    .weighted(&crate::select::build(&n.fired, &pairs, &named.nuis))?;
                lin.refit(&w)
            };
            let cost = |x: f64| Some(refit(x)?.0);
            // the probes of a first scan centred here (`select::change_probes`), on the
            // recording's clock as the scan's; the time to the model's 1 ms steps (a change
            // takes effect at a step), not to the 10 ms of its difference column
            let (dur, half) = crate::select::change_window(n.series);
            let probes = crate::select::change_probes(n.series, at, half, dur);
            let resolution = step.min(CHANGE_RESOLUTION_S);
            let se = crate::profile::held_error(&cost, at, (lo, hi), resolution, lin.rise, &probes);
            let held = off + j;
            cov[(held, held)] = se * se;
            if !se.is_finite() {
                continue;
            }
            // the re-fitted parameters' change over one error of the held one (the span
            // shorter where a bound clips it)
            let (x_up, x_down) = ((at + se).min(hi), (at - se).max(lo));
            let (Some(up), Some(down)) = (refit(x_up), refit(x_down)) else {
                continue;
            };
            let per_error = se / (x_up - x_down).max(f64::MIN_POSITIVE);
            let moved: Vec<(usize, f64)> =
                up.1.iter()
                    .zip(&down.1)
                    .filter(|(u, _)| u.0 < total)
                    .map(|(u, d)| (u.0, (u.1 - d.1) * per_error))
                    .collect();
            for &(i, gi) in &moved {
                cov[(held, i)] = gi * se;
                cov[(i, held)] = gi * se;
                for &(k, gk) in &moved {
                    cov[(i, k)] += gi * gk;
                }
            }
        }
        off += size;
    }
    for (i, se) in named.stderr.iter_mut().take(total).enumerate() {
        *se = cov[(i, i)].sqrt();
    }
    named.cov.view_mut((0, 0), (total, total)).copy_from(&cov);
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
