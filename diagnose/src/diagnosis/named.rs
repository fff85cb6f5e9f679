//! The state the stages hand on: the effects named so far and the model they make (its
//! joint fit, residual and BIC). One update, [`Named::adopt`], for every way the set
//! changes: an acceptance, a drop and a swap.

use super::nominal::Nominal;
use crate::candidate::{Trial, Tried};
use crate::effects::Describe;
use crate::effects::Kind;
use crate::fit;
use crate::locate;
use crate::ringing::RingingFit;
use crate::select::Settings;
use crate::stats::{self, ResidualTests};

/// One named effect.
pub(super) struct Accepted {
    pub kind: Kind,
    /// Parameters in the effect's own layout, as last fitted.
    pub theta: Vec<f64>,
    /// Standard errors, filled from the final joint fit (`conclusion.rs`).
    pub stderr: Vec<f64>,
    /// Their covariance, filled with them (empty for the ringing tone).
    pub cov: nalgebra::DMatrix<f64>,
    /// BIC of the whole model when it was named, against the nominal model.
    pub delta_bic: f64,
    pub rms_after: [f64; 3],
    pub windows: Vec<[i64; 2]>,
    pub evidence: String,
    /// What this recording cannot tell it from (`indistinct.rs`), listed as equivalent.
    pub alike: Vec<super::indistinct::Indistinct>,
}

/// What one round of the selection names: `(delta BIC, effect, note)` per effect, and the
/// model with them.
pub(super) type Taken = (Vec<(f64, Kind, String)>, Tried);

/// The named effects and the model they make.
pub(super) struct Named {
    pub accepted: Vec<Accepted>,
    /// Initial rate and rate jumps at gaps, fitted with the named effects.
    pub nuis: Vec<f64>,
    /// Chi-square of the rigid-body model (without the ringing tone).
    pub chi2_rigid: f64,
    pub rigid_residual: Vec<[f64; 3]>,
    /// Standard errors of the last joint fit, the named rigid effects in order.
    pub stderr: Vec<f64>,
    /// The covariance of the same fit.
    pub cov: nalgebra::DMatrix<f64>,
    /// The same fit linearised, when it holds a parameter (a change time's profile,
    /// `conclusion.rs`).
    pub linearised: Option<std::rc::Rc<crate::profile::Linearised>>,
    /// Parameters per named rigid effect in `stderr`.
    pub sizes: Vec<usize>,
    /// Valve latency of the named effects (ringing is excited at the actual valve motion).
    pub latency: (f64, f64),
    pub ringing: Option<RingingFit>,
    /// Residual of the whole model (rigid body and ringing).
    pub residual: Vec<[f64; 3]>,
    /// Identifiable parameters of the named effects (the BIC penalty).
    pub k: usize,
}

impl Named {
    /// Nothing named: the nominal model.
    pub fn nominal(n: &Nominal) -> Named {
        Named {
            accepted: vec![],
            nuis: n.nuis.clone(),
            chi2_rigid: n.chi2,
            rigid_residual: n.residual.clone(),
            stderr: vec![],
            cov: nalgebra::DMatrix::zeros(0, 0),
            linearised: None,
            sizes: vec![],
            latency: (0.0, 0.0),
            ringing: None,
            residual: n.residual.clone(),
            k: 0,
        }
    }

    /// What the ringing tone removes from the chi-square.
    pub fn ring_gain(&self) -> f64 {
        self.ringing.as_ref().map(|r| r.gain).unwrap_or(0.0)
    }

    /// Chi-square of the whole model.
    pub fn chi2(&self) -> f64 {
        self.chi2_rigid - self.ring_gain()
    }

    /// BIC of the whole model minus the nominal model's.
    pub fn delta_bic(&self, n: &Nominal) -> f64 {
        self.chi2() - n.chi2 + self.k as f64 * n.ln_n
    }

    /// RMS of the whole model's residual per axis.
    pub fn rms(&self, n: &Nominal) -> [f64; 3] {
        locate::rms(&self.residual, &n.series.valid)
    }

    /// Every named effect with its parameters.
    pub fn pairs(&self) -> Vec<(Kind, Vec<f64>)> {
        self.accepted
            .iter()
            .map(|a| (a.kind, a.theta.clone()))
            .collect()
    }

    /// The named rigid-body effects (not the ringing tone) except `out`.
    pub fn rigid_except(&self, out: Option<Kind>) -> Vec<(Kind, Vec<f64>)> {
        self.accepted
            .iter()
            .filter(|a| Some(a.kind) != out && !a.kind.effect().on_residual())
            .map(|a| (a.kind, a.theta.clone()))
            .collect()
    }

    /// How many of the named `kind`'s parameters the last joint fit identified.
    pub fn identifiable(&self, kind: Kind, n: &Nominal) -> usize {
        let rigid = self
            .accepted
            .iter()
            .filter(|a| !a.kind.effect().on_residual());
        let mut off = 0;
        for (a, &k) in rigid.zip(&self.sizes) {
            if a.kind == kind {
                return self
                    .stderr
                    .get(off..off + k)
                    .map(fit::identifiable)
                    .unwrap_or(k);
            }
            off += k;
        }
        crate::effects::n_params(kind, &n.fired)
    }

    /// The candidate's verdict on top of `rigid_acc` (some of the named rigid effects),
    /// measured against this model's residual and its tests `tests_prev`.
    pub fn trial<'a>(
        &'a self,
        n: &'a Nominal,
        rigid_acc: &'a [(Kind, Vec<f64>)],
        tests_prev: &'a ResidualTests,
        settings: &'a Settings,
    ) -> Trial<'a> {
        Trial {
            prob: &n.prob,
            fired: &n.fired,
            rigid_acc,
            nuis: &self.nuis,
            hint: &n.slosh_hint,
            settings,
            rigid_residual: &self.rigid_residual,
            whitening: &n.whitening,
            ringing_on: self.ringing.is_some(),
            sigma: n.sigma(),
            rms_prev: self.rms(n),
            tests_prev,
        }
    }

    /// The residual tests of the current model (what a candidate must not make worse).
    pub fn tests(&self, n: &Nominal) -> ResidualTests {
        stats::residual_tests(n.series, &self.residual)
    }

    /// Takes over the model `t` (a candidate accepted, an effect dropped or swapped): the
    /// named effects' refitted parameters, the ringing and the residual, and, when the
    /// rigid-body part was refitted (`rigid`), its nuisances, chi-square, standard errors
    /// and latency. `k` is the new model's identifiable parameter count.
    pub fn adopt(&mut self, t: &Tried, rigid: bool, k: usize) {
        if rigid {
            self.nuis = t.nuis.clone();
            self.chi2_rigid = t.chi2_rigid;
            self.rigid_residual = t.rigid_residual.clone();
            self.stderr = t.stderr.clone();
            self.cov = t.cov.clone();
            self.linearised = t.linearised.clone();
            self.sizes = t.sizes.clone();
            self.latency = t.latency;
        }
        for a in self.accepted.iter_mut() {
            if let Some((_, th)) = t.pairs.iter().find(|p| p.0 == a.kind) {
                a.theta = th.clone();
            }
        }
        self.ringing = t.ringing.clone();
        self.residual = t.residual.clone();
        self.k = k;
    }
}
