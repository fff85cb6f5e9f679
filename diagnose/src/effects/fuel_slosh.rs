//! A lightly damped low-frequency mode of a liquid, with a fluid inertia fraction per axis
//! (a liquid can move about some axes only).

use super::{contract, errors, vec3, Context, Effect, Reported, Spec};
use crate::model::{Params, NT};

pub struct FuelSlosh;

impl Effect for FuelSlosh {
    // (freq Hz, damping ratio, fluid fraction x, y, z)
    fn n_params(&self, _: &[bool; NT]) -> usize {
        5
    }
    fn apply(&self, th: &[f64], _: &[bool; NT], p: &mut Params) {
        p.slosh = Some((th[0], th[1], [th[2], th[3], th[4]]));
    }
    fn spec(&self, cx: &Context) -> Spec {
        // a frequency grid plus the residual's own low-frequency peaks; small liquid
        // fraction so every start is close to the current model
        let mut starts: Vec<Vec<f64>> = [0.15, 0.2, 0.3, 0.4, 0.5, 0.7, 1.0, 1.5, 2.0, 3.0]
            .iter()
            .map(|&f| vec![f, 0.01, 0.01, 0.01, 0.01])
            .collect();
        for &f in cx.slosh_hint_hz {
            starts.push(vec![f, 0.01, 0.01, 0.01, 0.01]);
            starts.push(vec![f, 0.005, 0.03, 0.03, 0.03]);
        }
        Spec {
            lo: vec![0.02, 0.0, 0.0, 0.0, 0.0],
            hi: vec![20.0, 0.5, 0.5, 0.5, 0.5],
            step: vec![1e-3, 2e-4, 1e-3, 1e-3, 1e-3],
            starts,
        }
    }
    fn no_effect(&self, _: &[f64], _: &Context) -> Vec<(usize, f64)> {
        vec![(2, 0.0), (3, 0.0), (4, 0.0)]
    }
    // a mode between 0.02 and 20 Hz, damping below 0.4, fractions below a third of the
    // craft's inertia
    fn implausible(
        &self,
        th: &[f64],
        at_bound: &dyn Fn(usize) -> bool,
        _: &Context,
    ) -> Option<String> {
        if th[1] > 0.4 || at_bound(0) {
            Some("slosh frequency or damping at its search bound".into())
        } else if th[2..5].iter().any(|&f| f > 0.34) {
            Some("fluid inertia fraction above 1/3".into())
        } else {
            None
        }
    }
    fn signature(&self) -> &'static str {
        "lightly damped low-frequency oscillation excited by firings, continuing while coasting"
    }
    fn report(&self, th: &[f64], se: &dyn Fn(usize) -> f64, _: &Context) -> Reported {
        let at = |freq_hz, damping_ratio, inertia_fraction| {
            contract::Effect::FuelSlosh(contract::FuelSlosh {
                freq_hz,
                damping_ratio,
                inertia_fraction,
            })
        };
        Reported::new(
            at(th[0], th[1], vec3(th, 2)),
            at(se(0), se(1), errors(se, 2)),
        )
    }
}
