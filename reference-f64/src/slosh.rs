//! The fuel-slosh model of seed Appendix B: a mass on a spring and dashpot (Fig. B.3,
//! eq. B.1-B.4), `H(s) = 1 / (s^2 + 0.02 s + 6)` (eq. B.5), and its zero-order-hold
//! discretisation (eq. B.6 at 0.01 s), at any sample time.
//!
//! The discretisation is written the textbook way: the exponential of the augmented matrix
//! `[[A, B], [0, 0]] dt` is `[[A_d, B_d], [0, I]]` (nalgebra's matrix exponential).
use nalgebra::{Matrix2, Matrix3, RowVector2, Vector2};
use serde::{Deserialize, Serialize};

/// Why a slosh model or discretisation is rejected.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SloshError {
    #[error("{name} must be a finite positive number, got {value}")]
    NotPositive { name: &'static str, value: f64 },
    #[error("{name} must be finite and >= 0, got {value}")]
    Negative { name: &'static str, value: f64 },
}

/// Continuous state-space model `x' = A x + B u`, `y = C x` (D = 0) with state `[x, x']`
/// (seed eq. B.2-B.4): `A = [[0, 1], [-k/M, -b/M]]`, `B = [0, gain]`, `C = [1, 0]`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SloshModel {
    /// `k / M`, 1/s^2 (the seed's 6).
    pub stiffness_per_mass: f64,
    /// `b / M`, 1/s (the seed's 0.02).
    pub damping_per_mass: f64,
    /// Input gain (the seed's H(s) has 1: "just the shape of the output is important").
    pub input_gain: f64,
}

impl SloshModel {
    /// Seed eq. B.5: `H(s) = 1 / (s^2 + 0.02 s + 6)` (M = 0.05 kg, k = 0.3, b = 0.001).
    pub const SEED: SloshModel = SloshModel {
        stiffness_per_mass: 6.0,
        damping_per_mass: 0.02,
        input_gain: 1.0,
    };

    /// From the physical parameters of eq. B.1 (`x'' + (b/M) x' + (k/M) x = u/M`): the input
    /// gain is `1/M`. `from_physical(0.05, 0.3, 0.001)` has the seed's poles with gain 20.
    pub fn from_physical(
        mass_kg: f64,
        spring_n_per_m: f64,
        damper_n_s_per_m: f64,
    ) -> Result<SloshModel, SloshError> {
        let m = pos("slosh mass", mass_kg)?;
        let k = pos("spring constant", spring_n_per_m)?;
        let b = nonneg("damping coefficient", damper_n_s_per_m)?;
        Ok(SloshModel {
            stiffness_per_mass: k / m,
            damping_per_mass: b / m,
            input_gain: 1.0 / m,
        })
    }

    pub fn a(&self) -> Matrix2<f64> {
        Matrix2::new(0.0, 1.0, -self.stiffness_per_mass, -self.damping_per_mass)
    }
    pub fn b(&self) -> Vector2<f64> {
        Vector2::new(0.0, self.input_gain)
    }
    pub fn c(&self) -> RowVector2<f64> {
        RowVector2::new(1.0, 0.0)
    }

    /// The poles `-zeta w_n +- i w_d` as `(real, imaginary >= 0)` (seed: `-0.01 +- 2.45 i`).
    pub fn poles(&self) -> (f64, f64) {
        let re = -self.damping_per_mass / 2.0;
        let disc = self.stiffness_per_mass - re * re;
        (re, disc.max(0.0).sqrt())
    }

    /// Zero-order-hold discretisation at sample time `dt` (s).
    pub fn discretize_zoh(&self, dt_s: f64) -> Result<DiscreteSlosh, SloshError> {
        let dt = pos("sample time", dt_s)?;
        for (name, v) in [
            ("k/M", self.stiffness_per_mass),
            ("b/M", self.damping_per_mass),
            ("input gain", self.input_gain),
        ] {
            if !v.is_finite() {
                return Err(SloshError::NotPositive { name, value: v });
            }
        }
        let mut aug = Matrix3::<f64>::zeros();
        aug.fixed_view_mut::<2, 2>(0, 0).copy_from(&(self.a() * dt));
        aug.fixed_view_mut::<2, 1>(0, 2).copy_from(&(self.b() * dt));
        let e = aug.exp();
        Ok(DiscreteSlosh {
            dt_s: dt,
            ad: e.fixed_view::<2, 2>(0, 0).into_owned(),
            bd: e.fixed_view::<2, 1>(0, 2).into_owned(),
            c: self.c(),
        })
    }
}

fn pos(name: &'static str, v: f64) -> Result<f64, SloshError> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(SloshError::NotPositive { name, value: v })
    }
}
fn nonneg(name: &'static str, v: f64) -> Result<f64, SloshError> {
    if v.is_finite() && v >= 0.0 {
        Ok(v)
    } else {
        Err(SloshError::Negative { name, value: v })
    }
}

/// Discrete model `x[k+1] = A_d x[k] + B_d u[k]`, `y[k] = C x[k]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DiscreteSlosh {
    pub dt_s: f64,
    pub ad: Matrix2<f64>,
    pub bd: Vector2<f64>,
    pub c: RowVector2<f64>,
}

impl DiscreteSlosh {
    /// Transfer function `H(z) = (n1 z + n0) / (z^2 + d1 z + d0)` as `([n1, n0], [d1, d0])`
    /// (the form of seed eq. B.6): `d1 = -trace(A_d)`, `d0 = det(A_d)`, and from
    /// `C adj(zI - A_d) B_d` with `adj(zI - A_d) = z I - (trace(A_d) I - A_d)`:
    /// `n1 = C B_d`, `n0 = -C (trace(A_d) I - A_d) B_d`.
    pub fn transfer_function(&self) -> ([f64; 2], [f64; 2]) {
        let a = self.ad;
        let d1 = -a.trace();
        let d0 = a.determinant();
        // adj(zI - A) = z I - (trace(A) I - A)  (Cayley-Hamilton for 2x2)
        let n1 = (self.c * self.bd)[0];
        let rest = a.trace() * Matrix2::identity() - a;
        let n0 = -(self.c * rest * self.bd)[0];
        ([n1, n0], [d1, d0])
    }

    /// Output sequence for an input sequence, from rest.
    pub fn simulate(&self, input: &[f64]) -> Vec<f64> {
        let mut x = Vector2::zeros();
        input
            .iter()
            .map(|&u| {
                let y = (self.c * x)[0];
                x = self.ad * x + self.bd * u;
                y
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zoh_step_response_settles_at_dc_gain() {
        // DC gain of H(s) is 1/6; the ZOH model preserves it exactly
        let d = SloshModel::SEED.discretize_zoh(0.01).unwrap();
        let ([n1, n0], [d1, d0]) = d.transfer_function();
        let dc = (n1 + n0) / (1.0 + d1 + d0);
        assert!((dc - 1.0 / 6.0).abs() < 1e-9, "{dc}");
    }

    #[test]
    fn zoh_matches_the_analytic_free_response() {
        // A_d = exp(A dt) for the damped oscillator, closed form
        let m = SloshModel::SEED;
        let dt = 0.37;
        let d = m.discretize_zoh(dt).unwrap();
        let (re, wd) = m.poles();
        let e = (re * dt).exp();
        let (s, c) = (wd * dt).sin_cos();
        let a11 = e * (c - re / wd * s);
        let a12 = e * s / wd;
        assert!((d.ad[(0, 0)] - a11).abs() < 1e-13 && (d.ad[(0, 1)] - a12).abs() < 1e-13);
    }

    proptest::proptest! {
        /// ZOH is a semigroup: two steps of dt equal one step of 2 dt, at any dt (checks the
        /// matrix exponential's scaling and squaring over a wide range).
        #[test]
        fn two_half_steps_make_one_step(dt in 1e-4f64..20.0, k in 0.5f64..50.0, b in 0.0f64..2.0) {
            let m = SloshModel { stiffness_per_mass: k, damping_per_mass: b, input_gain: 1.0 };
            let h = m.discretize_zoh(dt).unwrap();
            let f = m.discretize_zoh(2.0 * dt).unwrap();
            let ad2 = h.ad * h.ad;
            let bd2 = h.ad * h.bd + h.bd;
            let scale = 1.0 + f.ad.abs().max();
            proptest::prop_assert!((ad2 - f.ad).abs().max() < 1e-9 * scale);
            proptest::prop_assert!((bd2 - f.bd).abs().max() < 1e-9 * (1.0 + f.bd.abs().max()));
        }
    }

    #[test]
    fn bad_inputs() {
        assert!(SloshModel::SEED.discretize_zoh(0.0).is_err());
        assert!(SloshModel::from_physical(-1.0, 0.3, 0.001).is_err());
        assert!(SloshModel::from_physical(0.05, 0.3, -0.001).is_err());
    }
}
