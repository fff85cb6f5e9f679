//! Thrust lost per additional open valve (a shared tank's pressure drop).

use super::{all_at, contract, craft_scale, Context, Effect, Reported, Spec};
use crate::model::{Params, NT};

pub struct PressureDrop;

impl Effect for PressureDrop {
    fn n_params(&self, _: &[bool; NT]) -> usize {
        1
    }
    fn apply(&self, th: &[f64], _: &[bool; NT], p: &mut Params) {
        p.pressure_drop = th[0];
    }
    // searched to 0.05 N per extra valve on SPHERES, in proportion to a stronger craft's thrust
    fn spec(&self, cx: &Context) -> Spec {
        let k = craft_scale::force(cx);
        Spec {
            lo: vec![0.0],
            hi: vec![0.05 * k],
            step: vec![1e-5 * k],
            starts: vec![vec![0.002 * k]],
        }
    }
    fn no_effect(&self, theta: &[f64], _: &Context) -> Vec<(usize, f64)> {
        all_at(theta, 0.0)
    }
    // a tank cannot lose more than half a thruster's force per other open valve
    fn implausible(&self, th: &[f64], _: &dyn Fn(usize) -> bool, cx: &Context) -> Option<String> {
        (th[0] >= 0.5 * cx.min_thrust_n)
            .then(|| "pressure drop above half a thruster's force".into())
    }
    fn signature(&self) -> &'static str {
        "torque deficit grows with the number of valves open together"
    }
    fn window_ms(&self) -> i64 {
        200
    }
    fn report(&self, th: &[f64], se: &dyn Fn(usize) -> f64, _: &Context) -> Reported {
        let at = |newton_per_extra_thruster| {
            contract::Effect::PressureDrop(contract::PressureDrop {
                newton_per_extra_thruster,
            })
        };
        Reported::new(at(th[0]), at(se(0)))
    }
}
