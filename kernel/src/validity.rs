//! Physical validity of a solved estimate: what no rigid body can have is never reported as
//! `Ok`. A solve that fails these checks keeps the previous estimate and raises
//! [`crate::PipelineStatus::Implausible`] with the reason.
//!
//! * The inverse inertia (hence the inertia) is positive definite (leading minors).
//! * The inertia's diagonal obeys the triangle inequalities `Ixx + Iyy >= Izz` (and cyclic),
//!   which hold in any body frame because `Ixx = sum m (y^2 + z^2)` etc.
//! * The CoM lies inside the box spanned by the thruster positions (the craft's hull).
//!
//! No division: with `J = I^-1` positive definite, `I = adj(J) / det J` and `det J > 0`,
//! so the triangle inequalities are those of the adjugate's diagonal cofactors.

use crate::model::{SatelliteParams, N_THRUSTERS};
use crate::scalar::Scalar;

/// Why an estimate is not physical.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum Invalid {
    /// The inertia is not positive definite.
    NotPositiveDefinite = 1,
    /// A principal moment exceeds the sum of the other two.
    TriangleInequality = 2,
    /// The CoM is outside the box of the thruster positions.
    ComOutsideEnvelope = 3,
}

/// The checks' constants for one craft.
#[derive(Clone, Copy, Debug)]
pub struct Validity<S> {
    /// CoM offset bounds relative to the model's CoM, m, per axis (low, high).
    com_lo: [S; 3],
    com_hi: [S; 3],
    /// Power of two that brings the nominal inverse-inertia parameters near 1 (precision of
    /// the products in fixed point).
    theta_shift: i32,
}

impl<S: Scalar> Validity<S> {
    /// The envelope of `params`' thrusters and the scaling of its nominal inverse inertia
    /// `theta_nominal` (kernel units).
    pub fn new(params: &SatelliteParams, theta_nominal: &[S; 6]) -> Self {
        let mut lo = [f32::INFINITY; 3];
        let mut hi = [f32::NEG_INFINITY; 3];
        for p in params.thruster_pos_m.iter().take(N_THRUSTERS) {
            for a in 0..3 {
                if let (Some(l), Some(h), Some(&v)) = (lo.get_mut(a), hi.get_mut(a), p.get(a)) {
                    *l = l.min(v);
                    *h = h.max(v);
                }
            }
        }
        let com = params.com_offset_mm.map(|v| v * 1e-3);
        let big = S::headroom();
        let com_lo = core::array::from_fn(|a| {
            let (l, c) = (
                lo.get(a).copied().unwrap_or(f32::NEG_INFINITY),
                com.get(a).copied().unwrap_or(0.0),
            );
            if (l - c).is_finite() {
                S::from_f32(l - c)
            } else {
                big.negate()
            }
        });
        let com_hi = core::array::from_fn(|a| {
            let (h, c) = (
                hi.get(a).copied().unwrap_or(f32::INFINITY),
                com.get(a).copied().unwrap_or(0.0),
            );
            if (h - c).is_finite() {
                S::from_f32(h - c)
            } else {
                big
            }
        });
        let largest = theta_nominal
            .iter()
            .take(3)
            .fold(S::ZERO, |m, v| crate::scalar::max_abs(m, *v));
        let theta_shift = if S::ZERO.lt(largest) {
            largest.split_pow2().1.saturating_neg()
        } else {
            0
        };
        Validity {
            com_lo,
            com_hi,
            theta_shift,
        }
    }

    /// Checks an estimate: inverse-inertia parameters `theta` (xx yy zz xy xz yz, kernel
    /// units) and CoM offset `delta_com_m` from the model's CoM.
    pub fn check(&self, theta: &[S; 6], delta_com_m: &[S; 3]) -> Result<(), Invalid> {
        let [xx, yy, zz, xy, xz, yz] = theta.map(|v| v.mul_pow2(self.theta_shift));
        // Leading minors of J = [[xx xy xz] [xy yy yz] [xz yz zz]].
        let m2 = xx.times(yy).minus(xy.times(xy));
        let c00 = yy.times(zz).minus(yz.times(yz));
        let c01 = yz.times(xz).minus(xy.times(zz));
        let c02 = xy.times(yz).minus(yy.times(xz));
        let det = xx.times(c00).plus(xy.times(c01)).plus(xz.times(c02));
        let all_valid = [xx, m2, det, c00].iter().all(|v| v.is_valid());
        if !all_valid || !S::ZERO.lt(xx) || !S::ZERO.lt(m2) || !S::ZERO.lt(det) {
            return Err(Invalid::NotPositiveDefinite);
        }
        // Diagonal of adj(J), proportional to Ixx Iyy Izz.
        let c11 = xx.times(zz).minus(xz.times(xz));
        let c22 = m2;
        if c00.plus(c11).lt(c22) || c00.plus(c22).lt(c11) || c11.plus(c22).lt(c00) {
            return Err(Invalid::TriangleInequality);
        }
        for ((d, lo), hi) in delta_com_m
            .iter()
            .zip(self.com_lo.iter())
            .zip(self.com_hi.iter())
        {
            if !d.is_valid() || d.lt(*lo) || hi.lt(*d) {
                return Err(Invalid::ComOutsideEnvelope);
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::SPH2;

    fn theta_of(i: [f64; 6]) -> [f32; 6] {
        let [xx, yy, zz, xy, xz, yz] = i;
        let m = [[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]];
        let j = crate::pipeline::invert3(&m).unwrap_or([[0.0; 3]; 3]);
        [j[0][0], j[1][1], j[2][2], j[0][1], j[0][2], j[1][2]].map(|v| (v / 100.0) as f32)
    }

    fn check(i: [f64; 6], com: [f32; 3]) -> Result<(), Invalid> {
        let nominal = theta_of(SPH2.inertia_kgm2.map(f64::from));
        let v = Validity::<f32>::new(&SPH2, &nominal);
        v.check(&theta_of(i), &com)
    }

    #[test]
    fn sph2_is_valid_and_each_violation_is_named() {
        let i = SPH2.inertia_kgm2.map(f64::from);
        assert_eq!(check(i, [0.0; 3]), Ok(()));
        // a 2 mm CoM shift is fine, 0.3 m is outside the hull
        assert_eq!(check(i, [0.002, -0.002, 0.002]), Ok(()));
        assert_eq!(check(i, [0.3, 0.0, 0.0]), Err(Invalid::ComOutsideEnvelope));
        // negative moment (the saturated-data estimate of issue 12)
        assert_eq!(
            check([-21.3, i[1], i[2], i[3], i[4], i[5]], [0.0; 3]),
            Err(Invalid::NotPositiveDefinite)
        );
        // Ixx far above Iyy + Izz (the dead-gyro estimate)
        assert_eq!(
            check([1.04e6, i[1], i[2], i[3], i[4], i[5]], [0.0; 3]),
            Err(Invalid::TriangleInequality)
        );
        // a thin plate at the limit is still physical; just beyond it is not
        assert_eq!(check([0.02, 0.02, 0.0399, 0.0, 0.0, 0.0], [0.0; 3]), Ok(()));
        assert_eq!(
            check([0.02, 0.02, 0.0401, 0.0, 0.0, 0.0], [0.0; 3]),
            Err(Invalid::TriangleInequality)
        );
    }

    #[test]
    fn fixed_point_agrees_on_the_same_cases() {
        use crate::scalar::Q8_24;
        let nominal = theta_of(SPH2.inertia_kgm2.map(f64::from)).map(Q8_24::from_f32);
        let v = Validity::<Q8_24>::new(&SPH2, &nominal);
        let i = SPH2.inertia_kgm2.map(f64::from);
        let q = |t: [f32; 6]| t.map(Q8_24::from_f32);
        let z = [Q8_24::ZERO; 3];
        assert_eq!(v.check(&q(theta_of(i)), &z), Ok(()));
        assert_eq!(
            v.check(&q(theta_of([-21.3, i[1], i[2], i[3], i[4], i[5]])), &z),
            Err(Invalid::NotPositiveDefinite)
        );
        // 1/Ixx is below Q8.24's resolution here: the fixed check sees a singular J.
        assert!(v
            .check(&q(theta_of([1.04e6, i[1], i[2], i[3], i[4], i[5]])), &z)
            .is_err());
        assert_eq!(
            v.check(
                &q(theta_of(i)),
                &[Q8_24::from_f32(0.3), Q8_24::ZERO, Q8_24::ZERO]
            ),
            Err(Invalid::ComOutsideEnvelope)
        );
    }
}
