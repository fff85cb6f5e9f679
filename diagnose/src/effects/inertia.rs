//! An inertia tensor other than the model's.

use super::{contract, craft_scale, Context, Effect, Reported, Spec};
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
/// +-0.02 kg m^2 on SPHERES, in proportion to a craft's larger moments. A fixed +-0.02 left a
/// 7 kg m^2 craft's own products of inertia out of the box: a moment 10 % up fitted with its
/// products at the bound and lost to a thrust scale (`diagnose_random_craft`).
pub fn inertia_bounds(nominal: &[f64; 6]) -> (Vec<f64>, Vec<f64>) {
    let product = 0.02 * craft_scale::moment(nominal);
    let mut lo = vec![0.0; 6];
    let mut hi = vec![0.0; 6];
    for i in 0..3 {
        lo[i] = nominal[i] * 0.3;
        hi[i] = nominal[i] * 3.0;
        lo[3 + i] = -product;
        hi[3 + i] = product;
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
    /// Starts at the model's and, on a 3-D craft, at the recording's own linear estimate
    /// (`equation_error.rs`) when that is a plausible body inside the search box: a long
    /// tumbling flight can hold the fit from the model's start in another minimum.
    fn spec(&self, cx: &Context) -> Spec {
        let (lo, hi) = inertia_bounds(&cx.nominal_inertia);
        let mut starts = vec![cx.nominal_inertia.to_vec()];
        if let Some(own) = cx.inertia_start {
            let inside = (0..6).all(|i| own[i] >= lo[i] && own[i] <= hi[i]);
            if inside && self.implausible(&own, &|_| true, cx).is_none() {
                starts.push(own.to_vec());
            }
        }
        Spec {
            lo,
            hi,
            step: vec![2e-5; 6],
            starts,
        }
    }
    fn no_effect(&self, th: &[f64], cx: &Context) -> Vec<(usize, f64)> {
        (0..6)
            .filter(|&i| !th[i].is_nan())
            .map(|i| (i, cx.nominal_inertia[i]))
            .collect()
    }
    // a body, with principal inertias within 0.5 .. 2 x the model's
    fn implausible(&self, th: &[f64], _: &dyn Fn(usize) -> bool, cx: &Context) -> Option<String> {
        let nominal = &cx.nominal_inertia;
        let th = with_model_s(th, cx);
        not_a_body(&th).or_else(|| {
            (0..3)
                .any(|i| th[i] < 0.5 * nominal[i] || th[i] > 2.0 * nominal[i])
                .then(|| "principal inertia outside 0.5 .. 2 x the model's".into())
        })
    }
    fn signature(&self) -> &'static str {
        "rate response to all torques scaled consistently with a different inertia"
    }
    fn report(&self, th: &[f64], se: &dyn Fn(usize) -> f64, cx: &Context) -> Reported {
        let at = |inertia_kgm2| contract::Effect::Inertia(contract::Inertia { inertia_kgm2 });
        let held = (0..6).filter(|&i| th[i].is_nan()).collect();
        Reported::new(at(with_model_s(th, cx)), at(std::array::from_fn(se)))
            .held("inertia_kgm2", held)
    }
    /// The products, on a 3-D craft: a moment 10 % up on a random 3-D craft (products
    /// unchanged) was named a per-axis gyro scale (3 parameters), which fitted worse than
    /// the inertia but was charged three parameters fewer (`diagnose_random_craft`, seed
    /// 81210). A planar craft's turn sees Izz alone anyway.
    fn holdable(&self, cx: &Context) -> Vec<(usize, &'static str)> {
        if cx.plant.planar {
            return vec![];
        }
        vec![(3, "Ixy"), (4, "Ixz"), (5, "Iyz")]
    }
}

/// The six terms with the held ones at the model's values.
fn with_model_s(th: &[f64], cx: &Context) -> [f64; 6] {
    std::array::from_fn(|i| {
        if th[i].is_nan() {
            cx.nominal_inertia[i]
        } else {
            th[i]
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// SPHERES' products are searched within +-0.02 kg m^2 as before; a 7 kg m^2 craft's own
    /// products (0.4, -0.3, 0.2) lie inside its box, and its principal moments 10 % up too.
    /// Planted: the fixed +-0.02 leaves the model's own products out.
    #[test]
    fn the_box_holds_a_large_craft_s_own_products_of_inertia() {
        let sph2 = [0.0242, 0.0214, 0.0194, 0.000108, 0.000157, 1.23e-05];
        let (lo, hi) = inertia_bounds(&sph2);
        assert_eq!((&lo[3..], &hi[3..]), (&[-0.02; 3][..], &[0.02; 3][..]));
        let big = [7.0, 7.5, 4.0, 0.4, -0.3, 0.2];
        let (lo, hi) = inertia_bounds(&big);
        let inside = |v: &[f64; 6]| (0..6).all(|i| lo[i] < v[i] && v[i] < hi[i]);
        assert!(inside(&big), "{lo:?} {hi:?}");
        assert!(inside(&[7.7, 8.25, 4.4, 0.4, -0.3, 0.2]));
        assert!(
            !(-0.02..0.02).contains(&big[3]),
            "the planted box would hold it"
        );
    }
}
