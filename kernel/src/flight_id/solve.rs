//! The fit on the sums: Gauss-Newton on the mass properties and a Yule-Walker fit of each
//! axis' AR noise model, alternated, all as quadratic forms in [`FlightSums`] (no data pass).
//!
//! Parameters `theta` = inverse inertia `J` (xx yy zz xy xz yz, 1/(kg m^2)) and the CoM
//! minus the model's `dc` (m). The model matrix is `A = [J, -J [dc]x]`: the drive's torque
//! part acts through `J`, its force part through the lever `dc` (torque about the true CoM is
//! the model's plus `F x dc`). Axis `a`'s residual is `u_a . v - omega_0` with
//! `u_a = (-(A - A_nom)_a, 1)`; its whitened sum of squares with the initial rates eliminated
//! is `u_a^T W_a(phi) u_a`, `W_a = sum_l w_l(phi) L_l - c(phi)^2 C` (lagged moments `L_l`,
//! window term `C`, AR weights `w_l` and gain `c`). Edge effects of the AR filter at window
//! starts (p of each window's samples) are neglected.

use super::sums::{FlightSums, LagForm, LAGS, NZ};
use crate::lu::{Lu, LuError};
use crate::scalar::Scalar;

/// Parameters: six inverse-inertia entries, then three CoM offsets.
pub const NP: usize = 9;
/// Size of `v = (z, y)`.
pub(crate) const NV: usize = NZ + 1;
pub(crate) type M7<S> = [[S; NV]; NV];

/// Highest AR order the sums support.
pub const MAX_ORDER: usize = LAGS - 1;

/// An axis' rate-noise model: `e_k = sum_i phi_i e_(k-i) + innovation`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ArNoise<S> {
    /// Order (0..=[`MAX_ORDER`]).
    pub order: u8,
    /// AR coefficients (zero beyond the order).
    pub phi: [S; MAX_ORDER],
    /// Innovation variance, (rad/s)^2.
    pub sigma2: S,
}

/// What the fit is told.
#[derive(Clone, Copy, Debug)]
pub struct SolveConfig<S> {
    /// Nominal inverse inertia, xx yy zz xy xz yz: where held terms stay, and the sums'
    /// anchor until the caller moves it ([`super::anchor`]).
    pub j_nominal: [S; 6],
    /// Terms the fit may move (others stay at the nominal).
    pub free: [bool; NP],
    /// Axes whose rate enters the fit.
    pub axes: [bool; 3],
    /// Euler's gyroscopic term is in the model (3-D craft); the drive then carries the
    /// integrated rate products.
    pub gyroscopic: bool,
    /// Highest AR order tried (at most [`MAX_ORDER`]).
    pub max_noise_order: u8,
    /// Per term, the standard error beyond which the data do not determine it: the term is
    /// then held at the nominal ("unobservable").
    pub scale: [S; NP],
}

/// Why the fit gave no estimate.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SolveError {
    /// Not a single usable window, or no measured axis.
    NoData,
    /// The information of the free terms is singular even after holding the unobservable.
    Singular,
    /// A value left the scalar format.
    Overflow,
    /// Gauss-Newton did not settle.
    NotConverged,
}

/// The fit's result.
#[derive(Clone, Copy, Debug)]
pub struct Solution<S> {
    /// Estimated parameters (held ones at the nominal).
    pub theta: [S; NP],
    /// Covariance of the free terms (zero rows and columns for held ones).
    pub covariance: [[S; NP]; NP],
    /// Terms held because the data do not determine them (or not free).
    pub held: [bool; NP],
    /// Noise model per axis (axes not fitted: zero).
    pub noise: [ArNoise<S>; 3],
    /// Gauss-Newton steps taken.
    pub steps: u32,
    /// The inverse inertia is positive definite (else not a rigid body).
    pub positive_definite: bool,
    /// The timing consistency test's statistic (chi-square, 1 degree of freedom), if the timing
    /// direction is distinguishable from the fitted terms ([`super::consistency`]; filled by
    /// [`super::FlightId::solve`], `None` from [`solve`] alone).
    pub timing_statistic: Option<S>,
    /// The thrust-symmetry test's statistic per torque axis (chi-square, 1 degree of
    /// freedom each), where that direction is distinguishable (filled as `timing_statistic`).
    pub symmetry_statistic: [Option<S>; 3],
}

fn get<S: Scalar>(v: &[S], i: usize) -> S {
    v.get(i).copied().unwrap_or(S::ZERO)
}

fn get2<S: Scalar, const M: usize>(m: &[[S; M]], i: usize, j: usize) -> S {
    m.get(i).and_then(|r| r.get(j)).copied().unwrap_or(S::ZERO)
}

fn add2<S: Scalar, const M: usize>(m: &mut [[S; M]], i: usize, j: usize, v: S) {
    if let Some(e) = m.get_mut(i).and_then(|r| r.get_mut(j)) {
        *e = e.plus(v);
    }
}

/// `[[xx xy xz] [xy yy yz] [xz yz zz]]`.
pub(super) fn sym3<S: Scalar>(p: &[S]) -> [[S; 3]; 3] {
    let g = |i| get(p, i);
    [[g(0), g(3), g(4)], [g(3), g(1), g(5)], [g(4), g(5), g(2)]]
}

type M3<S> = [[S; 3]; 3];

pub(super) fn mul3<S: Scalar>(a: &M3<S>, b: &M3<S>) -> M3<S> {
    core::array::from_fn(|r| {
        core::array::from_fn(|c| {
            (0..3).fold(S::ZERO, |acc, k| acc.mul_add(get2(a, r, k), get2(b, k, c)))
        })
    })
}

/// `m^-1` by the adjugate, or None when the determinant is not certainly non-zero.
fn inv3<S: Scalar>(m: &M3<S>) -> Option<M3<S>> {
    const NEXT: [usize; 3] = [1, 2, 0];
    const AFTER: [usize; 3] = [2, 0, 1];
    let n1 = |i: usize| NEXT.get(i).copied().unwrap_or(0);
    let n2 = |i: usize| AFTER.get(i).copied().unwrap_or(0);
    let g = |r: usize, c: usize| get2(m, r, c);
    // Cofactor (r, c) by cyclic indices: no sign bookkeeping.
    let cof = |r: usize, c: usize| {
        g(n1(r), n1(c))
            .times(g(n2(r), n2(c)))
            .minus(g(n1(r), n2(c)).times(g(n2(r), n1(c))))
    };
    let det = (0..3).fold(S::ZERO, |acc, c| acc.mul_add(g(0, c), cof(0, c)));
    if !S::ZERO.lt(det.abs()) {
        return None;
    }
    let mut out = [[S::ZERO; 3]; 3];
    for (r, row) in out.iter_mut().enumerate() {
        for (c, v) in row.iter_mut().enumerate() {
            *v = cof(c, r).checked_div(det)?;
        }
    }
    Some(out)
}

/// The inverse inertia (xx yy zz xy xz yz) of an inertia given the same way: the
/// configuration's `j_nominal` from a model's inertia. None if it is singular.
pub fn inverse_inertia<S: Scalar>(inertia: &[S; 6]) -> Option<[S; 6]> {
    let j = inv3(&sym3(inertia))?;
    let g = |r: usize, c: usize| get2(&j, r, c);
    Some([g(0, 0), g(1, 1), g(2, 2), g(0, 1), g(0, 2), g(1, 2)])
}

/// Levi-Civita symbol.
fn levi<S: Scalar>(a: usize, b: usize, c: usize) -> S {
    match (a, b, c) {
        (0, 1, 2) | (1, 2, 0) | (2, 0, 1) => S::ONE,
        (0, 2, 1) | (2, 1, 0) | (1, 0, 2) => S::ONE.negate(),
        _ => S::ZERO,
    }
}

pub use super::components::PRODUCTS;

/// `G(I)`: `omega x I omega = G(I) p` with `p` the rate products ([`PRODUCTS`]).
fn gyro_map<S: Scalar>(i: &M3<S>) -> [[S; 6]; 3] {
    core::array::from_fn(|a| {
        core::array::from_fn(|p| {
            let (b, d) = PRODUCTS.get(p).copied().unwrap_or((0, 0));
            let term = |b: usize, d: usize| {
                (0..3).fold(S::ZERO, |acc, c| {
                    acc.mul_add(levi::<S>(a, b, c), get2(i, c, d))
                })
            };
            if b == d {
                term(b, d)
            } else {
                term(b, d).plus(term(d, b))
            }
        })
    })
}

/// `[dc]x`.
pub(super) fn skew<S: Scalar>(dc: &[S]) -> M3<S> {
    let (x, y, z) = (get(dc, 0), get(dc, 1), get(dc, 2));
    [
        [S::ZERO, z.negate(), y],
        [z, S::ZERO, x.negate()],
        [y.negate(), x, S::ZERO],
    ]
}

/// Writes the blocks `[p | q | k]` (3, 3, 6 columns) into a model-sized matrix.
fn blocks<S: Scalar>(p: &M3<S>, q: &M3<S>, k: &[[S; 6]; 3]) -> [[S; NZ]; 3] {
    core::array::from_fn(|r| {
        core::array::from_fn(|c| {
            if c < 3 {
                get2(p, r, c)
            } else if c < 6 {
                get2(q, r, c.saturating_sub(3))
            } else if c < 12 {
                get2(k, r, c.saturating_sub(6))
            } else {
                S::ZERO
            }
        })
    })
}

fn neg3<S: Scalar, const C: usize>(m: &[[S; C]; 3]) -> [[S; C]; 3] {
    m.map(|row| row.map(|v| v.negate()))
}

fn mul36<S: Scalar>(a: &M3<S>, b: &[[S; 6]; 3]) -> [[S; 6]; 3] {
    core::array::from_fn(|r| {
        core::array::from_fn(|c| {
            (0..3).fold(S::ZERO, |acc, k| acc.mul_add(get2(a, r, k), get2(b, k, c)))
        })
    })
}

/// The model matrix `A = [J, -J [dc]x, -J G(J^-1)]` for inverse-inertia entries `j6` and
/// lever `dc` (`gyro`: the gyroscopic block, zero for a planar craft). None when `J` is
/// singular.
pub(crate) fn model_matrix<S: Scalar>(j6: &[S], dc: &[S], gyro: bool) -> Option<[[S; NZ]; 3]> {
    let j = sym3(j6);
    let k = if gyro {
        neg3(&mul36(&j, &gyro_map(&inv3(&j)?)))
    } else {
        [[S::ZERO; 6]; 3]
    };
    Some(blocks(&j, &neg3(&mul3(&j, &skew(dc))), &k))
}

/// `dA / d theta_m` (inverse inertia entries, then the CoM).
fn model_derivative<S: Scalar>(j6: &[S], dc: &[S], gyro: bool, m: usize) -> Option<[[S; NZ]; 3]> {
    let j = sym3(j6);
    let zero3 = [[S::ZERO; 3]; 3];
    if m < 6 {
        let e = sym3(&basis::<S>(m));
        // d(-J G(I)) = -E G(I) + J G(I E I), since dI = -I E I and G is linear.
        let k = if gyro {
            let i = inv3(&j)?;
            let gi = gyro_map(&i);
            let iei = gyro_map(&mul3(&mul3(&i, &e), &i));
            let a = neg3(&mul36(&e, &gi));
            let b = mul36(&j, &iei);
            core::array::from_fn(|r| core::array::from_fn(|c| get2(&a, r, c).plus(get2(&b, r, c))))
        } else {
            [[S::ZERO; 6]; 3]
        };
        Some(blocks(&e, &neg3(&mul3(&e, &skew(dc))), &k))
    } else {
        let unit: [S; 3] = core::array::from_fn(|b| {
            if Some(b) == m.checked_sub(6) {
                S::ONE
            } else {
                S::ZERO
            }
        });
        Some(blocks(
            &zero3,
            &neg3(&mul3(&j, &skew(&unit))),
            &[[S::ZERO; 6]; 3],
        ))
    }
}

/// The inverse-inertia basis entry `m` (xx yy zz xy xz yz) as six numbers.
fn basis<S: Scalar>(m: usize) -> [S; 6] {
    core::array::from_fn(|i| if i == m { S::ONE } else { S::ZERO })
}

/// A combination of the sums, `sum_l w_l L_l - c2 C`, with the weights' sum `level` given
/// (not summed: for the AR weights it is the gain squared, `c2`, which can be 1e-4 of the
/// largest weight; [`LagForm::Differences`] weighs `L_0` by it).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Combination<S> {
    pub w: [S; LAGS],
    pub level: S,
    pub c2: S,
}

impl<S: Scalar> Combination<S> {
    /// `L_l - C`: the lag-`l` moments about the windows' means.
    fn centred_lag(l: usize) -> Self {
        Combination {
            w: core::array::from_fn(|i| if i == l { S::ONE } else { S::ZERO }),
            level: S::ONE,
            c2: S::ONE,
        }
    }
}

/// Axis `a`'s moment matrix for the combination `k`: with the AR noise model's weights
/// ([`ar_weights`]) the whitened, initial-rate-eliminated moments.
pub(crate) fn weighted<S: Scalar>(s: &FlightSums<S>, a: usize, k: &Combination<S>) -> M7<S> {
    let (w, c2) = (&k.w, k.c2);
    let mut out = [[S::ZERO; NV]; NV];
    for l in 0..LAGS {
        // `sum_l w_l L_l = level L_0 - sum_(l>0) w_l M_l` in differences.
        let wl = match (s.lag_form, l) {
            (LagForm::Levels, _) => get(w, l),
            (LagForm::Differences, 0) => k.level,
            (LagForm::Differences, _) => get(w, l).negate(),
        };
        let Some(yy) = s.lag.yy.get(l) else {
            continue;
        };
        for i in 0..NZ {
            for j in 0..NZ {
                add2(&mut out, i, j, wl.times(s.lag.zz_sym(l, i, j)));
            }
            let cross = wl.times(s.lag.zy_sym(l, a, i));
            add2(&mut out, i, NZ, cross);
            add2(&mut out, NZ, i, cross);
        }
        add2(&mut out, NZ, NZ, wl.times(get(&yy[..], a)));
    }
    for i in 0..NZ {
        for j in 0..NZ {
            add2(&mut out, i, j, c2.times(get2(&s.czz, i, j)).negate());
        }
        let cross = c2.times(get2(&s.czy, a, i)).negate();
        add2(&mut out, i, NZ, cross);
        add2(&mut out, NZ, i, cross);
    }
    add2(&mut out, NZ, NZ, c2.times(get(&s.cyy, a)).negate());
    out
}

pub(crate) fn quad<S: Scalar>(m: &M7<S>, u: &[S; NV], v: &[S; NV]) -> S {
    m.iter().zip(u).fold(S::ZERO, |acc, (row, ui)| {
        acc.plus(
            ui.times(
                row.iter()
                    .zip(v)
                    .fold(S::ZERO, |r, (mij, vj)| r.mul_add(*mij, *vj)),
            ),
        )
    })
}

/// AR weights of `(1 - sum phi_i B^i)`: `w_0 = sum f_i^2`, `w_l = 2 sum f_i f_(i+l)`,
/// and the gain squared `(sum f_i)^2`, also their sum.
pub(crate) fn ar_weights<S: Scalar>(phi: &[S; MAX_ORDER]) -> Combination<S> {
    let f: [S; LAGS] = core::array::from_fn(|i| match i.checked_sub(1) {
        None => S::ONE,
        Some(k) => get(phi, k).negate(),
    });
    let two = S::from_int_pow2(1, 1);
    let mut w = [S::ZERO; LAGS];
    for (l, wl) in w.iter_mut().enumerate() {
        let mut acc = S::ZERO;
        for i in 0..LAGS {
            acc = acc.mul_add(get(&f, i), get(&f, i.saturating_add(l)));
        }
        *wl = if l == 0 { acc } else { two.times(acc) };
    }
    let c = f.iter().fold(S::ZERO, |a, v| a.plus(*v));
    let c2 = c.times(c);
    Combination { w, level: c2, c2 }
}

/// `log2(n)` to within 0.09 (integer part plus a linear fraction): the BIC's order penalty.
fn log2_approx<S: Scalar>(n: u32) -> S {
    let k = n.max(1).ilog2();
    let base = 1u32.checked_shl(k).unwrap_or(1);
    let frac = S::from_int_pow2(i32::try_from(n.saturating_sub(base)).unwrap_or(0), 0)
        .checked_div(S::from_int_pow2(i32::try_from(base).unwrap_or(1), 0))
        .unwrap_or(S::ZERO);
    S::from_int_pow2(i32::try_from(k).unwrap_or(0), 0).plus(frac)
}

/// Yule-Walker AR fit of order 0..=`max_order` to autocovariances `g` (Levinson-Durbin), the
/// order chosen by BIC (`N ln s2 + p ln N`, compared as `s2_p < s2_best (1 - ln N / N)^(p -
/// p_best)`, one order at a time).
fn fit_noise<S: Scalar>(g: &[S; LAGS], n: u32, max_order: u8) -> Option<ArNoise<S>> {
    let g0 = get(g, 0);
    if !S::ZERO.lt(g0) {
        return None;
    }
    let ln2 = S::from_f32(core::f32::consts::LN_2);
    let nn = S::from_int_pow2(i32::try_from(n.max(1)).unwrap_or(i32::MAX), 0);
    let keep = S::ONE.minus(ln2.times(log2_approx::<S>(n)).checked_div(nn)?);
    let mut best = ArNoise {
        order: 0,
        phi: [S::ZERO; MAX_ORDER],
        sigma2: g0,
    };
    let mut phi = [S::ZERO; MAX_ORDER];
    let mut s2 = g0;
    for p in 1..=usize::from(max_order).min(MAX_ORDER) {
        // Reflection coefficient k = (g_p - sum phi_i g_(p-i)) / s2.
        let mut num = get(g, p);
        for i in 1..p {
            num = num.minus(get(&phi, i.saturating_sub(1)).times(get(g, p.saturating_sub(i))));
        }
        let k = num.checked_div(s2)?;
        let prev = phi;
        for i in 1..p {
            if let Some(v) = phi.get_mut(i.saturating_sub(1)) {
                *v = get(&prev, i.saturating_sub(1))
                    .minus(k.times(get(&prev, p.saturating_sub(i).saturating_sub(1))));
            }
        }
        if let Some(v) = phi.get_mut(p.saturating_sub(1)) {
            *v = k;
        }
        s2 = s2.times(S::ONE.minus(k.times(k)));
        if !S::ZERO.lt(s2) {
            break;
        }
        let mut threshold = best.sigma2;
        for _ in usize::from(best.order)..p {
            threshold = threshold.times(keep);
        }
        if s2.lt(threshold) {
            best = ArNoise {
                order: u8::try_from(p).unwrap_or(0),
                phi,
                sigma2: s2,
            };
        }
    }
    Some(best)
}

/// Residual degrees of freedom per axis: the samples less one initial rate per window (with
/// windows of a few samples, as a coarse replay cut at every change makes, dividing by the
/// samples alone put the noise 15 % low and the sigmas with it).
fn dof<S: Scalar>(s: &FlightSums<S>) -> S {
    let d = s.samples.saturating_sub(s.windows).max(1);
    S::from_int_pow2(i32::try_from(d).unwrap_or(i32::MAX), 0)
}

/// The parameters whose model the sums' rates are relative to ([`FlightSums::anchor`]):
/// inverse inertia and CoM offset.
fn anchor<S: Scalar>(s: &FlightSums<S>, cfg: &SolveConfig<S>) -> ([S; 6], [S; 3]) {
    s.anchor.unwrap_or((cfg.j_nominal, [S::ZERO; 3]))
}

/// Per-axis residual direction `u_a` and the parameter derivatives `D_a` (columns); None
/// when the inverse inertia is singular.
pub(crate) fn residual_and_jacobian<S: Scalar>(
    s: &FlightSums<S>,
    theta: &[S; NP],
    cfg: &SolveConfig<S>,
    a: usize,
) -> Option<([S; NV], [[S; NV]; NP])> {
    let (j6, dc) = theta.split_at(6);
    let am = model_matrix(j6, dc, cfg.gyroscopic)?;
    let (rj, rc) = anchor(s, cfg);
    let an = model_matrix(&rj, &rc, cfg.gyroscopic)?;
    let row = |m: &[[S; NZ]; 3]| m.get(a).copied().unwrap_or([S::ZERO; NZ]);
    let (ar, anr) = (row(&am), row(&an));
    let mut u = [S::ZERO; NV];
    for (i, ui) in u.iter_mut().enumerate() {
        *ui = if i < NZ {
            get(&anr, i).minus(get(&ar, i))
        } else {
            S::ONE
        };
    }
    let mut d = [[S::ZERO; NV]; NP];
    for (m, col) in d.iter_mut().enumerate() {
        let deriv = row(&model_derivative(j6, dc, cfg.gyroscopic, m)?);
        for (c, dv) in col.iter_mut().zip(deriv) {
            *c = dv.negate();
        }
    }
    Some((u, d))
}

/// One axis' whitened moments and the fit's directions at `theta`: what the consider
/// covariance and the score tests build their quadratic forms from.
pub(crate) struct AxisForms<S> {
    /// Whitened, initial-rate-eliminated moments ([`weighted`]).
    pub wm: M7<S>,
    /// The residual direction and the parameter derivatives ([`residual_and_jacobian`]).
    pub u: [S; NV],
    pub d: [[S; NV]; NP],
    /// The model matrix's row of the axis at `theta`.
    pub row: [S; NZ],
    /// One over the axis' innovation variance.
    pub inv_sigma2: S,
}

/// [`AxisForms`] of axis `a` with noise model `nz`; None if `J` is singular or the variance
/// is not invertible.
pub(crate) fn axis_forms<S: Scalar>(
    s: &FlightSums<S>,
    cfg: &SolveConfig<S>,
    theta: &[S; NP],
    nz: &ArNoise<S>,
    a: usize,
) -> Option<AxisForms<S>> {
    let wm = weighted(s, a, &ar_weights(&nz.phi));
    let (u, d) = residual_and_jacobian(s, theta, cfg, a)?;
    let (j6, dc) = theta.split_at(6);
    let row = model_matrix(j6, dc, cfg.gyroscopic)?.get(a).copied()?;
    let inv_sigma2 = S::ONE.checked_div(nz.sigma2)?;
    Some(AxisForms {
        wm,
        u,
        d,
        row,
        inv_sigma2,
    })
}

/// Normal equations of the free terms at `theta` with noise `noise`: information, score and
/// the whitened cost per axis.
fn normal<S: Scalar>(
    s: &FlightSums<S>,
    cfg: &SolveConfig<S>,
    theta: &[S; NP],
    noise: &[ArNoise<S>; 3],
    free: &[bool; NP],
) -> ([[S; NP]; NP], [S; NP], [S; 3]) {
    let mut info = [[S::ZERO; NP]; NP];
    let mut score = [S::ZERO; NP];
    let mut cost = [S::ZERO; 3];
    for (a, (used, nz)) in cfg.axes.iter().zip(noise).enumerate() {
        if !used {
            continue;
        }
        let wm = weighted(s, a, &ar_weights(&nz.phi));
        let Some((u, d)) = residual_and_jacobian(s, theta, cfg, a) else {
            continue;
        };
        let inv = S::ONE.checked_div(nz.sigma2).unwrap_or(S::ZERO);
        if let Some(c) = cost.get_mut(a) {
            *c = quad(&wm, &u, &u);
        }
        for m in 0..NP {
            if !free.get(m).copied().unwrap_or(false) {
                continue;
            }
            let dm = d.get(m).copied().unwrap_or([S::ZERO; NV]);
            if let Some(sm) = score.get_mut(m) {
                *sm = sm.minus(inv.times(quad(&wm, &dm, &u)));
            }
            for n in 0..=m {
                if !free.get(n).copied().unwrap_or(false) {
                    continue;
                }
                let dn = d.get(n).copied().unwrap_or([S::ZERO; NV]);
                let v = inv.times(quad(&wm, &dm, &dn));
                add2(&mut info, m, n, v);
                if n != m {
                    add2(&mut info, n, m, v);
                }
            }
        }
    }
    for (m, f) in free.iter().enumerate() {
        if !f {
            for n in 0..NP {
                if let Some(e) = info.get_mut(m).and_then(|r| r.get_mut(n)) {
                    *e = if m == n { S::ONE } else { S::ZERO };
                }
                if let Some(e) = info.get_mut(n).and_then(|r| r.get_mut(m)) {
                    *e = if m == n { S::ONE } else { S::ZERO };
                }
            }
        }
    }
    (info, score, cost)
}

/// The residual autocovariances at `theta` for axis `a` (lags 0..2, per sample).
fn autocovariances<S: Scalar>(
    s: &FlightSums<S>,
    cfg: &SolveConfig<S>,
    theta: &[S; NP],
    a: usize,
) -> Option<[S; LAGS]> {
    let (u, _) = residual_and_jacobian(s, theta, cfg, a)?;
    let n = dof::<S>(s);
    let mut g = [S::ZERO; LAGS];
    for (l, gl) in g.iter_mut().enumerate() {
        // One quadratic form of `L_l - C`, not two subtracted: their difference is small.
        *gl = quad(&weighted(s, a, &Combination::centred_lag(l)), &u, &u).checked_div(n)?;
    }
    Some(g)
}

/// Power-of-two Jacobi scaling: `k_m` with `info_mm 2^(-2 k_m)` in [1, 8), so that one
/// relative pivot threshold serves terms of any unit (1/(kg m^2) and m differ by 1e8 in
/// information) and held terms' unit diagonal.
fn scaling<S: Scalar>(info: &[[S; NP]; NP]) -> [i32; NP] {
    core::array::from_fn(|m| {
        let d = get2(info, m, m);
        if S::ZERO.lt(d) {
            d.split_pow2().1.div_euclid(2)
        } else {
            0
        }
    })
}

/// Why a step could not be taken: the information is singular at a term (the LU's column:
/// the term the others already explain), or another [`SolveError`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum StepError {
    Singular(usize),
    Other(SolveError),
}

impl From<SolveError> for StepError {
    fn from(e: SolveError) -> Self {
        StepError::Other(e)
    }
}

/// `info^-1 score` and `info^-1`, through the scaled system.
fn scaled_solve<S: Scalar>(
    info: &[[S; NP]; NP],
    score: &[S; NP],
    pivot_exp: i32,
) -> Result<([S; NP], [[S; NP]; NP]), StepError> {
    let k = scaling(info);
    let kk = |m: usize| k.get(m).copied().unwrap_or(0);
    let mut a = *info;
    for (m, row) in a.iter_mut().enumerate() {
        for (n, v) in row.iter_mut().enumerate() {
            *v = v.mul_pow2(kk(m).saturating_add(kk(n)).saturating_neg());
        }
    }
    let b: [S; NP] = core::array::from_fn(|m| get(score, m).mul_pow2(kk(m).saturating_neg()));
    let lu = Lu::factor(&a, S::from_int_pow2(1, pivot_exp)).map_err(|e| match e {
        LuError::Overflow => StepError::Other(SolveError::Overflow),
        LuError::Singular { column } => StepError::Singular(column),
        LuError::ZeroMatrix => StepError::Other(SolveError::Singular),
    })?;
    let x = lu.solve(&b).map_err(|_| SolveError::Overflow)?;
    let delta = core::array::from_fn(|m| get(&x, m).mul_pow2(kk(m).saturating_neg()));
    let mut cov = [[S::ZERO; NP]; NP];
    for c in 0..NP {
        let col = lu
            .solve(&basis9::<S>(c))
            .map_err(|_| SolveError::Overflow)?;
        for (r, v) in col.iter().enumerate() {
            if let Some(e) = cov.get_mut(r).and_then(|row| row.get_mut(c)) {
                *e = v.mul_pow2(kk(r).saturating_add(kk(c)).saturating_neg());
            }
        }
    }
    Ok((delta, cov))
}

fn basis9<S: Scalar>(m: usize) -> [S; NP] {
    core::array::from_fn(|i| if i == m { S::ONE } else { S::ZERO })
}

/// Leading minors of the inverse inertia are positive.
fn positive_definite<S: Scalar>(j6: &[S]) -> bool {
    let j = sym3(j6);
    let d = |r: usize, c: usize| get2(&j, r, c);
    let m1 = d(0, 0);
    let m2 = d(0, 0).times(d(1, 1)).minus(d(0, 1).times(d(1, 0)));
    let m3 = d(0, 0)
        .times(d(1, 1).times(d(2, 2)).minus(d(1, 2).times(d(2, 1))))
        .minus(d(0, 1).times(d(1, 0).times(d(2, 2)).minus(d(1, 2).times(d(2, 0)))))
        .plus(d(0, 2).times(d(1, 0).times(d(2, 1)).minus(d(1, 1).times(d(2, 0)))));
    S::ZERO.lt(m1) && S::ZERO.lt(m2) && S::ZERO.lt(m3)
}

/// Gauss-Newton steps (at most `max_steps`) at fixed noise; the step count, or None if it did
/// not settle (every free term moved by less than 1/64 of its standard error).
fn gauss_newton<S: Scalar>(
    s: &FlightSums<S>,
    cfg: &SolveConfig<S>,
    theta: &mut [S; NP],
    noise: &[ArNoise<S>; 3],
    free: &[bool; NP],
    max_steps: u32,
) -> Result<u32, StepError> {
    let tol = S::from_int_pow2(1, -6);
    for step in 1..=max_steps {
        let (info, score, cost) = normal(s, cfg, theta, noise, free);
        let (delta, cov) = scaled_solve(&info, &score, s.pivot_exp)?;
        let mut settled = true;
        let mut long = false;
        for (m, dv) in delta.iter().copied().enumerate() {
            if !free.get(m).copied().unwrap_or(false) {
                continue;
            }
            if !dv.is_valid() {
                return Err(StepError::Other(SolveError::Overflow));
            }
            let var = get2(&cov, m, m);
            // A variance that is not positive: the information is not numerically positive
            // definite (f32 on a nearly degenerate direction passes the LU's pivot threshold
            // and inverts to noise): the term is singular as surely as a failed pivot.
            if !S::ZERO.lt(var) {
                return Err(StepError::Singular(m));
            }
            // |delta| > tol * sigma  <=>  delta^2 > tol^2 var
            if tol.times(tol).times(var).lt(dv.times(dv)) {
                settled = false;
            }
            long |= var.lt(dv.times(dv));
        }
        // A step over one sigma must lower the whitened cost, else it is halved (at most
        // ten times): whole steps along a nearly degenerate direction (a one- or two-thruster
        // planar craft) went back and forth until the step limit, as the reference's did.
        let before = weighted_cost(&cost, noise, cfg);
        // The cost at a trial point; a point where the model matrix does not exist (a
        // singular inverse inertia) lowers nothing.
        let lowers = |trial: &[S; NP]| {
            let (j6, dc) = trial.split_at(6);
            model_matrix(j6, dc, cfg.gyroscopic).is_some() && {
                let (_, _, c) = normal(s, cfg, trial, noise, free);
                weighted_cost(&c, noise, cfg).lt(before)
            }
        };
        let mut fraction = S::ONE;
        if long {
            // No halving that lowers the cost: theta stays (the step limit then decides).
            fraction = S::ZERO;
            let mut f = S::ONE;
            for _ in 0..10 {
                if lowers(&step_to(theta, &delta, free, f)) {
                    fraction = f;
                    break;
                }
                f = f.mul_pow2(-1);
            }
        }
        // Past half the step limit, a step within 1/16 of a sigma that no longer lowers the
        // cost is at the format's rounding floor (f32 on a nearly degenerate flight, which
        // the kernel's algorithm in f64 settles): settled where it stands.
        if !settled
            && step > max_steps / 2
            && within(&delta, &cov, free, S::from_int_pow2(1, -4))
            && !lowers(&step_to(theta, &delta, free, S::ONE))
        {
            return Ok(step);
        }
        *theta = step_to(theta, &delta, free, fraction);
        if settled {
            return Ok(step);
        }
    }
    Err(StepError::Other(SolveError::NotConverged))
}

/// Every free term's step is within `k` of its standard error.
fn within<S: Scalar>(delta: &[S; NP], cov: &[[S; NP]; NP], free: &[bool; NP], k: S) -> bool {
    (0..NP).all(|m| {
        let d = get(delta, m);
        !free.get(m).copied().unwrap_or(false) || !k.times(k).times(get2(cov, m, m)).lt(d.times(d))
    })
}

/// `theta + fraction delta` on the free terms.
fn step_to<S: Scalar>(theta: &[S; NP], delta: &[S; NP], free: &[bool; NP], fraction: S) -> [S; NP] {
    core::array::from_fn(|m| {
        let t = get(theta, m);
        if free.get(m).copied().unwrap_or(false) {
            t.plus(fraction.times(get(delta, m)))
        } else {
            t
        }
    })
}

/// The whitened cost summed over the fitted axes, each over its innovation variance.
fn weighted_cost<S: Scalar>(cost: &[S; 3], noise: &[ArNoise<S>; 3], cfg: &SolveConfig<S>) -> S {
    cost.iter()
        .zip(noise)
        .zip(cfg.axes)
        .filter(|(_, used)| *used)
        .fold(S::ZERO, |acc, ((c, nz), _)| {
            acc.plus(c.checked_div(nz.sigma2).unwrap_or(S::ZERO))
        })
}

/// The free term whose variance in `cov` exceeds its scale squared by the largest factor, if
/// any: the data do not determine it.
fn least_determined<S: Scalar>(
    cov: &[[S; NP]; NP],
    free: &[bool; NP],
    scale: &[S; NP],
) -> Option<usize> {
    let mut worst: Option<(usize, S)> = None;
    for m in 0..NP {
        if !free.get(m).copied().unwrap_or(false) {
            continue;
        }
        let var = get2(cov, m, m);
        let sc = get(scale, m);
        if sc.times(sc).lt(var) {
            let ratio = var.checked_div(sc.times(sc)).unwrap_or(S::headroom());
            if worst.is_none_or(|(_, r)| r.lt(ratio)) {
                worst = Some((m, ratio));
            }
        }
    }
    worst.map(|(m, _)| m)
}

/// Fits the mass properties and the noise models to `s`, holding the terms the data do not
/// determine. Three rounds of (Gauss-Newton to convergence, noise refit).
pub fn solve<S: Scalar>(
    s: &FlightSums<S>,
    cfg: &SolveConfig<S>,
) -> Result<Solution<S>, SolveError> {
    if s.samples < 3 || s.windows == 0 || !cfg.axes.iter().any(|a| *a) {
        return Err(SolveError::NoData);
    }
    // The sample count enters as a number of the format: a format that cannot hold it
    // (Q8.24 above 127) cannot hold the sums either.
    let count = S::from_int_pow2(i32::try_from(s.samples).unwrap_or(i32::MAX), 0);
    if !s.lag.is_valid() || count.to_f32() != s.samples as f32 {
        return Err(SolveError::Overflow);
    }
    let nominal: [S; NP] = core::array::from_fn(|m| {
        if m < 6 {
            get(&cfg.j_nominal, m)
        } else {
            S::ZERO
        }
    });
    let mut free = cfg.free;
    let mut steps = 0u32;
    let white = ArNoise {
        order: 0,
        phi: [S::ZERO; MAX_ORDER],
        sigma2: S::ONE,
    };
    // Every round starts at the model, whatever the sums' anchor: on a flight the model does
    // not fit (a dead thruster) the cost has several minima, and a start at a mid-flight fit
    // led f32 to another one than the integer float's (open2 p08: CoM x 52 mm against 21).
    'holding: for _ in 0..NP {
        let mut theta = nominal;
        let mut noise = [white; 3];
        for (a, nz) in noise.iter_mut().enumerate() {
            if let Some(g) = autocovariances(s, cfg, &theta, a) {
                if S::ZERO.lt(get(&g, 0)) {
                    nz.sigma2 = get(&g, 0);
                }
            }
        }
        // A singular information holds the term the LU found the others already explain
        // (a one-thruster planar craft: Izz and the CoM across the thrust give the same
        // rates) and starts again, as the reference holds its degenerate term.
        macro_rules! step {
            ($e:expr) => {
                match $e {
                    Ok(v) => v,
                    Err(StepError::Singular(m)) if free.get(m).copied().unwrap_or(false) => {
                        if let Some(f) = free.get_mut(m) {
                            *f = false;
                        }
                        continue 'holding;
                    }
                    Err(StepError::Singular(_)) => return Err(SolveError::Singular),
                    // Not settled: a term beyond its scale where Gauss-Newton stopped is held
                    // as it would be at the optimum (a 3-D craft with one or two thrusters
                    // wandered along the directions they do not excite).
                    Err(StepError::Other(SolveError::NotConverged)) => {
                        let (info, score, _) = normal(s, cfg, &theta, &noise, &free);
                        let beyond = scaled_solve(&info, &score, s.pivot_exp)
                            .ok()
                            .and_then(|(_, cov)| least_determined(&cov, &free, &cfg.scale));
                        match beyond.and_then(|m| free.get_mut(m)) {
                            Some(f) => {
                                *f = false;
                                continue 'holding;
                            }
                            None => return Err(SolveError::NotConverged),
                        }
                    }
                    Err(StepError::Other(e)) => return Err(e),
                }
            };
        }
        for _round in 0..3 {
            steps =
                steps.saturating_add(step!(gauss_newton(s, cfg, &mut theta, &noise, &free, 20)));
            for (a, nz) in noise.iter_mut().enumerate() {
                if !cfg.axes.get(a).copied().unwrap_or(false) {
                    continue;
                }
                let g = autocovariances(s, cfg, &theta, a).ok_or(SolveError::Overflow)?;
                if let Some(fit) = fit_noise(&g, s.samples, cfg.max_noise_order) {
                    *nz = fit;
                }
            }
            // The innovation variance the whitened cost implies at this noise model.
            let (_, _, cost) = normal(s, cfg, &theta, &noise, &free);
            let n = dof::<S>(s);
            for (a, nz) in noise.iter_mut().enumerate() {
                if cfg.axes.get(a).copied().unwrap_or(false) {
                    let v = get(&cost, a).checked_div(n).unwrap_or(S::ZERO);
                    if S::ZERO.lt(v) {
                        nz.sigma2 = v;
                    }
                }
            }
        }
        steps = steps.saturating_add(step!(gauss_newton(s, cfg, &mut theta, &noise, &free, 20)));
        let (info, score, _) = normal(s, cfg, &theta, &noise, &free);
        let (_, cov) = step!(scaled_solve(&info, &score, s.pivot_exp));
        // Hold the least determined term beyond its scale and start again.
        if let Some(m) = least_determined(&cov, &free, &cfg.scale) {
            if let Some(f) = free.get_mut(m) {
                *f = false;
            }
            continue 'holding;
        }
        let mut covariance = cov;
        for (m, row) in covariance.iter_mut().enumerate() {
            for (n, v) in row.iter_mut().enumerate() {
                if !(free.get(m).copied().unwrap_or(false) && free.get(n).copied().unwrap_or(false))
                {
                    *v = S::ZERO;
                }
            }
        }
        let held = core::array::from_fn(|m| !free.get(m).copied().unwrap_or(false));
        let positive_definite = positive_definite(theta.split_at(6).0);
        return Ok(Solution {
            theta,
            covariance,
            held,
            noise,
            steps,
            positive_definite,
            timing_statistic: None,
            symmetry_statistic: [None; 3],
        });
    }
    Err(SolveError::Singular)
}
