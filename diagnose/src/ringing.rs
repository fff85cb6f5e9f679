//! Gyro ringing: a decaying tone excited at every valve edge (seed ch. 3: 338 Hz,
//! App. A: seen at 11.45 Hz / 38.33 Hz when sampled at 50 / 100 Hz). It is additive on
//! the gyro output, so it is fitted on the residual of the rigid-body model: the
//! spectrum of post-edge windows gives the apparent frequency, alias folding lists the
//! true frequencies it could be, and a decaying-sinusoid regression at each candidate
//! (amplitudes linear, decay on a grid) scores them. When the sampling makes candidates
//! indistinguishable, the seed's tuning-fork value is the prior that picks one.

use nalgebra::{Matrix2, Vector2};

use crate::alias;
use crate::model::ringing_basis;
use crate::series::Series;
use crate::spectrum;

/// Highest true ringing frequency considered, Hz (the tone must reach the gyro output;
/// above ~600 Hz the Gyrochip's own response has rolled off).
pub const F_MAX_HZ: f64 = 600.0;

/// The fitted tone.
#[derive(Clone, Debug)]
pub struct RingingFit {
    pub freq_hz: f64,
    pub apparent_hz: f64,
    pub decay_ms: f64,
    pub amp: [[f64; 2]; 3],
    pub freq_stderr: f64,
    pub decay_stderr: f64,
    /// Chi-square reduction of the regression.
    pub delta_chi2: f64,
    /// Other true frequencies that fit as well (within 10 chi-square).
    pub ambiguous: Vec<f64>,
    pub evidence: String,
    /// Post-edge spectrum (frequency, power) used to find the apparent tone.
    pub spectrum: Vec<(f64, f64)>,
}

/// Post-edge residual spectrum over (1 Hz, fs/2], summed over axes.
pub fn post_edge_spectrum(series: &Series, r: &[[f64; 3]], window_ms: i64) -> Vec<(f64, f64)> {
    let edges = series.edges();
    let mut t = vec![];
    let mut y: [Vec<f64>; 3] = [vec![], vec![], vec![]];
    let mut e = 0usize;
    for (i, &ts) in series.t_ms.iter().enumerate() {
        while e + 1 < edges.len() && edges[e + 1].0 <= ts {
            e += 1;
        }
        if !edges.is_empty() && edges[e].0 <= ts && ts - edges[e].0 < window_ms {
            t.push(ts as f64 * 1e-3);
            for a in 0..3 {
                y[a].push(r[i][a]);
            }
        }
    }
    let nyq = series.sample_rate_hz / 2.0;
    let n = ((nyq - 1.0) / 0.5).ceil().max(2.0) as usize;
    let freqs = spectrum::grid(1.0, nyq * 0.999, n);
    let mut total = vec![0.0; freqs.len()];
    for a in 0..3 {
        let p = spectrum::lomb_scargle(&t, &y[a], &freqs);
        for (tt, pp) in total.iter_mut().zip(p) {
            *tt += pp;
        }
    }
    freqs.into_iter().zip(total).collect()
}

/// Chi-square reduction and amplitudes of the best decaying-sinusoid regression at
/// (`f`, `tau_ms`), with per-axis weights `w` (1/sigma).
fn regress(series: &Series, r: &[[f64; 3]], w: &[f64; 3], f: f64, tau_ms: f64) -> (f64, [[f64; 2]; 3]) {
    let b = ringing_basis(series, f, tau_ms);
    let mut btb = Matrix2::zeros();
    let mut btr = [Vector2::zeros(); 3];
    for (i, bb) in b.iter().enumerate() {
        if bb[0] == 0.0 && bb[1] == 0.0 {
            continue;
        }
        let v = Vector2::new(bb[0], bb[1]);
        btb += v * v.transpose();
        for a in 0..3 {
            if series.valid[i][a] {
                btr[a] += v * r[i][a];
            }
        }
    }
    let Some(inv) = btb.try_inverse() else { return (0.0, [[0.0; 2]; 3]) };
    let mut d = 0.0;
    let mut amp = [[0.0; 2]; 3];
    for a in 0..3 {
        let c = inv * btr[a];
        amp[a] = [c[0], c[1]];
        d += (btr[a].dot(&c)) * w[a] * w[a];
    }
    (d, amp)
}

/// Best decay for frequency `f` by a coarse grid then golden-section refinement.
fn best_decay(series: &Series, r: &[[f64; 3]], w: &[f64; 3], f: f64) -> (f64, f64) {
    let grid = [2.0, 4.0, 8.0, 16.0, 32.0, 64.0, 128.0];
    let mut best = (f64::MIN, 8.0);
    for &tau in &grid {
        let (d, _) = regress(series, r, w, f, tau);
        if d > best.0 {
            best = (d, tau);
        }
    }
    // golden section on log tau within one grid step
    let (mut a, mut b) = ((best.1 / 2.0f64).ln(), (best.1 * 2.0f64).ln());
    let g = 0.618_033_988_75;
    for _ in 0..14 {
        let x1 = b - g * (b - a);
        let x2 = a + g * (b - a);
        let d1 = regress(series, r, w, f, x1.exp()).0;
        let d2 = regress(series, r, w, f, x2.exp()).0;
        if d1 > d2 {
            b = x2;
        } else {
            a = x1;
        }
    }
    let tau = (0.5 * (a + b)).exp();
    let d = regress(series, r, w, f, tau).0;
    if d > best.0 { (d, tau) } else { best }
}

/// Finds, folds and fits the ringing in residual `r`. `w` are per-axis weights 1/sigma for
/// high-frequency content. None when there are no valve edges.
pub fn fit(series: &Series, r: &[[f64; 3]], w: &[f64; 3], prior_hz: f64) -> Option<RingingFit> {
    if series.edges().is_empty() {
        return None;
    }
    let fs = series.sample_rate_hz;
    let spec = post_edge_spectrum(series, r, 100);
    // the apparent tone: strongest post-edge peak above 2 Hz (slower content is rigid-body
    // model error, which the other mechanisms explain)
    let (f_app, _) = spec
        .iter()
        .filter(|(f, _)| *f > 2.0)
        .fold((0.0, f64::MIN), |acc, &(f, p)| if p > acc.1 { (f, p) } else { acc });
    let f_max = F_MAX_HZ.max(fs / 2.0);
    let cands = alias::candidates(f_app, fs, f_max);
    let mut scored: Vec<(f64, f64, f64)> = vec![]; // (f, delta chi2, tau)
    for &f in &cands {
        // refine f locally (the spectrum grid is 0.5 Hz)
        let mut best = (f64::MIN, f, 8.0);
        for df in [-0.5, -0.25, 0.0, 0.25, 0.5] {
            let (d, tau) = best_decay(series, r, w, f + df);
            if d > best.0 {
                best = (d, f + df, tau);
            }
        }
        scored.push((best.1, best.0, best.2));
    }
    if scored.is_empty() {
        return None;
    }
    let top = scored.iter().map(|s| s.1).fold(f64::MIN, f64::max);
    let close: Vec<&(f64, f64, f64)> = scored.iter().filter(|s| s.1 > top - 10.0).collect();
    let chosen = **close
        .iter()
        .min_by(|a, b| (a.0 - prior_hz).abs().partial_cmp(&(b.0 - prior_hz).abs()).unwrap())
        .unwrap();
    let ambiguous: Vec<f64> = close.iter().map(|s| s.0).filter(|&f| (f - chosen.0).abs() > 1.0).collect();
    // fine frequency search around the chosen candidate
    let mut bestf = chosen;
    let mut step = 0.1;
    for _ in 0..2 {
        let c = bestf.0;
        for k in -4..=4 {
            let f = c + k as f64 * step;
            let d = regress(series, r, w, f, bestf.2).0;
            if d > bestf.1 {
                bestf = (f, d, bestf.2);
            }
        }
        step /= 4.0;
    }
    let (d, tau) = best_decay(series, r, w, bestf.0);
    let f = bestf.0;
    let (d, amp) = if d >= bestf.1 { (d, regress(series, r, w, f, tau).1) } else { (bestf.1, regress(series, r, w, f, bestf.2).1) };
    // curvature of chi-square in f and log tau gives standard errors: var = 2 / d2chi2
    let hf = 0.05;
    let df2 = (2.0 * d - regress(series, r, w, f + hf, tau).0 - regress(series, r, w, f - hf, tau).0) / (hf * hf);
    let ht = 0.02 * tau;
    let dt2 = (2.0 * d - regress(series, r, w, f, tau + ht).0 - regress(series, r, w, f, tau - ht).0) / (ht * ht);
    let freq_stderr = if df2 > 0.0 { (2.0 / df2).sqrt() } else { f64::INFINITY };
    let decay_stderr = if dt2 > 0.0 { (2.0 / dt2).sqrt() } else { f64::INFINITY };
    let apparent_hz = alias::apparent(f, fs);
    let evidence = if ambiguous.is_empty() {
        format!(
            "decaying {:.1} Hz tone after valve edges (post-edge spectrum peak at {:.1} Hz at {} Hz sampling); \
             no other alias fits as well",
            f, apparent_hz, fs
        )
    } else {
        let mut a: Vec<String> = ambiguous.iter().map(|x| format!("{x:.1}")).collect();
        a.truncate(8);
        format!(
            "decaying tone after valve edges, seen at {:.1} Hz at {} Hz sampling; the true frequency is \
             ambiguous among the aliases {} Hz and {:.1} Hz: picked by the seed's prior (tuning-fork gyro \
             ringing at ~{:.0} Hz, App. A)",
            apparent_hz,
            fs,
            a.join(", "),
            f,
            prior_hz
        )
    };
    Some(RingingFit {
        freq_hz: f,
        apparent_hz,
        decay_ms: tau,
        amp,
        freq_stderr,
        decay_stderr,
        delta_chi2: d,
        ambiguous,
        evidence,
        spectrum: spec,
    })
}
