//! Valve opening and closing delays: torque arrives later than commanded.

use super::{all_at, scalar, Context, Effect, Reported, Spec};
use crate::model::{Params, NT};

pub struct ThrusterLatency;

impl Effect for ThrusterLatency {
    fn name(&self) -> &'static str {
        "thruster_latency"
    }
    fn n_params(&self, _: &[bool; NT]) -> usize {
        2
    }
    fn apply(&self, th: &[f64], _: &[bool; NT], p: &mut Params) {
        p.open_ms = th[0];
        p.close_ms = th[1];
    }
    fn spec(&self, _: &Context) -> Spec {
        Spec {
            lo: vec![0.0, 0.0],
            hi: vec![50.0, 50.0],
            step: vec![0.05, 0.05],
            starts: vec![vec![2.0, 2.0]],
        }
    }
    fn no_effect(&self, theta: &[f64], _: &Context) -> Vec<(usize, f64)> {
        all_at(theta, 0.0)
    }
    // valves open/close within 0..50 ms (seed ch. 2 measures ~6 ms)
    fn implausible(
        &self,
        th: &[f64],
        at_bound: &dyn Fn(usize) -> bool,
        _: &Context,
    ) -> Option<String> {
        (at_bound(0) && th[0] > 0.0 || at_bound(1) && th[1] > 0.0)
            .then(|| "latency at the 50 ms search bound".into())
    }
    fn signature(&self) -> &'static str {
        "residual concentrates at valve edges: torque arrives later than commanded"
    }
    fn window_ms(&self) -> i64 {
        20
    }
    fn report(&self, th: &[f64], se: &dyn Fn(usize) -> f64, _: &Context) -> Reported {
        let mut r = Reported::default();
        scalar(&mut r, "open_ms", th[0], se(0));
        scalar(&mut r, "close_ms", th[1], se(1));
        r
    }
}
