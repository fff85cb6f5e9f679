//! A constant external torque (air drag, a cable, gravity gradient on the testbed).

use super::{all_at, contract, craft_scale, errors, vec3, Context, Effect, Reported, Spec};
use crate::model::{Params, NT};

pub struct DisturbanceTorque;

impl Effect for DisturbanceTorque {
    fn n_params(&self, _: &[bool; NT]) -> usize {
        3
    }
    fn apply(&self, th: &[f64], _: &[bool; NT], p: &mut Params) {
        p.disturbance_nm = [th[0], th[1], th[2]];
    }
    // searched to about one thruster's torque (0.01 N m on SPHERES)
    fn spec(&self, cx: &Context) -> Spec {
        let k = craft_scale::torque(cx);
        Spec {
            lo: vec![-0.01 * k; 3],
            hi: vec![0.01 * k; 3],
            step: vec![1e-7 * k; 3],
            starts: vec![vec![0.0; 3]],
        }
    }
    fn no_effect(&self, theta: &[f64], _: &Context) -> Vec<(usize, f64)> {
        all_at(theta, 0.0)
    }
    // an external torque above a tenth of a thruster's (1e-3 N m on SPHERES) would be a
    // thruster, not a disturbance
    fn implausible(&self, th: &[f64], _: &dyn Fn(usize) -> bool, cx: &Context) -> Option<String> {
        let limit = 1e-3 * craft_scale::torque(cx);
        th.iter()
            .any(|x| x.abs() > limit)
            .then(|| format!("disturbance above {limit:e} N m"))
    }
    fn signature(&self) -> &'static str {
        "rate drifts steadily even while coasting"
    }
    fn report(&self, th: &[f64], se: &dyn Fn(usize) -> f64, _: &Context) -> Reported {
        let at = |torque_nm| {
            contract::Effect::DisturbanceTorque(contract::DisturbanceTorque { torque_nm })
        };
        Reported::new(at(vec3(th, 0)), at(errors(se, 0)))
    }
}
