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
use super::sums::{FlightSums, LagMoments, Sample, LAGS};
use crate::scalar::Scalar;

/// `d . x` over the drive components.
fn dot<S: Scalar>(d: &[S; NZ], x: impl Fn(usize) -> S) -> S {
    d.iter()
        .enumerate()
        .fold(S::ZERO, |acc, (j, dj)| acc.mul_add(*dj, x(j)))
}

/// The sample relative to a reference `d` further on: `y_a - d_a . z`.
pub(crate) fn shifted<S: Scalar>(s: &Sample<S>, d: &[[S; NZ]; 3]) -> Sample<S> {
    let mut out = *s;
    for (y, da) in out.y.iter_mut().zip(d) {
        *y = y.minus(dot(da, |j| s.z.get(j).copied().unwrap_or(S::ZERO)));
    }
    out
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
                if let Some(e) = f
                    .lag
                    .zy
                    .get_mut(l)
                    .and_then(|x| x.get_mut(a))
                    .and_then(|r| r.get_mut(i))
                {
                    *e = e.minus(dot(da, |j| zz_at(&old, l, i, j)));
                }
                if l > 0 {
                    if let Some(e) = f
                        .lag
                        .yz
                        .get_mut(l)
                        .and_then(|x| x.get_mut(a))
                        .and_then(|r| r.get_mut(i))
                    {
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
