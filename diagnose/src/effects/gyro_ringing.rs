//! A decaying tone after valve edges (the gyro's tuning fork), aliased by the sampling. It
//! is additive with a random phase per edge, so it is fitted on the residual edge by edge
//! (`crate::ringing`), not through the model's parameters; its bounds are
//! `acceptance::implausible_ringing`.

use super::{contract, vec3, Context, Effect, Reported, Spec};
use crate::model::{Params, NT};

pub struct GyroRinging;

impl Effect for GyroRinging {
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
        let at = |freq_hz, decay_ms, apparent_hz, amplitude_rad_s| {
            contract::Effect::GyroRinging(contract::GyroRinging {
                freq_hz,
                decay_ms,
                apparent_hz,
                amplitude_rad_s,
            })
        };
        let apparent = crate::alias::apparent(th[0], cx.sample_rate_hz);
        // the amplitudes' errors are not estimated
        Reported::new(
            at(th[0], th[1], apparent, vec3(th, 2)),
            at(se(0), se(1), se(0), [f64::NAN; 3]),
        )
        .unestimated("amplitude_rad_s")
    }
}
