//! Thrust decaying exponentially after a start time (tank blowdown), for every thruster.

use super::{contract, Context, Effect, Reported, Spec};
use crate::model::{Params, NT};

pub struct Blowdown;

impl Effect for Blowdown {
    fn n_params(&self, _: &[bool; NT]) -> usize {
        2
    }
    // (start s, decay rate 1/s)
    fn apply(&self, th: &[f64], _: &[bool; NT], p: &mut Params) {
        p.blowdown = Some((th[0], 1.0 / th[1].max(1e-9)));
    }
    fn spec(&self, cx: &Context) -> Spec {
        let dur = cx.duration_s;
        Spec {
            lo: vec![0.0, 0.0],
            hi: vec![dur, 20.0 / dur.max(1.0)],
            step: vec![0.01 * dur, 0.02 / dur.max(1.0)],
            starts: [0.2, 0.45, 0.7]
                .iter()
                .map(|f| vec![f * dur, 1.0 / dur.max(1.0)])
                .collect(),
        }
    }
    fn no_effect(&self, _: &[f64], _: &Context) -> Vec<(usize, f64)> {
        vec![(1, 0.0)]
    }
    // a blowdown starting after the last firing cannot be observed
    fn observable(&self, theta: &[f64], _first_s: f64, last_s: f64) -> bool {
        theta[0] < last_s - 0.5
    }
    // a time constant between 1 s and 10^4 s
    fn implausible(&self, th: &[f64], _: &dyn Fn(usize) -> bool, _: &Context) -> Option<String> {
        (th[1] > 1.0 || th[1] < 1e-4).then(|| "blowdown time constant outside 1 s .. 10^4 s".into())
    }
    fn signature(&self) -> &'static str {
        "torque deficit grows with time in the run after a start time, for every thruster"
    }
    fn report(&self, th: &[f64], se: &dyn Fn(usize) -> f64, _: &Context) -> Reported {
        // fitted as a rate, reported as a time constant (its error by the delta method)
        let tau = 1.0 / th[1].max(1e-12);
        let at = |start_s, tau_s| contract::Effect::Blowdown(contract::Blowdown { start_s, tau_s });
        Reported::new(at(th[0], tau), at(se(0), se(1) * tau * tau))
    }
}
