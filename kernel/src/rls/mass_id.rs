//! The mass-property estimator's state: the CoM and inverse-inertia problems, the
//! estimate, its solve and its variances. How measurements enter it is [`super::update`].

use super::info_ls::{Factored, InfoLs, MaybeVariances, Solution};
use crate::lu::LuError;
use crate::scalar::{Scalar, Scaled};

/// Change detector on the RLS innovations, evaluated once per firing from the firing's
/// final angular acceleration: the normalised innovation squared
/// `nis = sum_i nu_i^2 / (P_i + (A Q A')_ii)` against the estimate from before the firing
/// (inertia equations for a firing with torque, CoM equations for a translation), divided by its learnt level (the Kalman filter's formal variances
/// are optimistic, so the level is learnt over `warmup_firings` firings and then tracked),
/// feeds a one-sided CUSUM `g = max(0, g + ratio - 1 - drift)`; an alarm (`g > threshold`)
/// divides the information by `2^deflate_bits` (a covariance reset that keeps the estimate)
/// and restarts the level learning while the estimate re-converges.
#[derive(Clone, Copy, Debug)]
pub struct DetectorConfig<S> {
    /// Allowed excess of the ratio over 1 per firing.
    pub drift: S,
    /// Alarm when the cumulative excess exceeds this.
    pub threshold: S,
    /// On alarm, the information is divided by 2^deflate_bits (covariance reset).
    pub deflate_bits: i32,
    /// Firings (with every term observable) that only learn the innovation level.
    pub warmup_firings: u32,
}

impl<S: Scalar> DetectorConfig<S> {
    /// Drift 3, threshold 30, information divided by 2^10 (~1e-3, the reference's shrink),
    /// level learnt over 6 firings.
    pub fn standard() -> Self {
        DetectorConfig {
            drift: S::from_int_pow2(3, 0),
            threshold: S::from_int_pow2(30, 0),
            deflate_bits: 10,
            warmup_firings: 6,
        }
    }
}

/// RLS options.
#[derive(Clone, Copy, Debug)]
pub struct RlsConfig<S> {
    /// Forgetting factor per update (`None` = the seed's RLS, never forgets).
    pub forgetting: Option<S>,
    /// Change detector (`None` = off).
    pub detector: Option<DetectorConfig<S>>,
    /// A term is unobservable when its information is below this fraction of the largest.
    pub unobservable_rel: S,
    /// LU pivot threshold relative to the matrix scale.
    pub pivot_rel: S,
    /// Weak prior on each inverse-inertia term: standard deviation as a fraction of the mean
    /// nominal diagonal of `I^-1` (the f64 reference's 1.0; 0 = no prior).
    pub prior_inertia_rel_std: f32,
    /// Weak prior on each CoM offset term: standard deviation, m (reference: 0.02; 0 = none).
    pub prior_com_std_m: f32,
}

impl<S: Scalar> Default for RlsConfig<S> {
    fn default() -> Self {
        RlsConfig {
            forgetting: None,
            detector: None,
            unobservable_rel: S::from_int_pow2(1, -14),
            pivot_rel: S::from_int_pow2(1, -20),
            prior_inertia_rel_std: 1.0,
            prior_com_std_m: 0.02,
        }
    }
}

/// Outcome of a solve.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RlsStatus {
    /// Estimate updated, every term observable.
    Ok,
    /// Estimate updated; some terms held at the prior (see the masks).
    PartlyUnobservable,
    /// The information matrix is numerically singular beyond the unobservable terms.
    Singular,
    /// A value did not fit the scalar format.
    Overflow,
    /// No information yet.
    NoData,
}

/// CoM offset + inverse inertia identification state.
#[derive(Clone, Copy, Debug)]
pub struct MassId<S> {
    pub(super) cfg: RlsConfig<S>,
    pub(super) com: InfoLs<S, 3>,
    pub(super) inertia: InfoLs<S, 6>,
    pub(super) pending_com: InfoLs<S, 3>,
    pub(super) pending_inertia: InfoLs<S, 6>,
    pub(super) pending_updates: u32,
    pub(super) prior_inertia: [S; 6],
    /// CoM offset estimate, m (relative to the model's CoM).
    pub delta_com_m: [S; 3],
    /// Inverse-inertia parameters (xx yy zz xy xz yz), 1/(kg m^2)/100.
    pub theta_inertia: [S; 6],
    /// Terms held at the prior.
    pub unobservable_com: [bool; 3],
    /// Terms held at the prior.
    pub unobservable_inertia: [bool; 6],
    /// Latest solve's status.
    pub status: RlsStatus,
    /// Measurement updates folded in.
    pub updates: u32,
    /// Covariance resets by the change detector.
    pub resets: u32,
    pub(super) cusum: S,
    pub(super) level: Scaled<S>,
    pub(super) level_firings: u32,
    /// Last firing's detector statistic (normalised innovation squared over its level), for telemetry.
    pub last_ratio: S,
    /// The latest solve of each problem, kept while the problem is unchanged: the change
    /// detector tests a firing against it instead of solving again (a tick's budget).
    pub(super) solved_com: Option<Solution<S, 3>>,
    pub(super) solved_inertia: Option<Solution<S, 6>>,
    /// Terms the excitation so far leaves unobservable ([`crate::observability`]): held at
    /// the prior in every solve. None until told (standalone use: numerical criterion only).
    pub(super) held_com: [bool; 3],
    pub(super) held_inertia: [bool; 6],
    /// Sum of the RLS firings' normalised innovations squared and their row count, per
    /// problem (CoM, inverse inertia).
    pub(super) innovations: [(Scaled<S>, u32); 2],
}

/// The estimate part of a [`MassId`] (kept to undo a solve that is not physical).
#[derive(Clone, Copy, Debug)]
pub struct EstimateState<S> {
    delta_com_m: [S; 3],
    theta_inertia: [S; 6],
    unobservable_com: [bool; 3],
    unobservable_inertia: [bool; 6],
}

impl<S: Scalar> EstimateState<S> {
    /// A placeholder (storage initialisation).
    pub fn empty() -> Self {
        EstimateState {
            delta_com_m: [S::ZERO; 3],
            theta_inertia: [S::ZERO; 6],
            unobservable_com: [true; 3],
            unobservable_inertia: [true; 6],
        }
    }
}

impl<S: Scalar> MassId<S> {
    /// Empty state; `prior_inertia` are the nominal parameters unobservable terms fall back to.
    pub fn new(cfg: RlsConfig<S>, prior_inertia: [S; 6]) -> Self {
        let mut com = InfoLs::new();
        let mut inertia = InfoLs::new();
        // Weak priors (variance^-1), in the kernel's units: CoM in m, inverse inertia / 100.
        let mean_diag = prior_inertia
            .iter()
            .take(3)
            .fold(0.0f64, |acc, v| acc + f64::from(v.to_f32()))
            / 3.0;
        let si = f64::from(cfg.prior_inertia_rel_std) * mean_diag;
        if si > 0.0 && si.is_finite() {
            inertia.add_diag(&[Scaled::from_f64(1.0 / (si * si)); 6], &prior_inertia);
        }
        let sc = f64::from(cfg.prior_com_std_m);
        if sc > 0.0 && sc.is_finite() {
            com.add_diag(&[Scaled::from_f64(1.0 / (sc * sc)); 3], &[S::ZERO; 3]);
        }
        MassId {
            cfg,
            com,
            inertia,
            pending_com: InfoLs::new(),
            pending_inertia: InfoLs::new(),
            pending_updates: 0,
            prior_inertia,
            delta_com_m: [S::ZERO; 3],
            theta_inertia: prior_inertia,
            unobservable_com: [true; 3],
            unobservable_inertia: [true; 6],
            status: RlsStatus::NoData,
            updates: 0,
            resets: 0,
            cusum: S::ZERO,
            level: Scaled::zero(),
            level_firings: 0,
            last_ratio: S::ZERO,
            solved_com: None,
            solved_inertia: None,
            held_com: [false; 3],
            held_inertia: [false; 6],
            innovations: [(Scaled::zero(), 0); 2],
        }
    }

    /// Which terms to hold at the prior (the excitation's unobservable terms).
    pub fn hold_unexcited(&mut self, com: [bool; 3], inertia: [bool; 6]) {
        if com != self.held_com {
            self.solved_com = None;
        }
        if inertia != self.held_inertia {
            self.solved_inertia = None;
        }
        self.held_com = com;
        self.held_inertia = inertia;
    }

    /// The current estimate (to [`MassId::restore`] it).
    pub fn estimate(&self) -> EstimateState<S> {
        EstimateState {
            delta_com_m: self.delta_com_m,
            theta_inertia: self.theta_inertia,
            unobservable_com: self.unobservable_com,
            unobservable_inertia: self.unobservable_inertia,
        }
    }

    /// Puts back an earlier estimate (a solve was rejected); the change detector has no
    /// solve to test against until the next one.
    pub fn restore(&mut self, e: &EstimateState<S>) {
        self.delta_com_m = e.delta_com_m;
        self.theta_inertia = e.theta_inertia;
        self.unobservable_com = e.unobservable_com;
        self.unobservable_inertia = e.unobservable_inertia;
        self.solved_com = None;
        self.solved_inertia = None;
    }

    /// True when the estimate can be trusted to form other rows with: always without
    /// forgetting (a covariance reset scales all information alike, so every direction stays
    /// as determined as before); with forgetting, only while no change detector is learning
    /// its level (directions not excited since a reset have lost their information and the
    /// estimate can wander there: on `kernel_tracking` it cost a second reset and 26 % of Ixx).
    pub fn in_control(&self) -> bool {
        self.cfg.forgetting.is_none()
            || self
                .cfg
                .detector
                .is_none_or(|d| self.level_firings >= d.warmup_firings)
    }

    /// The a-posteriori variance factors (CoM, inverse inertia): the mean normalised
    /// innovation squared per row of the RLS firings against the estimate from before each
    /// firing, at least 1. Under the model each row's value averages 1; larger means the
    /// Kalman filter's variances (and every unmodelled error) are bigger than predicted,
    /// and the LS variances are scaled by it, as the reference scales its covariance by the
    /// observed/predicted residual ratio. 1 before any innovation.
    pub fn variance_factors(&self) -> [Scaled<S>; 2] {
        self.innovations.map(|(sum, n)| {
            let one = Scaled::from_i64(1);
            match sum.over(Scaled::from_i64(i64::from(n))) {
                Some(v) if n > 0 && S::ONE.lt(v.value()) => v,
                _ => one,
            }
        })
    }

    /// Solves both problems for the current estimate.
    pub fn solve(&mut self) -> RlsStatus {
        let c = self.solve_com();
        let i = self.solve_inertia();
        self.combine(c, i)
    }

    /// Solves the CoM problem alone (its status; the estimate is kept on failure).
    pub(crate) fn solve_com(&mut self) -> RlsStatus {
        let zero3 = [S::ZERO; 3];
        match self.com.solve(
            &zero3,
            &self.held_com,
            self.cfg.unobservable_rel,
            self.cfg.pivot_rel,
        ) {
            Ok(sol) => {
                self.delta_com_m = sol.x;
                self.unobservable_com = sol.unobservable;
                self.solved_com = Some(sol);
                RlsStatus::Ok
            }
            Err(e) => {
                self.solved_com = None;
                lu_status(e)
            }
        }
    }

    /// Solves the inverse-inertia problem alone (its status; the estimate is kept on failure).
    pub(crate) fn solve_inertia(&mut self) -> RlsStatus {
        let f = self.factor_inertia();
        self.finish_inertia(f)
    }

    /// The first half of [`MassId::solve_inertia`] (reads only): the factorisation.
    pub(crate) fn factor_inertia(&self) -> Result<Factored<S, 6>, LuError> {
        self.inertia.factor(
            &self.prior_inertia,
            &self.held_inertia,
            self.cfg.unobservable_rel,
            self.cfg.pivot_rel,
        )
    }

    /// The second half of [`MassId::solve_inertia`], from [`MassId::factor_inertia`] (nothing
    /// may change the inverse-inertia problem in between).
    pub(crate) fn finish_inertia(
        &mut self,
        factored: Result<Factored<S, 6>, LuError>,
    ) -> RlsStatus {
        match factored.and_then(|f| f.solve()) {
            Ok(sol) => {
                self.theta_inertia = sol.x;
                self.unobservable_inertia = sol.unobservable;
                self.solved_inertia = Some(sol);
                RlsStatus::Ok
            }
            Err(e) => {
                self.solved_inertia = None;
                lu_status(e)
            }
        }
    }

    /// The overall status of a solve from its two halves.
    pub(crate) fn combine(&mut self, com: RlsStatus, inertia: RlsStatus) -> RlsStatus {
        let mut status = worst(com, inertia);
        if status == RlsStatus::Ok
            && (self.unobservable_com.iter().any(|u| *u)
                || self.unobservable_inertia.iter().any(|u| *u))
        {
            status = RlsStatus::PartlyUnobservable;
        }
        self.status = status;
        status
    }

    /// Variances of the CoM terms (m^2) and of the inverse-inertia parameters, where they
    /// fit, scaled by the [`MassId::variance_factors`]. Terms held at the prior have no
    /// variance from the data (`None`; the caller reports the prior's).
    pub fn variances(&self) -> (MaybeVariances<S, 3>, MaybeVariances<S, 6>) {
        let (c, i) = self.ls_variances();
        let [fc, fi] = self.variance_factors();
        let held = |v: Option<Scaled<S>>, h: bool, f: Scaled<S>| {
            if h {
                None
            } else {
                v.map(|v| v.times(f))
            }
        };
        let mut c2 = [None; 3];
        for ((o, v), h) in c2
            .iter_mut()
            .zip(c.iter())
            .zip(self.unobservable_com.iter())
        {
            *o = held(*v, *h, fc);
        }
        let mut i2 = [None; 6];
        for ((o, v), h) in i2
            .iter_mut()
            .zip(i.iter())
            .zip(self.unobservable_inertia.iter())
        {
            *o = held(*v, *h, fi);
        }
        (c2, i2)
    }

    /// The LS variances alone (the information's inverse, no variance factor).
    pub fn ls_variances(&self) -> (MaybeVariances<S, 3>, MaybeVariances<S, 6>) {
        let zero3 = [S::ZERO; 3];
        let c = self
            .com
            .solve(
                &zero3,
                &self.held_com,
                self.cfg.unobservable_rel,
                self.cfg.pivot_rel,
            )
            .map(|s| s.variances())
            .unwrap_or([None; 3]);
        let i = self
            .inertia
            .solve(
                &self.prior_inertia,
                &self.held_inertia,
                self.cfg.unobservable_rel,
                self.cfg.pivot_rel,
            )
            .map(|s| s.variances())
            .unwrap_or([None; 6]);
        (c, i)
    }

    /// The information problems (for tests and the range analysis).
    pub fn problems(&self) -> (&InfoLs<S, 3>, &InfoLs<S, 6>) {
        (&self.com, &self.inertia)
    }
}

fn lu_status(e: LuError) -> RlsStatus {
    match e {
        LuError::Singular { .. } => RlsStatus::Singular,
        LuError::Overflow => RlsStatus::Overflow,
        LuError::ZeroMatrix => RlsStatus::NoData,
    }
}

fn worst(a: RlsStatus, b: RlsStatus) -> RlsStatus {
    let rank = |s: RlsStatus| match s {
        RlsStatus::Ok => 0,
        RlsStatus::PartlyUnobservable => 1,
        RlsStatus::NoData => 2,
        RlsStatus::Singular => 3,
        RlsStatus::Overflow => 4,
    };
    if rank(b) > rank(a) {
        b
    } else {
        a
    }
}
