//! The centre of mass away from the model's.

use super::{all_at, contract, errors, vec3, Context, Effect, Reported, Spec};
use crate::model::{Params, NT};

pub struct ComOffset;

/// A CoM more than 50 mm from the model's is outside a 0.2 m craft's tolerance.
pub const MAX_OFFSET_MM: f64 = 45.0;

impl Effect for ComOffset {
    fn n_params(&self, _: &[bool; NT]) -> usize {
        3
    }
    fn apply(&self, th: &[f64], _: &[bool; NT], p: &mut Params) {
        p.com_offset_mm = [th[0], th[1], th[2]];
    }
    fn spec(&self, _: &Context) -> Spec {
        Spec {
            lo: vec![-50.0; 3],
            hi: vec![50.0; 3],
            step: vec![0.05; 3],
            starts: vec![vec![0.0; 3]],
        }
    }
    fn no_effect(&self, theta: &[f64], _: &Context) -> Vec<(usize, f64)> {
        all_at(theta, 0.0)
    }
    fn implausible(&self, th: &[f64], _: &dyn Fn(usize) -> bool, _: &Context) -> Option<String> {
        th.iter()
            .any(|&x| x.abs() > MAX_OFFSET_MM)
            .then(|| "CoM offset beyond 45 mm".into())
    }
    fn signature(&self) -> &'static str {
        "torque error on translation firings (opposed pairs) consistent with a moved CoM"
    }
    fn report(&self, th: &[f64], se: &dyn Fn(usize) -> f64, _: &Context) -> Reported {
        let at = |offset_mm| contract::Effect::ComOffset(contract::ComOffset { offset_mm });
        Reported::new(at(vec3(th, 0)), at(errors(se, 0)))
    }
}
