//! How a firing's measurement enters the estimate: the whole RLS update, in the order it
//! runs, in this file.
//!
//! [`FiringFold`] is one firing's update as a sequence of stages, one per tick so that no
//! tick carries more than one (`Pipeline::tick` runs one per tick; `Pipeline::finish` and a
//! firing that ends early run the rest at once). Each `Stage` variant holds what the previous
//! stage produced and only its own step can make the next one. The stages, and the
//! [`MassId`] steps below them in the same order:
//!
//! 1. `FoldCom`: the firing's CoM rows into the information (a batch firing) or into the
//!    pending firing ([`InfoLs::add`]);
//! 2. `PlanInertia`, `FoldInertia`: the same for the inverse-inertia rows, in two halves
//!    ([`InfoLs::plan_add`], [`InfoLs::apply_add`]);
//! 3. `Detect`, `DetectFinish`: the firing's normalised innovation against the latest solve,
//!    counted into the variance factor and fed to the change detector (a CUSUM that deflates
//!    the information on an alarm: [`DetectorConfig`]);
//! 4. `MergeInertia`, `MergeCom`: forgetting over the firing's updates, then the pending
//!    firing merged into the information ([`InfoLs::forget`], [`InfoLs::merge`]);
//! 5. `SolveCom`, `FactorInertia`, `SolveInertia`: the LU solves (`MassId`'s `solve_com`,
//!    `factor_inertia`, `finish_inertia`).
//!
//! A batch firing (the first two) skips 3 and 4, and only the last of them solves. This is
//! the only way measurements enter [`MassId`]: the pipeline, the proofs and the tests all fold
//! through it, so every check exercises what flies.

use super::info_ls::{AddPlan, Factored, InfoLs, Solution};
use super::mass_id::{DetectorConfig, EstimateState, MassId, RlsStatus};
use crate::deferred_stage::DeferredStage;
use crate::lu::LuError;
use crate::scalar::{Scalar, Scaled};

/// The two least-squares problems' regressors for one measurement (seed eqs 3.5-3.8): a
/// firing's, in aggregate, is what the update folds in.
#[derive(Clone, Copy, Debug)]
pub struct Measurement<S> {
    /// CoM rows `I^-1 [c]x` (rad/s^2 per m).
    pub a_com: [[S; 3]; 3],
    /// CoM right-hand side `omega_dot - I^-1 a` (rad/s^2).
    pub b_com: [S; 3],
    /// Inverse-inertia rows from the torque in cN m.
    pub a_inertia: [[S; 6]; 3],
    /// Inverse-inertia right-hand side `omega_dot` (rad/s^2).
    pub b_inertia: [S; 3],
    /// Per-axis weight `1 / variance(omega_dot)`.
    pub weight: [Scaled<S>; 3],
    /// Per-axis variance of `omega_dot` (for the change detector).
    pub variance: [Scaled<S>; 3],
}

impl<S: Scalar> Measurement<S> {
    /// All zero (storage initialisation; adds nothing).
    pub fn zero() -> Self {
        Measurement {
            a_com: [[S::ZERO; 3]; 3],
            b_com: [S::ZERO; 3],
            a_inertia: [[S::ZERO; 6]; 3],
            b_inertia: [S::ZERO; 3],
            weight: [Scaled::zero(); 3],
            variance: [Scaled::zero(); 3],
        }
    }

    /// The torque (cN m) the inverse-inertia rows were built from (their diagonal entries).
    pub fn a_inertia_torque(&self) -> [S; 3] {
        [0usize, 1, 2].map(|i| {
            self.a_inertia
                .get(i)
                .and_then(|r| r.get(i))
                .copied()
                .unwrap_or(S::ZERO)
        })
    }
}

/// A solve the fold completed: its status and the estimate it started from (kept by the
/// caller if the new one is not physical).
#[derive(Clone, Copy, Debug)]
pub struct Solved<S> {
    /// The combined status of the two problems' solves.
    pub status: RlsStatus,
    /// The estimate before the solve.
    pub before: EstimateState<S>,
}

/// What one [`FiringFold::step`] did.
#[derive(Clone, Copy, Debug)]
pub enum FoldStep<S> {
    /// More stages follow.
    Pending,
    /// The fold is over; `Some` if it ended with a solve (an RLS firing or the last batch
    /// firing), `None` for an earlier batch firing (information added, no solve yet).
    Done(Option<Solved<S>>),
}

/// Where a fold is. Each variant carries what its step needs from the steps before.
#[derive(Clone, Copy, Debug)]
enum Stage<S> {
    FoldCom,
    PlanInertia,
    FoldInertia(AddPlan<S>),
    Detect,
    DetectFinish(Option<Scaled<S>>),
    MergeInertia,
    MergeCom,
    SolveCom,
    FactorInertia {
        com: RlsStatus,
        before: EstimateState<S>,
    },
    SolveInertia {
        com: RlsStatus,
        before: EstimateState<S>,
        factored: Result<Factored<S, 6>, LuError>,
    },
    Done,
}

/// One firing's fold into a [`MassId`].
#[derive(Clone, Copy, Debug)]
pub struct FiringFold<S> {
    /// The firing's per-sample measurements in aggregate (a fixed slot: stages move no
    /// large value).
    agg: Measurement<S>,
    /// How many per-sample measurements `agg` stands for.
    updates: u32,
    /// One of the batch firings (straight into the information, no test, no forgetting).
    batch: bool,
    /// The last batch firing (the batch is solved after it).
    batch_complete: bool,
    stage: Stage<S>,
}

impl<S: Scalar> FiringFold<S> {
    /// A fold of the aggregate measurement `agg` of `updates` samples. `batch`: one of the
    /// batch firings; `batch_complete`: the last of them.
    pub fn new(agg: Measurement<S>, updates: u32, batch: bool, batch_complete: bool) -> Self {
        FiringFold {
            agg,
            updates,
            batch,
            batch_complete,
            stage: Stage::FoldCom,
        }
    }

    /// The stage the next [`FiringFold::step`] runs (telemetry), `None` when done.
    pub fn stage(&self) -> Option<DeferredStage> {
        Some(match self.stage {
            Stage::FoldCom => DeferredStage::FoldCom,
            Stage::PlanInertia => DeferredStage::PlanInertia,
            Stage::FoldInertia(_) => DeferredStage::FoldInertia,
            Stage::Detect => DeferredStage::Detect,
            Stage::DetectFinish(_) => DeferredStage::DetectFinish,
            Stage::MergeInertia => DeferredStage::MergeInertia,
            Stage::MergeCom => DeferredStage::MergeCom,
            Stage::SolveCom => DeferredStage::SolveCom,
            Stage::FactorInertia { .. } => DeferredStage::FactorInertia,
            Stage::SolveInertia { .. } => DeferredStage::SolveInertia,
            Stage::Done => return None,
        })
    }

    /// Runs one stage.
    pub fn step(&mut self, mass: &mut MassId<S>) -> FoldStep<S> {
        let agg = &self.agg;
        let (next, done) = match core::mem::replace(&mut self.stage, Stage::Done) {
            Stage::FoldCom => {
                mass.add_com_part(agg, self.batch);
                (Stage::PlanInertia, None)
            }
            Stage::PlanInertia => (
                Stage::FoldInertia(mass.plan_inertia_part(agg, self.batch)),
                None,
            ),
            Stage::FoldInertia(plan) => {
                mass.apply_inertia_part(agg, &plan, self.batch, self.updates);
                if !self.batch {
                    (Stage::Detect, None)
                } else if self.batch_complete {
                    (Stage::SolveCom, None)
                } else {
                    (Stage::Done, Some(None))
                }
            }
            // The innovation of the aggregate against the latest solve, with the weights the
            // LS uses (its mean over the firings is the a-posteriori variance factor), in two
            // parts: rows 0-1, then row 2 ...
            Stage::Detect => (
                Stage::DetectFinish(mass.innovation_part(agg, (0, 2), Scaled::zero())),
                None,
            ),
            Stage::DetectFinish(part) => {
                // ... then the variance factor and, against a solve with every term
                // estimated, the change test.
                if let Some(nis) = part.and_then(|p| mass.innovation_part(agg, (2, 3), p)) {
                    mass.record_innovation(nis, mass.tests_inertia(agg));
                    if !mass.holds_terms_for(agg) {
                        mass.detect_with(nis);
                    }
                }
                (Stage::MergeInertia, None)
            }
            Stage::MergeInertia => {
                mass.merge_inertia();
                (Stage::MergeCom, None)
            }
            Stage::MergeCom => {
                mass.merge_com();
                let before = mass.estimate();
                (
                    Stage::FactorInertia {
                        com: mass.solve_com(),
                        before,
                    },
                    None,
                )
            }
            Stage::SolveCom => {
                let before = mass.estimate();
                (
                    Stage::FactorInertia {
                        com: mass.solve_com(),
                        before,
                    },
                    None,
                )
            }
            Stage::FactorInertia { com, before } => (
                Stage::SolveInertia {
                    com,
                    before,
                    factored: mass.factor_inertia(),
                },
                None,
            ),
            Stage::SolveInertia {
                com,
                before,
                factored,
            } => {
                let inertia = mass.finish_inertia(factored);
                (
                    Stage::Done,
                    Some(Some(Solved {
                        status: mass.combine(com, inertia),
                        before,
                    })),
                )
            }
            Stage::Done => (Stage::Done, Some(None)),
        };
        self.stage = next;
        match done {
            Some(solved) => FoldStep::Done(solved),
            None => FoldStep::Pending,
        }
    }

    /// Runs every remaining stage now (a firing that ends before its fold did, the end of
    /// data, the proofs); returns the fold's outcome.
    pub fn run(&mut self, mass: &mut MassId<S>) -> Option<Solved<S>> {
        for _ in 0..STAGES {
            if let FoldStep::Done(s) = self.step(mass) {
                return s;
            }
        }
        None
    }
}

/// The most stages a fold has (an RLS firing: FoldCom .. SolveInertia).
pub const STAGES: usize = 10;

/// The update's steps on the estimator, in the order the stages run them.
impl<S: Scalar> MassId<S> {
    /// Adds the CoM rows of a firing's aggregate measurement: straight into the information
    /// (`batch`) or into the pending firing ([`FiringFold`] runs these steps).
    pub(crate) fn add_com_part(&mut self, m: &Measurement<S>, batch: bool) {
        if batch {
            self.solved_com = None;
        }
        let target = if batch {
            &mut self.com
        } else {
            &mut self.pending_com
        };
        target.add(&m.a_com, &m.b_com, &m.weight);
    }

    /// Plans the add of a firing's inverse-inertia rows (the first half of its work; reads only).
    pub(crate) fn plan_inertia_part(&self, m: &Measurement<S>, batch: bool) -> AddPlan<S> {
        let target = if batch {
            &self.inertia
        } else {
            &self.pending_inertia
        };
        target.plan_add(&m.a_inertia, &m.b_inertia, &m.weight)
    }

    /// Adds a firing's inverse-inertia rows (counting the `updates`) as planned by [`MassId::plan_inertia_part`]
    /// (same measurement and `batch`; nothing else may change the problem in between).
    pub(crate) fn apply_inertia_part(
        &mut self,
        m: &Measurement<S>,
        plan: &AddPlan<S>,
        batch: bool,
        updates: u32,
    ) {
        if batch {
            self.solved_inertia = None;
            self.inertia.apply_add(&m.a_inertia, &m.b_inertia, plan);
        } else {
            self.pending_inertia
                .apply_add(&m.a_inertia, &m.b_inertia, plan);
            self.pending_updates = self.pending_updates.saturating_add(updates);
        }
        self.updates = self.updates.saturating_add(updates);
    }

    /// Part of the change test's statistic (the normalised innovation squared of `m`, rows
    /// `rows.0..rows.1`, added to `acc`) against the latest solve (`None`: no test), from the equations
    /// that carry the firing: the inertia equations for a firing with torque (>= 0.5 cN m),
    /// else (a translation) the CoM equations. A translation's inertia rows are near zero,
    /// so after a CoM change the seed's inertia equations (nominal lever arms) cannot explain
    /// its rate change: testing them there would raise alarms on every translation.
    pub(crate) fn innovation_part(
        &self,
        m: &Measurement<S>,
        rows: (usize, usize),
        acc: Scaled<S>,
    ) -> Option<Scaled<S>> {
        if self.tests_inertia(m) {
            nis_of(
                self.solved_inertia.as_ref()?,
                &m.a_inertia,
                &m.b_inertia,
                &m.variance,
                rows,
                acc,
            )
        } else {
            nis_of(
                self.solved_com.as_ref()?,
                &m.a_com,
                &m.b_com,
                &m.variance,
                rows,
                acc,
            )
        }
    }

    /// True when a firing's innovation is taken on the inverse-inertia equations (a firing
    /// with torque), false for the CoM equations (a translation).
    pub(crate) fn tests_inertia(&self, m: &Measurement<S>) -> bool {
        let torque_sq = m
            .a_inertia
            .iter()
            .enumerate()
            .fold(S::ZERO, |acc, (i, row)| {
                let a = row.get(i).copied().unwrap_or(S::ZERO);
                acc.mul_add(a, a)
            });
        let strong = S::from_int_pow2(1, -2);
        strong.lt(torque_sq)
    }

    /// True if the latest solve of the problem `m` is tested on holds some term at the prior
    /// (the change detector then has no meaningful prediction; the variance factor still
    /// counts the innovation).
    pub(crate) fn holds_terms_for(&self, m: &Measurement<S>) -> bool {
        if self.tests_inertia(m) {
            self.solved_inertia
                .as_ref()
                .is_none_or(|s| s.unobservable.iter().any(|u| *u))
        } else {
            self.solved_com
                .as_ref()
                .is_none_or(|s| s.unobservable.iter().any(|u| *u))
        }
    }

    /// Counts one ended firing's normalised innovation squared `nis` over its three rows
    /// into the variance factor of the problem it was taken on ([`MassId::variance_factors`]).
    pub(crate) fn record_innovation(&mut self, nis: Scaled<S>, inertia: bool) {
        let (sum, n) = if inertia {
            &mut self.innovations[1]
        } else {
            &mut self.innovations[0]
        };
        *sum = sum.plus(nis);
        *n = n.saturating_add(3);
    }

    /// The change test with its statistic computed (no-op without a detector configured).
    pub(crate) fn detect_with(&mut self, nis: Scaled<S>) {
        if let Some(det) = self.cfg.detector {
            self.detect(&det, nis);
        }
    }

    fn detect(&mut self, det: &DetectorConfig<S>, nis: Scaled<S>) {
        if self.level_firings < det.warmup_firings {
            // Learning: the level is the running mean of the statistic.
            let n = self.level_firings.saturating_add(1);
            let w = Scaled::from_i64(i64::from(n));
            let sum = self
                .level
                .times(Scaled::from_i64(i64::from(self.level_firings)))
                .plus(nis);
            if let Some(mean) = sum.over(w) {
                self.level = mean;
            }
            self.level_firings = n;
            return;
        }
        let Some(ratio) = nis.over(self.level) else {
            return;
        };
        let ratio = ratio.value(); // saturates for a huge excess: still an alarm
        self.last_ratio = ratio;
        let s = self.cusum.plus(ratio).minus(S::ONE).minus(det.drift);
        self.cusum = if S::ZERO.lt(s) { s } else { S::ZERO };
        if det.threshold.lt(self.cusum) {
            self.solved_com = None;
            self.solved_inertia = None;
            self.com.deflate(det.deflate_bits);
            self.inertia.deflate(det.deflate_bits);
            self.cusum = S::ZERO;
            self.resets = self.resets.saturating_add(1);
            // The estimate has to re-converge on the new configuration: learn the level again
            // (no further alarm meanwhile, so one change gives one reset).
            self.level = Scaled::zero();
            self.level_firings = 0;
        } else if ratio.lt(S::ONE.plus(det.drift)) {
            // Track slow changes of the level with the in-control firings (weight 1/8).
            self.level = self
                .level
                .times(Scaled::from_f64(0.875))
                .plus(nis.times(Scaled::from_f64(0.125)));
        }
    }

    /// Forgetting of the inverse-inertia information over the pending firing's updates, and
    /// the firing's inverse-inertia information merged in.
    pub(crate) fn merge_inertia(&mut self) {
        self.solved_inertia = None;
        if let Some(l) = self.cfg.forgetting {
            self.inertia.forget(pow_u32(l, self.pending_updates));
        }
        let pi = self.pending_inertia;
        self.inertia.merge(&pi);
        self.pending_inertia = InfoLs::new();
    }

    /// [`MassId::merge_inertia`] for the CoM information; ends the firing's fold (run it last).
    pub(crate) fn merge_com(&mut self) {
        self.solved_com = None;
        if let Some(l) = self.cfg.forgetting {
            self.com.forget(pow_u32(l, self.pending_updates));
        }
        let pc = self.pending_com;
        self.com.merge(&pc);
        self.pending_com = InfoLs::new();
        self.pending_updates = 0;
    }
}

/// `sum_i nu_i^2 / (P_i + (A Q A')_ii)` for one problem (held terms count as known).
/// The normalised innovation squared of rows `from..to` of a measurement against a solve,
/// added to `acc` (rows in order, so a statistic computed in parts equals the whole).
fn nis_of<S: Scalar, const N: usize>(
    sol: &Solution<S, N>,
    rows: &[[S; N]; 3],
    b: &[S; 3],
    variance: &[Scaled<S>; 3],
    (from, to): (usize, usize),
    acc: Scaled<S>,
) -> Option<Scaled<S>> {
    let mut total = acc;
    for ((row, b), var) in rows
        .iter()
        .zip(b.iter())
        .zip(variance.iter())
        .take(to)
        .skip(from)
    {
        let pred = row
            .iter()
            .zip(sol.x.iter())
            .fold(S::ZERO, |acc, (a, x)| acc.mul_add(*a, *x));
        let nu = b.minus(pred);
        let s = sol.predicted_variance(row)?.plus(*var);
        let nu_s = Scaled { m: nu, e: 0 }.normalized();
        total = total.plus(nu_s.times(nu_s).over(s)?);
    }
    Some(total)
}

/// `x^n` by repeated squaring.
pub fn pow_u32<S: Scalar>(x: S, n: u32) -> S {
    let mut result = S::ONE;
    let mut base = x;
    let mut n = n;
    while n > 0 {
        if n & 1 == 1 {
            result = result.times(base);
        }
        base = base.times(base);
        n >>= 1;
    }
    result
}
