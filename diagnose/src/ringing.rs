//! Gyro ringing: a decaying tone excited at every valve edge (seed ch. 3: 338 Hz,
//! App. A: seen at 11.45 Hz / 38.33 Hz when sampled at 50 / 100 Hz). Its phase relative
//! to the samples differs from edge to edge (the valve shock meets the tines at a random
//! point of their cycle), so it is not one coherent signal: it is detected and fitted as
//! a random-effects model. For each edge, the residual window after it (mean and slope
//! removed, so slow rigid-body error does not count) is projected on a decaying cosine
//! and sine; the projections' excess variance over the noise, by maximum likelihood over
//! the per-axis amplitude, gives a likelihood-ratio statistic for each (frequency, decay).
//! Scanning the apparent frequency finds the tone; alias folding lists the true
//! frequencies it could be; those the sampling cannot tell apart are settled by the
//! seed's tuning-fork value as the prior (and the evidence says so).

use nalgebra::{Matrix2, SymmetricEigen, Vector2};

use crate::alias;
use crate::series::Series;

/// Per-axis prewhitening filter (AR coefficients, innovation variance), see
/// [`crate::noise::NoiseModel::ar`]: the gyro noise is band-limited, so at 1 kHz it is
/// slightly coloured, and unwhitened it would look like excess low-frequency "tone"
/// variance in the post-edge windows.
pub type Whitening = [(Vec<f64>, f64); 3];

/// Highest true ringing frequency considered, Hz (the tone must reach the gyro output;
/// above ~600 Hz the Gyrochip's own response has rolled off).
pub const F_MAX_HZ: f64 = 600.0;
/// Length of the residual window after each edge, ms.
pub const WINDOW_MS: i64 = 150;

/// The fitted tone.
#[derive(Clone, Debug)]
pub struct RingingFit {
    pub freq_hz: f64,
    pub apparent_hz: f64,
    pub decay_ms: f64,
    /// Root-mean-square peak amplitude per axis, rad/s.
    pub amplitude: [f64; 3],
    pub freq_stderr: f64,
    pub decay_stderr: f64,
    /// Likelihood-ratio statistic (2 ln LR), comparable to a chi-square reduction.
    pub gain: f64,
    /// Other true frequencies that fit as well (within 10 of the best statistic).
    pub ambiguous: Vec<f64>,
    pub evidence: String,
    /// The coarse scan: statistic against apparent frequency (the report's spectrum).
    pub scan: Vec<(f64, f64)>,
}

/// Residual windows after each valve shock: (shock time ms, sample indices). A shock is
/// the actual valve motion, `latency` (open, close ms, from an accepted
/// `thruster_latency`) after the commanded edge.
pub fn edge_windows(series: &Series, latency: (f64, f64)) -> Vec<(f64, Vec<usize>)> {
    let edges: Vec<f64> = series
        .edges()
        .iter()
        .map(|&(t, old, new)| {
            t as f64
                + if new & !old != 0 {
                    latency.0
                } else {
                    latency.1
                }
        })
        .collect();
    let mut out = vec![];
    let mut i0 = 0usize;
    for (k, &e) in edges.iter().enumerate() {
        let end = edges
            .get(k + 1)
            .copied()
            .unwrap_or(f64::MAX)
            .min(e + WINDOW_MS as f64);
        while i0 < series.len() && (series.t_ms[i0] as f64) < e {
            i0 += 1;
        }
        let mut idx = vec![];
        let mut i = i0;
        while i < series.len() && (series.t_ms[i] as f64) < end {
            idx.push(i);
            i += 1;
        }
        if idx.len() >= 4 {
            out.push((e, idx));
        }
    }
    out
}

/// The edge windows as every tone reads them: per window and axis, the samples kept (a
/// sample, or one the whitening filter reaches back to, that is not a measurement on the
/// axis is left out), their times after the shock, and the residual prewhitened with
/// mean and slope removed. None of it depends on the tone, so a scan of a few hundred
/// (frequency, decay) pairs whitens and detrends the residual once.
struct Prepared<'w> {
    windows: Vec<PreparedWindow>,
    whitening: Option<&'w Whitening>,
}

struct PreparedWindow {
    /// First sample the window and its whitening reach, and each such sample's time after
    /// the shock, ms (where the tone's basis is evaluated).
    first: usize,
    times: Vec<f64>,
    axes: [Rows; 3],
}

/// One axis of a window: kept samples, their times (ms after the shock) less their mean,
/// the times' sum of squares, and the detrended whitened residual.
#[derive(Default)]
struct Rows {
    idx: Vec<usize>,
    t: Vec<f64>,
    stt: f64,
    r: Vec<f64>,
}

impl<'w> Prepared<'w> {
    fn new(
        series: &Series,
        r: &[[f64; 3]],
        windows: &[(f64, Vec<usize>)],
        wh: Option<&'w Whitening>,
    ) -> Prepared<'w> {
        // the longest whitening filter of the three axes: how far a window reaches back
        let reach_back = wh
            .map(|w| w.iter().map(|x| x.0.len()).max().unwrap_or(0))
            .unwrap_or(0);
        let windows = windows
            .iter()
            .map(|(te, idx)| {
                let first = idx
                    .iter()
                    .copied()
                    .min()
                    .unwrap_or(0)
                    .saturating_sub(reach_back);
                let last = idx.iter().copied().max().unwrap_or(0).max(first);
                let axes = std::array::from_fn(|a| {
                    let phi: &[f64] = wh.map(|w| w[a].0.as_slice()).unwrap_or(&[]);
                    let mut rows = Rows::default();
                    for &i in idx {
                        let reach = i.saturating_sub(phi.len());
                        if !(reach..=i).all(|j| series.valid[j][a]) {
                            continue;
                        }
                        let mut rv = r[i][a];
                        for (k, ph) in phi.iter().enumerate() {
                            let Some(j) = i.checked_sub(1 + k) else { break };
                            rv -= ph * r[j][a];
                        }
                        rows.idx.push(i);
                        rows.t.push(series.t_ms[i] as f64 - te);
                        rows.r.push(rv);
                    }
                    if rows.idx.len() >= 4 {
                        let n = rows.t.len() as f64;
                        let mt = rows.t.iter().sum::<f64>() / n;
                        rows.t.iter_mut().for_each(|t| *t -= mt);
                        rows.stt = rows.t.iter().map(|t| t * t).sum();
                        detrend(&rows.t, rows.stt, &mut rows.r);
                    }
                    rows
                });
                PreparedWindow {
                    first,
                    times: (first..=last).map(|j| series.t_ms[j] as f64 - te).collect(),
                    axes,
                }
            })
            .collect();
        Prepared {
            windows,
            whitening: wh,
        }
    }

    /// Per edge and axis, the 2x2 Gram matrix of the decaying cosine/sine and the
    /// residual's projection on them, both prewhitened (when the whitening is given) and
    /// with mean and slope removed within the window.
    fn projections(&self, f: f64, tau: f64) -> Vec<[(Matrix2<f64>, Vector2<f64>); 3]> {
        let w = 2.0 * std::f64::consts::PI * f * 1e-3;
        let basis = |dt: f64| -> (f64, f64) {
            if dt < 0.0 {
                return (0.0, 0.0);
            }
            let env = (-dt / tau).exp();
            let (s, c) = (w * dt).sin_cos();
            (env * c, env * s)
        };
        let mut cached: Vec<(f64, f64)> = vec![];
        let mut c: Vec<f64> = vec![];
        let mut sn: Vec<f64> = vec![];
        self.windows
            .iter()
            .map(|win| {
                // the basis at every sample the window and its whitening reach, computed
                // once for the three axes and every filter tap (the exp and sin/cos)
                cached.clear();
                cached.extend(win.times.iter().map(|&dt| basis(dt)));
                let at = |j: usize| {
                    cached
                        .get(j.wrapping_sub(win.first))
                        .copied()
                        .unwrap_or((0.0, 0.0))
                };
                std::array::from_fn(|a| {
                    let rows = &win.axes[a];
                    if rows.idx.len() < 4 {
                        return (Matrix2::zeros(), Vector2::zeros());
                    }
                    let phi: &[f64] = self.whitening.map(|w| w[a].0.as_slice()).unwrap_or(&[]);
                    c.clear();
                    sn.clear();
                    for &i in &rows.idx {
                        let (mut ci, mut si) = at(i);
                        for (k, ph) in phi.iter().enumerate() {
                            let Some(j) = i.checked_sub(1 + k) else { break };
                            let (cj, sj) = at(j);
                            ci -= ph * cj;
                            si -= ph * sj;
                        }
                        c.push(ci);
                        sn.push(si);
                    }
                    detrend(&rows.t, rows.stt, &mut c);
                    detrend(&rows.t, rows.stt, &mut sn);
                    let mut g = Matrix2::zeros();
                    let mut p = Vector2::zeros();
                    for ((ci, si), ri) in c.iter().zip(&sn).zip(&rows.r) {
                        let v = Vector2::new(*ci, *si);
                        g += v * v.transpose();
                        p += v * *ri;
                    }
                    (g, p)
                })
            })
            .collect()
    }
}

/// Removes mean and slope (against the centred times `t`, sum of squares `stt`) from `x`.
fn detrend(t: &[f64], stt: f64, x: &mut [f64]) {
    let n = x.len() as f64;
    let m = x.iter().sum::<f64>() / n;
    let b = if stt > 0.0 {
        t.iter()
            .zip(x.iter())
            .map(|(t, x)| t * (x - m))
            .sum::<f64>()
            / stt
    } else {
        0.0
    };
    for (x, t) in x.iter_mut().zip(t) {
        *x -= m + b * t;
    }
}

/// 2 ln LR for the per-axis coefficient variance, maximised over it; returns (stat, s).
fn lr_axis(proj: &[[(Matrix2<f64>, Vector2<f64>); 3]], axis: usize, sigma2: f64) -> (f64, f64) {
    // eigen-decompose each Gram matrix once: components independent with variance
    // sigma2 * l + s * l^2
    let comps: Vec<(f64, f64)> = proj
        .iter()
        .flat_map(|pa| {
            let (g, p) = &pa[axis];
            let e = SymmetricEigen::new(*g);
            let u = e.eigenvectors;
            let gp = u.transpose() * p;
            [(e.eigenvalues[0], gp[0]), (e.eigenvalues[1], gp[1])]
        })
        .filter(|(l, _)| *l > 1e-12)
        .collect();
    let ll = |s: f64| -> f64 {
        comps
            .iter()
            .map(|&(l, g)| {
                let v = sigma2 * l + s * l * l;
                -0.5 * (g * g / v + v.ln())
            })
            .sum()
    };
    let l0 = ll(0.0);
    let (a, b) = golden_max((sigma2 * 1e-4).ln(), (sigma2 * 1e5).ln(), 40, |x| {
        ll(x.exp())
    });
    let s = (0.5 * (a + b)).exp();
    let stat = 2.0 * (ll(s) - l0);
    if stat > 0.0 {
        (stat, s)
    } else {
        (0.0, 0.0)
    }
}

/// Golden-section search for the maximum of `f` on `[a, b]`: the bracket after `steps`
/// steps, each reusing one of the previous step's two evaluations (one new evaluation a
/// step, where evaluating both points afresh cost two).
fn golden_max(mut a: f64, mut b: f64, steps: usize, f: impl Fn(f64) -> f64) -> (f64, f64) {
    let g = 0.618_033_988_75;
    let mut x1 = b - g * (b - a);
    let mut x2 = a + g * (b - a);
    let (mut f1, mut f2) = (f(x1), f(x2));
    for _ in 0..steps {
        if f1 > f2 {
            b = x2;
            (x2, f2) = (x1, f1);
            x1 = b - g * (b - a);
            f1 = f(x1);
        } else {
            a = x1;
            (x1, f1) = (x2, f2);
            x2 = a + g * (b - a);
            f2 = f(x2);
        }
    }
    (a, b)
}

fn statistic(win: &Prepared, f: f64, tau: f64) -> (f64, [f64; 3]) {
    let Some(wh) = win.whitening else {
        return (0.0, [0.0; 3]);
    };
    let proj = win.projections(f, tau);
    let mut tot = 0.0;
    let mut s = [0.0; 3];
    for a in 0..3 {
        let (st, sa) = lr_axis(&proj, a, wh[a].1);
        tot += st;
        s[a] = sa;
    }
    (tot, s)
}

fn best_decay(win: &Prepared, f: f64, coarse: bool) -> (f64, f64) {
    let grid: &[f64] = if coarse {
        &[20.0]
    } else {
        &[3.0, 6.0, 12.0, 24.0, 48.0, 96.0]
    };
    let mut best = (f64::MIN, 8.0);
    for &tau in grid {
        let d = statistic(win, f, tau).0;
        if d > best.0 {
            best = (d, tau);
        }
    }
    if coarse {
        return best;
    }
    let (a, b) = golden_max((best.1 / 2.0f64).ln(), (best.1 * 2.0f64).ln(), 12, |x| {
        statistic(win, f, x.exp()).0
    });
    let tau = (0.5 * (a + b)).exp();
    let d = statistic(win, f, tau).0;
    if d > best.0 {
        (d, tau)
    } else {
        best
    }
}

/// Finds, folds and fits the ringing in residual `r` with the noise's prewhitening `wh`. None when there are no usable valve edges.
pub fn fit(
    series: &Series,
    r: &[[f64; 3]],
    wh: &Whitening,
    prior_hz: f64,
    latency: (f64, f64),
) -> Option<RingingFit> {
    let edges = edge_windows(series, latency);
    if edges.len() < 3 {
        return None;
    }
    let win = Prepared::new(series, r, &edges, Some(wh));
    let fs = series.sample_rate_hz;
    let nyq = fs / 2.0;
    // coarse scan of the apparent frequency
    let step = (nyq / 160.0).max(0.25);
    let mut scan = vec![];
    let mut f = 2.0;
    while f < nyq {
        scan.push((f, best_decay(&win, f, true).0));
        f += step;
    }
    let (f_app0, _) = scan
        .iter()
        .cloned()
        .fold((0.0, f64::MIN), |acc, x| if x.1 > acc.1 { x } else { acc });
    // refine the apparent frequency
    let mut f_app = f_app0;
    let mut best = best_decay(&win, f_app, true).0;
    let mut h = step / 2.0;
    for _ in 0..6 {
        for cand in [f_app - h, f_app + h] {
            if cand > 0.5 && cand < nyq {
                let d = best_decay(&win, cand, true).0;
                if d > best {
                    best = d;
                    f_app = cand;
                }
            }
        }
        h /= 2.0;
    }
    let f_max = F_MAX_HZ.max(nyq);
    let cands = alias::candidates(f_app, fs, f_max);
    let mut scored: Vec<(f64, f64, f64)> = cands
        .iter()
        .map(|&f| {
            let (d, tau) = best_decay(&win, f, false);
            (f, d, tau)
        })
        .collect();
    if scored.is_empty() {
        return None;
    }
    scored.sort_by(|a, b| b.1.total_cmp(&a.1));
    let top = scored[0].1;
    if !top.is_finite() {
        return None;
    }
    let close: Vec<(f64, f64, f64)> = scored
        .iter()
        .cloned()
        .filter(|s| s.1 > top - 10.0)
        .collect();
    let chosen = close
        .iter()
        .cloned()
        .min_by(|a, b| (a.0 - prior_hz).abs().total_cmp(&(b.0 - prior_hz).abs()))?;
    let mut ambiguous: Vec<f64> = close
        .iter()
        .map(|s| s.0)
        .filter(|&f| (f - chosen.0).abs() > 1e-6)
        .collect();
    ambiguous.sort_by(|a, b| a.total_cmp(b));
    let (f, gain, tau) = chosen;
    let (_, s) = statistic(&win, f, tau);
    // standard errors from the curvature of the statistic (a chi-square): var = 2 / d2
    let hf = 0.2;
    let d2f =
        (2.0 * gain - statistic(&win, f + hf, tau).0 - statistic(&win, f - hf, tau).0) / (hf * hf);
    let ht = 0.05 * tau;
    let d2t =
        (2.0 * gain - statistic(&win, f, tau + ht).0 - statistic(&win, f, tau - ht).0) / (ht * ht);
    let freq_stderr = if d2f > 0.0 {
        (2.0 / d2f).sqrt()
    } else {
        f64::INFINITY
    };
    let decay_stderr = if d2t > 0.0 {
        (2.0 / d2t).sqrt()
    } else {
        f64::INFINITY
    };
    let apparent_hz = alias::apparent(f, fs);
    let evidence = if ambiguous.is_empty() {
        format!("decaying {f:.1} Hz tone after {} valve edges with a random phase per edge; at {fs} Hz sampling it shows at {apparent_hz:.1} Hz and no other alias fits as well", edges.len())
    } else {
        let mut a: Vec<String> = ambiguous.iter().map(|x| format!("{x:.1}")).collect();
        a.truncate(10);
        format!(
            "decaying tone after {} valve edges with a random phase per edge, seen at {apparent_hz:.1} Hz at {fs} Hz sampling; \
             the true frequency is ambiguous among the aliases {} and {f:.1} Hz, which fit equally well: picked {f:.1} Hz by \
             the seed's prior (tuning-fork gyro ringing at ~{prior_hz:.0} Hz, App. A)",
            edges.len(),
            a.join(", ")
        )
    };
    Some(RingingFit {
        freq_hz: f,
        apparent_hz,
        decay_ms: tau,
        amplitude: s.map(|x| (2.0 * x).sqrt()),
        freq_stderr,
        decay_stderr,
        gain,
        ambiguous,
        evidence,
        scan,
    })
}

/// Removes the fitted ringing from a residual: per edge, the best linear predictor of the
/// tone's coefficients given the window (shrunk towards zero by the noise).
pub fn remove(
    series: &Series,
    r: &[[f64; 3]],
    wh: &Whitening,
    rf: &RingingFit,
    latency: (f64, f64),
) -> Vec<[f64; 3]> {
    let win = edge_windows(series, latency);
    let proj = Prepared::new(series, r, &win, None).projections(rf.freq_hz, rf.decay_ms);
    let mut out = r.to_vec();
    let w = 2.0 * std::f64::consts::PI * rf.freq_hz * 1e-3;
    for ((te, idx), pa) in win.iter().zip(proj.iter()) {
        for a in 0..3 {
            let (g, p) = &pa[a];
            let s = rf.amplitude[a].powi(2) / 2.0;
            // E[c | proj] = s (sigma2 I + s G)^-1 proj
            let m = Matrix2::identity() * wh[a].1 + g * s;
            let Some(inv) = m.try_inverse() else { continue };
            let c = inv * p * s;
            for &i in idx {
                let dt = series.t_ms[i] as f64 - te;
                let env = (-dt / rf.decay_ms).exp();
                let (sn, cs) = (w * dt).sin_cos();
                out[i][a] -= env * (c[0] * cs + c[1] * sn);
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The golden-section search brackets the maximum of a smooth peak within its
    /// contraction (0.618 per step), evaluating once a step. Planted: keeping the wrong
    /// point when the bracket shrinks loses the peak.
    #[test]
    fn the_golden_search_brackets_the_maximum_with_one_evaluation_a_step() {
        let calls = std::cell::Cell::new(0);
        let peak = |x: f64| {
            calls.set(calls.get() + 1);
            -(x - 0.3f64).powi(2)
        };
        let (a, b) = golden_max(-2.0, 5.0, 30, peak);
        assert!(a <= 0.3 && 0.3 <= b, "[{a}, {b}]");
        assert!(b - a < 7.0 * 0.6181f64.powi(30), "{}", b - a);
        assert_eq!(calls.get(), 32);
    }
}
