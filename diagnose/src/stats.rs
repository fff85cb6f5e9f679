//! Residual tests that back the BIC decision: whiteness (Ljung-Box on block-averaged
//! residuals, so the gyro's own band-limited noise colour does not count as structure)
//! and cross-correlation with the input (thruster activity), which a complete model
//! leaves at noise level.

use crate::series::Series;

/// Block averages of `x` (one axis) and of the number of open valves over `block_ms`.
fn blocks(series: &Series, r: &[[f64; 3]], axis: usize, block_ms: i64) -> (Vec<f64>, Vec<f64>) {
    let mut out = vec![];
    let mut inp = vec![];
    let mut start = series.t_ms[0];
    let (mut s, mut n) = (0.0, 0usize);
    for (i, &t) in series.t_ms.iter().enumerate() {
        if t - start >= block_ms {
            if n > 0 {
                out.push(s / n as f64);
                let a = start as usize;
                let b = (t as usize).min(series.word_ms.len());
                let open: f64 = series.word_ms[a..b]
                    .iter()
                    .map(|w| w.count_ones() as f64)
                    .sum();
                inp.push(open / (b - a).max(1) as f64);
            }
            start = t;
            s = 0.0;
            n = 0;
        }
        if series.valid[i][axis] {
            s += r[i][axis];
            n += 1;
        }
    }
    (out, inp)
}

fn autocorr(x: &[f64], lag: usize) -> f64 {
    let n = x.len();
    let m = x.iter().sum::<f64>() / n as f64;
    let v: f64 = x.iter().map(|a| (a - m).powi(2)).sum();
    if v <= 0.0 || lag >= n {
        return 0.0;
    }
    (0..n - lag)
        .map(|i| (x[i] - m) * (x[i + lag] - m))
        .sum::<f64>()
        / v
}

fn crosscorr(x: &[f64], u: &[f64], lag: usize) -> f64 {
    let n = x.len().min(u.len());
    if lag >= n {
        return 0.0;
    }
    let mx = x[..n].iter().sum::<f64>() / n as f64;
    let mu = u[..n].iter().sum::<f64>() / n as f64;
    let vx: f64 = x[..n].iter().map(|a| (a - mx).powi(2)).sum();
    let vu: f64 = u[..n].iter().map(|a| (a - mu).powi(2)).sum();
    if vx <= 0.0 || vu <= 0.0 {
        return 0.0;
    }
    (0..n - lag)
        .map(|i| (x[i + lag] - mx) * (u[i] - mu))
        .sum::<f64>()
        / (vx * vu).sqrt()
}

/// Whiteness and input-correlation figures of one residual.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ResidualTests {
    /// Ljung-Box Q over 20 lags of 50 ms block means, per axis (chi-square(20) if white;
    /// judged against [`WHITE_BELOW`]).
    pub ljung_box_q: [f64; 3],
    /// Largest |cross-correlation| with valve activity over lags 0..20 blocks, times
    /// sqrt(blocks) (about N(0,1) if uncorrelated).
    pub input_xcorr_z: [f64; 3],
}

pub const LJUNG_BOX_LAGS: usize = 20;
/// Ljung-Box Q over 20 lags below which a residual counts as white, the one threshold every
/// verdict and printout uses: the chi-square(20) 99.9 % quantile, so three axes of a correct
/// model pass together 99.7 % of the time.
pub const WHITE_BELOW: f64 = 45.31;

pub fn residual_tests(series: &Series, r: &[[f64; 3]]) -> ResidualTests {
    let mut q = [0.0; 3];
    let mut z = [0.0; 3];
    for a in 0..3 {
        let (x, u) = blocks(series, r, a, 50);
        let n = x.len() as f64;
        if x.len() < 3 * LJUNG_BOX_LAGS {
            continue;
        }
        q[a] = n
            * (n + 2.0)
            * (1..=LJUNG_BOX_LAGS)
                .map(|k| autocorr(&x, k).powi(2) / (n - k as f64))
                .sum::<f64>();
        z[a] = (0..=LJUNG_BOX_LAGS)
            .map(|k| crosscorr(&x, &u, k).abs())
            .fold(0.0, f64::max)
            * n.sqrt();
    }
    ResidualTests {
        ljung_box_q: q,
        input_xcorr_z: z,
    }
}
