//! First-order thrust rise and decay at every valve edge: the force follows the valve
//! through a lag of time constant `tau_ms` (plenum filling, a solenoid's travel). Outside
//! the contract's vocabulary (an extra effect, documented in `diagnose/README.md`); its
//! simulator twin is `sim/src/effects/thrust_rise.rs`.
//!
//! How it differs from a latency: a delay shifts the whole force pulse by a fixed time, so
//! a pulse delivers its full impulse, just late; a lag smears the pulse's edges, so it
//! starts at once but reaches full force gradually, and a short pulse delivers less of its
//! commanded peak. Both move the pulse's centroid by about the same time; the shape of the
//! edges is what tells them apart, and the fit sees it because the model carries both
//! mechanisms (a latency and a rise together are fitted jointly when both are named).

use super::{contract, Context, Effect, Reported, Spec};
use crate::model::{Params, NT};

pub struct ThrustRise;

/// Search bound, ms: a lag beyond this is not a valve (it would smear 10 Hz control).
const MAX_TAU_MS: f64 = 100.0;

impl Effect for ThrustRise {
    fn n_params(&self, _: &[bool; NT]) -> usize {
        1
    }
    fn apply(&self, th: &[f64], _: &[bool; NT], p: &mut Params) {
        p.rise_ms = th[0];
    }
    fn spec(&self, _: &Context) -> Spec {
        Spec {
            lo: vec![0.0],
            hi: vec![MAX_TAU_MS],
            step: vec![0.05],
            starts: vec![vec![3.0]],
        }
    }
    fn no_effect(&self, _: &[f64], _: &Context) -> Vec<(usize, f64)> {
        vec![(0, 0.0)]
    }
    // a valve's force settles within MAX_TAU_MS
    fn implausible(
        &self,
        th: &[f64],
        at_bound: &dyn Fn(usize) -> bool,
        _: &Context,
    ) -> Option<String> {
        (at_bound(0) && th[0] > 0.0)
            .then(|| format!("rise time at the {MAX_TAU_MS} ms search bound"))
    }
    fn signature(&self) -> &'static str {
        "residual at valve edges is a smeared step: force arrives gradually, not late"
    }
    fn window_ms(&self) -> i64 {
        20
    }
    fn report(&self, th: &[f64], se: &dyn Fn(usize) -> f64, _: &Context) -> Reported {
        let at = |tau_ms| contract::Effect::ThrustRise(contract::ThrustRise { tau_ms });
        Reported::new(at(th[0]), at(se(0)))
    }
}
