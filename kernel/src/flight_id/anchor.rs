//! Moving the sums' reference model mid-flight (re-anchoring), exactly.
//!
//! The sums hold each rate less the prediction of a reference model `A_r` (the model file's,
//! [`super::sums`]). Far from the flight's mass properties that residual is the drift
//! `(A - A_r) z`, hundreds or thousands of times the noise, and the fit's quadratic forms
//! cancel it down to the noise: f32 sums have nothing left (random planar craft 64018, spun to
//! 48.5 rad/s: the f32 kernel `ok` and 3.3 sigma off where its algorithm in f64 is within
//! 1.2; 73017, the model's Izz 12 % off: 1.5 sigma from it). The residual is linear in the
//! sample, `y' = y - D z` with `D = A_new - A_r`, so every sum moves to a new reference
//! exactly (`v' = T v`, each lagged moment `T L T^T`, each window's sum `T s`): what the old
//! reference rounded stays, but from then on the sums grow with the noise, not the drift.
//!
//! The caller re-anchors at a fit's estimate ([`super::FlightId::reanchor`]: background work,
//! as the fit is). The fixed kernel's exact sums do not round, and their integer scales are
//! derived for the model they were built for: they are not moved.

use super::components::NZ;
use super::sums::{FlightSums, LagMoments, LAGS};
use crate::scalar::Scalar;

/// `d . x` over the drive components.
fn dot<S: Scalar>(d: &[S; NZ], x: impl Fn(usize) -> S) -> S {
    d.iter()
        .enumerate()
        .fold(S::ZERO, |acc, (j, dj)| acc.mul_add(*dj, x(j)))
}

/// Entry `[l][a][i]` of a `zy` or `yz` block.
fn entry_mut<S>(m: &mut [[[S; NZ]; 3]; LAGS], l: usize, a: usize, i: usize) -> Option<&mut S> {
    m.get_mut(l)?.get_mut(a)?.get_mut(i)
}

/// `zz[l][i][j]` as a full matrix (lag 0 keeps its upper triangle only).
fn zz_at<S: Scalar>(m: &LagMoments<S>, l: usize, i: usize, j: usize) -> S {
    let (r, c) = if l == 0 { (i.min(j), i.max(j)) } else { (i, j) };
    m.zz.get(l)
        .and_then(|x| x.get(r))
        .and_then(|row| row.get(c))
        .copied()
        .unwrap_or(S::ZERO)
}

/// Moves the flight's folded sums to a reference `d` further on (`d` the new model matrix
/// less the old). Both factors of every moment move (in [`super::sums::LagForm::Differences`]
/// the second factor is a difference of samples, which moves the same way); the `z` blocks do
/// not change.
pub(crate) fn shift_sums<S: Scalar>(f: &mut FlightSums<S>, d: &[[S; NZ]; 3]) {
    let old = f.lag;
    for l in 0..LAGS {
        for (a, da) in d.iter().enumerate() {
            let at3 = |m: &[[[S; NZ]; 3]; LAGS], i: usize| {
                m.get(l)
                    .and_then(|x| x.get(a))
                    .and_then(|row| row.get(i))
                    .copied()
                    .unwrap_or(S::ZERO)
            };
            // Lag 0 keeps `zy` only (`yz` is its transpose).
            let yz = |i: usize| {
                if l == 0 {
                    at3(&old.zy, i)
                } else {
                    at3(&old.yz, i)
                }
            };
            // yy' = yy - d.zy - d.yz + d^T zz d
            let quad = (0..NZ).fold(S::ZERO, |acc, i| {
                acc.mul_add(get(da, i), dot(da, |j| zz_at(&old, l, i, j)))
            });
            if let Some(yy) = f.lag.yy.get_mut(l).and_then(|x| x.get_mut(a)) {
                *yy = yy
                    .minus(dot(da, |j| at3(&old.zy, j)))
                    .minus(dot(da, yz))
                    .plus(quad);
            }
            for i in 0..NZ {
                // zy'[i] = zy[i] - sum_j zz[i][j] d_j;  yz'[i] = yz[i] - sum_j d_j zz[j][i]
                if let Some(e) = entry_mut(&mut f.lag.zy, l, a, i) {
                    *e = e.minus(dot(da, |j| zz_at(&old, l, i, j)));
                }
                if l > 0 {
                    if let Some(e) = entry_mut(&mut f.lag.yz, l, a, i) {
                        *e = e.minus(dot(da, |j| zz_at(&old, l, j, i)));
                    }
                }
            }
        }
    }
    // The windows' terms: czz[i][j] = sum m_z[i] s_z[j], czy[a][i] = sum m_y[a] s_z[i]
    // (= sum s_z[i] s_y[a] / n, so it also stands for sum m_z[i] s_y[a]).
    let (czz, czy) = (f.czz, f.czy);
    let c_zz = |i: usize, j: usize| {
        czz.get(i)
            .and_then(|row| row.get(j))
            .copied()
            .unwrap_or(S::ZERO)
    };
    for (a, da) in d.iter().enumerate() {
        let czy_a = czy.get(a).copied().unwrap_or([S::ZERO; NZ]);
        let quad = (0..NZ).fold(S::ZERO, |acc, i| {
            acc.mul_add(get(da, i), dot(da, |j| c_zz(i, j)))
        });
        if let Some(c) = f.cyy.get_mut(a) {
            *c = c.minus(dot(da, |j| get(&czy_a, j)).mul_pow2(1)).plus(quad);
        }
        if let Some(row) = f.czy.get_mut(a) {
            for (i, e) in row.iter_mut().enumerate() {
                *e = e.minus(dot(da, |j| c_zz(j, i)));
            }
        }
    }
}

fn get<S: Scalar>(v: &[S], i: usize) -> S {
    v.get(i).copied().unwrap_or(S::ZERO)
}

#[cfg(test)]
mod tests {
    #![allow(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::indexing_slicing,
        clippy::arithmetic_side_effects
    )]
    use super::super::solve::NP;
    use super::super::sums::{entry_components, SumScalar, ENTRIES};
    use super::super::test_flights::{config, fly_planar, planar};
    use super::super::FlightId;
    use super::*;

    fn split(t: &[f64; NP]) -> ([f64; 6], [f64; 3]) {
        (
            core::array::from_fn(|m| t[m]),
            core::array::from_fn(|m| t[m + 6]),
        )
    }

    const J0: [f32; 6] = [10.0, 12.0, 14.0, 0.5, -0.3, 0.2];
    /// The new anchor: inverse inertia 10-15 % off, a CoM 2-5 cm off.
    const THETA1: [f64; NP] = [11.5, 10.6, 15.6, 0.2, -0.1, 0.6, 0.02, -0.05, 0.03];

    /// Pushes samples `from..to` of a flight of torque and force pulses on every axis, the
    /// rate a noisy rough integral of them.
    fn fly(id: &mut FlightId<f64>, from: u32, to: u32) {
        for k in from..to {
            let on = (k / 90) % 6;
            let sign = if (k / 540) % 2 == 0 { 1.0 } else { -1.0 };
            let wrench: [f64; 6] =
                core::array::from_fn(|i| if i as u32 == on { 0.02 * sign } else { 0.0 });
            let t = f64::from(k) * 1e-3;
            let rate = [
                0.3 + 0.2 * t + 1e-3 * (f64::from(k) * 0.7).sin(),
                -0.1 * t + 1e-3 * (f64::from(k) * 1.3).cos(),
                0.5 - 0.15 * t + 1e-3 * (f64::from(k) * 2.1).sin(),
            ];
            id.push(1e-3, rate, true, super::super::command_of_wrench(wrench));
        }
    }

    /// Every entry of `a`'s and `b`'s sums, each against the Cauchy-Schwarz scale of its two
    /// components in `b` (`sqrt(L0_ii L0_jj)`): the largest relative difference.
    fn largest_difference(a: &FlightSums<f64>, b: &FlightSums<f64>) -> f64 {
        let (mut a, mut b) = (*a, *b);
        let diag = |s: &FlightSums<f64>, c: usize| {
            if c < NZ {
                s.lag.zz[0][c][c]
            } else {
                s.lag.yy[0][c - NZ]
            }
        };
        let scale =
            |s: &FlightSums<f64>, i: usize, j: usize| (diag(s, i) * diag(s, j)).sqrt().max(1e-300);
        let mut worst = 0.0f64;
        for k in 0..ENTRIES {
            let (i, j) = entry_components(k).unwrap();
            let s = scale(&b, i, j);
            let (x, y) = (*a.lag.entry_mut(k).unwrap(), *b.lag.entry_mut(k).unwrap());
            worst = worst.max((x - y).abs() / s);
        }
        for i in 0..NZ {
            for j in 0..NZ {
                worst = worst.max((a.czz[i][j] - b.czz[i][j]).abs() / scale(&b, i, j));
            }
            for c in 0..3 {
                worst = worst.max((a.czy[c][i] - b.czy[c][i]).abs() / scale(&b, i, NZ + c));
            }
        }
        for c in 0..3 {
            worst = worst.max((a.cyy[c] - b.cyy[c]).abs() / scale(&b, NZ + c, NZ + c));
        }
        worst
    }

    /// A flight re-anchored mid-window (two closed windows' terms still waiting) ends with the
    /// sums of the same flight anchored at the new model from its start, to f64's rounding;
    /// the check fails on planted faults: no re-anchoring, and one that leaves the open
    /// window's sum and lag history where they were.
    #[test]
    fn re_anchoring_mid_flight_gives_the_sums_anchored_there_from_the_start() {
        let anchored_late = |plant_window: bool| {
            let mut id = FlightId::new(config::<f64>(J0)).unwrap();
            fly(&mut id, 0, 1420);
            assert!(id.pending.waiting() > 0 && !id.window.is_empty());
            let before = id.nominal;
            id.reanchor(&THETA1).unwrap();
            if plant_window {
                let back: [[f64; NZ]; 3] = core::array::from_fn(|a| {
                    core::array::from_fn(|j| before[a][j] - id.nominal[a][j])
                });
                id.window.shift(&back);
            }
            fly(&mut id, 1420, 3000);
            id.finish();
            id.sums_so_far()
        };
        let mut from_start = FlightId::new(config::<f64>(J0)).unwrap();
        from_start.reanchor(&THETA1).unwrap();
        fly(&mut from_start, 0, 3000);
        from_start.finish();
        let truth = from_start.sums_so_far();
        assert_eq!(truth.anchor, Some(split(&THETA1)));
        let late = anchored_late(false);
        assert_eq!(late.anchor, Some(split(&THETA1)));
        assert!(
            largest_difference(&late, &truth) < 1e-9,
            "{}",
            largest_difference(&late, &truth)
        );
        // Planted: never re-anchored; the open window left at the old model.
        let mut never = FlightId::new(config::<f64>(J0)).unwrap();
        fly(&mut never, 0, 3000);
        never.finish();
        assert!(largest_difference(&never.sums_so_far(), &truth) > 1e-3);
        let planted = largest_difference(&anchored_late(true), &truth);
        // (The window held 20 samples: 2e-5, against the check's 1e-9.)
        assert!(planted > 1e-7, "{planted}");
    }

    /// A fit mid-window includes the open window's initial-rate term: it is the fit of the
    /// same samples with the window closed (and differs from it one sample later).
    #[test]
    fn a_fit_mid_window_is_the_fit_with_the_window_closed() {
        let mut id = FlightId::new(config::<f64>(J0)).unwrap();
        fly(&mut id, 0, 1800);
        let open = id.sums_so_far();
        let mut closed = id;
        closed.finish();
        assert!(largest_difference(&open, &closed.sums_so_far()) < 1e-12);
        let mut later = id;
        fly(&mut later, 1800, 1801);
        later.finish();
        assert!(largest_difference(&open, &later.sums_so_far()) > 1e-6);
    }

    /// The fit of a flight far from its model (three nearly collinear thrusters, `n` samples
    /// in one window, AR(`phi`) rate noise from generator seed `seed`) in format `S`, the sums
    /// re-anchored at the fit after 1024 samples and each doubling (as `massid_kernel_host`
    /// does) or never: Izz and the CoM with their sigmas, or None if the fit failed.
    fn fit<S: SumScalar>(
        reanchor: bool,
        phi: f64,
        seed: u64,
        izz: f32,
        n: u32,
    ) -> Option<([f64; 3], [f64; 3])> {
        let mut id = FlightId::new(planar::<S>(izz)).unwrap();
        // Three nearly collinear thrusters.
        let thrusters = [
            ((0.0, 0.1), (1.0, 0.05), 3.0),
            ((0.0, -0.1), (1.0, -0.05), 3.0),
            ((0.0, 0.12), (-1.0, 0.02), 0.3),
        ];
        let mut next = 1024u32;
        fly_planar(&mut id, &thrusters, n, (phi, seed), |id, k| {
            if reanchor && k + 1 == next {
                next *= 2;
                let fit = id.solve().unwrap();
                id.reanchor(&fit.theta).unwrap();
            }
        });
        id.finish();
        let fit = id.solve().ok()?;
        let terms = [2, 6, 7];
        Some((
            terms.map(|m| f64::from(fit.theta[m].to_f32())),
            terms.map(|m| f64::from(fit.covariance[m][m].to_f32()).sqrt()),
        ))
    }

    /// f32's largest distance from the same algorithm in f64, in f64's sigmas (None: f32's
    /// fit failed).
    fn f32_gap(reanchor: bool, phi: f64, seed: u64, izz: f32, n: u32) -> Option<f64> {
        let (f64_, sigma) = fit::<f64>(false, phi, seed, izz, n).unwrap();
        let (f32_, _) = fit::<f32>(reanchor, phi, seed, izz, n)?;
        Some(
            (0..3)
                .map(|m| ((f32_[m] - f64_[m]) / sigma[m]).abs())
                .fold(0.0, f64::max),
        )
    }

    /// Re-anchored, f32 stays at its algorithm in f64 far from the model (measured: at most
    /// 0.005 sigma in white noise, 0.02 in AR(0.9)); planted, never re-anchored: the fit does not
    /// converge or ends 3.5-7.6 sigma away, as random planar craft 64018 and 73017 were `ok`
    /// 3.3 and 1.5 sigma off. (Model Izz 25 % low, or 15 % low over 40,000 samples; milder
    /// cases leave f32 0.04-0.8 sigma off, seed by seed.)
    #[test]
    fn re_anchoring_keeps_f32_at_its_algorithm_far_from_the_model() {
        let white = (1..=4).map(|seed| (0.0, seed, 0.075, 20_000));
        let coloured = [(0.9, 1, 0.085, 40_000), (0.9, 6, 0.085, 40_000)];
        for (phi, seed, izz, n) in white.chain(coloured) {
            let re_anchored = f32_gap(true, phi, seed, izz, n);
            assert!(
                re_anchored.is_some_and(|g| g < 0.05),
                "{phi} {seed}: {re_anchored:?}"
            );
            let never = f32_gap(false, phi, seed, izz, n);
            assert!(never.is_none_or(|g| g > 1.0), "{phi} {seed}: {never:?}");
        }
    }
}
