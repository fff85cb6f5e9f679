//! A decaying tone after valve edges (the gyro's tuning fork), aliased by the sampling. It
//! is additive with a random phase per edge, so it is fitted on the residual edge by edge
//! (`crate::ringing`), not through the model's parameters; its bounds are
//! `acceptance::implausible_ringing`.

use super::{Context, Effect, Reported, Spec};
use crate::json_number::{num, nums};
use crate::model::{Params, NT};

pub struct GyroRinging;

impl Effect for GyroRinging {
    fn name(&self) -> &'static str {
        "gyro_ringing"
    }
    // (freq Hz, decay ms, amplitude x, y, z)
    fn n_params(&self, _: &[bool; NT]) -> usize {
        5
    }
    // additive with a random phase per edge: see ringing.rs
    fn apply(&self, _: &[f64], _: &[bool; NT], _: &mut Params) {}
    fn spec(&self, _: &Context) -> Spec {
        Spec {
            lo: vec![],
            hi: vec![],
            step: vec![],
            starts: vec![],
        }
    }
    fn no_effect(&self, _: &[f64], _: &Context) -> Vec<(usize, f64)> {
        vec![]
    }
    fn on_residual(&self) -> bool {
        true
    }
    fn signature(&self) -> &'static str {
        "decaying tone after valve edges"
    }
    fn window_ms(&self) -> i64 {
        20
    }
    fn report(&self, th: &[f64], se: &dyn Fn(usize) -> f64, cx: &Context) -> Reported {
        let mut r = Reported::default();
        r.0.insert("freq_hz".into(), num(th[0]));
        r.0.insert("decay_ms".into(), num(th[1]));
        r.0.insert(
            "apparent_hz".into(),
            num(crate::alias::apparent(th[0], cx.sample_rate_hz)),
        );
        r.0.insert("amplitude_rad_s".into(), nums(&th[2..5]));
        r.1.insert("freq_hz".into(), num(se(0)));
        r.1.insert("decay_ms".into(), num(se(1)));
        r.1.insert("apparent_hz".into(), num(se(0)));
        r
    }
}
