//! A thrust scale per thruster (one per thruster that fires in the recording).

use super::{all_at, contract, Context, Effect, Reported, Spec};
use crate::model::{Params, NT};

pub struct ThrustScale;

impl Effect for ThrustScale {
    fn n_params(&self, fired: &[bool; NT]) -> usize {
        fired.iter().filter(|&&f| f).count()
    }
    fn apply(&self, th: &[f64], fired: &[bool; NT], p: &mut Params) {
        let mut j = 0;
        for i in 0..NT {
            if fired[i] {
                p.thrust_scale[i] = th[j];
                j += 1;
            }
        }
    }
    fn spec(&self, cx: &Context) -> Spec {
        let n = self.n_params(cx.fired);
        Spec {
            lo: vec![0.0; n],
            hi: vec![2.0; n],
            step: vec![1e-3; n],
            starts: vec![vec![1.0; n]],
        }
    }
    fn no_effect(&self, theta: &[f64], _: &Context) -> Vec<(usize, f64)> {
        all_at(theta, 1.0)
    }
    // thrust scale within 0 .. 1.5 of nominal, not at the search bound 2
    fn implausible(&self, th: &[f64], _: &dyn Fn(usize) -> bool, _: &Context) -> Option<String> {
        th.iter()
            .any(|&s| !(0.0..=1.5).contains(&s))
            .then(|| "thrust scale outside 0 .. 1.5".into())
    }
    fn signature(&self) -> &'static str {
        "torque error tied to the firings of particular thrusters"
    }
    fn window_ms(&self) -> i64 {
        200
    }
    // every thruster: unfired ones at 1 with an unbounded uncertainty
    fn report(&self, th: &[f64], se: &dyn Fn(usize) -> f64, cx: &Context) -> Reported {
        let n = cx.n_thrusters.min(NT);
        let mut v = vec![1.0; n];
        let mut e = vec![0.0; n];
        let mut j = 0;
        for i in 0..n {
            if cx.fired[i] {
                v[i] = th[j];
                e[i] = se(j);
                j += 1;
            } else {
                e[i] = f64::INFINITY;
            }
        }
        let at = |scale| contract::Effect::ThrustScale(contract::ThrustScale { scale });
        Reported::new(at(v), at(e))
    }
}
