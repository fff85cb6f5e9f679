//! A constant offset of the measured rate, per axis, in counts.

use super::{all_at, contract, errors, vec3, Context, Effect, Reported, Spec};
use crate::model::{Params, NT};

pub struct GyroBias;

impl Effect for GyroBias {
    fn n_params(&self, _: &[bool; NT]) -> usize {
        3
    }
    fn apply(&self, th: &[f64], _: &[bool; NT], p: &mut Params) {
        p.gyro_bias_counts = [th[0], th[1], th[2]];
    }
    fn spec(&self, _: &Context) -> Spec {
        Spec {
            lo: vec![-300.0; 3],
            hi: vec![300.0; 3],
            step: vec![0.05; 3],
            starts: vec![vec![0.0; 3]],
        }
    }
    fn no_effect(&self, theta: &[f64], _: &Context) -> Vec<(usize, f64)> {
        all_at(theta, 0.0)
    }
    // a bias within 200 counts
    fn implausible(&self, th: &[f64], _: &dyn Fn(usize) -> bool, _: &Context) -> Option<String> {
        th.iter()
            .any(|x| x.abs() > 200.0)
            .then(|| "gyro bias beyond 200 counts".into())
    }
    fn signature(&self) -> &'static str {
        "constant offset of the measured rate"
    }
    fn report(&self, th: &[f64], se: &dyn Fn(usize) -> f64, _: &Context) -> Reported {
        let at = |counts| contract::Effect::GyroBias(contract::GyroBias { counts });
        Reported::new(at(vec3(th, 0)), at(errors(se, 0)))
    }
}
