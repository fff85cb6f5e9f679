//! Noise statistics of the gyro residual. The gyro noise is white but band-limited
//! (seed Fig. 3.10: 300 Hz bandwidth), so at 1 kHz neighbouring samples are correlated
//! and a plain variance overstates how much information each sample carries about slow
//! model errors. We estimate the autocovariance from lagged differences inside coasting
//! stretches (no valve open, away from edges), where model error barely changes over a
//! few ms, and use the long-run variance (spectral density at low frequency) to scale
//! chi-square, BIC and standard errors.

use crate::series::Series;

/// Per-axis noise description.
#[derive(Clone, Debug, PartialEq)]
pub struct NoiseModel {
    /// Per-sample variance, (rad/s)^2.
    pub var: [f64; 3],
    /// Long-run variance gamma0 + 2 sum gamma_k, (rad/s)^2: the white-noise-equivalent
    /// variance for signals far below the noise bandwidth.
    pub long_run_var: [f64; 3],
    /// Lag-1 autocorrelation.
    pub rho1: [f64; 3],
    /// How many lagged samples entered the estimate.
    pub pairs: usize,
    /// Autocovariance at lags 0..=m per axis (lag 0 = `var`).
    pub acov: [Vec<f64>; 3],
}

impl NoiseModel {
    /// White noise of per-sample variance `var` (no correlation).
    pub fn white(var: [f64; 3]) -> NoiseModel {
        NoiseModel {
            var,
            long_run_var: var,
            rho1: [0.0; 3],
            pairs: 0,
            acov: var.map(|v| vec![v]),
        }
    }

    /// Prewhitening filter per axis: AR coefficients (order <= `order`, by Levinson-Durbin
    /// on the autocovariance) and the innovation variance.
    pub fn ar(&self, order: usize) -> [(Vec<f64>, f64); 3] {
        std::array::from_fn(|a| levinson(&self.acov[a], order))
    }
}

/// Levinson-Durbin: AR coefficients phi (x_t = sum phi_k x_{t-k} + e_t) and var(e).
fn levinson(g: &[f64], order: usize) -> (Vec<f64>, f64) {
    let p = order.min(g.len().saturating_sub(1));
    let mut phi: Vec<f64> = vec![];
    let mut err = g.first().copied().unwrap_or(0.0);
    for k in 1..=p {
        if err <= 0.0 {
            break;
        }
        let acc: f64 = g[k]
            - phi
                .iter()
                .enumerate()
                .map(|(j, c)| c * g[k - 1 - j])
                .sum::<f64>();
        let refl = (acc / err).clamp(-0.95, 0.95);
        let mut next = phi.clone();
        next.push(refl);
        for j in 0..phi.len() {
            next[j] = phi[j] - refl * phi[phi.len() - 1 - j];
        }
        phi = next;
        err *= 1.0 - refl * refl;
    }
    (phi, err.max(1e-30))
}

/// Samples that are in a coasting stretch: no valve commanded open from `guard_ms`
/// before the sample to the sample.
pub fn coasting_mask(series: &Series, guard_ms: i64) -> Vec<bool> {
    // last time (ms) any valve was open, per ms tick
    let mut last_open = vec![i64::MIN / 2; series.word_ms.len()];
    let mut lo = i64::MIN / 2;
    for (k, &w) in series.word_ms.iter().enumerate() {
        if w != 0 {
            lo = k as i64;
        }
        last_open[k] = lo;
    }
    series
        .t_ms
        .iter()
        .map(|&t| {
            let k = (t as usize).min(last_open.len() - 1);
            t - last_open[k] > guard_ms
        })
        .collect()
}

/// Estimates the noise from the residual `r` (measured minus predicted) in coasting
/// stretches. Falls back to all samples when coasting is too rare.
pub fn estimate(series: &Series, r: &[[f64; 3]]) -> NoiseModel {
    let dt = (1000.0 / series.sample_rate_hz).round().max(1.0) as i64;
    // lags up to ~12 ms, at least 3 samples
    let max_lag = ((12 / dt) as usize).max(3);
    let mut mask = coasting_mask(series, 60);
    if mask.iter().filter(|&&m| m).count() < 200 {
        mask = vec![true; series.len()];
    }
    // structure function D(L) = E[(x_{t+L} - x_t)^2] = 2 (g0 - gL), robustly by median
    let mut dl = vec![[0.0f64; 3]; max_lag + 2];
    let mut pairs = 0;
    for lag in 1..=max_lag + 1 {
        for a in 0..3 {
            let mut v: Vec<f64> = Vec::new();
            for i in 0..series.len().saturating_sub(lag) {
                let j = i + lag;
                if mask[i]
                    && mask[j]
                    && series.t_ms[j] - series.t_ms[i] == lag as i64 * dt
                    && series.valid[i][a]
                    && series.valid[j][a]
                {
                    v.push((r[j][a] - r[i][a]).powi(2));
                }
            }
            if a == 0 && lag == 1 {
                pairs = v.len();
            }
            dl[lag][a] = robust_mean_sq(&mut v);
        }
    }
    let mut var = [0.0; 3];
    let mut lr = [0.0; 3];
    let mut rho1 = [0.0; 3];
    let mut acov: [Vec<f64>; 3] = Default::default();
    for a in 0..3 {
        // gamma0 from the largest lags, where correlation has died out
        let g0 = 0.5 * (dl[max_lag][a] + dl[max_lag + 1][a]) / 2.0;
        let mut s = g0;
        for lag in 1..max_lag {
            let gk = g0 - dl[lag][a] / 2.0;
            s += 2.0 * gk;
        }
        var[a] = g0.max(1e-30);
        acov[a] = (0..max_lag)
            .map(|lag| {
                if lag == 0 {
                    var[a]
                } else {
                    g0 - dl[lag][a] / 2.0
                }
            })
            .collect();
        lr[a] = s.max(0.2 * g0).max(1e-30);
        rho1[a] = 1.0 - dl[1][a] / (2.0 * var[a]);
    }
    NoiseModel {
        var,
        long_run_var: lr,
        rho1,
        pairs,
        acov,
    }
}

/// Mean square with the largest 2 % trimmed and the trimmed tail compensated for a
/// chi-square(1) shape (so an isolated jump does not inflate the estimate).
fn robust_mean_sq(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(|a, b| a.total_cmp(b));
    // median of chi2(1) is 0.4549 times its mean
    let med = v[v.len() / 2];
    let mean: f64 = v.iter().sum::<f64>() / v.len() as f64;
    let from_median = med / 0.4549;
    // take the smaller unless the data are clearly not chi-square shaped (quantized)
    if from_median > 0.0 {
        mean.min(from_median * 1.2).max(from_median * 0.8)
    } else {
        mean
    }
}
