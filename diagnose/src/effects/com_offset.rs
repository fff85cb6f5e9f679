//! The centre of mass away from the model's.

use super::{all_at, contract, craft_scale, errors, vec3, Context, Effect, Reported, Spec};
use crate::model::{Params, Plant, NT};

pub struct ComOffset;

/// How far from the model's the CoM is searched, mm: 50 mm on a craft up to SPHERES' size,
/// in proportion on a larger one. A fixed 50 mm clamped a 1 m free-flyer's 60 mm offset at
/// the bound and called it implausible: the diagnosis named nothing, or a thrust scale,
/// where the CoM had moved (`diagnose_random_craft`).
pub fn search_bound_mm(plant: &Plant) -> f64 {
    50.0 * craft_scale::length(plant)
}

/// A CoM farther than this from the model's (mm) is outside the craft's tolerance: 0.9 of
/// the search bound (45 mm on SPHERES).
pub fn plausible_mm(plant: &Plant) -> f64 {
    0.9 * search_bound_mm(plant)
}

impl Effect for ComOffset {
    fn n_params(&self, _: &[bool; NT]) -> usize {
        3
    }
    fn apply(&self, th: &[f64], _: &[bool; NT], p: &mut Params) {
        p.com_offset_mm = [th[0], th[1], th[2]];
    }
    fn spec(&self, cx: &Context) -> Spec {
        let b = search_bound_mm(cx.plant);
        Spec {
            lo: vec![-b; 3],
            hi: vec![b; 3],
            step: vec![0.05; 3],
            starts: vec![vec![0.0; 3]],
        }
    }
    fn no_effect(&self, theta: &[f64], _: &Context) -> Vec<(usize, f64)> {
        all_at(theta, 0.0)
    }
    fn implausible(&self, th: &[f64], _: &dyn Fn(usize) -> bool, cx: &Context) -> Option<String> {
        let limit = plausible_mm(cx.plant);
        th.iter()
            .any(|&x| x.abs() > limit)
            .then(|| format!("CoM offset beyond {limit:.0} mm"))
    }
    fn signature(&self) -> &'static str {
        "torque error on translation firings (opposed pairs) consistent with a moved CoM"
    }
    fn report(&self, th: &[f64], se: &dyn Fn(usize) -> f64, _: &Context) -> Reported {
        let at = |offset_mm| contract::Effect::ComOffset(contract::ComOffset { offset_mm });
        Reported::new(at(vec3(th, 0)), at(errors(se, 0)))
    }
}
