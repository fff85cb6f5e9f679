//! A constant external torque (air drag, a cable, gravity gradient on the testbed).

use super::{all_at, contract, errors, vec3, Context, Effect, Reported, Spec};
use crate::model::{Params, NT};

pub struct DisturbanceTorque;

impl Effect for DisturbanceTorque {
    fn n_params(&self, _: &[bool; NT]) -> usize {
        3
    }
    fn apply(&self, th: &[f64], _: &[bool; NT], p: &mut Params) {
        p.disturbance_nm = [th[0], th[1], th[2]];
    }
    fn spec(&self, _: &Context) -> Spec {
        Spec {
            lo: vec![-0.01; 3],
            hi: vec![0.01; 3],
            step: vec![1e-7; 3],
            starts: vec![vec![0.0; 3]],
        }
    }
    fn no_effect(&self, theta: &[f64], _: &Context) -> Vec<(usize, f64)> {
        all_at(theta, 0.0)
    }
    // an external torque above 1e-3 N m would be a thruster, not a disturbance
    fn implausible(&self, th: &[f64], _: &dyn Fn(usize) -> bool, _: &Context) -> Option<String> {
        th.iter()
            .any(|x| x.abs() > 1e-3)
            .then(|| "disturbance above 1e-3 N m".into())
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
