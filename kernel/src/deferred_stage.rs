//! Which part of a firing's end-of-firing work a tick runs: the pipeline's own stages
//! (`pipeline.rs`) then the fold's (`fold.rs`). Its own module so that both name the stages
//! without depending on each other.

/// The end-of-firing stage the next tick runs (telemetry: which part of the deferred work a
/// tick carried, e.g. to attribute its execution time).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum DeferredStage {
    /// The firing's final angular-acceleration estimate.
    Measure = 1,
    /// The firing's measurements in aggregate.
    Aggregate = 2,
    /// CoM information added.
    FoldCom = 3,
    /// Inverse-inertia add planned (its rounding exponent).
    PlanInertia = 4,
    /// Inverse-inertia information added.
    FoldInertia = 5,
    /// Innovation against the latest solve, first two rows.
    Detect = 6,
    /// Innovation, third row; variance factor and (with a detector) the change test.
    DetectFinish = 7,
    /// Forgetting and merge of the inverse-inertia information.
    MergeInertia = 8,
    /// Forgetting and merge of the CoM information, and the CoM solve.
    MergeCom = 9,
    /// CoM solve (after the batch, which has nothing to merge).
    SolveCom = 10,
    /// Inverse-inertia LU factorisation.
    FactorInertia = 11,
    /// Inverse-inertia solve and status.
    SolveInertia = 12,
}
