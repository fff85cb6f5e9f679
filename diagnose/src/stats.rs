//! Residual tests that back the BIC decision: whiteness (Ljung-Box on block-averaged
//! residuals, so the gyro's own band-limited noise colour does not count as structure)
//! and cross-correlation with the input (thruster activity), which a complete model
//! leaves at noise level. With a rate sensor whose noise is correlated even between block
//! means (differenced attitude: neighbouring 50 ms means share one attitude sample, so they
//! correlate at about -0.5), [`residual_tests_for`] leaves samples out between the blocks
//! so that under the estimated noise model their means share no noise: the test asks
//! "anything beyond this sensor's noise?" rather than "is it white?". Leaving samples out
//! needs no estimate of how small the white part is (the block correlation depends on it
//! steeply), so it is robust where whitening with the estimated correlation was not.

use crate::noise::NoiseModel;
use crate::series::Series;

/// Block averages of `x` (one axis) and of the number of open valves over `block_ms`,
/// `gap` samples left out after each block, the first block from sample `from`.
fn blocks(
    series: &Series,
    r: &[[f64; 3]],
    axis: usize,
    block_ms: i64,
    gap: usize,
    from: usize,
) -> (Vec<f64>, Vec<f64>) {
    let mut out = vec![];
    let mut inp = vec![];
    let Some(&first) = series.t_ms.get(from) else {
        return (out, inp);
    };
    let mut start = first;
    let (mut s, mut n) = (0.0, 0usize);
    let mut skip = 0usize;
    let mut restart = false;
    for (i, &t) in series.t_ms.iter().enumerate().skip(from) {
        if skip > 0 {
            skip -= 1;
            continue;
        }
        if restart {
            start = t;
            restart = false;
        }
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
            if gap > 0 {
                // this sample is the first of the `gap` left out
                skip = gap - 1;
                restart = true;
                continue;
            }
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
    tests_with(series, r, None)
}

/// A block-level correlation of the noise below this is left alone: 1/sqrt(1200 blocks of
/// a 60 s run) is 0.03, so it changes Q by well under one unit. Only a sensor like
/// differenced attitude gets samples left out between its blocks.
const BLOCK_CORR_NEGLIGIBLE: f64 = 0.02;

/// [`residual_tests`] judged against the noise model `noise`: the blocks are cut
/// [`NoiseModel::block_gap`] samples apart, so that under the model their means share no
/// noise (differenced attitude: the span, as neighbouring means share attitude samples and
/// correlate at about -0.5; white noise and SPHERES' gyro: none), and the whiteness
/// statistic is the mean of Ljung-Box Q over every place the first block can start (one
/// block and gap's worth of samples; the input correlation from the first sample). Where
/// the blocks start is arbitrary, and the blocks of a sensor with a gap read only some of
/// the samples: open3's nominal pl6 recording (central differences at 25 Hz, blocks of two
/// samples, two left out) gave Q 78, 18, 18 and 20 from its first four samples, the first
/// over [`WHITE_BELOW`] (p < 1e-5 for this sensor's noise, simulated), so its verdict was
/// one of where the blocks fell. Under the model each Q is chi-square(20), so their mean is
/// 20 on average with less spread: the threshold is no easier to pass by chance.
pub fn residual_tests_for(series: &Series, r: &[[f64; 3]], noise: &NoiseModel) -> ResidualTests {
    tests_with(series, r, Some(noise))
}

/// Ljung-Box Q over [`LJUNG_BOX_LAGS`] lags of the block means `x` (None: too few).
fn ljung_box(x: &[f64]) -> Option<f64> {
    let n = x.len() as f64;
    (x.len() >= 3 * LJUNG_BOX_LAGS).then(|| {
        n * (n + 2.0)
            * (1..=LJUNG_BOX_LAGS)
                .map(|k| autocorr(x, k).powi(2) / (n - k as f64))
                .sum::<f64>()
    })
}

fn tests_with(series: &Series, r: &[[f64; 3]], noise: Option<&NoiseModel>) -> ResidualTests {
    // samples per block as the blocks are cut (time >= 50 ms from the block's start)
    let per_block = (50.0 * series.sample_rate_hz / 1000.0).ceil().max(1.0) as usize;
    let gap = noise
        .map(|m| m.block_gap(per_block, BLOCK_CORR_NEGLIGIBLE))
        .unwrap_or(0);
    // where the first block may start: from the first sample only without a noise model
    // (the acceptance checks compare two residuals alike), else every place in a period
    let starts = if noise.is_some() { per_block + gap } else { 1 };
    let mut q = [0.0; 3];
    let mut z = [0.0; 3];
    for a in 0..3 {
        let (x, u) = blocks(series, r, a, 50, gap, 0);
        let Some(q0) = ljung_box(&x) else {
            continue;
        };
        let qs: Vec<f64> = std::iter::once(q0)
            .chain((1..starts).filter_map(|from| ljung_box(&blocks(series, r, a, 50, gap, from).0)))
            .collect();
        q[a] = qs.iter().sum::<f64>() / qs.len() as f64;
        z[a] = (0..=LJUNG_BOX_LAGS)
            .map(|k| crosscorr(&x, &u, k).abs())
            .fold(0.0, f64::max)
            * (x.len() as f64).sqrt();
    }
    ResidualTests {
        ljung_box_q: q,
        input_xcorr_z: z,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// With a noise model the whiteness statistic is the mean of Ljung-Box Q over every
    /// sample the first block can start at (here 25 Hz: blocks of two samples, none left out
    /// for white noise, so two starts); a residual whose structure sits at one phase of the
    /// blocks (here every fourth pair of samples carries a slow wave) gives different Qs.
    #[test]
    fn the_whiteness_statistic_is_the_mean_over_the_blocks_starts() {
        let mut st = 777u64;
        let mut u = || {
            st = st
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((st >> 11) as f64 / (1u64 << 53) as f64) - 0.5
        };
        let n = 3_000;
        let x: Vec<[f64; 3]> = (0..n)
            .map(|k| {
                let wave = if k % 4 < 2 {
                    (k as f64 * 0.01).sin()
                } else {
                    0.0
                };
                [u() + 0.3 * wave; 3]
            })
            .collect();
        let t: Vec<i64> = (0..n as i64).map(|k| k * 40).collect();
        let s = Series::from_rates(&t, &x, &vec![0u16; n], 0xff, Some(25.0)).unwrap();
        let m = NoiseModel::white([1.0 / 12.0; 3]);
        let q: Vec<f64> = (0..2)
            .map(|from| ljung_box(&blocks(&s, &s.rate, 0, 50, 0, from).0).unwrap())
            .collect();
        assert!((q[0] - q[1]).abs() > 5.0, "{q:?}");
        let got = residual_tests_for(&s, &s.rate, &m).ljung_box_q[0];
        assert!((got - 0.5 * (q[0] + q[1])).abs() < 1e-9, "{got} {q:?}");
    }

    /// Block means of differenced-attitude noise correlate at about -0.5 when cut
    /// contiguously, and not at all with one sample left out between blocks.
    #[test]
    fn a_gap_of_one_sample_decorrelates_differenced_noise() {
        let mut st = 12345u64;
        let mut u = || {
            st = st
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((st >> 11) as f64 / (1u64 << 53) as f64) - 0.5
        };
        let n = 30_000;
        let att: Vec<f64> = (0..=n).map(|_| u()).collect();
        let x: Vec<[f64; 3]> = (1..=n).map(|k| [att[k] - att[k - 1]; 3]).collect();
        let t: Vec<i64> = (0..n as i64).map(|k| k * 10).collect();
        let s = Series::from_rates(&t, &x, &vec![0u16; n], 0xff, Some(100.0)).unwrap();
        let (b0, _) = blocks(&s, &s.rate, 0, 50, 0, 0);
        let (b1, _) = blocks(&s, &s.rate, 0, 50, 1, 0);
        assert!(autocorr(&b0, 1) < -0.45, "{}", autocorr(&b0, 1));
        assert!(autocorr(&b1, 1).abs() < 0.05, "{}", autocorr(&b1, 1));
    }
}
