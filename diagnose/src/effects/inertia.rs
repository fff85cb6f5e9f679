//! An inertia tensor other than the model's.

use super::{contract, Context, Effect, Reported, Spec};
use crate::model::{Params, NT};

pub struct Inertia;

/// Why an inertia (Ixx, Iyy, Izz, Ixy, Ixz, Iyz) is not a body's: not positive definite, or
/// principal values breaking the triangle inequality.
pub fn not_a_body(i: &[f64]) -> Option<String> {
    let m = nalgebra::Matrix3::new(i[0], i[3], i[4], i[3], i[1], i[5], i[4], i[5], i[2]);
    let eig = m.symmetric_eigenvalues();
    if eig.iter().any(|&e| e <= 0.0) {
        return Some("inertia not positive definite".into());
    }
    let (a, b, c) = (eig[0], eig[1], eig[2]);
    if a + b < c || a + c < b || b + c < a {
        return Some("principal inertias break the triangle inequality".into());
    }
    None
}

/// Inertia parameters' search space around the model's: principal 0.3..3x, products
/// +-0.02 kg m^2.
pub fn inertia_bounds(nominal: &[f64; 6]) -> (Vec<f64>, Vec<f64>) {
    let mut lo = vec![0.0; 6];
    let mut hi = vec![0.0; 6];
    for i in 0..3 {
        lo[i] = nominal[i] * 0.3;
        hi[i] = nominal[i] * 3.0;
        lo[3 + i] = -0.02;
        hi[3 + i] = 0.02;
    }
    (lo, hi)
}

impl Effect for Inertia {
    fn n_params(&self, _: &[bool; NT]) -> usize {
        6
    }
    fn apply(&self, th: &[f64], _: &[bool; NT], p: &mut Params) {
        p.inertia = Some(std::array::from_fn(|i| th[i]));
    }
    fn spec(&self, cx: &Context) -> Spec {
        let (lo, hi) = inertia_bounds(&cx.nominal_inertia);
        Spec {
            lo,
            hi,
            step: vec![2e-5; 6],
            starts: vec![cx.nominal_inertia.to_vec()],
        }
    }
    fn no_effect(&self, _: &[f64], cx: &Context) -> Vec<(usize, f64)> {
        (0..6).map(|i| (i, cx.nominal_inertia[i])).collect()
    }
    // a body, with principal inertias within 0.5 .. 2 x the model's
    fn implausible(&self, th: &[f64], _: &dyn Fn(usize) -> bool, cx: &Context) -> Option<String> {
        let nominal = &cx.nominal_inertia;
        not_a_body(th).or_else(|| {
            (0..3)
                .any(|i| th[i] < 0.5 * nominal[i] || th[i] > 2.0 * nominal[i])
                .then(|| "principal inertia outside 0.5 .. 2 x the model's".into())
        })
    }
    fn signature(&self) -> &'static str {
        "rate response to all torques scaled consistently with a different inertia"
    }
    fn report(&self, th: &[f64], se: &dyn Fn(usize) -> f64, _: &Context) -> Reported {
        let at = |inertia_kgm2| contract::Effect::Inertia(contract::Inertia { inertia_kgm2 });
        Reported::new(
            at(std::array::from_fn(|i| th[i])),
            at(std::array::from_fn(se)),
        )
    }
}
