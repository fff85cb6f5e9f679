//! The mixer for a craft without SPHERES' opposing pairs: the smallest non-negative duties
//! whose wrench is the command (`min |u|^2` subject to `B u = c`, `u >= 0`), then the seed's
//! stages 6-10 (scaling by the maximum, pressure drop, 1 ms resolution, deadband, centring).
//!
//! The seed's pseudo-inverse is the smallest-norm solution of `B u = c`; its pair rules repair
//! negative duties, which needs opposing pairs. Keeping the smallest norm and asking `u >= 0`
//! works for any layout and gives the pair rules' answer when pairs are exactly opposite.
//!
//! # Algorithm (why this one)
//! The problem's dual is unconstrained and has one variable per axis (6, or 3 for a planar
//! craft): maximise `phi(l) = c'l - |max(0, B'l)|^2 / 2`; then `u = max(0, B'l)`. Newton steps
//! on `phi` (Hessian `sum over firing thrusters of b b'`, damped by a small multiple of the
//! identity) with step halving solve it in a few 6x6 LU solves, whatever the thruster count,
//! with a fixed bound on the work ([`MAX_NEWTON_STEPS`] x [`MAX_HALVINGS`]). A command outside
//! the thrusters' cone has no maximiser: the gradient `c - B u` (the wrench still missing)
//! does not vanish, and the mixer says [`MixerError::OutOfReach`] instead of firing.
//! The f64 reference (`reference_f64::allocation`) solves the same problem by a different
//! method (least-distance NNLS), so the two check each other.
//!
//! # Units
//! Force rows are scaled by `2^ef` so that the largest thrust is in `[1/2, 1)`, lever arms by
//! `2^el` so that the largest thruster coordinate is in `[1/2, 1)`, torque rows by
//! `2^(ef + el)`, then every row by the power of two that brings its largest entry to
//! `[1/2, 1)`; the row-scaled command is normalised by a power of two so that its largest
//! entry is in `[2^-4, 2^-3)` (duties O(1), the dual's `|u|^2` far inside Q8.24's range). Scaling rows of `B` and `c` alike leaves `u` unchanged, so every quantity is
//! O(1) in Q8.24 and the duties come back exactly by the normalising power of two.

use crate::craft::cross;
use crate::craft::{Thruster, MAX_THRUSTERS};
use crate::lu::Lu;
use crate::mixer::{pressure_correction, quantise, MixerConfig, MixerError};
use crate::scalar::{max_abs, Scalar};

/// Newton steps on the dual at most.
pub const MAX_NEWTON_STEPS: usize = 24;
/// Step halvings per Newton step at most.
pub const MAX_HALVINGS: usize = 24;
/// Damping retries (x16 each) when a Newton system is too ill-conditioned for the format.
const MAX_DAMPING_RETRIES: usize = 4;
/// Converged when the missing wrench is below `2^-CONVERGED_LOG2` (the normalised command's
/// largest entry is in `[2^-4, 2^-3)`; Q8.24 resolves 2^-24).
const CONVERGED_LOG2: i32 = 22;
/// Within reach when the missing wrench after the last step is below `2^-REACH_LOG2`: at most
/// 2^-12 (2.4e-4) of the normalised command, far below what the 1 ms resolution delivers.
const REACH_LOG2: i32 = 16;
/// Damping of the Newton matrix relative to its largest diagonal entry: small, so that a
/// step on the right set of firing thrusters is nearly the exact Newton step (2^-12 made
/// the convergence linear, ratio 0.12, on the air-bearing craft).
const DAMPING_LOG2: i32 = -20;

/// Axes: `Fx Fy Fz Tx Ty Tz`; a planar craft controls `Fx Fy Tz`.
const PLANAR_AXES: [bool; 6] = [true, true, false, false, false, true];

/// Stages 2-5 for any craft: the non-negative allocation.
#[derive(Clone, Copy, Debug)]
pub struct Allocator<S> {
    /// Column `i`: thruster `i`'s wrench in the scaled units (rows `Fx Fy Fz Tx Ty Tz`).
    cols: [[S; 6]; MAX_THRUSTERS],
    count: usize,
    /// Scaling exponent per row (force rows `ef`, torque rows `ef + el`, then each row's
    /// largest entry brought to `[1/2, 1)`).
    row_log2: [i32; 6],
    /// Rows the craft controls.
    axes: [bool; 6],
    /// See [`Allocator::force_log2`].
    thrust_log2: i32,
}

/// The smallest `e` with `v * 2^e < 1` and `v * 2^e >= 1/2` (`v > 0`, finite, f32 model value).
fn unit_log2(v: f32) -> i32 {
    let mut e = 0i32;
    let mut x = v;
    for _ in 0..128 {
        if x >= 1.0 {
            x *= 0.5;
            e = e.saturating_sub(1);
        } else if x < 0.5 {
            x *= 2.0;
            e = e.saturating_add(1);
        } else {
            break;
        }
    }
    e
}

impl<S: Scalar> Allocator<S> {
    /// The allocator of `thrusters` (1 to 16) with lever arms about `com_m` (m, from the
    /// geometric centre: the current CoM estimate); `planar` for an air-bearing craft.
    pub fn new(thrusters: &[Thruster], com_m: [S; 3], planar: bool) -> Result<Self, MixerError> {
        if thrusters.is_empty() || thrusters.len() > MAX_THRUSTERS {
            return Err(MixerError::BadThruster);
        }
        let mut max_thrust = 0.0f32;
        let mut max_reach = 0.0f32;
        for t in thrusters {
            let finite = t.pos_m.iter().chain(t.dir.iter()).all(|v| v.is_finite())
                && t.thrust_n.is_finite()
                && t.thrust_n > 0.0;
            if !finite {
                return Err(MixerError::BadThruster);
            }
            max_thrust = max_thrust.max(t.thrust_n);
            for p in t.pos_m {
                max_reach = max_reach.max(p.abs());
            }
        }
        let ef = unit_log2(max_thrust);
        // Lever components are below twice the largest thruster coordinate (< 2 in these
        // units) when the CoM is inside the thrusters' box, so torque entries are below 4:
        // force and torque rows are both O(1), which keeps the Newton matrix well balanced.
        let el = unit_log2(max_reach.max(1e-3));
        let et = ef.saturating_add(el);
        let com = com_m.map(|c| c.mul_pow2(el));
        let mut cols = [[S::ZERO; 6]; MAX_THRUSTERS];
        for (t, col) in thrusters.iter().zip(cols.iter_mut()) {
            let f: [S; 3] = t.dir.map(|d| S::from_f32(d * t.thrust_n).mul_pow2(ef));
            let lever: [S; 3] = core::array::from_fn(|k| {
                let p = t.pos_m.get(k).copied().map(S::from_f32).unwrap_or(S::ZERO);
                p.mul_pow2(el).minus(com.get(k).copied().unwrap_or(S::ZERO))
            });
            let torque = cross(&lever, &f);
            for (k, e) in col.iter_mut().enumerate() {
                *e = if k < 3 {
                    f.get(k).copied().unwrap_or(S::ZERO)
                } else {
                    torque.get(k.saturating_sub(3)).copied().unwrap_or(S::ZERO)
                };
            }
            if !col.iter().all(|v| v.is_valid()) {
                return Err(MixerError::BadThruster);
            }
        }
        // Balance the rows: each row's largest entry to [1/2, 1), so that a weak axis (the
        // cubesat's sideways force, 1/4 of its axial one) does not make the Newton matrix
        // ill-conditioned (measured: duties 2.6e-5 off the reference without this).
        let mut row_log2 = [ef, ef, ef, et, et, et];
        for (k, r) in row_log2.iter_mut().enumerate() {
            let top = cols
                .iter()
                .take(thrusters.len())
                .fold(S::ZERO, |m, col| max_abs(m, get6(col, k)));
            if S::ZERO.lt(top) {
                let (_, e) = top.split_pow2();
                let shift = e.saturating_add(1).saturating_neg();
                for col in cols.iter_mut() {
                    if let Some(v) = col.get_mut(k) {
                        *v = v.mul_pow2(shift);
                    }
                }
                *r = r.saturating_add(shift);
            }
        }
        let axes = if planar { PLANAR_AXES } else { [true; 6] };
        Ok(Allocator {
            cols,
            count: thrusters.len(),
            row_log2,
            axes,
            thrust_log2: ef,
        })
    }

    /// Number of thrusters.
    pub fn count(&self) -> usize {
        self.count
    }

    /// The unit of thrust for the pressure-drop stage: `2^ef` with the largest thrust times
    /// it in `[1/2, 1)`.
    pub fn force_log2(&self) -> i32 {
        self.thrust_log2
    }

    /// The smallest non-negative duties for `force_n` (N) and `torque_nm` (N m about the
    /// CoM), then scaled by the maximum if one exceeds 1 (seed stage 6, direction kept).
    /// Slots past [`Allocator::count`] are 0.
    pub fn allocate(
        &self,
        force_n: [S; 3],
        torque_nm: [S; 3],
    ) -> Result<[S; MAX_THRUSTERS], MixerError> {
        let raw: [S; 6] = core::array::from_fn(|k| {
            if k < 3 {
                force_n.get(k).copied().unwrap_or(S::ZERO)
            } else {
                torque_nm
                    .get(k.saturating_sub(3))
                    .copied()
                    .unwrap_or(S::ZERO)
            }
        });
        if !raw.iter().all(|v| v.is_valid()) {
            return Err(MixerError::BadCommand);
        }
        for (v, on) in raw.iter().zip(self.axes.iter()) {
            if !on && !v.abs().lt(S::from_int_pow2(1, -30)) && S::ZERO.lt(v.abs()) {
                return Err(MixerError::OffPlane);
            }
        }
        // Scale the rows and normalise: with `raw_k = m_k 2^e_k` (`m_k` in [1, 2)), the
        // largest row-scaled entry has exponent `top = max(e_k + row_k)`; dividing by
        // 2^(top + 4) puts every entry below 2^-3 in magnitude, so that duties stay O(1)
        // and the dual's `|u|^2` far inside Q8.24's range, whatever the command's size.
        let mut top: Option<i32> = None;
        for ((v, on), row) in raw.iter().zip(self.axes.iter()).zip(self.row_log2.iter()) {
            if *on && S::ZERO.lt(v.abs()) {
                let (_, e) = v.split_pow2();
                let x = e.saturating_add(*row);
                top = Some(top.map_or(x, |t| t.max(x)));
            }
        }
        let Some(top) = top else {
            return Ok([S::ZERO; MAX_THRUSTERS]);
        };
        let shift = top.saturating_add(4);
        let c: [S; 6] = core::array::from_fn(|k| {
            let on = self.axes.get(k).copied().unwrap_or(false);
            let row = self.row_log2.get(k).copied().unwrap_or(0);
            if on {
                raw.get(k)
                    .copied()
                    .unwrap_or(S::ZERO)
                    .mul_pow2(row.saturating_sub(shift))
            } else {
                S::ZERO
            }
        });
        if !c.iter().all(|v| v.is_valid()) {
            return Err(MixerError::BadCommand);
        }
        let u = self.solve_dual(&c)?;
        // Back to the command's size: u * 2^shift, or divided by its maximum when a duty
        // would exceed 1 (stage 6).
        let max = u.iter().fold(S::ZERO, |m, v| max_abs(m, *v));
        let limit = S::ONE.mul_pow2(shift.saturating_neg());
        let mut out = [S::ZERO; MAX_THRUSTERS];
        if limit.lt(max) || !limit.is_valid() {
            for (o, v) in out.iter_mut().zip(u.iter()) {
                *o = v.checked_div(max).ok_or(MixerError::Overflow)?;
            }
        } else {
            for (o, v) in out.iter_mut().zip(u.iter()) {
                *o = v.mul_pow2(shift);
            }
        }
        Ok(out)
    }

    /// Newton on the dual for the normalised, row-scaled command `c`; the duties for `c`.
    fn solve_dual(&self, c: &[S; 6]) -> Result<[S; MAX_THRUSTERS], MixerError> {
        // Start at the pseudo-inverse's multipliers: (B B' + damping) l = c.
        let all = [true; MAX_THRUSTERS];
        let mut l = self.newton_solve(&all, c)?;
        let mut g = self.missing(c, &l);
        let fine = S::from_int_pow2(1, -CONVERGED_LOG2);
        for _ in 0..MAX_NEWTON_STEPS {
            if !fine.lt(norm_inf(&g)) {
                break;
            }
            let firing: [bool; MAX_THRUSTERS] = core::array::from_fn(|i| {
                self.cols
                    .get(i)
                    .map(|b| S::ZERO.lt(dot(b, &l)))
                    .unwrap_or(false)
                    && i < self.count
            });
            let d = self.newton_solve(&firing, &g)?;
            // A step is taken when it raises the dual or shrinks the missing wrench: near the
            // optimum the dual's rise (quadratic in the gradient) falls below Q8.24's
            // resolution while the gradient still shrinks quadratically.
            let phi0 = self.dual(c, &l);
            let g0 = norm_inf(&g);
            let mut t_log2 = 0i32;
            let mut accepted = false;
            for _ in 0..MAX_HALVINGS {
                let trial: [S; 6] =
                    core::array::from_fn(|k| get6(&l, k).plus(get6(&d, k).mul_pow2(t_log2)));
                if trial.iter().all(|v| v.is_valid()) {
                    let g_trial = self.missing(c, &trial);
                    if phi0.lt(self.dual(c, &trial)) || norm_inf(&g_trial).lt(g0) {
                        l = trial;
                        g = g_trial;
                        accepted = true;
                        break;
                    }
                }
                t_log2 = t_log2.saturating_sub(1);
            }
            if !accepted {
                break;
            }
        }
        if !norm_inf(&g).lt(S::from_int_pow2(1, -REACH_LOG2)) {
            return Err(MixerError::OutOfReach);
        }
        Ok(self.duties(&l))
    }

    /// `u = max(0, B' l)`.
    fn duties(&self, l: &[S; 6]) -> [S; MAX_THRUSTERS] {
        let mut u = [S::ZERO; MAX_THRUSTERS];
        for (ui, b) in u.iter_mut().zip(self.cols.iter()).take(self.count) {
            let s = dot(b, l);
            if S::ZERO.lt(s) {
                *ui = s;
            }
        }
        u
    }

    /// The wrench still missing, `c - B u(l)` (the dual gradient), on the controlled rows.
    fn missing(&self, c: &[S; 6], l: &[S; 6]) -> [S; 6] {
        let u = self.duties(l);
        core::array::from_fn(|k| {
            if !self.axes.get(k).copied().unwrap_or(false) {
                return S::ZERO;
            }
            self.cols
                .iter()
                .zip(u.iter())
                .take(self.count)
                .fold(get6(c, k), |acc, (b, ui)| acc.minus(get6(b, k).times(*ui)))
        })
    }

    /// `phi(l) = c'l - |u(l)|^2 / 2`.
    fn dual(&self, c: &[S; 6], l: &[S; 6]) -> S {
        let u = self.duties(l);
        let half_norm = u
            .iter()
            .fold(S::ZERO, |a, v| a.mul_add(*v, *v))
            .mul_pow2(-1);
        dot(c, l).minus(half_norm)
    }

    /// Solves `(sum over selected thrusters of b b' + damping I) x = rhs` on the controlled
    /// rows (identity on the others), raising the damping when the format cannot hold it.
    fn newton_solve(
        &self,
        selected: &[bool; MAX_THRUSTERS],
        rhs: &[S; 6],
    ) -> Result<[S; 6], MixerError> {
        let mut h = [[S::ZERO; 6]; 6];
        for (b, _) in self
            .cols
            .iter()
            .zip(selected.iter())
            .take(self.count)
            .filter(|(_, on)| **on)
        {
            for (r, row) in h.iter_mut().enumerate() {
                for (k, e) in row.iter_mut().enumerate() {
                    *e = e.mul_add(get6(b, r), get6(b, k));
                }
            }
        }
        let top = h
            .iter()
            .enumerate()
            .fold(S::ZERO, |m, (r, row)| max_abs(m, get6(row, r)));
        let mut damping = if S::ZERO.lt(top) {
            top.mul_pow2(DAMPING_LOG2)
        } else {
            S::ONE.mul_pow2(DAMPING_LOG2)
        };
        for _ in 0..=MAX_DAMPING_RETRIES {
            let mut m = h;
            for (r, row) in m.iter_mut().enumerate() {
                let on = self.axes.get(r).copied().unwrap_or(false);
                for (k, e) in row.iter_mut().enumerate() {
                    if !on || !self.axes.get(k).copied().unwrap_or(false) {
                        *e = if r == k { S::ONE } else { S::ZERO };
                    } else if r == k {
                        *e = e.plus(damping);
                    }
                }
            }
            let rhs_on: [S; 6] = core::array::from_fn(|k| {
                if self.axes.get(k).copied().unwrap_or(false) {
                    get6(rhs, k)
                } else {
                    S::ZERO
                }
            });
            if let Ok(x) = Lu::factor(&m, S::from_int_pow2(1, -24)).and_then(|lu| lu.solve(&rhs_on))
            {
                if x.iter().all(|v| v.is_valid()) {
                    return Ok(x);
                }
            }
            damping = damping.mul_pow2(4);
        }
        Err(MixerError::OutOfReach)
    }
}

/// The mixer of a craft without opposing pairs: [`Allocator`] then the seed's stages 9-10.
#[derive(Clone, Copy, Debug)]
pub struct AllocationMixer<S> {
    allocator: Allocator<S>,
    /// Thrust per slot in the force rows' unit (the largest in `[1/2, 1)`; only the ratios
    /// with the pressure drop matter).
    thrust: [S; MAX_THRUSTERS],
    cfg: MixerConfig<S>,
}

/// ON/OFF times of one control period for up to 16 thrusters, ms from the period start
/// (`on == off == 0`: not firing; slots past the craft's thrusters never fire).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CraftFiring {
    /// ON time per thruster slot, ms.
    pub on_ms: [u32; MAX_THRUSTERS],
    /// OFF time per thruster slot, ms.
    pub off_ms: [u32; MAX_THRUSTERS],
}

impl<S: Scalar> AllocationMixer<S> {
    /// The mixer of `thrusters` about the CoM `com_m` (m from the geometric centre).
    pub fn new(
        thrusters: &[Thruster],
        com_m: [S; 3],
        planar: bool,
        cfg: MixerConfig<S>,
    ) -> Result<Self, MixerError> {
        cfg.check()?;
        let allocator = Allocator::new(thrusters, com_m, planar)?;
        let unit = allocator.force_log2();
        let mut thrust = [S::ZERO; MAX_THRUSTERS];
        for (o, t) in thrust.iter_mut().zip(thrusters.iter()) {
            *o = S::from_f32(t.thrust_n).mul_pow2(unit);
        }
        Ok(AllocationMixer {
            allocator,
            thrust,
            cfg: MixerConfig {
                pressure_drop_n: cfg.pressure_drop_n.mul_pow2(unit),
                ..cfg
            },
        })
    }

    /// Stages 2-9: pulse lengths as fractions of the period.
    pub fn pulse_fractions(
        &self,
        force_n: [S; 3],
        torque_nm: [S; 3],
    ) -> Result<[S; MAX_THRUSTERS], MixerError> {
        let duty = self.allocator.allocate(force_n, torque_nm)?;
        pressure_correction(&duty, &self.thrust, self.cfg.pressure_drop_n)
    }

    /// Mixes a command: `force_n` (N) and `torque_nm` (N m about the CoM), the averages
    /// wanted over the control period.
    pub fn mix(&self, force_n: [S; 3], torque_nm: [S; 3]) -> Result<CraftFiring, MixerError> {
        let frac = self.pulse_fractions(force_n, torque_nm)?;
        let (on_ms, off_ms) = quantise(&frac, self.cfg.period_ms, self.cfg.min_pulse_ms)?;
        Ok(CraftFiring { on_ms, off_ms })
    }
}

fn get6<S: Scalar>(v: &[S; 6], k: usize) -> S {
    v.get(k).copied().unwrap_or(S::ZERO)
}

fn dot<S: Scalar>(a: &[S; 6], b: &[S; 6]) -> S {
    a.iter()
        .zip(b.iter())
        .fold(S::ZERO, |acc, (x, y)| acc.mul_add(*x, *y))
}

fn norm_inf<S: Scalar>(v: &[S; 6]) -> S {
    v.iter().fold(S::ZERO, |m, x| max_abs(m, *x))
}
