//! Which mass-property terms the flight so far can support: the one observability criterion
//! of this project, the same as the f64 reference's (`reference_f64::mass_id::Excitation`,
//! documented in `reference-f64/README.md`, "Unobservable terms").
//!
//! A Kalman update of a firing *excites* a term when the column of the unweighted design
//! matrix that multiplies it reaches a reference level: half the weakest single thruster's
//! force for the CoM terms (`[F]x` columns), half the weakest single thruster's torque for
//! the inverse-inertia terms (the torque components that multiply it). A term is observable
//! once it has seen `min_updates` excited updates (the reference's 50 ms of them). Small
//! leftovers (a couple's net force from unequal thrusters) never count, however long, so a
//! flight of rotations leaves the CoM unobservable in every implementation, whatever the
//! information matrix's numerical rank says.
//!
//! The decision uses only the commanded thruster word and the model, never the measured data:
//! it is exact and identical in f64, f32 and fixed point.

use crate::model::{FiringTerms, SatelliteParams, N_THRUSTERS};
use crate::scalar::Scalar;

/// Number of terms: CoM x y z, then inverse inertia xx yy zz xy xz yz.
pub const N_TERMS: usize = 9;

/// Excited-update counts per term and the criterion's constants.
#[derive(Clone, Copy, Debug)]
pub struct Excitation<S> {
    /// Squared reference net force, N^2 (a quarter of the weakest thruster's squared force).
    force_ref_sq: S,
    /// Squared reference torque, (cN m)^2.
    torque_ref_sq: S,
    /// Some thruster has thrust (otherwise nothing is ever excited).
    working: bool,
    /// Excited updates per term.
    counts: [u32; N_TERMS],
    /// Updates a term needs to be observable.
    min_updates: u32,
}

impl<S: Scalar> Excitation<S> {
    /// The criterion for `params` at `min_updates` excited updates (the reference: 50 ms of
    /// samples). Thrusters with zero thrust do not set the reference level; a model with no
    /// working thruster excites nothing.
    pub fn new(params: &SatelliteParams, min_updates: u32) -> Self {
        let com = params.com_offset_mm.map(|v| v * 1e-3);
        let mut f_min = f32::INFINITY;
        let mut t_min = f32::INFINITY;
        for i in 0..N_THRUSTERS {
            let (Some(p), Some(d), Some(&f)) = (
                params.thruster_pos_m.get(i),
                params.thrust_dir.get(i),
                params.thrust_n.get(i),
            ) else {
                continue;
            };
            if f.is_nan() || f <= 0.0 {
                continue;
            }
            let r = [p[0] - com[0], p[1] - com[1], p[2] - com[2]];
            let t = [
                r[1] * d[2] - r[2] * d[1],
                r[2] * d[0] - r[0] * d[2],
                r[0] * d[1] - r[1] * d[0],
            ];
            let t_sq = (t[0] * t[0] + t[1] * t[1] + t[2] * t[2]) * f * f;
            let f_sq = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) * f * f;
            f_min = f_min.min(f_sq);
            t_min = t_min.min(t_sq);
        }
        // (0.5 f)^2; torque in cN m: (0.5 * 100 t)^2 = 2500 t^2. No working thruster: a level
        // nothing reaches.
        let working = f_min.is_finite() && t_min.is_finite();
        let level = |v: f32, k: f32| {
            if v.is_finite() {
                S::from_f32(k * v)
            } else {
                S::headroom()
            }
        };
        Excitation {
            working,
            force_ref_sq: level(f_min, 0.25),
            torque_ref_sq: level(t_min, 2500.0),
            counts: [0; N_TERMS],
            min_updates: min_updates.max(1),
        }
    }

    /// The terms a firing with these model terms excites (per update).
    pub fn excited_by(&self, ft: &FiringTerms<S>) -> [bool; N_TERMS] {
        let sq = |v: &[S; 3]| v.map(|x| x.times(x));
        let [fx, fy, fz] = sq(&ft.force_n);
        let [tx, ty, tz] = sq(&ft.torque_cnm);
        // Column norms^2 of [F]x (CoM) and of the inverse-inertia rows (model::inertia_rows).
        let cols = [
            (fy.plus(fz), self.force_ref_sq),
            (fx.plus(fz), self.force_ref_sq),
            (fx.plus(fy), self.force_ref_sq),
            (tx, self.torque_ref_sq),
            (ty, self.torque_ref_sq),
            (tz, self.torque_ref_sq),
            (tx.plus(ty), self.torque_ref_sq),
            (tx.plus(tz), self.torque_ref_sq),
            (ty.plus(tz), self.torque_ref_sq),
        ];
        cols.map(|(v, level)| self.working && !v.lt(level))
    }

    /// Counts `updates` Kalman updates of a firing that excited `excited`.
    pub fn add(&mut self, excited: &[bool; N_TERMS], updates: u32) {
        for (c, e) in self.counts.iter_mut().zip(excited.iter()) {
            if *e {
                *c = c.saturating_add(updates);
            }
        }
    }

    /// Forgets the counts (after a detected change of the mass properties).
    pub fn restart(&mut self) {
        self.counts = [0; N_TERMS];
    }

    /// Terms not (yet) observable: CoM x y z and inverse inertia xx yy zz xy xz yz.
    pub fn unobservable(&self) -> ([bool; 3], [bool; 6]) {
        let u = self.counts.map(|c| c < self.min_updates);
        ([u[0], u[1], u[2]], [u[3], u[4], u[5], u[6], u[7], u[8]])
    }

    /// Excited updates per term so far (telemetry, tests).
    pub fn counts(&self) -> [u32; N_TERMS] {
        self.counts
    }
}

/// Excited updates a term needs at sample period `dt_ms`: the reference's 50 ms of samples.
pub fn min_updates_for(dt_ms: u32) -> u32 {
    50u32.div_ceil(dt_ms.max(1))
}
