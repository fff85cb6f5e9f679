//! The onboard consistency test: does the flight agree with the model's command timing?
//!
//! A command-to-thrust delay `L` the model leaves out moves the accumulated drive by `-L`
//! times the wrench being applied, so its rate signature is `A_(torque, force) w_k` (the sums
//! carry `w_k` as drive components 12-17). The score test of `L = 0` at the fitted mass
//! properties, with the noise model's whitening and the initial rates eliminated, is
//! chi-square with one degree of freedom when the model is right. An unmodelled latency, a
//! thrust rise (a delay of the openings) and other timing errors give a large statistic, and
//! the estimate is then `inconsistent`, never `ok`. (The reference tests per-thruster thrust
//! scales too; the kernel does not: see `kernel/README.md`.)
use super::solve::{
    ar_weights, model_matrix, quad, residual_and_jacobian, weighted, ArNoise, SolveConfig, NP, NV,
};
use super::sums::{FlightSums, NZ, N_MODEL};
use crate::scalar::Scalar;

/// Chi-square(1) at which the test rejects: the 0.999 quantile (level 1e-3, the reference's).
pub const REJECT_ABOVE: f32 = 10.828;

/// Share of the timing direction's information that must remain after the fitted terms
/// explain what they can, for the direction to be tested (the reference's).
const MIN_RESIDUAL_SHARE: f32 = 1e-3;

/// The score statistic of a common command delay at `theta` (None if the direction is not
/// distinguishable from the fitted terms, or a value left the format).
pub fn timing_statistic<S: Scalar>(
    s: &FlightSums<S>,
    cfg: &SolveConfig<S>,
    theta: &[S; NP],
    noise: &[ArNoise<S>; 3],
    free: &[bool; NP],
    covariance: &[[S; NP]; NP],
) -> Option<S> {
    let mut score = S::ZERO;
    let mut info_ll = S::ZERO;
    let mut info_lt = [S::ZERO; NP];
    for (a, (used, nz)) in cfg.axes.iter().zip(noise).enumerate() {
        if !used {
            continue;
        }
        let (w, c2) = ar_weights(&nz.phi);
        let wm = weighted(s, a, &w, c2);
        let (u, d) = residual_and_jacobian(theta, cfg, a)?;
        // d residual / d L: the model's torque-and-force row at the held-wrench components.
        let (j6, dc) = theta.split_at(6);
        let model = model_matrix(j6, dc, cfg.gyroscopic)?;
        let row = model.get(a).copied().unwrap_or([S::ZERO; NZ]);
        let mut e = [S::ZERO; NV];
        for (c, coefficient) in row.iter().take(6).enumerate() {
            if let Some(v) = e.get_mut(N_MODEL.saturating_add(c)) {
                *v = *coefficient;
            }
        }
        let inv = S::ONE.checked_div(nz.sigma2)?;
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
    let stat = score.times(score).checked_div(efficient)?;
    stat.is_valid().then_some(stat)
}
