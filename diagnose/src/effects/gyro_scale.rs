//! A gyro scale factor per axis: rate error proportional to the rate.

use super::{all_at, contract, errors, vec3, Context, Effect, Reported, Spec};
use crate::model::{Params, NT};

pub struct GyroScale;

impl Effect for GyroScale {
    fn n_params(&self, _: &[bool; NT]) -> usize {
        3
    }
    fn apply(&self, th: &[f64], _: &[bool; NT], p: &mut Params) {
        p.gyro_scale = [th[0], th[1], th[2]];
    }
    fn spec(&self, _: &Context) -> Spec {
        Spec {
            lo: vec![0.5; 3],
            hi: vec![1.5; 3],
            step: vec![1e-4; 3],
            starts: vec![vec![1.0; 3]],
        }
    }
    fn no_effect(&self, theta: &[f64], _: &Context) -> Vec<(usize, f64)> {
        all_at(theta, 1.0)
    }
    // a scale within 20 %
    fn implausible(&self, th: &[f64], _: &dyn Fn(usize) -> bool, _: &Context) -> Option<String> {
        th.iter()
            .any(|x| (x - 1.0).abs() > 0.2)
            .then(|| "gyro scale beyond 20 %".into())
    }
    fn signature(&self) -> &'static str {
        "rate error proportional to the rate itself"
    }
    fn report(&self, th: &[f64], se: &dyn Fn(usize) -> f64, _: &Context) -> Reported {
        let at = |scale| contract::Effect::GyroScale(contract::GyroScale { scale });
        Reported::new(at(vec3(th, 0)), at(errors(se, 0)))
    }
}
