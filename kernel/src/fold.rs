//! The end-of-firing fold of the mass-property identification as one type: a firing's
//! measurement in aggregate goes into the information, the innovation is tested, the firing
//! is merged and the estimate re-solved, one [`FiringFold::step`] per tick so that no tick
//! carries more than one stage (`Pipeline::tick` runs one per tick; `Pipeline::finish` and a
//! firing that ends early run the rest at once).
//!
//! The order is the types': each `Stage` variant holds what the previous stage produced and
//! only its own step can make the next one, and the [`MassId`] half-steps it calls are
//! private to the crate. This is the only way measurements enter [`MassId`]: the pipeline,
//! the proofs and the tests all fold through it, so every check exercises what flies.

use crate::deferred_stage::DeferredStage;
use crate::lu::LuError;
use crate::rls::{AddPlan, EstimateState, Factored, MassId, Measurement, RlsStatus};
use crate::scalar::{Scalar, Scaled};

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
