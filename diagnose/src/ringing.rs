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

/// Per edge and axis, the 2x2 Gram matrix of the decaying cosine/sine and the residual's
/// projection on them, after prewhitening with `wh` (when given) and removing mean and
/// slope within the window.
fn projections(
    series: &Series,
    r: &[[f64; 3]],
    windows: &[(f64, Vec<usize>)],
    f: f64,
    tau: f64,
    wh: Option<&Whitening>,
) -> Vec<[(Matrix2<f64>, Vector2<f64>); 3]> {
    let w = 2.0 * std::f64::consts::PI * f * 1e-3;
    let basis = |dt: f64| -> (f64, f64) {
        if dt < 0.0 {
            return (0.0, 0.0);
        }
        let env = (-dt / tau).exp();
        let (s, c) = (w * dt).sin_cos();
        (env * c, env * s)
    };
    // the longest whitening filter of the three axes: how far a window reaches back
    let reach_back = wh
        .map(|w| w.iter().map(|x| x.0.len()).max().unwrap_or(0))
        .unwrap_or(0);
    windows
        .iter()
        .map(|(te, idx)| {
            // the basis at every sample the window and its whitening reach, computed once
            // for the three axes and every filter tap (the exp and sin/cos are most of a scan)
            let first = idx
                .iter()
                .copied()
                .min()
                .unwrap_or(0)
                .saturating_sub(reach_back);
            let last = idx.iter().copied().max().unwrap_or(0);
            let cached: Vec<(f64, f64)> = (first..=last.max(first))
                .map(|j| basis(series.t_ms[j] as f64 - te))
                .collect();
            let at = |j: usize| {
                cached
                    .get(j.wrapping_sub(first))
                    .copied()
                    .unwrap_or((0.0, 0.0))
            };
            std::array::from_fn(|a| {
                let phi: &[f64] = wh.map(|w| w[a].0.as_slice()).unwrap_or(&[]);
                let n = idx.len();
                let mut rows: Vec<[f64; 4]> = Vec::with_capacity(n); // t, c, s, r
                for &i in idx {
                    // a sample (or one the whitening filter reaches back to) that is not a
                    // measurement on this axis is left out of the window
                    let reach = i.saturating_sub(phi.len());
                    if !(reach..=i).all(|j| series.valid[j][a]) {
                        continue;
                    }
                    let dt = series.t_ms[i] as f64 - te;
                    let (mut c, mut sn) = at(i);
                    let mut rv = r[i][a];
                    for (k, ph) in phi.iter().enumerate() {
                        let j = i as i64 - 1 - k as i64;
                        if j < 0 {
                            break;
                        }
                        let j = j as usize;
                        let (cj, sj) = at(j);
                        c -= ph * cj;
                        sn -= ph * sj;
                        rv -= ph * r[j][a];
                    }
                    rows.push([dt, c, sn, rv]);
                }
                let nt = rows.len() as f64;
                if rows.len() < 4 {
                    return (Matrix2::zeros(), Vector2::zeros());
                }
                let mt = rows.iter().map(|x| x[0]).sum::<f64>() / nt;
                let stt: f64 = rows.iter().map(|x| (x[0] - mt).powi(2)).sum();
                for col in 1..4 {
                    let m = rows.iter().map(|x| x[col]).sum::<f64>() / nt;
                    let b = if stt > 0.0 {
                        rows.iter().map(|x| (x[0] - mt) * (x[col] - m)).sum::<f64>() / stt
                    } else {
                        0.0
                    };
                    for x in rows.iter_mut() {
                        x[col] -= m + b * (x[0] - mt);
                    }
                }
                let mut g = Matrix2::zeros();
                let mut p = Vector2::zeros();
                for x in &rows {
                    let v = Vector2::new(x[1], x[2]);
                    g += v * v.transpose();
                    p += v * x[3];
                }
                (g, p)
            })
        })
        .collect()
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
    // golden-section search over log s
    let (mut a, mut b) = ((sigma2 * 1e-4).ln(), (sigma2 * 1e5).ln());
    let gr = 0.618_033_988_75;
    for _ in 0..40 {
        let x1 = b - gr * (b - a);
        let x2 = a + gr * (b - a);
        if ll(x1.exp()) > ll(x2.exp()) {
            b = x2;
        } else {
            a = x1;
        }
    }
    let s = (0.5 * (a + b)).exp();
    let stat = 2.0 * (ll(s) - l0);
    if stat > 0.0 {
        (stat, s)
    } else {
        (0.0, 0.0)
    }
}

fn statistic(
    series: &Series,
    r: &[[f64; 3]],
    win: &[(f64, Vec<usize>)],
    wh: &Whitening,
    f: f64,
    tau: f64,
) -> (f64, [f64; 3]) {
    let proj = projections(series, r, win, f, tau, Some(wh));
    let mut tot = 0.0;
    let mut s = [0.0; 3];
    for a in 0..3 {
        let (st, sa) = lr_axis(&proj, a, wh[a].1);
        tot += st;
        s[a] = sa;
    }
    (tot, s)
}

fn best_decay(
    series: &Series,
    r: &[[f64; 3]],
    win: &[(f64, Vec<usize>)],
    wh: &Whitening,
    f: f64,
    coarse: bool,
) -> (f64, f64) {
    let grid: &[f64] = if coarse {
        &[20.0]
    } else {
        &[3.0, 6.0, 12.0, 24.0, 48.0, 96.0]
    };
    let mut best = (f64::MIN, 8.0);
    for &tau in grid {
        let d = statistic(series, r, win, wh, f, tau).0;
        if d > best.0 {
            best = (d, tau);
        }
    }
    if coarse {
        return best;
    }
    let (mut a, mut b) = ((best.1 / 2.0f64).ln(), (best.1 * 2.0f64).ln());
    let g = 0.618_033_988_75;
    for _ in 0..12 {
        let x1 = b - g * (b - a);
        let x2 = a + g * (b - a);
        if statistic(series, r, win, wh, f, x1.exp()).0
            > statistic(series, r, win, wh, f, x2.exp()).0
        {
            b = x2;
        } else {
            a = x1;
        }
    }
    let tau = (0.5 * (a + b)).exp();
    let d = statistic(series, r, win, wh, f, tau).0;
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
    let win = edge_windows(series, latency);
    if win.len() < 3 {
        return None;
    }
    let fs = series.sample_rate_hz;
    let nyq = fs / 2.0;
    // coarse scan of the apparent frequency
    let step = (nyq / 160.0).max(0.25);
    let mut scan = vec![];
    let mut f = 2.0;
    while f < nyq {
        scan.push((f, best_decay(series, r, &win, wh, f, true).0));
        f += step;
    }
    let (f_app0, _) = scan
        .iter()
        .cloned()
        .fold((0.0, f64::MIN), |acc, x| if x.1 > acc.1 { x } else { acc });
    // refine the apparent frequency
    let mut f_app = f_app0;
    let mut best = best_decay(series, r, &win, wh, f_app, true).0;
    let mut h = step / 2.0;
    for _ in 0..6 {
        for cand in [f_app - h, f_app + h] {
            if cand > 0.5 && cand < nyq {
                let d = best_decay(series, r, &win, wh, cand, true).0;
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
            let (d, tau) = best_decay(series, r, &win, wh, f, false);
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
    let (_, s) = statistic(series, r, &win, wh, f, tau);
    // standard errors from the curvature of the statistic (a chi-square): var = 2 / d2
    let hf = 0.2;
    let d2f = (2.0 * gain
        - statistic(series, r, &win, wh, f + hf, tau).0
        - statistic(series, r, &win, wh, f - hf, tau).0)
        / (hf * hf);
    let ht = 0.05 * tau;
    let d2t = (2.0 * gain
        - statistic(series, r, &win, wh, f, tau + ht).0
        - statistic(series, r, &win, wh, f, tau - ht).0)
        / (ht * ht);
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
        format!("decaying {f:.1} Hz tone after {} valve edges with a random phase per edge; at {fs} Hz sampling it shows at {apparent_hz:.1} Hz and no other alias fits as well", win.len())
    } else {
        let mut a: Vec<String> = ambiguous.iter().map(|x| format!("{x:.1}")).collect();
        a.truncate(10);
        format!(
            "decaying tone after {} valve edges with a random phase per edge, seen at {apparent_hz:.1} Hz at {fs} Hz sampling; \
             the true frequency is ambiguous among the aliases {} and {f:.1} Hz, which fit equally well: picked {f:.1} Hz by \
             the seed's prior (tuning-fork gyro ringing at ~{prior_hz:.0} Hz, App. A)",
            win.len(),
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
    let proj = projections(series, r, &win, rf.freq_hz, rf.decay_ms, None);
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
