//! A profile over a parameter no fit steps (a mass-property change's time): the fit's cost
//! with that parameter moved and every other parameter re-fitted, to first order.
//!
//! Why: a change time moves the prediction only where it crosses a firing, so the fit does
//! not step it; it is scanned. Scanned with the other parameters left where they were fitted
//! (the conditional cost), the open set's p04 kept its change at 14.61 s, where the CoM and
//! inertia had been fitted to it; with them re-fitted at each time (the profile) the truth,
//! 15.0 s, fits far better (chi-square 113,330 against 159,865). A fit at every point of a
//! scan costs a fit each; the fit's own Jacobian gives the re-fit to first order for the
//! price of the one prediction each point makes anyway. The same profile gives the held
//! parameter an honest error ([`held_error`]).

use nalgebra::{Cholesky, DMatrix, DVector, Dyn};

/// A fit at its end, linear in the parameters it stepped.
#[derive(Clone, Debug)]
pub struct Linearised {
    /// The stepped parameters' Jacobian columns (of the weighted residual, data minus
    /// prediction).
    jac: DMatrix<f64>,
    /// Their places in the fit's parameter vector.
    stepped: Vec<usize>,
    /// Of their normal matrix.
    normal: Cholesky<f64, Dyn>,
    /// How far the cost rises over one parameter's one-sigma interval: the fit's covariance
    /// scale (the residual's excess over its noise model, over the stride).
    pub rise: f64,
}

impl Linearised {
    /// From the fit's Jacobian `jac`, its columns `stepped`, and its covariance scale.
    /// None when their normal matrix is singular.
    pub fn new(jac: &DMatrix<f64>, stepped: &[usize], scale: f64) -> Option<Self> {
        let jac = jac.select_columns(stepped);
        let normal = (jac.transpose() * &jac).cholesky()?;
        Some(Linearised {
            jac,
            stepped: stepped.to_vec(),
            normal,
            rise: scale,
        })
    }

    /// The stepped parameters' places in the fit's parameter vector.
    pub fn stepped(&self) -> &[usize] {
        &self.stepped
    }

    /// Their covariance with the held parameters where they are (in the order of
    /// [`Linearised::stepped`]), scaled like the fit's.
    pub fn covariance(&self) -> DMatrix<f64> {
        self.normal.inverse() * self.rise
    }

    /// For the weighted residual `r` of the model with the held parameter moved: the cost
    /// with the stepped parameters re-fitted to first order, and their Gauss-Newton step
    /// (place in the parameter vector, change). None when `r` is not of the fit's samples or
    /// not finite. The Jacobian is the fit's, at the held parameter's fitted value: between
    /// that and the new value the columns of what the change moves are those of the old
    /// time, so the re-fit is a first-order guess that LM then settles.
    pub fn refit(&self, r: &DVector<f64>) -> Option<(f64, Vec<(usize, f64)>)> {
        if r.len() != self.jac.nrows() {
            return None;
        }
        let g = self.jac.transpose() * r;
        let back = self.normal.solve(&g);
        // a non-finite residual is no cost at all (NaN would pass `max` as 0)
        let cost = r.norm_squared() - g.dot(&back);
        if !cost.is_finite() {
            return None;
        }
        let cost = cost.max(0.0);
        let step = self.stepped.iter().copied().zip(back.iter().map(|b| -b));
        Some((cost, step.collect()))
    }
}

/// The standard error of a held parameter from its profile `cost` (with the other
/// parameters re-fitted, [`Linearised::refit`]): the larger distance from `at` to where the
/// cost first rises by more than `rise` above its value at `at`, found to `resolution` by
/// doubling and then bisection within `[lo, hi]` (an interval that reaches `lo` or `hi`
/// gives the distance to it), or to the farthest of `probes` within that rise (the profile
/// of a change time has a minimum at every firing: one as good a firing away is as likely).
/// Why not the covariance's difference column: a 10 ms difference of a change time that
/// crosses a firing edge is steep, one that does not is zero, and neither says how far the
/// time can move with the fit as good (p04: a change at 14.61 s given +-0.004 s, the truth
/// 0.39 s away). NaN when the cost at `at` is unknown or not finite, `rise` is negative or
/// NaN, or a bound is not finite.
pub fn held_error(
    cost: &dyn Fn(f64) -> Option<f64>,
    at: f64,
    (lo, hi): (f64, f64),
    resolution: f64,
    rise: f64,
    probes: &[f64],
) -> f64 {
    let Some(base) = cost(at).filter(|c| c.is_finite() && rise >= 0.0) else {
        return f64::NAN;
    };
    if !(lo.is_finite() && hi.is_finite() && at.is_finite()) {
        return f64::NAN;
    }
    let within = |x: f64| cost(x).is_some_and(|c| c <= base + rise);
    let resolution = resolution.max(f64::EPSILON * at.abs().max(1.0));
    let side = |bound: f64| {
        let reach = (bound - at).abs();
        let dir = (bound - at).signum();
        // `inside`: within the rise; `outside`: past it (None: not found yet)
        let (mut inside, mut outside) = (0.0f64, None);
        let mut d = resolution;
        while inside < reach {
            let step = d.min(reach);
            if within(at + dir * step) {
                inside = step;
                d *= 2.0;
            } else {
                outside = Some(step);
                break;
            }
        }
        let Some(mut outside) = outside else {
            return reach;
        };
        while outside - inside > resolution {
            let mid = 0.5 * (inside + outside);
            if mid <= inside || mid >= outside {
                break;
            }
            if within(at + dir * mid) {
                inside = mid;
            } else {
                outside = mid;
            }
        }
        0.5 * (inside + outside)
    };
    let near = side(lo).max(side(hi));
    probes
        .iter()
        .filter(|&&x| (lo..=hi).contains(&x) && (x - at).abs() > near)
        .filter(|&&x| within(x))
        .map(|&x| (x - at).abs())
        .fold(near, f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The first-order re-fit is the least-squares fit of the stepped columns: its cost is
    /// `min |r + J d|^2` and its step that `d` (solved here by SVD, independently of the
    /// Cholesky factor). The columns not stepped are left alone. Planted fault checked by
    /// hand: the step's sign flipped (the cost unchanged, the steps negated).
    #[test]
    fn the_first_order_refit_is_the_least_squares_refit() {
        let mut draw = crate::model::tests::lcg(7);
        let mut next = || draw(1 << 20) as f64 / (1 << 20) as f64 - 0.5;
        let jac = DMatrix::from_fn(40, 4, |_, _| next());
        let r = DVector::from_fn(40, |_, _| next());
        let lin = Linearised::new(&jac, &[0, 2, 3], 1.0).unwrap();
        let (cost, step) = lin.refit(&r).unwrap();
        let sub = jac.select_columns(&[0, 2, 3]);
        let d = sub.clone().svd(true, true).solve(&(-&r), 1e-12).unwrap();
        let want = (&r + &sub * &d).norm_squared();
        assert!((cost - want).abs() < 1e-12 * want, "{cost} {want}");
        assert_eq!(step.iter().map(|s| s.0).collect::<Vec<_>>(), [0, 2, 3]);
        for ((_, got), want) in step.iter().zip(d.iter()) {
            assert!((got - want).abs() < 1e-10, "{got} {want}");
        }
        // a residual of other samples is refused
        assert!(lin.refit(&DVector::zeros(39)).is_none());
    }

    /// The error of a held parameter is how far it moves before the cost rises by `rise`:
    /// on a quadratic cost `((x - 2) / 0.5)^2` with rise 1, 0.5 (the standard error); on a
    /// cost flat over the coast 1.58-1.80 s around 1.70 s (a change time between firings),
    /// the larger distance to its ends, 0.12 s, whatever the rise below the step; against a
    /// bound, the distance to the bound; a stretch as good (within the rise) elsewhere, at a
    /// probe, the distance to that probe. Planted fault checked by hand: the smaller side
    /// taken (0.10 s).
    #[test]
    fn a_held_parameter_is_as_uncertain_as_its_flat_stretch() {
        let quadratic = |x: f64| Some(((x - 2.0) / 0.5).powi(2));
        let se = held_error(&quadratic, 2.0, (0.0, 10.0), 1e-6, 1.0, &[]);
        assert!((se - 0.5).abs() < 1e-5, "{se}");
        let coast = |x: f64| {
            Some(if (1.58..=1.80).contains(&x) {
                10.0
            } else {
                50.0
            })
        };
        let se = held_error(&coast, 1.70, (0.0, 3.0), 0.001, 1.0, &[]);
        assert!(
            (se - 0.10).abs() > 0.01 && (se - 0.12).abs() < 0.001,
            "{se}"
        );
        let se = held_error(&coast, 1.70, (1.65, 1.75), 0.001, 1.0, &[]);
        assert!((se - 0.05).abs() < 1e-12, "{se}");
        // a second stretch as good two firings away, seen by a probe there (not by the
        // local search, which stops where the cost first rises)
        let two = |x: f64| {
            Some(if (2.50..=2.60).contains(&x) {
                10.5
            } else {
                coast(x)?
            })
        };
        let se = held_error(&two, 1.70, (0.0, 3.0), 0.001, 1.0, &[0.5, 2.55]);
        assert!((se - 0.85).abs() < 1e-12, "{se}");
        let se = held_error(&two, 1.70, (0.0, 3.0), 0.001, 0.2, &[0.5, 2.55]);
        assert!((se - 0.12).abs() < 0.001, "{se}");
        // an unknown cost where it stands, or a negative rise: no error
        assert!(held_error(&|_| None, 1.0, (0.0, 2.0), 0.01, 1.0, &[]).is_nan());
        assert!(held_error(&coast, 1.7, (0.0, 2.0), 0.01, -1.0, &[]).is_nan());
    }
}
