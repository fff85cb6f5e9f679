//! One candidate (a single effect, or a set named together) fitted on top of the named
//! effects and put through the acceptance checks of `acceptance.rs`: the same verdict for
//! the forward selection, the pair search and the exchange step.

use crate::acceptance;
use crate::effects::Describe;
use crate::effects::{self, Kind};
use crate::fit::{self, Problem};
use crate::locate;
use crate::model::NT;
use crate::profile::Linearised;
use crate::ringing::{self, RingingFit};
use crate::select::latency_of;
use crate::select::{self, Settings};
use crate::series::Series;
use crate::stats::{self, ResidualTests};
use std::rc::Rc;

/// What a round knows before it tries a candidate: the named rigid effects, the state
/// nuisances, the residual and its tests.
pub(crate) struct Trial<'a> {
    pub prob: &'a Problem<'a>,
    pub fired: &'a [bool; NT],
    pub rigid_acc: &'a [(Kind, Vec<f64>)],
    pub nuis: &'a [f64],
    pub hint: &'a [f64],
    pub settings: &'a Settings,
    pub rigid_residual: &'a [[f64; 3]],
    pub whitening: &'a ringing::Whitening,
    pub ringing_on: bool,
    /// Gyro noise standard deviation per axis.
    pub sigma: [f64; 3],
    pub rms_prev: [f64; 3],
    pub tests_prev: &'a ResidualTests,
}

impl Trial<'_> {
    /// The candidate `new` fitted on top of the named effects, if it passes every check of
    /// `acceptance.rs`; otherwise why not.
    pub fn check(&self, new: &[(Kind, Vec<f64>)], rf: Option<RingingFit>) -> Result<Tried, String> {
        let series = self.prob.series;
        let t = self.refit(new, rf)?;
        if let Some(why) = t.implausible.clone() {
            return Err(format!("implausible: {why}"));
        }
        for (kind, d) in &t.contributions {
            let material = acceptance::materiality(d, &series.valid, self.sigma);
            if material.iter().all(|&m| m < acceptance::MATERIAL_FRACTION) {
                let who = if new.len() > 1 {
                    format!("{} ", kind.name())
                } else {
                    String::new()
                };
                return Err(format!(
                    "not material: {who}adds at most {:.2} of the gyro noise where it acts (needs {})",
                    material.iter().cloned().fold(0.0, f64::max),
                    acceptance::MATERIAL_FRACTION
                ));
            }
        }
        let rms_new = locate::rms(&t.residual, &series.valid);
        let tests_new = stats::residual_tests(series, &t.residual);
        if let Some(why) =
            acceptance::axis_worse(self.rms_prev, rms_new, self.tests_prev, &tests_new)
        {
            return Err(why);
        }
        if !new[0].0.effect().on_residual() {
            match acceptance::holdout(
                self.prob,
                self.fired,
                self.rigid_acc,
                new,
                self.nuis,
                self.hint,
                self.settings.max_iter,
            ) {
                Some(h) => {
                    if let Some(why) = h.failure() {
                        return Err(why);
                    }
                }
                None => return Err("the out-of-sample fit failed".into()),
            }
        }
        Ok(t)
    }
}

impl Trial<'_> {
    /// The named effects alone, refitted jointly (the model as it would be if the one left
    /// out of `rigid_acc` were dropped): the backward step of the exchange.
    pub fn without(&self) -> Result<Tried, String> {
        self.refit(&[], None)
    }

    /// The model with `new` added to the named effects, refitted jointly, unchecked.
    fn refit(&self, new: &[(Kind, Vec<f64>)], rf: Option<RingingFit>) -> Result<Tried, String> {
        try_candidate(
            self.prob,
            self.fired,
            self.rigid_acc,
            new,
            rf,
            self.nuis,
            self.hint,
            self.settings,
            self.rigid_residual,
            self.whitening,
            self.ringing_on,
        )
    }
}

/// The model with one more effect, as it would be if the effect were accepted.
pub(crate) struct Tried {
    /// Accepted rigid effects plus the candidate, refitted jointly (ringing not included).
    pub pairs: Vec<(Kind, Vec<f64>)>,
    pub nuis: Vec<f64>,
    pub chi2_rigid: f64,
    pub stderr: Vec<f64>,
    /// The joint fit's covariance (for the Wald test of one effect's parameters together).
    pub cov: nalgebra::DMatrix<f64>,
    /// The same fit linearised, when it holds a parameter ([`crate::fit::FitResult::linearised`]).
    pub linearised: Option<Rc<Linearised>>,
    pub sizes: Vec<usize>,
    pub rigid_residual: Vec<[f64; 3]>,
    pub latency: (f64, f64),
    pub ringing: Option<RingingFit>,
    pub residual: Vec<[f64; 3]>,
    /// What each new effect adds to the predicted rates (or removes from the residual),
    /// in the order they were tried.
    pub contributions: Vec<(Kind, Vec<[f64; 3]>)>,
    pub implausible: Option<String>,
}

impl Tried {
    /// How many of `kind`'s parameters the joint fit could identify (its BIC penalty).
    pub(crate) fn identifiable(&self, kind: Kind, fired: &[bool; NT]) -> usize {
        let Some(at) = self.pairs.iter().position(|p| p.0 == kind) else {
            return effects::n_params(kind, fired);
        };
        let off: usize = self.sizes.iter().take(at).sum();
        match (self.sizes.get(at), self.stderr.get(off..)) {
            (Some(&n), Some(se)) if se.len() >= n => fit::identifiable(&se[..n]),
            _ => effects::n_params(kind, fired),
        }
    }
}

/// Refits the model with the candidate (one effect, or a set named together) added and
/// measures what each of its effects changes.
#[allow(clippy::too_many_arguments)]
fn try_candidate(
    prob: &Problem,
    fired: &[bool; NT],
    rigid_acc: &[(Kind, Vec<f64>)],
    new: &[(Kind, Vec<f64>)],
    rf: Option<RingingFit>,
    nuis: &[f64],
    hint: &[f64],
    settings: &Settings,
    rigid_residual: &[[f64; 3]],
    whitening: &ringing::Whitening,
    ringing_on: bool,
) -> Result<Tried, String> {
    let series = prob.series;
    if let [(kind, _)] = new {
        if kind.effect().on_residual() {
            return try_ringing(
                series,
                rigid_acc,
                *kind,
                rf,
                nuis,
                rigid_residual,
                whitening,
            );
        }
    }
    let mut pairs = rigid_acc.to_vec();
    pairs.extend_from_slice(new);
    let (pairs, chi2_rigid, w, (stderr, cov, linearised), sizes) =
        refit_all(prob, fired, &pairs, nuis, hint, settings);
    let with = select::build(fired, &pairs, &w);
    let y1 = prob
        .predict(&with)
        .ok_or("the model with it cannot be predicted")?;
    let mut contributions = vec![];
    let mut implausible = None;
    let cx = select::context(prob, fired, hint);
    for (kind, _) in new {
        let without: Vec<(Kind, Vec<f64>)> =
            pairs.iter().filter(|p| p.0 != *kind).cloned().collect();
        let y0 = prob
            .predict(&select::build(fired, &without, &w))
            .ok_or("the model without it cannot be predicted")?;
        contributions.push((
            *kind,
            y1.iter()
                .zip(&y0)
                .map(|(a, b)| std::array::from_fn(|i| a[i] - b[i]))
                .collect(),
        ));
        let th = pairs
            .iter()
            .find(|p| p.0 == *kind)
            .map(|p| p.1.clone())
            .unwrap_or_default();
        let sp = select::spec(*kind, prob, fired, hint);
        implausible = implausible.or(
            acceptance::implausible(*kind, &th, &cx, &sp.lo, &sp.hi).map(|why| {
                if new.len() > 1 {
                    format!("{}: {why}", kind.name())
                } else {
                    why
                }
            }),
        );
    }
    let rigid_residual = prob.residual(&with).ok_or("no residual")?;
    let latency = latency_of(&pairs);
    let ringing = if ringing_on {
        ringing::fit(
            series,
            &rigid_residual,
            whitening,
            settings.ringing_prior_hz,
            latency,
        )
    } else {
        None
    };
    let residual = match &ringing {
        Some(r) => ringing::remove(series, &rigid_residual, whitening, r, latency),
        None => rigid_residual.clone(),
    };
    Ok(Tried {
        pairs,
        nuis: w,
        chi2_rigid,
        stderr,
        cov,
        linearised,
        sizes,
        rigid_residual,
        latency,
        ringing,
        residual,
        contributions,
        implausible,
    })
}

/// The ringing candidate: a tone removed from the rigid residual, the rigid fit unchanged.
fn try_ringing(
    series: &Series,
    rigid_acc: &[(Kind, Vec<f64>)],
    kind: Kind,
    rf: Option<RingingFit>,
    nuis: &[f64],
    rigid_residual: &[[f64; 3]],
    whitening: &ringing::Whitening,
) -> Result<Tried, String> {
    let rf = rf.ok_or("no ringing fit")?;
    let latency = latency_of(rigid_acc);
    let residual = ringing::remove(series, rigid_residual, whitening, &rf, latency);
    let contribution = rigid_residual
        .iter()
        .zip(&residual)
        .map(|(a, b)| std::array::from_fn(|i| a[i] - b[i]))
        .collect();
    Ok(Tried {
        pairs: rigid_acc.to_vec(),
        nuis: nuis.to_vec(),
        chi2_rigid: f64::NAN,
        stderr: vec![],
        cov: nalgebra::DMatrix::zeros(0, 0),
        linearised: None,
        sizes: vec![],
        rigid_residual: rigid_residual.to_vec(),
        latency,
        implausible: acceptance::implausible_ringing(rf.decay_ms, rf.freq_hz),
        ringing: Some(rf),
        residual,
        contributions: vec![(kind, contribution)],
    })
}

/// The refitted effects, chi-square, nuisances, (standard errors, covariance, the fit
/// linearised) and sizes.
type Refit = (
    Vec<(Kind, Vec<f64>)>,
    f64,
    Vec<f64>,
    (Vec<f64>, nalgebra::DMatrix<f64>, Option<Rc<Linearised>>),
    Vec<usize>,
);

/// Joint refit of every accepted effect (ringing held, then re-regressed on the result).
fn refit_all(
    prob: &Problem,
    fired: &[bool; NT],
    pairs: &[(Kind, Vec<f64>)],
    nuis: &[f64],
    hint: &[f64],
    settings: &Settings,
) -> Refit {
    let res = select::fit_joint(prob, fired, pairs, None, nuis, hint, settings.max_iter * 2);
    let Some((fr, sizes)) = res else {
        let p = select::build(fired, pairs, nuis);
        return (
            pairs.to_vec(),
            prob.chi2(&p).unwrap_or(f64::INFINITY),
            nuis.to_vec(),
            (vec![], nalgebra::DMatrix::zeros(0, 0), None),
            vec![],
        );
    };
    let mut out = vec![];
    let mut off = 0;
    for ((k, _), &n) in pairs.iter().zip(sizes.iter()) {
        out.push((*k, fr.theta[off..off + n].to_vec()));
        off += n;
    }
    let w = fr.theta[off..].to_vec();
    let p = select::build(fired, &out, &w);
    let chi2 = prob.chi2(&p).unwrap_or(fr.chi2);
    (out, chi2, w, (fr.stderr, fr.cov, fr.linearised), sizes)
}
