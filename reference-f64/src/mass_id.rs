//! Mass-property identification (seed section 4.2 and 4.4.3, eqs. 3.1-3.10, numbered 4.x
//! in its text; App. D.5-D.6): the least-squares forms for the centre-of-mass offset and
//! the six inverse-inertia terms, batch LS, and recursive LS in information form with an
//! LU solve, plus observability of each term, forgetting and a change detector.
//!
//! Euler's equation (3.1) `omega_dot = I^-1 (tau - omega x I omega)` with the thruster
//! torque (3.2-3.3) `tau = sum_i (L_i x d_i) F_i T_i` is linear in
//! - the CoM offset `Delta` (3.5-3.7): with `L_i = L_nom,i - Delta` and `c = sum d_i F_i T_i`
//!   (the net force), `tau = tau_nom + c x Delta`, so
//!   `A1 = I^-1 [c]x`, `b1 = omega_dot + I^-1 (omega x I omega) - I^-1 tau_nom`;
//! - the inverse inertia `x = [Ixx', Iyy', Izz', Ixy', Ixz', Iyz']` (primes: entries of
//!   `I^-1`) (3.8): with `a = tau_nom - omega x I_nom omega`, `omega_dot = I^-1 a` reads
//!   `A2 x = b2`, `A2 = [[a1,0,0,a2,a3,0],[0,a2,0,a1,0,a3],[0,0,a3,0,a1,a2]]`, `b2 = omega_dot`.
//!
//! The seed's printed listing drops the gyroscopic term `omega x I omega`; its equations
//! (3.1, 3.4, 3.8) keep it, and so does this crate.
//!
//! Every problem carries a weak prior at the nominal values (information `1/s^2`); with it
//! the batch over the first two firings (often single-axis) is never singular, and the RLS
//! started from it ends exactly where the batch over all data does.
use crate::satellite::Satellite;
use nalgebra::{DMatrix, DVector, Matrix3, SMatrix, SVector, Vector3};

/// Names of the CoM terms, in estimate order.
pub const COM_TERMS: [&str; 3] = ["cm_x", "cm_y", "cm_z"];
/// Names of the inertia terms, in estimate (and contract) order.
pub const INERTIA_TERMS: [&str; 6] = ["Ixx", "Iyy", "Izz", "Ixy", "Ixz", "Iyz"];

/// One vector measurement `b = A x + v`, `cov(v) = R`.
#[derive(Clone, Copy, Debug)]
pub struct Observation<const N: usize> {
    pub a: SMatrix<f64, 3, N>,
    pub b: Vector3<f64>,
    pub r: Matrix3<f64>,
}

/// `[v]x`, the cross-product matrix: `[v]x w = v x w`.
pub fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// Net force `c = D F T` (seed eq. 3.7, `Ck = D*Fk'`) and nominal torque `(L x D) F T`
/// about the model's CoM for a thruster word, with the model's pressure drop.
pub fn force_and_nominal_torque(sat: &Satellite, word: u16) -> (Vector3<f64>, Vector3<f64>) {
    sat.force_torque_for_word(word)
}

/// Seed eqs. 3.5-3.8, CoM form: `A1 = I^-1 [c]x`, `b1 = omega_dot + I^-1 (omega x I omega) - I^-1 tau_nom`.
/// The unknown is the CoM offset from the model's CoM, m.
pub fn com_row(
    sat: &Satellite,
    word: u16,
    omega: &Vector3<f64>,
    omega_dot: &Vector3<f64>,
) -> (Matrix3<f64>, Vector3<f64>) {
    let i_nom = sat.inertia_matrix();
    let i_inv = i_nom.try_inverse().unwrap_or_else(Matrix3::zeros);
    let (c, tau_nom) = force_and_nominal_torque(sat, word);
    let a1 = i_inv * skew(&c);
    let b1 = omega_dot + i_inv * omega.cross(&(i_nom * omega)) - i_inv * tau_nom;
    (a1, b1)
}

/// Seed eq. 3.8, inertia form: `a = (L x D) F T - omega x I_nom omega`,
/// `A2 = [[a1,0,0,a2,a3,0],[0,a2,0,a1,0,a3],[0,0,a3,0,a1,a2]]`, `b2 = omega_dot`.
/// The unknown is the inverse-inertia vector `[Ixx', Iyy', Izz', Ixy', Ixz', Iyz']`.
pub fn inertia_row(
    sat: &Satellite,
    word: u16,
    omega: &Vector3<f64>,
    omega_dot: &Vector3<f64>,
) -> (SMatrix<f64, 3, 6>, Vector3<f64>) {
    let i_nom = sat.inertia_matrix();
    let (_, tau_nom) = force_and_nominal_torque(sat, word);
    let a = tau_nom - omega.cross(&(i_nom * omega));
    #[rustfmt::skip]
    let a2 = SMatrix::<f64, 3, 6>::from_row_slice(&[
        a.x, 0.0, 0.0, a.y, a.z, 0.0,
        0.0, a.y, 0.0, a.x, 0.0, a.z,
        0.0, 0.0, a.z, 0.0, a.x, a.y,
    ]);
    (a2, *omega_dot)
}

/// The inverse-inertia rows of eq. 3.8 for a given torque `a` (N m): `A2 a`-layout with
/// `b2 = omega_dot`.
pub fn inertia_row_for_torque(
    a: &Vector3<f64>,
    omega_dot: &Vector3<f64>,
) -> (SMatrix<f64, 3, 6>, Vector3<f64>) {
    #[rustfmt::skip]
    let a2 = SMatrix::<f64, 3, 6>::from_row_slice(&[
        a.x, 0.0, 0.0, a.y, a.z, 0.0,
        0.0, a.y, 0.0, a.x, 0.0, a.z,
        0.0, 0.0, a.z, 0.0, a.x, a.y,
    ]);
    (a2, *omega_dot)
}

/// The inverse-inertia vector `[Ixx', Iyy', Izz', Ixy', Ixz', Iyz']` as a symmetric matrix
/// (seed `I_inv_mat`).
pub fn inverse_inertia_matrix(x: &SVector<f64, 6>) -> Matrix3<f64> {
    Matrix3::new(x[0], x[3], x[4], x[3], x[1], x[5], x[4], x[5], x[2])
}

/// A symmetric matrix as `[xx, yy, zz, xy, xz, yz]`.
pub fn sym_to_vec6(m: &Matrix3<f64>) -> SVector<f64, 6> {
    SVector::<f64, 6>::from([
        m[(0, 0)],
        m[(1, 1)],
        m[(2, 2)],
        m[(0, 1)],
        m[(0, 2)],
        m[(1, 2)],
    ])
}

/// The inverse-inertia vector of a satellite's nominal inertia.
pub fn nominal_inverse_inertia(sat: &Satellite) -> SVector<f64, 6> {
    sym_to_vec6(
        &sat.inertia_matrix()
            .try_inverse()
            .unwrap_or_else(Matrix3::zeros),
    )
}

/// Inertia (xx yy zz xy xz yz) from the inverse-inertia vector and its covariance, with
/// the covariance carried through `I = J^-1` by its exact derivative `dI = -I dJ I`.
/// None when the inverse-inertia matrix is singular.
pub fn inertia_from_inverse(
    x: &SVector<f64, 6>,
    cov_x: &SMatrix<f64, 6, 6>,
) -> Option<(SVector<f64, 6>, SMatrix<f64, 6, 6>)> {
    let j = inverse_inertia_matrix(x);
    let i = j.try_inverse()?;
    let mut g = SMatrix::<f64, 6, 6>::zeros();
    for m in 0..6 {
        let mut e = SVector::<f64, 6>::zeros();
        e[m] = 1.0;
        let d = -(i * inverse_inertia_matrix(&e) * i);
        g.set_column(m, &sym_to_vec6(&d));
    }
    Some((sym_to_vec6(&i), g * cov_x * g.transpose()))
}

/// Physical validity of an estimate, the criterion the kernel implements too
/// (`massid_kernel::validity`): the inertia (xx yy zz xy xz yz, kg m^2) is positive
/// definite and its diagonal obeys the triangle inequalities (`Ixx + Iyy >= Izz`, cyclic),
/// and the CoM (model CoM + `com_offset_mm`) lies within the craft's reach
/// ([`Satellite::reach_m`]). The kernel's SPHERES pipeline (`massid_kernel::validity`) checks
/// the box of the thruster positions instead (for SPHERES, whose thrusters sit symmetrically,
/// the box within the reach).
/// `Err` names the first check that fails, as the estimate JSON's status does.
pub fn physical_validity(
    sat: &Satellite,
    com_offset_mm: &[f64; 3],
    inertia: &[f64; 6],
) -> Result<(), &'static str> {
    let [xx, yy, zz, xy, xz, yz] = *inertia;
    let m = Matrix3::new(xx, xy, xz, xy, yy, yz, xz, yz, zz);
    let minors = [xx, xx * yy - xy * xy, m.determinant()];
    if !minors.iter().all(|v| v.is_finite() && *v > 0.0) {
        return Err("implausible_inertia_not_positive_definite");
    }
    if xx + yy < zz || xx + zz < yy || yy + zz < xx {
        return Err("implausible_inertia_triangle_inequality");
    }
    let com = Vector3::from_fn(|a, _| (sat.com_offset_mm[a] + com_offset_mm[a]) * 1e-3);
    // A NaN CoM is outside too.
    let inside = com.norm() <= sat.reach_m();
    if !inside {
        return Err("implausible_com_outside_envelope");
    }
    Ok(())
}

/// `M^-1 b` by LU with partial pivoting (nalgebra's, on a dynamic copy so that it works
/// for any size `N`). None when `M` is singular.
pub fn lu_solve<const N: usize>(
    m: &SMatrix<f64, N, N>,
    b: &SVector<f64, N>,
) -> Option<SVector<f64, N>> {
    let lu = DMatrix::from_column_slice(N, N, m.as_slice()).lu();
    let x = lu.solve(&DVector::from_column_slice(b.as_slice()))?;
    if x.iter().all(|v| v.is_finite()) {
        Some(SVector::<f64, N>::from_column_slice(x.as_slice()))
    } else {
        None
    }
}

/// `M^-1` by LU. None when `M` is singular.
pub fn lu_inverse<const N: usize>(m: &SMatrix<f64, N, N>) -> Option<SMatrix<f64, N, N>> {
    let inv = DMatrix::from_column_slice(N, N, m.as_slice())
        .lu()
        .try_inverse()?;
    if inv.iter().all(|v| v.is_finite()) {
        Some(SMatrix::<f64, N, N>::from_column_slice(inv.as_slice()))
    } else {
        None
    }
}

/// Holds the terms `pinned` at `values` and re-solves the others given them (seed eq.
/// 3.13's reduction, applied after the fact): with the information `J` and estimate `x`,
/// `x_o = x_o + J_oo^-1 J_ou (x_u - values_u)`. Returns the conditioned estimate and the
/// conditional covariance (`J_oo^-1` on the free block, zero rows/columns for pinned terms).
pub fn pin_terms<const N: usize>(
    x: &SVector<f64, N>,
    info: &SMatrix<f64, N, N>,
    pinned: &[usize],
    values: &SVector<f64, N>,
) -> Option<(SVector<f64, N>, SMatrix<f64, N, N>)> {
    let free: Vec<usize> = (0..N).filter(|j| !pinned.contains(j)).collect();
    let mut out = *x;
    let mut cov = SMatrix::<f64, N, N>::zeros();
    for &u in pinned {
        out[u] = values[u];
    }
    if free.is_empty() {
        return Some((out, cov));
    }
    let j_oo = DMatrix::from_fn(free.len(), free.len(), |a, b| info[(free[a], free[b])]);
    let shift = DVector::from_fn(free.len(), |a, _| {
        pinned
            .iter()
            .map(|&u| info[(free[a], u)] * (x[u] - values[u]))
            .sum::<f64>()
    });
    let lu = j_oo.lu();
    let dx = lu.solve(&shift)?;
    let inv = lu.try_inverse()?;
    for (a, &fa) in free.iter().enumerate() {
        out[fa] = x[fa] + dx[a];
        for (b, &fb) in free.iter().enumerate() {
            cov[(fa, fb)] = inv[(a, b)];
        }
    }
    out.iter().all(|v| v.is_finite()).then_some((out, cov))
}

/// Why a solve failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LsError {
    #[error("singular_information")]
    SingularInformation,
}

/// Batch least squares in information form: `Q^-1 = L0 + sum A' R^-1 A`,
/// `x = Q (L0 x0 + sum A' R^-1 b)` (seed: `inv(A'*A)*A'*b` and `A'*inv(R)*A`, here
/// weighted throughout so that it and the recursion agree exactly).
#[derive(Clone, Debug)]
pub struct BatchLs<const N: usize> {
    pub prior_x: SVector<f64, N>,
    pub prior_info: SMatrix<f64, N, N>,
    /// `L0 + sum A' R^-1 A`.
    pub info: SMatrix<f64, N, N>,
    /// `L0 x0 + sum A' R^-1 b`.
    pub rhs: SVector<f64, N>,
    /// `sum b' R^-1 b` (for the residual).
    pub btwb: f64,
    pub observations: usize,
}

impl<const N: usize> BatchLs<N> {
    /// Starts from a prior `x0` with standard deviations `std` (information `1/std^2`).
    pub fn with_prior(x0: SVector<f64, N>, std: SVector<f64, N>) -> Self {
        let prior_info = SMatrix::<f64, N, N>::from_diagonal(&std.map(|s| 1.0 / (s * s)));
        BatchLs {
            prior_x: x0,
            prior_info,
            info: prior_info,
            rhs: prior_info * x0,
            btwb: (x0.transpose() * prior_info * x0)[0],
            observations: 0,
        }
    }

    pub fn add(&mut self, o: &Observation<N>) {
        let Some(r_inv) = o.r.try_inverse() else {
            return;
        };
        self.info += o.a.transpose() * r_inv * o.a;
        self.rhs += o.a.transpose() * r_inv * o.b;
        self.btwb += (o.b.transpose() * r_inv * o.b)[0];
        self.observations += 1;
    }

    /// Solves `Q^-1 x = rhs` by LU.
    pub fn solve(&self) -> Result<SVector<f64, N>, LsError> {
        lu_solve(&self.info, &self.rhs).ok_or(LsError::SingularInformation)
    }

    /// Estimate covariance `Q = (Q^-1)^-1`.
    pub fn covariance(&self) -> Result<SMatrix<f64, N, N>, LsError> {
        lu_inverse(&self.info).ok_or(LsError::SingularInformation)
    }

    /// Weighted residual sum of squares (prior included) at the solution.
    pub fn weighted_rss(&self) -> Result<f64, LsError> {
        let x = self.solve()?;
        Ok((self.btwb - (self.rhs.transpose() * x)[0]).max(0.0))
    }
}

/// Change detector on the RLS innovations, one value per firing: a one-sided CUSUM
/// `g = max(0, g + e/e_ref - 1 - drift)` of the firing's normalised innovation squared
/// `e = nu' (R + A Q A')^-1 nu`, `nu = b - A x` (its last, best Kalman estimate against the
/// RLS prediction from before the firing; the pipeline computes it), with `e_ref` the mean
/// of the first `warmup` firings' values. When `g > threshold` a change is declared (the
/// caller inflates the covariance so new data dominates, e.g. after a proof mass is
/// attached mid-run, seed Fig. 4.4), the detector rests for `refractory` firings while
/// every axis is re-excited, and the level `e_ref` is learnt anew.
/// Per firing rather than per update because within a firing the Kalman filter's
/// variance shrinks like `1/n^3` while its error does not, so per-update normalised
/// innovations are not stationary.
#[derive(Clone, Debug)]
pub struct ChangeDetector {
    pub drift: f64,
    pub threshold: f64,
    pub warmup: usize,
    pub refractory: usize,
    g: f64,
    seen: usize,
    e_sum: f64,
    rest: usize,
}

impl ChangeDetector {
    pub fn new(drift: f64, threshold: f64, warmup: usize, refractory: usize) -> Self {
        ChangeDetector {
            drift,
            threshold,
            warmup,
            refractory,
            g: 0.0,
            seen: 0,
            e_sum: 0.0,
            rest: 0,
        }
    }

    /// True once the innovation level is learnt and no change is being absorbed (the
    /// estimate can be trusted to form other rows with).
    pub fn in_control(&self) -> bool {
        self.seen > self.warmup && self.rest == 0
    }

    /// Feeds one firing's normalised innovation; true when a change is declared.
    pub fn feed(&mut self, e: f64) -> bool {
        if !e.is_finite() {
            return false;
        }
        self.seen += 1;
        if self.seen <= self.warmup {
            self.e_sum += e;
            return false;
        }
        if self.rest > 0 {
            self.rest -= 1;
            return false;
        }
        let e_ref = (self.e_sum / self.warmup.max(1) as f64).max(1e-12);
        self.g = (self.g + e / e_ref - 1.0 - self.drift).max(0.0);
        if self.g > self.threshold {
            // After a change the innovations' level is re-learnt while the estimate
            // re-converges (as the kernel's detector does): the old level belongs to the old
            // mass properties and to a converged estimate.
            self.g = 0.0;
            self.rest = self.refractory;
            self.seen = 0;
            self.e_sum = 0.0;
            return true;
        }
        false
    }
}

/// Recursive least squares in information form (seed eqs. 3.9-3.10):
/// `Q_k^-1 = lambda Q_{k-1}^-1 + A' R^-1 A`,
/// `x_k = x_{k-1} + Q_k A' R^-1 (b - A x_{k-1})`, the product `Q_k (.)` by an LU solve of
/// `Q_k^-1`. `lambda = 1` (no forgetting) by default; with forgetting the prior's
/// information is never forgotten (only the data's), so unexcited terms stay regular.
#[derive(Clone, Debug)]
pub struct Rls<const N: usize> {
    pub x: SVector<f64, N>,
    pub info: SMatrix<f64, N, N>,
    pub prior_info: SMatrix<f64, N, N>,
    /// Exponential forgetting factor per update (1 = none).
    pub forgetting: f64,
    /// Sum of `nu' S^-1 nu` (equals the batch's weighted residual without forgetting).
    pub innovation_ss: f64,
    pub updates: usize,
}

impl<const N: usize> Rls<N> {
    /// Seeds the recursion with a batch estimate (seed: batch over the first two firings).
    pub fn from_batch(batch: &BatchLs<N>) -> Result<Self, LsError> {
        Ok(Rls {
            x: batch.solve()?,
            info: batch.info,
            prior_info: batch.prior_info,
            forgetting: 1.0,
            innovation_ss: batch.weighted_rss()?,
            updates: 0,
        })
    }

    /// Keeps the estimate but scales the data's information by `shrink` (the prior's
    /// stays), so that the next data dominate: the reset after a detected change.
    pub fn reset_covariance(&mut self, shrink: f64) {
        self.info = self.prior_info + (self.info - self.prior_info) * shrink;
    }

    /// One update (eqs. 3.9-3.10).
    pub fn update(&mut self, o: &Observation<N>) -> Result<(), LsError> {
        let r_inv = o.r.try_inverse().ok_or(LsError::SingularInformation)?;
        let nu = o.b - o.a * self.x;
        // innovation statistics before the update (predictive residual)
        let q = lu_inverse(&self.info).ok_or(LsError::SingularInformation)?;
        let s = o.a * q * o.a.transpose() + o.r;
        let e = s
            .try_inverse()
            .map(|si| (nu.transpose() * si * nu)[0])
            .unwrap_or(0.0);
        self.innovation_ss += e;
        if self.forgetting < 1.0 {
            self.info = self.prior_info + (self.info - self.prior_info) * self.forgetting;
        }
        self.info += o.a.transpose() * r_inv * o.a;
        let dx = lu_solve(&self.info, &(o.a.transpose() * r_inv * nu))
            .ok_or(LsError::SingularInformation)?;
        self.x += dx;
        self.updates += 1;
        Ok(())
    }

    pub fn covariance(&self) -> Result<SMatrix<f64, N, N>, LsError> {
        lu_inverse(&self.info).ok_or(LsError::SingularInformation)
    }
}

/// How much a maneuver excited each term: the number of updates in which column `j` of
/// the unweighted design matrix, `|A_k e_j|`, reached a reference level: half the weakest
/// single-thruster force (CoM: the net force perpendicular to the axis) or torque
/// (inertia: the torque components that multiply the term). A term is observable when
/// it saw at least `min_updates` of them; small leftovers (a couple's net force from
/// unequal thrusters, off-axis torque from direction errors) never count, however long. Rotations (force couples) leave the CoM
/// unobservable; single-axis rotations leave the other axes' inertias unobservable (seed
/// eq. 3.13 and the discussion before it).
#[derive(Clone, Debug)]
pub struct Excitation {
    pub com: [f64; 3],
    pub inertia: [f64; 6],
    force_ref: f64,
    torque_ref: f64,
}

impl Excitation {
    pub fn new(sat: &Satellite) -> Self {
        // the weakest thruster that can fire (a model may disable one with zero thrust)
        let firing = (0..crate::satellite::N_THRUSTERS).filter(|&i| sat.thrust_n[i] > 0.0);
        let f_min = firing
            .clone()
            .map(|i| sat.thrust_n[i])
            .fold(f64::INFINITY, f64::min);
        let t_min = firing
            .map(|i| sat.torque_nm(i).norm())
            .fold(f64::INFINITY, f64::min);
        Excitation {
            com: [0.0; 3],
            inertia: [0.0; 6],
            force_ref: 0.5 * f_min,
            torque_ref: 0.5 * t_min,
        }
    }

    /// The terms one update with thruster word `word` excites. The rows are taken at zero
    /// rate, as the observations are (the Kalman state is the thrust-induced acceleration),
    /// so the decision depends on the word and the model only and the kernel makes it exactly.
    pub fn excited(&self, sat: &Satellite, word: u16) -> ([bool; 3], [bool; 6]) {
        let (c, _) = force_and_nominal_torque(sat, word);
        let sc = skew(&c);
        let com = [0, 1, 2].map(|j| sc.column(j).norm() >= self.force_ref);
        let (a2, _) = inertia_row(sat, word, &Vector3::zeros(), &Vector3::zeros());
        let inertia = [0, 1, 2, 3, 4, 5].map(|j| a2.column(j).norm() >= self.torque_ref);
        (com, inertia)
    }

    /// Adds one update with thruster word `word`.
    pub fn add(&mut self, sat: &Satellite, word: u16) {
        let (com, inertia) = self.excited(sat, word);
        for j in 0..3 {
            if com[j] {
                self.com[j] += 1.0;
            }
        }
        for j in 0..6 {
            if inertia[j] {
                self.inertia[j] += 1.0;
            }
        }
    }

    /// Names of the terms with less than `min_updates` of reference excitation.
    pub fn unobservable(&self, min_updates: f64) -> Vec<String> {
        let mut out = Vec::new();
        for (j, n) in COM_TERMS.iter().enumerate() {
            if self.com[j] < min_updates {
                out.push(n.to_string());
            }
        }
        for (j, n) in INERTIA_TERMS.iter().enumerate() {
            if self.inertia[j] < min_updates {
                out.push(n.to_string());
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector6;

    fn sat() -> Satellite {
        Satellite::builtin("sph2").unwrap()
    }

    #[test]
    fn com_row_predicts_the_offset_torque() {
        // A satellite whose CoM is moved by delta: its omega_dot satisfies A1 delta = b1.
        let s = sat();
        let delta = Vector3::new(0.0015, -0.002, 0.003);
        let mut moved = s.clone();
        for k in 0..3 {
            moved.com_offset_mm[k] += delta[k] * 1e3;
        }
        let omega = Vector3::new(0.3, -0.1, 0.2);
        for word in [0b11u16, 0b1000010, 2064, 0b110000000000, 0b100001000] {
            // true dynamics with the moved CoM but the nominal inertia
            let i = s.inertia_matrix();
            let (_, tau) = moved.force_torque_for_word(word);
            let wd = i.try_inverse().unwrap() * (tau - omega.cross(&(i * omega)));
            let (a1, b1) = com_row(&s, word, &omega, &wd);
            assert!(
                (a1 * delta - b1).norm() < 1e-12 * b1.norm().max(1.0),
                "word {word}"
            );
        }
    }

    #[test]
    fn inertia_row_is_euler_in_inverse_inertia() {
        let s = sat();
        let x = nominal_inverse_inertia(&s);
        let omega = Vector3::new(0.5, 0.2, -0.4);
        let word = 0b100001000u16;
        let i = s.inertia_matrix();
        let (_, tau) = s.force_torque_for_word(word);
        let wd = i.try_inverse().unwrap() * (tau - omega.cross(&(i * omega)));
        let (a2, b2) = inertia_row(&s, word, &omega, &wd);
        assert!((a2 * x - b2).norm() < 1e-12);
    }

    #[test]
    fn inverse_inertia_round_trip_and_jacobian() {
        let s = sat();
        let x = nominal_inverse_inertia(&s);
        let cov = SMatrix::<f64, 6, 6>::identity() * 1e-4;
        let (ivec, icov) = inertia_from_inverse(&x, &cov).unwrap();
        let expect = Vector6::from(s.inertia_kgm2);
        assert!((ivec - expect).norm() < 1e-15);
        // the covariance by finite differences of the map
        let h = 1e-4;
        for m in 0..6 {
            let mut xp = x;
            xp[m] += h;
            let mut xm = x;
            xm[m] -= h;
            let (ip, _) = inertia_from_inverse(&xp, &cov).unwrap();
            let (im, _) = inertia_from_inverse(&xm, &cov).unwrap();
            let col = (ip - im) / (2.0 * h);
            // diag of G cov G' = 1e-4 * sum_m G_jm^2; check G column by column via a unit cov
            let unit =
                SMatrix::<f64, 6, 6>::from_fn(|a, b| if a == m && b == m { 1.0 } else { 0.0 });
            let (_, c) = inertia_from_inverse(&x, &unit).unwrap();
            let scale = col.norm_squared();
            for j in 0..6 {
                assert!(
                    (c[(j, j)] - col[j] * col[j]).abs() < 1e-6 * scale,
                    "m={m} j={j}"
                );
            }
        }
        assert!(icov[(0, 0)] > 0.0);
    }

    #[test]
    fn rls_ends_where_the_batch_ends() {
        let s = sat();
        let x_true = nominal_inverse_inertia(&s) * 1.05;
        let j_true = inverse_inertia_matrix(&x_true);
        let words = [2064u16, 1056, 129, 66, 516, 264, 0b100001, 0b1010000];
        let mut obs = Vec::new();
        for (n, &w) in words.iter().enumerate() {
            for k in 0..50 {
                let omega = Vector3::new(0.01 * k as f64, -0.02 * n as f64, 0.005);
                let i_nom = s.inertia_matrix();
                let (_, tau) = s.force_torque_for_word(w);
                let wd = j_true * (tau - omega.cross(&(i_nom * omega)));
                let (a, b) = inertia_row(&s, w, &omega, &wd);
                let noise = Vector3::new(1e-3, -2e-3, 1.5e-3) * ((k % 7) as f64 - 3.0);
                obs.push(Observation {
                    a,
                    b: b + noise,
                    r: Matrix3::identity() * (1e-4 + 1e-6 * k as f64),
                });
            }
        }
        let x0 = nominal_inverse_inertia(&s);
        let std = SVector::<f64, 6>::repeat(40.0);
        let mut all = BatchLs::with_prior(x0, std);
        let mut first = BatchLs::with_prior(x0, std);
        for (k, o) in obs.iter().enumerate() {
            all.add(o);
            if k < 100 {
                first.add(o);
            }
        }
        let mut rls = Rls::from_batch(&first).unwrap();
        for o in &obs[100..] {
            rls.update(o).unwrap();
        }
        let xb = all.solve().unwrap();
        assert!(
            (rls.x - xb).norm() < 1e-9 * xb.norm(),
            "{} vs {}",
            rls.x,
            xb
        );
        // the predictive-residual sum equals the batch weighted residual
        let rss = all.weighted_rss().unwrap();
        assert!(
            (rls.innovation_ss - rss).abs() < 1e-6 * rss,
            "{} vs {rss}",
            rls.innovation_ss
        );
        // and the estimate is close to the truth
        assert!((xb - x_true).norm() < 0.02 * x_true.norm());
    }

    #[test]
    fn pinning_a_term_equals_solving_with_it_known() {
        // a 3-term problem: pin term 1 at 0.5; the result must equal the LS over terms 0, 2
        // of b - A e1 * 0.5
        let a = Matrix3::new(1.0, 0.3, 0.0, 0.2, 1.0, 0.4, 0.0, 0.5, 1.0);
        let b = Vector3::new(1.0, 2.0, 3.0);
        let info = a.transpose() * a + Matrix3::identity() * 0.1;
        let x = info.try_inverse().unwrap() * (a.transpose() * b);
        let values = Vector3::new(0.0, 0.5, 0.0);
        let (xp, cov) = pin_terms(&x, &info, &[1], &values).unwrap();
        // direct: minimise |A x - b|^2 + 0.1 |x|^2 (the same information) with x1 = 0.5
        let keep = [0usize, 2];
        let red = nalgebra::Matrix2::from_fn(|i, j| info[(keep[i], keep[j])]);
        let rhs_full = a.transpose() * b - info.column(1) * 0.5;
        let rhs = nalgebra::Vector2::new(rhs_full[0], rhs_full[2]);
        let direct = red.try_inverse().unwrap() * rhs;
        assert!((xp[0] - direct[0]).abs() < 1e-12 && (xp[2] - direct[1]).abs() < 1e-12);
        assert_eq!(xp[1], 0.5);
        assert_eq!(cov[(1, 1)], 0.0);
        assert!((cov[(0, 0)] - red.try_inverse().unwrap()[(0, 0)]).abs() < 1e-12);
    }

    #[test]
    fn single_axis_rotation_leaves_other_axes_unobservable() {
        let s = sat();
        let mut ex = Excitation::new(&s);
        for _ in 0..1000 {
            ex.add(&s, 2064); // thrusters 5 + 12: +x torque couple
        }
        let u = ex.unobservable(50.0);
        assert_eq!(u, vec!["cm_x", "cm_y", "cm_z", "Iyy", "Izz", "Iyz"]);
        for _ in 0..1000 {
            ex.add(&s, 0b11); // thrusters 1 + 2: +x translation
        }
        assert_eq!(ex.unobservable(50.0), vec!["cm_x", "Iyy", "Izz", "Iyz"]);
    }
}
