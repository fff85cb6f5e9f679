//! Rate damping: a torque against the body rate, `-b omega` per axis (air-bearing film
//! shear, air drag, a trailing cable). Outside the contract's vocabulary (an extra effect,
//! documented in `diagnose/README.md`); its simulator twin is `sim/src/effects/rate_damping.rs`.
//!
//! Its signature differs from a constant disturbance torque (which pushes the same way at
//! any rate) and from an inertia error (which scales the response to thrust, not the
//! coasting): the rate decays toward zero while coasting, faster the faster it turns.

use super::{all_at, contract, errors, vec3, Context, Effect, Reported, Spec};
use crate::model::{Params, NT};

pub struct RateDamping;

/// The fastest decay the search allows: a time constant `I / b` of 0.5 s. A bearing or
/// drag that stops a free-floating body faster than that would be friction, not damping.
const MIN_DECAY_S: f64 = 0.5;

impl Effect for RateDamping {
    fn n_params(&self, _: &[bool; NT]) -> usize {
        3
    }
    fn apply(&self, th: &[f64], _: &[bool; NT], p: &mut Params) {
        p.damping_nms = [th[0], th[1], th[2]];
    }
    fn spec(&self, cx: &Context) -> Spec {
        let i = &cx.nominal_inertia;
        // b = I / time constant: searched from none to the fastest plausible decay
        let hi: Vec<f64> = (0..3).map(|a| i[a] / MIN_DECAY_S).collect();
        Spec {
            lo: vec![0.0; 3],
            step: hi.iter().map(|h| h * 1e-4).collect(),
            starts: vec![hi.iter().map(|h| h * 0.01).collect()],
            hi,
        }
    }
    fn no_effect(&self, theta: &[f64], _: &Context) -> Vec<(usize, f64)> {
        all_at(theta, 0.0)
    }
    // a decay time under MIN_DECAY_S (the search bound) is not a bearing or drag
    fn implausible(
        &self,
        th: &[f64],
        at_bound: &dyn Fn(usize) -> bool,
        _: &Context,
    ) -> Option<String> {
        (0..3)
            .any(|a| at_bound(a) && th[a] > 0.0)
            .then(|| format!("damping at the search bound (decay faster than {MIN_DECAY_S} s)"))
    }
    fn signature(&self) -> &'static str {
        "rate decays toward zero while coasting, faster the faster the body turns"
    }
    fn report(&self, th: &[f64], se: &dyn Fn(usize) -> f64, _: &Context) -> Reported {
        let at = |nms_per_rad| contract::Effect::RateDamping(contract::RateDamping { nms_per_rad });
        Reported::new(at(vec3(th, 0)), at(errors(se, 0)))
    }
}
