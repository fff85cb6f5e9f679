//! The onboard consistency tests: does the flight agree with the model's command timing
//! and with its thrusts?
//!
//! Each is the score test of one extra parameter at the fitted mass properties, with the
//! noise model's whitening and the initial rates eliminated: chi-square with one degree of
//! freedom when the model is right.
//! - **Timing.** A command-to-thrust delay `L` the model leaves out moves the accumulated
//!   torque by `-L` times the torque being applied, so its rate signature is `J tau_k` (the
//!   sums carry `tau_k` as drive components 12-14). An unmodelled latency, a thrust rise (a
//!   delay of the openings) and other timing errors give a large statistic. (The force's part
//!   of the signature, `-J [dc]x f_k`, is left out: the CoM offset `dc` is millimetres against
//!   lever arms of decimetres.)
//! - **Thrust symmetry, per axis.** A uniform thrust error is exactly an inertia error on
//!   rates and no test can see it, but one weak or strong thruster scales the turns it drives
//!   one way and not the other: its signature is `J e_b` times the open thrusters' positive
//!   torques about axis `b`, accumulated (components 15-17; [`crate::craft::Craft::command`]).
//!   The three axes are tested at a third of the level each (Bonferroni). The reference tests each thruster's scale; the kernel cannot
//!   afford a drive component per thruster in the tick, and tests the symmetry it breaks.
//!
//! Either test over its threshold makes the estimate `inconsistent`, never `ok`.
use super::consider::{Consider, ThrustUncertainty, MAX_CONSIDERED};
use super::solve::{axis_forms, quad, ArNoise, AxisForms, SolveConfig, NP, NV};
use super::sums::{FlightSums, NZ, N_MODEL, SPLIT_TORQUE};
use crate::scalar::Scalar;

/// Chi-square(1) at which the timing test rejects: the 0.999 quantile (level 1e-3, the
/// reference's).
pub const REJECT_ABOVE: f32 = 10.828;

/// Chi-square(1) at which one axis' thrust-symmetry test rejects: the quantile at
/// `1 - 1e-3 / 3`, so that the three axes together reject a right model at 1e-3.
pub const SYMMETRY_REJECT_ABOVE: f32 = 12.873;

/// The status rule: true if the timing test or any axis' thrust-symmetry test rejects (the
/// estimate is then `inconsistent`; a test that could not be run rejects nothing).
pub fn rejects<S: Scalar>(timing: Option<S>, symmetry: &[Option<S>; 3]) -> bool {
    let over = |v: Option<S>, limit: f32| v.is_some_and(|v| S::from_f32(limit).lt(v));
    over(timing, REJECT_ABOVE) || symmetry.iter().any(|v| over(*v, SYMMETRY_REJECT_ABOVE))
}

/// Share of a direction's information that must remain after the fitted terms explain what
/// they can, for the direction to be tested (the reference's).
const MIN_RESIDUAL_SHARE: f32 = 1e-3;

/// Which extra parameter a score test is about.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Direction {
    /// A common command delay.
    Timing,
    /// A scale of the positive torque about axis `b` (0, 1, 2) relative to the negative.
    Symmetry(usize),
}

impl Direction {
    /// Axis `a`'s rate signature of the parameter, as coefficients of `(z, y)`, from the
    /// model's row `row` (its torque block is `J`'s row `a`).
    fn signature<S: Scalar>(self, row: &[S; NZ]) -> [S; NV] {
        let mut e = [S::ZERO; NV];
        match self {
            Direction::Timing => {
                for (c, coefficient) in row.iter().take(3).enumerate() {
                    if let Some(v) = e.get_mut(N_MODEL.saturating_add(c)) {
                        *v = *coefficient;
                    }
                }
            }
            // An axis past z has no direction (its statistic is then not computed).
            Direction::Symmetry(b) if b < 3 => {
                if let (Some(v), Some(coefficient)) =
                    (e.get_mut(SPLIT_TORQUE.saturating_add(b)), row.get(b))
                {
                    *v = *coefficient;
                }
            }
            Direction::Symmetry(_) => {}
        }
        e
    }
}

/// The score statistic of `direction`'s parameter at `theta`, fitted with covariance
/// `covariance` (before the consider widening), its variance allowing for the `considered`
/// quantities' errors (None if the direction is not distinguishable from the fitted terms,
/// or a value left the format).
#[allow(clippy::too_many_arguments)]
pub fn score_statistic<S: Scalar>(
    s: &FlightSums<S>,
    cfg: &SolveConfig<S>,
    theta: &[S; NP],
    noise: &[ArNoise<S>; 3],
    free: &[bool; NP],
    covariance: &[[S; NP]; NP],
    considered: (&Consider<S>, &ThrustUncertainty),
    direction: Direction,
) -> Option<S> {
    let (consider, thrust) = considered;
    let len = consider.len();
    // Per considered quantity, the direction's cross term with its signature.
    let mut cross = [S::ZERO; MAX_CONSIDERED];
    let mut score = S::ZERO;
    let mut info_ll = S::ZERO;
    let mut info_lt = [S::ZERO; NP];
    for (a, (used, nz)) in cfg.axes.iter().zip(noise).enumerate() {
        if !used {
            continue;
        }
        let AxisForms {
            wm,
            u,
            d,
            row,
            inv_sigma2: inv,
        } = axis_forms(s, cfg, theta, nz, a)?;
        let e = direction.signature(&row);
        for (k, c) in cross.iter_mut().enumerate().take(len) {
            let ek = consider.signature(k, &d, &row, thrust);
            *c = c.plus(inv.times(quad(&wm, &e, &ek)));
        }
        score = score.minus(inv.times(quad(&wm, &e, &u)));
        info_ll = info_ll.plus(inv.times(quad(&wm, &e, &e)));
        for (m, it) in info_lt.iter_mut().enumerate() {
            if free.get(m).copied().unwrap_or(false) {
                let dm = d.get(m).copied().unwrap_or([S::ZERO; NV]);
                *it = it.plus(inv.times(quad(&wm, &e, &dm)));
            }
        }
    }
    // Efficient information: what the fitted terms cannot explain of the direction.
    let mut explained = S::ZERO;
    for (m, row) in covariance.iter().enumerate() {
        for (n, c) in row.iter().enumerate() {
            let (lm, ln) = (
                info_lt.get(m).copied().unwrap_or(S::ZERO),
                info_lt.get(n).copied().unwrap_or(S::ZERO),
            );
            explained = explained.plus(lm.times(*c).times(ln));
        }
    }
    let efficient = info_ll.minus(explained);
    if !S::from_f32(MIN_RESIDUAL_SHARE).times(info_ll).lt(efficient) {
        return None;
    }
    // The considered errors move the score by `(c_k - l^T g_k)` each (what of the direction
    // the fitted terms do not absorb).
    let mut allowance = S::ZERO;
    for (k, ck) in cross.iter().enumerate().take(len) {
        let (variance, gain) = consider.term(k);
        let absorbed = info_lt
            .iter()
            .zip(&gain)
            .fold(S::ZERO, |acc, (l, g)| acc.mul_add(*l, *g));
        let moved = ck.minus(absorbed);
        allowance = allowance.plus(variance.times(moved).times(moved));
    }
    let stat = score.times(score).checked_div(efficient.plus(allowance))?;
    stat.is_valid().then_some(stat)
}

#[cfg(test)]
mod tests {
    #![allow(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::panic,
        clippy::indexing_slicing
    )]
    use super::*;

    /// Each direction puts the model row's torque coefficients on its own drive components
    /// and nowhere else; an axis past z has none.
    #[test]
    fn each_direction_reads_its_own_components() {
        let row: [f32; NZ] = core::array::from_fn(|i| i as f32 + 1.0);
        let timing = Direction::Timing.signature(&row);
        for (i, v) in timing.iter().enumerate() {
            let want = if (N_MODEL..N_MODEL + 3).contains(&i) {
                row[i - N_MODEL]
            } else {
                0.0
            };
            assert_eq!(*v, want, "timing, component {i}");
        }
        for b in 0..3 {
            let e = Direction::Symmetry(b).signature(&row);
            for (i, v) in e.iter().enumerate() {
                let want = if i == SPLIT_TORQUE + b { row[b] } else { 0.0 };
                assert_eq!(*v, want, "symmetry {b}, component {i}");
            }
        }
        assert!(Direction::Symmetry(3)
            .signature(&row)
            .iter()
            .all(|v| *v == 0.0));
    }

    #[test]
    fn the_status_rule_holds_each_test_to_its_level() {
        assert!(!rejects::<f32>(None, &[None; 3]));
        assert!(!rejects(Some(10.5f32), &[Some(12.5), None, Some(0.0)]));
        assert!(rejects(Some(11.0f32), &[None; 3]));
        assert!(rejects(None, &[None, None, Some(13.0f32)]));
    }
}
