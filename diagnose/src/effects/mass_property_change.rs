//! A step change of CoM and inertia at one time in the run (a proof mass attached).

use super::com_offset::{plausible_mm, search_bound_mm};
use super::inertia::{inertia_bounds, not_a_body};
use super::{contract, errors, vec3, Context, Effect, Reported, Spec};
use crate::model::{Params, NT};

pub struct MassPropertyChange;

/// Starting change times, spread evenly over the run.
pub const MASS_CHANGE_STARTS: usize = 16;

impl Effect for MassPropertyChange {
    // (at s, CoM offset mm x3, inertia x6)
    fn n_params(&self, _: &[bool; NT]) -> usize {
        10
    }
    fn apply(&self, th: &[f64], _: &[bool; NT], p: &mut Params) {
        p.mass_change = Some((
            th[0],
            [th[1], th[2], th[3]],
            std::array::from_fn(|i| th[4 + i]),
        ));
    }
    fn spec(&self, cx: &Context) -> Spec {
        let dur = cx.duration_s;
        let (ilo, ihi) = inertia_bounds(&cx.nominal_inertia);
        let b = search_bound_mm(cx.plant);
        let mut lo = vec![0.0, -b, -b, -b];
        let mut hi = vec![dur, b, b, b];
        lo.extend(ilo);
        hi.extend(ihi);
        let mut step = vec![0.05; 10];
        step[0] = 0.01;
        for s in step.iter_mut().skip(4) {
            *s = 2e-5;
        }
        // the change time barely has a gradient (the fit only sees it move across a
        // firing), so it is started on a grid of the whole run
        let starts = (0..MASS_CHANGE_STARTS)
            .map(|k| (k as f64 + 0.5) / MASS_CHANGE_STARTS as f64)
            .map(|f| {
                let mut s = vec![f * dur, 0.0, 0.0, 0.0];
                s.extend_from_slice(&cx.nominal_inertia);
                s
            })
            .collect();
        Spec {
            lo,
            hi,
            step,
            starts,
        }
    }
    // the change time: started on a grid and scanned (`select::fit_with_starts`)
    fn held(&self) -> &'static [usize] {
        &[0]
    }
    fn no_effect(&self, _: &[f64], cx: &Context) -> Vec<(usize, f64)> {
        let mut v: Vec<(usize, f64)> = (1..4).map(|i| (i, 0.0)).collect();
        v.extend((0..6).map(|i| (4 + i, cx.nominal_inertia[i])));
        v
    }
    // a change before the first or after the last firing is a constant inertia / CoM
    // error (or nothing)
    fn observable(&self, theta: &[f64], first_s: f64, last_s: f64) -> bool {
        theta[0] > first_s + 0.5 && theta[0] < last_s - 0.5
    }
    fn implausible(&self, th: &[f64], _: &dyn Fn(usize) -> bool, cx: &Context) -> Option<String> {
        let limit = plausible_mm(cx.plant);
        not_a_body(&th[4..10]).or_else(|| {
            th[1..4]
                .iter()
                .any(|x| x.abs() > limit)
                .then(|| format!("CoM offset beyond {limit:.0} mm"))
        })
    }
    fn signature(&self) -> &'static str {
        "torque response changes at one time in the run"
    }
    fn report(&self, th: &[f64], se: &dyn Fn(usize) -> f64, _: &Context) -> Reported {
        let at = |at_s, offset_mm, inertia_kgm2| {
            contract::Effect::MassPropertyChange(contract::MassPropertyChange {
                at_s,
                offset_mm,
                inertia_kgm2,
            })
        };
        Reported::new(
            at(th[0], vec3(th, 1), std::array::from_fn(|i| th[4 + i])),
            at(se(0), errors(se, 1), std::array::from_fn(|i| se(4 + i))),
        )
    }
}
