//! The rate sensor's noise model: an autoregressive process per axis, fitted to the fit's own
//! residuals, order chosen by BIC. It covers the noise the identification meets: white gyro
//! noise (order 0), band-limited gyro noise (order 1), rates differenced from motion-capture
//! attitude (a moving average with a near-unit root, which a few AR terms approximate), and
//! slowly wandering residuals (unmodelled impulses, a disturbance: a root near 1).
//! Whitening the data and the model by `A(q)` makes the least squares the Gaussian maximum
//! likelihood (prediction-error) fit, which is what keeps it efficient on coloured noise and
//! consistent in closed loop, where the commands depend on earlier noise.
use nalgebra::{DMatrix, DVector};

/// ARMA(p, 1): `v_k = sum_i phi_i v_k-i + e_k + ma e_k-1`, `var(e) = sigma2`. The moving
/// average term is what rates differenced from a noisy attitude need (`ma` near -1: white
/// attitude noise differenced, plus a little white rate noise); the AR terms cover band-limited
/// gyros and slowly wandering residuals.
#[derive(Clone, Debug, PartialEq)]
pub struct ArNoise {
    pub phi: Vec<f64>,
    /// Innovation variance, (rad/s)^2.
    pub sigma2: f64,
    /// The moving-average coefficient, in (-1, 1).
    pub ma: f64,
    /// The moving average's lag: 1 for attitude differenced over one sample, 2 for a central
    /// difference (`v_k = ... + e_k + ma e_k-2`).
    pub ma_lag: usize,
}

/// The moving average's lags tried: attitude differenced over one sample or over two (a
/// central difference, whose noise a lag-1 term with AR terms whitened only in part: on
/// central-differenced 25-50 Hz motion capture the sigmas were 1.3-1.5x optimistic).
pub const MA_LAGS: [usize; 2] = [1, 2];

/// Median stretch length, samples, below which no moving-average term is fitted.
pub const MIN_MA_STRETCH: usize = 200;

/// Moving-average coefficients tried (a grid: the likelihood is smooth in it and the fit only
/// needs it to a few per cent).
pub const MA_GRID: [f64; 23] = [
    -0.98, -0.95, -0.9, -0.85, -0.8, -0.7, -0.6, -0.5, -0.4, -0.3, -0.2, -0.1, 0.0, 0.1, 0.2, 0.3,
    0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 0.95,
];

impl ArNoise {
    /// White noise of variance `sigma2`.
    pub fn white(sigma2: f64) -> Self {
        ArNoise {
            phi: Vec::new(),
            sigma2,
            ma: 0.0,
            ma_lag: 1,
        }
    }

    pub fn order(&self) -> usize {
        self.phi.len()
    }

    /// Variance of the rate noise itself (not the innovation), from its impulse response.
    pub fn process_variance(&self) -> f64 {
        let p = self.order();
        let mut h = vec![0.0; 2000];
        h[0] = 1.0;
        for k in 1..h.len() {
            h[k] = (1..=p.min(k)).map(|i| self.phi[i - 1] * h[k - i]).sum();
        }
        let lag = self.ma_lag.max(1);
        for k in (lag..h.len()).rev() {
            h[k] += self.ma * h[k - lag];
        }
        self.sigma2 * h.iter().map(|x| x * x).sum::<f64>()
    }

    /// The innovations `e_k = A(q) z_k` for `k >= order` (earlier samples have no full
    /// history), with `z = x / (1 + ma q^-1)` started at zero.
    pub fn whiten(&self, x: &[f64]) -> Vec<f64> {
        let mut w = self.whitener(1);
        let mut e = [0.0];
        x.iter()
            .filter_map(|v| w.push(std::slice::from_ref(v), &mut e).then_some(e[0]))
            .collect()
    }

    /// [`ArNoise::whiten`] one sample at a time for `width` series at once.
    pub fn whitener(&self, width: usize) -> Whitener<'_> {
        Whitener::new(&self.phi, self.ma, self.ma_lag, width)
    }

    /// Fits the moving-average coefficient (on [`MA_GRID`]) and the AR order (0..=`max_order`)
    /// by BIC to series that are each a stretch of one process (the residuals of one axis,
    /// window by window). Every candidate's transform is causal with a unit diagonal, so the
    /// innovation variances compare directly.
    /// Short stretches (median under [`MIN_MA_STRETCH`] samples) get no moving-average term:
    /// its filter starts from zero at every stretch, which is far from the exact likelihood
    /// when the stretch is shorter than the filter's memory (measured: with cut windows on 50 Hz
    /// combo flights the sigmas were 1.3-1.6x optimistic with it, about right without).
    pub fn fit(series: &[Vec<f64>], max_order: usize) -> ArNoise {
        let mut lengths: Vec<usize> = series.iter().map(Vec::len).collect();
        lengths.sort_unstable();
        let long = lengths
            .get(lengths.len() / 2)
            .is_some_and(|&m| m >= MIN_MA_STRETCH);
        let grid: &[f64] = if long { &MA_GRID } else { &[0.0] };
        let mut best: Option<(f64, ArNoise)> = None;
        // Lag 1, then lag 2 with the negative coefficients only: a central difference's (its
        // zero coefficient is lag 1's; a positive one has no sensor behind it). Measured, user
        // time of `massid estimate` on p01, o03 and open3 r04 against lag 1 alone: the whole
        // grid at lag 2 +39 / +20 / +69 %, its negative half +31 / +12 / +29 %.
        let candidates = MA_LAGS
            .iter()
            .flat_map(|&lag| grid.iter().map(move |&ma| (ma, lag)))
            .filter(|&(ma, lag)| lag == 1 || ma < 0.0);
        for (ma, lag) in candidates {
            let mut worse_in_a_row = 0;
            for p in 0..=max_order {
                let Some((m, n)) = fit_order(series, (ma, lag), p) else {
                    break;
                };
                let k = p + usize::from(ma != 0.0);
                let bic = n as f64 * m.sigma2.max(1e-300).ln() + k as f64 * (n as f64).ln();
                if best.as_ref().is_none_or(|(b, _)| bic < *b) {
                    best = Some((
                        bic,
                        ArNoise {
                            ma,
                            ma_lag: lag,
                            ..m
                        },
                    ));
                    worse_in_a_row = 0;
                } else {
                    worse_in_a_row += 1;
                    if worse_in_a_row >= 3 {
                        break;
                    }
                }
            }
        }
        best.map_or(ArNoise::white(0.0), |(_, m)| m)
    }
}

/// [`ArNoise::whiten`] one sample at a time, for several series at once (a residual and its
/// sensitivities): a fit can whiten a window as it integrates it, holding `order + 1` samples
/// instead of the window. Bit for bit the same arithmetic as the whole-series filter.
#[derive(Clone, Debug)]
pub struct Whitener<'a> {
    phi: &'a [f64],
    ma: f64,
    /// The moving average's lag (1 or 2).
    ma_lag: usize,
    width: usize,
    /// `z_k-1` and `z_k-2` of each series (the inverse moving average's state).
    z_prev: Vec<[f64; 2]>,
    /// The last `order + 1` values of `z`, a ring of samples of `width` series each.
    ring: Vec<f64>,
    /// The ring slot of `z_k-i`, i = 1..=order, for the sample being pushed.
    lag_slots: Vec<usize>,
    seen: usize,
}

impl<'a> Whitener<'a> {
    fn new(phi: &'a [f64], ma: f64, ma_lag: usize, width: usize) -> Self {
        Whitener {
            phi,
            ma,
            ma_lag: ma_lag.clamp(1, 2),
            width,
            z_prev: vec![[0.0; 2]; width],
            ring: vec![0.0; (phi.len() + 1) * width],
            lag_slots: vec![0; phi.len()],
            seen: 0,
        }
    }

    /// Takes the next sample of every series (`x`, `width` long). Returns true and writes each
    /// series' innovation into `out` once `order` samples came before it.
    pub fn push(&mut self, x: &[f64], out: &mut [f64]) -> bool {
        let p = self.phi.len();
        let slots = p + 1;
        let now = self.seen % slots;
        let width = self.width;
        let current = &mut self.ring[now * width..(now + 1) * width];
        if self.ma == 0.0 {
            current.copy_from_slice(&x[..width]);
        } else {
            let back = self.ma_lag - 1;
            for ((z, prev), v) in current.iter_mut().zip(&mut self.z_prev).zip(x) {
                *z = v - self.ma * prev[back];
                *prev = [*z, prev[0]];
            }
        }
        let ready = self.seen >= p;
        self.seen += 1;
        if !ready {
            return false;
        }
        for (i, slot) in self.lag_slots.iter_mut().enumerate() {
            *slot = (now + slots - 1 - i) % slots;
        }
        for (c, o) in out[..width].iter_mut().enumerate() {
            let ring = &self.ring;
            *o = ring[now * width + c]
                - self
                    .phi
                    .iter()
                    .zip(&self.lag_slots)
                    .map(|(phi, slot)| phi * ring[slot * width + c])
                    .sum::<f64>();
        }
        true
    }
}

#[cfg(test)]
mod whitener_tests {
    use super::*;

    /// `z_k = x_k - ma z_k-lag`, `z_-1 = z_-2 = 0`: the whole-series inverse moving average
    /// (the oracle).
    fn inverse_ma((ma, lag): (f64, usize), x: &[f64]) -> Vec<f64> {
        if ma == 0.0 {
            return x.to_vec();
        }
        let mut z: Vec<f64> = Vec::with_capacity(x.len());
        for (k, v) in x.iter().enumerate() {
            let back = k.checked_sub(lag).map_or(0.0, |i| z[i]);
            z.push(v - ma * back);
        }
        z
    }

    /// `x_k - sum phi_i x_k-i` for `k >= phi.len()`: the whole-series AR filter (the oracle).
    fn ar_filter(phi: &[f64], x: &[f64]) -> Vec<f64> {
        let p = phi.len();
        (p..x.len())
            .map(|k| x[k] - (1..=p).map(|i| phi[i - 1] * x[k - i]).sum::<f64>())
            .collect()
    }

    /// [`fit_order`] (its filtered series made as it reads, in chunks of [`Lags::CHUNK`]) is
    /// the least squares over whole filtered series bit for bit: every order up to 12, three
    /// moving-average values, stretches around the chunk length.
    #[test]
    fn fit_order_equals_the_whole_series_least_squares_bit_for_bit() {
        let whole = |series: &[Vec<f64>], p: usize| -> Option<(ArNoise, usize)> {
            let mut ata = DMatrix::<f64>::zeros(p, p);
            let mut atb = DVector::<f64>::zeros(p);
            let mut n = 0usize;
            for s in series {
                for k in p..s.len() {
                    for i in 0..p {
                        atb[i] += s[k - 1 - i] * s[k];
                        for j in 0..p {
                            ata[(i, j)] += s[k - 1 - i] * s[k - 1 - j];
                        }
                    }
                    n += 1;
                }
            }
            if n < 10 * (p + 1) {
                return None;
            }
            let phi = if p == 0 {
                DVector::zeros(0)
            } else {
                ata.lu().solve(&atb)?
            };
            let phi: Vec<f64> = phi.iter().copied().collect();
            let ss: f64 = series
                .iter()
                .map(|s| ar_filter(&phi, s).iter().map(|e| e * e).sum::<f64>())
                .sum();
            Some((
                ArNoise {
                    phi,
                    sigma2: ss / n as f64,
                    ma: 0.0,
                    ma_lag: 1,
                },
                n,
            ))
        };
        let mut x = 12345u64;
        let mut rnd = || {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (x >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let series: Vec<Vec<f64>> = [5usize, 40, 4095, 4096, 4097, 4100, 8200, 13000, 3]
            .iter()
            .map(|&n| {
                let mut prev = 0.0;
                (0..n)
                    .map(|_| {
                        prev = 0.7 * prev + rnd();
                        prev
                    })
                    .collect()
            })
            .collect();
        for ma in [(0.0, 1), (-0.6, 1), (0.45, 1), (-0.6, 2)] {
            let filtered: Vec<Vec<f64>> = series.iter().map(|s| inverse_ma(ma, s)).collect();
            for p in 0..=12 {
                let want = whole(&filtered, p);
                let got = fit_order(&series, ma, p);
                let bits = |r: &Option<(ArNoise, usize)>| {
                    r.as_ref().map(|(m, n)| {
                        let phi: Vec<u64> = m.phi.iter().map(|v| v.to_bits()).collect();
                        (phi, m.sigma2.to_bits(), *n)
                    })
                };
                assert_eq!(bits(&want), bits(&got), "ma {ma:?} p {p}");
            }
        }
    }

    /// The streaming whitener is the whole-series filter bit for bit, for several series at
    /// once, with and without a moving-average term, at every order the fit may choose.
    #[test]
    fn streaming_equals_the_whole_series_filter_bit_for_bit() {
        let series: Vec<Vec<f64>> = (0..3)
            .map(|c| {
                (0..300)
                    .map(|k| {
                        ((k * (c + 3)) as f64 * 0.37).sin()
                            + if k % 7 == 0 { -0.0 } else { 1e-3 * k as f64 }
                    })
                    .collect()
            })
            .collect();
        for (ma, lag) in [(0.0, 1), (-0.9, 1), (0.3, 1), (-0.9, 2)] {
            for p in 0..=10usize {
                let phi: Vec<f64> = (0..p).map(|i| 0.5 / (i + 1) as f64 - 0.1).collect();
                let model = ArNoise {
                    phi: phi.clone(),
                    sigma2: 1.0,
                    ma,
                    ma_lag: lag,
                };
                let mut w = model.whitener(series.len());
                let mut out = vec![0.0; series.len()];
                let mut streamed: Vec<Vec<f64>> = vec![Vec::new(); series.len()];
                for k in 0..series[0].len() {
                    let x: Vec<f64> = series.iter().map(|s| s[k]).collect();
                    if w.push(&x, &mut out) {
                        for (s, o) in streamed.iter_mut().zip(&out) {
                            s.push(*o);
                        }
                    }
                }
                for (s, got) in series.iter().zip(&streamed) {
                    let want = ar_filter(&phi, &inverse_ma((ma, lag), s));
                    assert_eq!(want.len(), got.len());
                    for (a, b) in want.iter().zip(got) {
                        assert_eq!(a.to_bits(), b.to_bits(), "ma {ma} lag {lag} p {p}");
                    }
                }
            }
        }
    }
}

/// The recent values of a series read one at a time, `z_k-i` for `i <= order`, in a buffer
/// that is shifted once every few thousand samples instead of at every sample.
struct Lags {
    buf: Vec<f64>,
    /// Index of `z_k` (the latest) in `buf`.
    now: usize,
    order: usize,
}

impl Lags {
    const CHUNK: usize = 4096;

    fn new(order: usize) -> Self {
        Lags {
            buf: vec![0.0; order + Self::CHUNK],
            now: order.saturating_sub(1),
            order,
        }
    }

    fn push(&mut self, z: f64) {
        self.now += 1;
        if self.now == self.buf.len() {
            let keep = self.buf.len() - self.order;
            self.buf.copy_within(keep.., 0);
            self.now = self.order;
        }
        self.buf[self.now] = z;
    }

    /// `z_k-order ..= z_k`, latest last.
    fn recent(&self) -> &[f64] {
        &self.buf[self.now - self.order..=self.now]
    }
}

/// Calls `f` with `z_k-p ..= z_k` (latest last) of `z = x / (1 + ma q^-lag)` for every
/// `k >= p`.
fn for_each_z(x: &[f64], (ma, lag): (f64, usize), p: usize, mut f: impl FnMut(&[f64])) {
    let mut lags = Lags::new(p);
    let back = lag.clamp(1, 2) - 1;
    let mut z_prev = [0.0; 2];
    for (k, v) in x.iter().enumerate() {
        let z = if ma == 0.0 { *v } else { v - ma * z_prev[back] };
        z_prev = [z, z_prev[0]];
        lags.push(z);
        if k >= p {
            f(lags.recent());
        }
    }
}

/// Least-squares AR(`p`) of `z = x / (1 + ma q^-lag)` over every stretch `x`, with the
/// number of innovations it used. None when there are too few samples. `z` is made as it is
/// read (a stretch can be the whole flight, so no copy of it is kept).
fn fit_order(series: &[Vec<f64>], ma: (f64, usize), p: usize) -> Option<(ArNoise, usize)> {
    let mut ata = DMatrix::<f64>::zeros(p, p);
    let mut atb = DVector::<f64>::zeros(p);
    let mut n = 0usize;
    for s in series {
        for_each_z(s, ma, p, |r: &[f64]| {
            // r[p] is z_k, r[p - 1 - i] is z_k-1-i.
            let z = r[p];
            for i in 0..p {
                atb[i] += r[p - 1 - i] * z;
                // The upper triangle is the same products (a product commutes exactly).
                for j in 0..=i {
                    ata[(i, j)] += r[p - 1 - i] * r[p - 1 - j];
                }
            }
            n += 1;
        });
    }
    ata.fill_upper_triangle_with_lower_triangle();
    if n < 10 * (p + 1) {
        return None;
    }
    let phi = if p == 0 {
        DVector::zeros(0)
    } else {
        ata.lu().solve(&atb)?
    };
    let phi: Vec<f64> = phi.iter().copied().collect();
    let zero: f64 = std::iter::empty::<f64>().sum();
    let mut ss = 0.0;
    for s in series {
        let mut squares = zero;
        for_each_z(s, ma, p, |r: &[f64]| {
            // The AR filter's arithmetic, as in `Whitener::push`.
            let e = r[p] - (1..=p).map(|i| phi[i - 1] * r[p - i]).sum::<f64>();
            squares += e * e;
        });
        ss += squares;
    }
    Some((
        ArNoise {
            phi,
            sigma2: ss / n as f64,
            ma: 0.0,
            ma_lag: 1,
        },
        n,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};

    fn gauss(n: usize, seed: u64) -> Vec<f64> {
        let mut r = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        (0..n).map(|_| StandardNormal.sample(&mut r)).collect()
    }

    #[test]
    fn white_noise_gets_order_zero_and_ar1_gets_its_coefficient() {
        let w = gauss(20_000, 1);
        let m = ArNoise::fit(std::slice::from_ref(&w), 8);
        assert_eq!(m.order(), 0, "{m:?}");
        assert!((m.sigma2 - 1.0).abs() < 0.03);
        let mut x = vec![0.0; w.len()];
        for k in 1..w.len() {
            x[k] = 0.6 * x[k - 1] + w[k];
        }
        let m = ArNoise::fit(&[x], 8);
        assert_eq!(m.order(), 1, "{m:?}");
        assert!((m.phi[0] - 0.6).abs() < 0.02);
        assert!((m.process_variance() - 1.0 / (1.0 - 0.36)).abs() < 0.1);
    }

    #[test]
    fn differenced_attitude_noise_is_whitened() {
        // Rate from attitude noise differenced over one sample, plus a little white noise:
        // lag-1 correlation near -0.45; the fitted model must leave white innovations.
        let a = gauss(20_001, 2);
        let w = gauss(20_000, 3);
        let x: Vec<f64> = (0..20_000)
            .map(|k| (a[k + 1] - a[k]) + 0.5 * w[k])
            .collect();
        let m = ArNoise::fit(std::slice::from_ref(&x), 12);
        assert!(m.ma < -0.5, "{m:?}");
        let e = m.whiten(&x);
        let r1 =
            e.windows(2).map(|p| p[0] * p[1]).sum::<f64>() / e.iter().map(|v| v * v).sum::<f64>();
        assert!(r1.abs() < 0.03, "lag-1 correlation of the innovations {r1}");
        // A fault planted: whitening with white noise assumed leaves the correlation.
        let r1_raw =
            x.windows(2).map(|p| p[0] * p[1]).sum::<f64>() / x.iter().map(|v| v * v).sum::<f64>();
        assert!(r1_raw < -0.3, "{r1_raw}");
        assert_eq!(m.ma_lag, 1, "{m:?}");
    }

    #[test]
    fn central_differenced_attitude_noise_gets_a_lag_2_moving_average() {
        // Attitude noise central-differenced (over the previous and next samples), plus a
        // little white noise: lag-2 correlation near -0.45.
        let a = gauss(20_002, 4);
        let w = gauss(20_000, 5);
        let x: Vec<f64> = (0..20_000)
            .map(|k| 0.5 * (a[k + 2] - a[k]) + 0.25 * w[k])
            .collect();
        let m = ArNoise::fit(std::slice::from_ref(&x), 12);
        assert!(m.ma_lag == 2 && m.ma < -0.5, "{m:?}");
        let e = m.whiten(&x);
        let lag = |v: &[f64], l: usize| {
            v.iter().skip(l).zip(v).map(|(p, q)| p * q).sum::<f64>()
                / v.iter().map(|u| u * u).sum::<f64>()
        };
        assert!(lag(&e, 1).abs() < 0.03 && lag(&e, 2).abs() < 0.03, "{m:?}");
        // Planted: the same noise whitened at lag 1 with that coefficient stays correlated.
        let wrong = ArNoise {
            ma_lag: 1,
            ..m.clone()
        }
        .whiten(&x);
        assert!(lag(&wrong, 2).abs() > 0.1 || lag(&wrong, 1).abs() > 0.1);
    }
}
