//! Mass-property identification: CoM offset and inverse inertia by recursive least squares
//! in information form (seed eqs 3.9-3.10), seeded by a batch over the first two firings,
//! with optional exponential forgetting and an optional innovation change detector that
//! resets the covariance.
//!
//! Information form: `Lambda_k = lambda Lambda_{k-1} + A' R^-1 A`, `eta_k = lambda eta_{k-1} +
//! A' R^-1 b`, `x_k = Lambda_k^-1 eta_k` (LU solve). This is the seed's recursion rewritten
//! without the per-update inverse; the final value equals the batch over all data.
//!
//! Fixed point: the information grows without bound (~1e10 in SI units over a run), so
//! `Lambda` and `eta` are stored as **block floating point**: O(1) mantissas plus one shared
//! exponent ([`InfoLs::exponent`]). Because `x = Lambda^-1 eta` is invariant to a common
//! scale, the solve uses the mantissas directly; the exponent only matters for the
//! covariance. A covariance reset is then a change of exponent (free and exact).

use crate::lu::{Lu, LuError};
use crate::scalar::{max_abs, Scalar, Scaled};

/// One least-squares problem `A x ~= b` in information form, `N` unknowns, 3 rows per update.
#[derive(Clone, Copy, Debug)]
pub struct InfoLs<S, const N: usize> {
    /// Upper triangle of the information mantissa (the lower triangle is not maintained).
    lam: [[S; N]; N],
    eta: [S; N],
    exp: i32,
    empty: bool,
    /// A value stopped fitting the format (status, never silent).
    saturated: bool,
}

/// Where the mantissas are kept: the largest diagonal stays below this (f32: irrelevant).
const DIAG_LIMIT_LOG2: i32 = 4;

impl<S: Scalar, const N: usize> Default for InfoLs<S, N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<S: Scalar, const N: usize> InfoLs<S, N> {
    /// No information.
    pub fn new() -> Self {
        InfoLs {
            lam: [[S::ZERO; N]; N],
            eta: [S::ZERO; N],
            exp: 0,
            empty: true,
            saturated: false,
        }
    }

    /// The shared exponent: true information = stored mantissa * 2^exponent.
    pub fn exponent(&self) -> i32 {
        self.exp
    }

    /// True if nothing has been added.
    pub fn is_empty(&self) -> bool {
        self.empty
    }

    /// True if some value hit the format's limit.
    pub fn is_saturated(&self) -> bool {
        self.saturated
    }

    /// The full symmetric information mantissa.
    pub fn information(&self) -> [[S; N]; N] {
        let mut m = self.lam;
        for i in 0..N {
            for j in 0..i {
                let v = self
                    .lam
                    .get(j)
                    .and_then(|r| r.get(i))
                    .copied()
                    .unwrap_or(S::ZERO);
                if let Some(d) = m.get_mut(i).and_then(|r| r.get_mut(j)) {
                    *d = v;
                }
            }
        }
        m
    }

    /// The information-vector mantissa.
    pub fn info_vector(&self) -> [S; N] {
        self.eta
    }

    fn max_diag(&self) -> S {
        let mut m = S::ZERO;
        for (i, row) in self.lam.iter().enumerate() {
            m = max_abs(m, row.get(i).copied().unwrap_or(S::ZERO));
        }
        m
    }

    /// Multiplies the stored mantissas by 2^-k and raises the exponent by k (value unchanged).
    fn shift_down(&mut self, k: i32) {
        if k <= 0 {
            return;
        }
        for v in self.lam.iter_mut().flatten().chain(self.eta.iter_mut()) {
            *v = v.mul_pow2_nearest(k.saturating_neg());
        }
        self.exp = self.exp.saturating_add(k);
    }

    /// The magnitude normalisation acts on: the largest diagonal or information-vector
    /// mantissa (`eta` can exceed the diagonal when a problem alone is ill-posed, e.g. the
    /// inertia rows of a pure translation).
    fn magnitude(&self) -> S {
        self.eta.iter().fold(self.max_diag(), |m, v| max_abs(m, *v))
    }

    /// Keeps [`InfoLs::magnitude`] in [2^(L-2), 2^L) so precision is neither lost to
    /// underflow nor to overflow, whatever the true magnitude (the exponent absorbs it).
    fn renormalise(&mut self) {
        let mag = self.magnitude();
        if !S::ZERO.lt(mag) {
            return;
        }
        // mag in [2^e, 2^(e+1)): one shift brings it to [2^(L-1), 2^L).
        let e = Scaled { m: mag, e: 0 }.normalized().e;
        let k = e.saturating_sub(DIAG_LIMIT_LOG2.saturating_sub(1));
        if k > 0 {
            self.shift_down(k);
        } else if e < DIAG_LIMIT_LOG2.saturating_sub(2) {
            let up = k.saturating_neg();
            for v in self.lam.iter_mut().flatten().chain(self.eta.iter_mut()) {
                *v = v.mul_pow2(up);
            }
            self.exp = self.exp.saturating_sub(up);
        }
    }

    fn check_valid(&mut self) {
        if !self
            .lam
            .iter()
            .flatten()
            .chain(self.eta.iter())
            .all(|v| v.is_valid())
        {
            self.saturated = true;
        }
    }

    /// Adds three weighted rows: `Lambda += sum_i w_i a_i' a_i`, `eta += sum_i w_i a_i' b_i`:
    /// [`InfoLs::plan_add`] then [`InfoLs::apply_add`] (the pipeline runs them on separate
    /// ticks).
    pub fn add(&mut self, rows: &[[S; N]; 3], b: &[S; 3], w: &[Scaled<S>; 3]) {
        let plan = self.plan_add(rows, b, w);
        self.apply_add(rows, b, &plan);
    }

    /// Chooses the exponent the add's products are rounded at; it decides the precision
    /// (proofs finding 8: a loose bound put them at a coarse exponent, and the result was then
    /// shifted up). A cheap upper bound gives an exponent at which nothing can overflow; at
    /// it, the diagonal and information vector after the add, and every intermediate of the
    /// add that the result does not bound, are computed (a third of the add's products); the
    /// plan is the finest exponent those figures show safe (every intermediate of the add
    /// scales by the same power of two). Does not modify the problem.
    pub fn plan_add(&self, rows: &[[S; N]; 3], b: &[S; 3], w: &[Scaled<S>; 3]) -> AddPlan<S> {
        let w = w.map(|v| v.normalized());
        let (safe, wm) = self.safe_exponent(rows, b, &w);
        let (mag, peak) = self.predict(rows, b, &wm, safe);
        let mut target = safe;
        if S::ZERO.lt(mag) {
            let e_mag = mag.split_pow2().1;
            let e_peak = max_abs(peak, mag).split_pow2().1;
            // mag to [2^(L-1), 2^L); every intermediate below 2^(L+1).
            let up = DIAG_LIMIT_LOG2
                .saturating_sub(1)
                .saturating_sub(e_mag)
                .min(DIAG_LIMIT_LOG2.saturating_sub(e_peak));
            if up > 0 {
                target = safe.saturating_sub(up);
            }
        }
        AddPlan { w, exp: target }
    }

    /// Runs a planned add (the same rows, right-hand side and weights as the plan's).
    pub fn apply_add(&mut self, rows: &[[S; N]; 3], b: &[S; 3], plan: &AddPlan<S>) {
        self.set_exponent(plan.exp);
        let wm = plan.w.map(|v| v.mantissa_at(plan.exp));
        self.accumulate(rows, b, &wm);
        self.renormalise();
        self.check_valid();
    }

    /// A stored mantissa re-expressed at exponent `e` (as [`InfoLs::set_exponent`] would).
    fn at_exponent(&self, v: S, e: i32) -> S {
        if self.empty {
            S::ZERO
        } else {
            v.mul_pow2_nearest(self.exp.saturating_sub(e))
        }
    }

    /// At exponent `e` with weight mantissas `wm`: the largest diagonal or
    /// information-vector entry after the add (computed as [`InfoLs::accumulate`] would, so
    /// exactly its result), and the largest intermediate the result does not bound: the
    /// entries before the add, the weights, the scaled rows `w_i a_ij`, the information
    /// vector's products and partial sums (the matrix's partial sums are positive
    /// semidefinite, so bounded by their diagonals).
    fn predict(&self, rows: &[[S; N]; 3], b: &[S; 3], wm: &[S; 3], e: i32) -> (S, S) {
        let mut peak = wm
            .iter()
            .fold(self.at_exponent(self.magnitude(), e), |m, v| max_abs(m, *v));
        let mut mag = S::ZERO;
        for (j, (lam_row, eta_j)) in self.lam.iter().zip(self.eta.iter()).enumerate() {
            let mut d = self.at_exponent(lam_row.get(j).copied().unwrap_or(S::ZERO), e);
            let mut acc = self.at_exponent(*eta_j, e);
            for ((row, bi), wi) in rows.iter().zip(b.iter()).zip(wm.iter()) {
                let a = row.get(j).copied().unwrap_or(S::ZERO);
                let v = wi.times(a);
                d = d.mul_add(v, a);
                let p = v.times(*bi);
                acc = acc.plus(p);
                peak = max_abs(max_abs(peak, v), max_abs(p, acc));
            }
            mag = max_abs(mag, max_abs(d, acc));
        }
        (mag, peak)
    }

    /// An exponent (at least the stored one and the weights') at which a cheap bound on the
    /// update fits (weights times row sizes below 1, every entry after the add below
    /// `2^(L+1)`), and the weight mantissas there.
    fn safe_exponent(&self, rows: &[[S; N]; 3], b: &[S; 3], w: &[Scaled<S>; 3]) -> (i32, [S; 3]) {
        let we = w.iter().fold(i32::MIN, |m, v| m.max(v.e));
        let mut e = if self.empty { we } else { self.exp.max(we) };
        let mut wm = w.map(|v| v.mantissa_at(e));
        let mut old = self.at_exponent(self.magnitude(), e);
        // Row sizes sum_j |a_ij| (regressors are O(10) in kernel units).
        let r = rows.map(|row| row.iter().fold(S::ZERO, |acc, v| acc.plus(v.abs())));
        let one = S::ONE;
        let budget = S::from_int_pow2(1, DIAG_LIMIT_LOG2.saturating_add(1));
        let rb = b
            .iter()
            .zip(r.iter())
            .fold(S::ZERO, |m, (bi, ri)| max_abs(m, max_abs(*bi, *ri)));
        for _ in 0..8 {
            let t = [0usize, 1, 2].map(|i| {
                let wi = wm.get(i).copied().unwrap_or(S::ZERO);
                let ri = r.get(i).copied().unwrap_or(S::ZERO);
                wi.times(ri)
            });
            let t_max = t.iter().fold(S::ZERO, |m, ti| max_abs(m, *ti));
            let bound = t.iter().fold(old, |acc, ti| acc.mul_add(*ti, rb));
            if t_max.lt(one) && bound.lt(budget) {
                break;
            }
            // Everything scales by 2^-k: take the k that brings both below their limits at once
            // (values in [2^e, 2^(e+1)); at least one step).
            let e_t = t_max.split_pow2().1;
            let e_b = bound.split_pow2().1;
            let k = e_t
                .saturating_add(1)
                .max(e_b.saturating_sub(DIAG_LIMIT_LOG2))
                .max(1);
            e = e.saturating_add(k);
            wm = w.map(|v| v.mantissa_at(e));
            old = self.at_exponent(self.magnitude(), e);
        }
        (e, wm)
    }

    /// Re-expresses the stored mantissas at exponent `target` (an empty problem just takes it).
    fn set_exponent(&mut self, target: i32) {
        if self.empty {
            self.exp = target;
            self.empty = false;
        } else if target > self.exp {
            self.shift_down(target.saturating_sub(self.exp));
        } else {
            let up = self.exp.saturating_sub(target);
            for v in self.lam.iter_mut().flatten().chain(self.eta.iter_mut()) {
                *v = v.mul_pow2(up);
            }
            self.exp = target;
        }
    }

    /// The rank-3 update with weight mantissas `wm` at the stored exponent.
    fn accumulate(&mut self, rows: &[[S; N]; 3], b: &[S; 3], wm: &[S; 3]) {
        for ((row, bi), wi) in rows.iter().zip(b.iter()).zip(wm.iter()) {
            let v: [S; N] = row.map(|a| wi.times(a));
            for (j, (lam_row, vj)) in self.lam.iter_mut().zip(v.iter()).enumerate() {
                for (lam_jk, a_k) in lam_row.iter_mut().zip(row.iter()).skip(j) {
                    *lam_jk = lam_jk.mul_add(*vj, *a_k);
                }
            }
            for (eta_j, vj) in self.eta.iter_mut().zip(v.iter()) {
                *eta_j = eta_j.plus(vj.times(*bi));
            }
        }
    }

    /// Adds a diagonal prior: information `info_j` about `x0_j` for each term.
    pub fn add_diag(&mut self, info: &[Scaled<S>; N], x0: &[S; N]) {
        let info = info.map(|v| v.normalized());
        let we = info.iter().fold(i32::MIN, |m, v| m.max(v.e));
        if self.empty {
            self.exp = we;
            self.empty = false;
        } else if we > self.exp {
            self.shift_down(we.saturating_sub(self.exp));
        }
        for (j, (w, x)) in info.iter().zip(x0.iter()).enumerate() {
            let wm = w.mantissa_at(self.exp);
            if let Some(d) = self.lam.get_mut(j).and_then(|r| r.get_mut(j)) {
                *d = d.plus(wm);
            }
            if let Some(e) = self.eta.get_mut(j) {
                *e = e.mul_add(wm, *x);
            }
        }
        self.renormalise();
        self.check_valid();
    }

    /// Exponential forgetting: information times `lambda` (0 < lambda <= 1).
    pub fn forget(&mut self, lambda: S) {
        for v in self.lam.iter_mut().flatten().chain(self.eta.iter_mut()) {
            *v = v.times(lambda);
        }
    }

    /// Divides the information by 2^bits without touching the estimate (covariance reset).
    pub fn deflate(&mut self, bits: i32) {
        self.exp = self.exp.saturating_sub(bits.max(0));
    }

    /// Adds another problem's information (exponents aligned).
    pub fn merge(&mut self, other: &Self) {
        if other.empty {
            return;
        }
        if self.empty {
            *self = *other;
            return;
        }
        let mut o = *other;
        let e = self.exp.max(o.exp).saturating_add(1);
        self.shift_down(e.saturating_sub(self.exp));
        o.shift_down(e.saturating_sub(o.exp));
        for (a, b) in self.lam.iter_mut().flatten().zip(o.lam.iter().flatten()) {
            *a = a.plus(*b);
        }
        for (a, b) in self.eta.iter_mut().zip(o.eta.iter()) {
            *a = a.plus(*b);
        }
        self.saturated |= o.saturated;
        self.renormalise();
        self.check_valid();
    }

    /// The terms whose information is not certainly above `rel * max diag` (a numerical
    /// safeguard; observability itself is decided by [`crate::observability`]).
    pub fn unobservable(&self, rel: S) -> [bool; N] {
        let thr = rel.times(self.max_diag());
        core::array::from_fn(|i| {
            let d = self
                .lam
                .get(i)
                .and_then(|r| r.get(i))
                .copied()
                .unwrap_or(S::ZERO);
            !thr.lt(d)
        })
    }

    /// Solves for the estimate; unobservable terms (see [`InfoLs::unobservable`]) are held
    /// at `prior` and the rest solved with them fixed. Returns the estimate, the mask and the
    /// factorisation of the reduced system (for covariances).
    pub fn solve(
        &self,
        prior: &[S; N],
        held: &[bool; N],
        unobs_rel: S,
        pivot_rel: S,
    ) -> Result<Solution<S, N>, LuError> {
        self.factor(prior, held, unobs_rel, pivot_rel)?.solve()
    }

    /// The first half of [`InfoLs::solve`]: the reduced system and its LU factorisation.
    /// Terms in `held` (not excited) and numerically unobservable ones are held at `prior`.
    pub fn factor(
        &self,
        prior: &[S; N],
        held: &[bool; N],
        unobs_rel: S,
        pivot_rel: S,
    ) -> Result<Factored<S, N>, LuError> {
        if self.empty {
            return Err(LuError::ZeroMatrix);
        }
        if self.saturated {
            return Err(LuError::Overflow);
        }
        let mut unobs = self.unobservable(unobs_rel);
        for (u, h) in unobs.iter_mut().zip(held.iter()) {
            *u |= *h;
        }
        let mut m = self.information();
        let mut rhs = self.eta;
        let scale = self.max_diag();
        for (j, &u) in unobs.iter().enumerate() {
            if !u {
                continue;
            }
            let pj = prior.get(j).copied().unwrap_or(S::ZERO);
            for (i, (row, r)) in m.iter_mut().zip(rhs.iter_mut()).enumerate() {
                if let Some(mij) = row.get_mut(j) {
                    if i != j {
                        *r = r.minus(mij.times(pj));
                        *mij = S::ZERO;
                    }
                }
            }
            if let (Some(row), Some(r)) = (m.get_mut(j), rhs.get_mut(j)) {
                for v in row.iter_mut() {
                    *v = S::ZERO;
                }
                if let Some(d) = row.get_mut(j) {
                    *d = scale;
                }
                *r = scale.times(pj);
            }
        }
        let lu = Lu::factor(&m, pivot_rel)?;
        Ok(Factored {
            lu,
            rhs,
            unobservable: unobs,
            exp: self.exp,
        })
    }
}

/// A factored [`InfoLs`] problem ([`InfoLs::factor`]), ready to solve.
#[derive(Clone, Copy, Debug)]
pub struct Factored<S, const N: usize> {
    lu: Lu<S, N>,
    rhs: [S; N],
    unobservable: [bool; N],
    exp: i32,
}

impl<S: Scalar, const N: usize> Factored<S, N> {
    /// The second half of [`InfoLs::solve`].
    pub fn solve(&self) -> Result<Solution<S, N>, LuError> {
        let x = self.lu.solve(&self.rhs)?;
        Ok(Solution {
            x,
            unobservable: self.unobservable,
            lu: self.lu,
            exp: self.exp,
        })
    }
}

/// The exponent an [`InfoLs`] add rounds its products at ([`InfoLs::plan_add`]).
#[derive(Clone, Copy, Debug)]
pub struct AddPlan<S> {
    /// The weights, normalised.
    w: [Scaled<S>; 3],
    /// The exponent of the stored mantissas during and after the add (before renormalising).
    exp: i32,
}

impl<S: Scalar> AddPlan<S> {
    /// A plan that adds nothing (zero weights), e.g. to initialise storage.
    pub fn none() -> Self {
        AddPlan {
            w: [Scaled::zero(); 3],
            exp: 0,
        }
    }
}

/// Per-term variances, `None` where they do not fit the format.
pub type MaybeVariances<S, const N: usize> = [Option<Scaled<S>>; N];

/// The result of [`InfoLs::solve`].
#[derive(Clone, Copy, Debug)]
pub struct Solution<S, const N: usize> {
    /// The estimate.
    pub x: [S; N],
    /// Terms held at the prior.
    pub unobservable: [bool; N],
    lu: Lu<S, N>,
    exp: i32,
}

impl<S: Scalar, const N: usize> Solution<S, N> {
    /// `row * Lambda^-1 * row'` (block floating point): the variance the estimate predicts
    /// for a measurement with regressor `row`. `None` if it does not fit.
    pub fn predicted_variance(&self, row: &[S; N]) -> Option<Scaled<S>> {
        let y = self.lu.solve(row).ok()?;
        let q = row
            .iter()
            .zip(y.iter())
            .fold(S::ZERO, |acc, (a, b)| acc.mul_add(*a, *b));
        Some(Scaled {
            m: q,
            e: self.exp.saturating_neg(),
        })
    }

    /// Variance of each estimated term (diagonal of `Lambda^-1`), `None` where it does not fit.
    pub fn variances(&self) -> [Option<Scaled<S>>; N] {
        core::array::from_fn(|j| {
            let e: [S; N] = core::array::from_fn(|i| if i == j { S::ONE } else { S::ZERO });
            let y = self.lu.solve(&e).ok()?;
            let v = y.get(j).copied()?;
            Some(Scaled {
                m: v,
                e: self.exp.saturating_neg(),
            })
        })
    }
}

/// The two least-squares problems' regressors for one measurement (seed eqs 3.5-3.8).
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
    cfg: RlsConfig<S>,
    com: InfoLs<S, 3>,
    inertia: InfoLs<S, 6>,
    pending_com: InfoLs<S, 3>,
    pending_inertia: InfoLs<S, 6>,
    pending_updates: u32,
    prior_inertia: [S; 6],
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
    cusum: S,
    level: Scaled<S>,
    level_firings: u32,
    /// Last firing's detector statistic (normalised innovation squared over its level), for telemetry.
    pub last_ratio: S,
    /// The latest solve of each problem, kept while the problem is unchanged: the change
    /// detector tests a firing against it instead of solving again (a tick's budget).
    solved_com: Option<Solution<S, 3>>,
    solved_inertia: Option<Solution<S, 6>>,
    /// Terms the excitation so far leaves unobservable ([`crate::observability`]): held at
    /// the prior in every solve. None until told (standalone use: numerical criterion only).
    held_com: [bool; 3],
    held_inertia: [bool; 6],
    /// Sum of the RLS firings' normalised innovations squared and their row count, per
    /// problem (CoM, inverse inertia).
    innovations: [(Scaled<S>, u32); 2],
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

    /// Adds the CoM rows of a firing's aggregate measurement: straight into the information
    /// (`batch`) or into the pending firing ([`crate::fold::FiringFold`] runs these steps).
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

    /// The change test with its statistic computed (no-op without a detector configured).
    pub(crate) fn detect_with(&mut self, nis: Scaled<S>) {
        if let Some(det) = self.cfg.detector {
            self.detect(&det, nis);
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
