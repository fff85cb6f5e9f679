//! What a rate sensor reports of the body's rate between its samples.
//!
//! A gyro reports the rate at the sample (the model's prediction as it is). A rate
//! differenced from motion-capture attitude is an attitude difference over a time: the mean
//! rate over that time, not the rate at the sample. Over the central difference
//! `(a_(k+1) - a_(k-1)) / 2 dt` (open3's pl6) that mean is centred on the sample, so it
//! smooths the rate's kinks at the valve edges without delaying it; a diagnosis that
//! compared it with the point rate found 0.29 of the noise of structure in a nominal flight
//! and reported it `unexplained` (open3 r01). The sensor is told from the noise's lag
//! structure ([`crate::noise`]: differenced attitude over two samples). The difference with
//! the previous sample, `(a_k - a_(k-1)) / dt`, is the mean over the period before the sample,
//! to first order the rate half a period late, but a negative lag-1 correlation does not prove
//! that response (a gyro with such noise, as open2's p07, or this project's simulator, whose
//! differenced sensor is the point rate with differenced noise): that span keeps the point
//! rate (README, "Attitude differenced with the previous sample": what it costs, and a choice by the
//! nominal fit's cost that was tried).

use crate::noise::{NoiseKind, NoiseModel};
use crate::series::Series;

/// The sensor's response to the body's rate.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Response {
    /// The rate at the sample.
    Point,
    /// The mean rate from the sample before to the sample after (a central difference of
    /// attitude).
    CentralMean,
}

/// The environment variable that keeps the point response whatever the noise says: a
/// planted fault for the tests that show the response matters.
pub const FORCE_POINT_ENV: &str = "MASSID_POINT_RESPONSE";

impl Response {
    /// The response the noise model implies: a central difference's mean, else the point
    /// rate.
    pub fn of_noise(noise: &NoiseModel) -> Response {
        if std::env::var_os(FORCE_POINT_ENV).is_some() {
            return Response::Point;
        }
        match (noise.kind, noise.span) {
            (NoiseKind::DifferencedAttitude, 2) => Response::CentralMean,
            _ => Response::Point,
        }
    }

    /// How the JSON's `noise.response` names it (None for the point rate, which it leaves
    /// out), and what the summary says.
    pub fn name(self) -> Option<(&'static str, &'static str)> {
        match self {
            Response::Point => None,
            Response::CentralMean => Some((
                "central_mean",
                "the mean over the periods before and after each sample (attitude differenced centrally)",
            )),
        }
    }

    /// The sensor's output at every sample of `series`, from the gyro output `y` the model
    /// predicts there and its time integral `integral` (rad, from the first sample:
    /// [`crate::model::predict_with_integral`]): for the central mean, the integral's change
    /// from the sample before to the sample after over that time; the rate itself where a
    /// neighbour is missing, a period is not the recording's step, or the model's state is
    /// re-estimated (a gap or a horizon: the predicted rate jumps there and the sensor saw no
    /// such jump).
    pub fn apply(self, series: &Series, y: &[[f64; 3]], integral: &[[f64; 3]]) -> Vec<[f64; 3]> {
        // the recording's step, ms (a rate logged in whole ms, 120 Hz as 8 and 9 ms, is within
        // half a step of it)
        let step = 1000.0 / series.sample_rate_hz.max(1e-9);
        let t = &series.t_ms;
        // the period ending at sample i is one step, with no re-estimate at i
        let continuous = |i: usize| {
            i > 0
                && i < integral.len()
                && t[i] > t[i - 1]
                && ((t[i] - t[i - 1]) as f64 - step).abs() < 0.5 * step
                && series.gap_resets.binary_search(&i).is_err()
        };
        // (first, last) samples of the mean's interval around sample k
        let interval = |k: usize| match self {
            Response::Point => None,
            Response::CentralMean => (continuous(k) && continuous(k + 1)).then(|| (k - 1, k + 1)),
        };
        (0..y.len())
            .map(|k| match interval(k) {
                Some((a, b)) => {
                    let span_s = (t[b] - t[a]) as f64 * 1e-3;
                    std::array::from_fn(|i| (integral[b][i] - integral[a][i]) / span_s)
                }
                None => y[k],
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn series(t: &[i64]) -> Series {
        let rates = vec![[0.0; 3]; t.len()];
        Series::from_rates(t, &rates, &vec![0u16; t.len()], 0xff, Some(25.0)).unwrap()
    }

    /// The central mean is the integral's change over the two periods around the sample;
    /// the point response leaves the rates alone; no mean reaches across a gap.
    #[test]
    fn the_central_mean_is_the_integral_over_the_samples_around() {
        let t: Vec<i64> = (0..6).map(|k| 40 * k).collect();
        let s = series(&t);
        // the rate rises by 1 a period up to sample 2, then stays: its integral (rad s)
        let y: Vec<[f64; 3]> = [0.0, 1.0, 2.0, 2.0, 2.0, 2.0]
            .iter()
            .map(|&v| [v; 3])
            .collect();
        let integral: Vec<[f64; 3]> = [0.0, 0.02, 0.08, 0.16, 0.24, 0.32]
            .iter()
            .map(|&v| [v; 3])
            .collect();
        let out = Response::CentralMean.apply(&s, &y, &integral);
        let near = |a: f64, b: f64| (a - b).abs() < 1e-12;
        // from sample 1 to 3 over 80 ms: (0.16 - 0.02) / 0.08
        assert!(near(out[2][0], 1.75), "{out:?}");
        assert!(near(out[1][0], 1.0) && near(out[3][0], 2.0), "{out:?}");
        // the ends keep the rate
        assert_eq!(out[0][0], 0.0);
        assert_eq!(out[5][0], 2.0);
        assert_eq!(Response::Point.apply(&s, &y, &integral), y);
        // a gap after sample 2 (120 ms instead of 40): samples 2 and 3 keep their rates
        let t_gap = [0, 40, 80, 200, 240, 280];
        let out = Response::CentralMean.apply(&series(&t_gap), &y, &integral);
        assert_eq!(out[2][0], 2.0);
        assert_eq!(out[3][0], 2.0);
        assert!(near(out[1][0], 1.0));
    }
}
