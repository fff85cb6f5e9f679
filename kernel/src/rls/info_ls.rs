//! One least-squares problem in information form, kept as block floating point.
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
