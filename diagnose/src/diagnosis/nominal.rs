//! Stage 1, the nominal model: the recording predicted from its own commands with only the
//! initial rate (and the rate jumps at telemetry gaps) fitted. Its residual gives the noise
//! model every later test weighs with, and the chi-square every BIC is measured from.

use crate::effects::{self, Context};
use crate::fit::{self, Problem};
use crate::model::{Plant, NT};
use crate::noise::{self, NoiseModel};
use crate::response::Response;
use crate::ringing::Whitening;
use crate::select::{self, fit_nuisance_with};
use crate::series::Series;

/// What every later stage measures against; fixed once this stage is done.
pub(super) struct Nominal<'a> {
    pub series: &'a Series,
    pub plant: &'a Plant,
    /// The fitting problem, weighted by the noise model below.
    pub prob: Problem<'a>,
    pub noise: NoiseModel,
    /// Which thrusters are ever commanded open.
    pub fired: [bool; NT],
    /// Initial rate and rate jumps at gaps, fitted.
    pub nuis: Vec<f64>,
    pub residual: Vec<[f64; 3]>,
    pub chi2: f64,
    /// BIC cost of one parameter, ln(number of observations).
    pub ln_n: f64,
    /// Low-frequency peaks of the residual, Hz (slosh starting points).
    pub slosh_hint: Vec<f64>,
    /// The noise's autoregressive whitening filter (the ringing fit's weights).
    pub whitening: Whitening,
}

impl Nominal<'_> {
    /// What an effect may look at about this recording and model.
    pub fn context(&self) -> Context<'_> {
        select::context(&self.prob, &self.fired, &self.slosh_hint)
    }

    /// Gyro noise standard deviation per axis.
    pub fn sigma(&self) -> [f64; 3] {
        self.noise.var.map(f64::sqrt)
    }
}

/// Fits the nominal model; `None` when it does not predict the recording (an extreme model
/// can make the prediction non-finite), which the caller reports as an error rather than as
/// a residual of zero.
pub(super) fn fit<'a>(series: &'a Series, plant: &'a Plant) -> Option<Nominal<'a>> {
    let fired = effects::fired_thrusters(series);
    // a provisional fit with unit weights, the noise model from its residual, then the fit
    // again with the noise's weights
    let provisional = NoiseModel::white([1e-6; 3]);
    let prob0 = Problem::new(plant, series, &provisional);
    let mut start = initial_rate(series).to_vec();
    start.extend(std::iter::repeat_n(0.0, 3 * series.gap_resets.len()));
    let w0 = fit_nuisance(&prob0, &start)
        .map(|f| f.theta)
        .unwrap_or(start);
    let r0 = prob0.residual(&select::nuisance_params(&w0))?;
    let mut noise = noise::estimate(series, &r0);
    if Response::of_noise(&noise) != Response::Point {
        // a sensor that reports a mean rate: its level read again from the residual of that
        // mean (the point rate's residual holds the difference between the two, 2-6 % of the
        // level on central differences at 25 Hz), its kind as found
        let seen = Problem::new(plant, series, &noise);
        let r1 = seen.residual(&select::nuisance_params(&w0))?;
        noise = noise::estimate_as(series, &r1, &noise);
    }
    let mut prob = Problem::new(plant, series, &noise);
    prob.stride = (series.sample_rate_hz / 200.0).round().max(1.0) as usize;
    let nuis = fit_nuisance(&prob, &w0).map(|f| f.theta).unwrap_or(w0);
    let params = select::nuisance_params(&nuis);
    let residual = prob.residual(&params)?;
    let chi2 = prob.chi2(&params).unwrap_or(f64::INFINITY);
    let ln_n = (prob.n_obs() as f64).max(2.0).ln();
    let slosh_hint = slosh_hints(series, &residual);
    let whitening = noise.ar(4);
    Some(Nominal {
        series,
        plant,
        prob,
        noise,
        fired,
        nuis,
        residual,
        chi2,
        ln_n,
        slosh_hint,
        whitening,
    })
}

/// Fits the nuisances (initial rate, rate jumps at gaps) of the nominal model.
fn fit_nuisance(prob: &Problem, nuis: &[f64]) -> Option<fit::FitResult> {
    fit_nuisance_with(prob, &[], nuis)
}

/// Mean of the first usable samples per axis as the starting initial rate.
pub(crate) fn initial_rate(series: &Series) -> [f64; 3] {
    std::array::from_fn(|a| {
        let first: Vec<f64> = (0..series.len())
            .filter(|&i| series.valid[i][a])
            .take(5)
            .map(|i| series.rate[i][a])
            .collect();
        if first.is_empty() {
            0.0
        } else {
            first.iter().sum::<f64>() / first.len() as f64
        }
    })
}

/// Low-frequency peaks of the nominal residual (slosh starting points), Hz.
fn slosh_hints(series: &Series, r: &[[f64; 3]]) -> Vec<f64> {
    let mask = noise::coasting_mask(series, 100);
    let step = (series.sample_rate_hz / 20.0).max(1.0) as usize;
    let mut t = vec![];
    let mut y: [Vec<f64>; 3] = Default::default();
    for i in (0..series.len()).step_by(step) {
        if mask[i] && series.valid[i].iter().all(|&v| v) {
            t.push(series.t_ms[i] as f64 * 1e-3);
            for a in 0..3 {
                y[a].push(r[i][a]);
            }
        }
    }
    if t.len() < 50 {
        return vec![0.4];
    }
    let freqs = crate::spectrum::grid(0.05, 5.0, 400);
    let mut tot = vec![0.0; freqs.len()];
    for a in 0..3 {
        // remove a linear trend per axis so drift does not dominate
        let p = crate::spectrum::lomb_scargle(&t, &detrend(&t, &y[a]), &freqs);
        for (x, v) in tot.iter_mut().zip(p) {
            *x += v;
        }
    }
    let mut idx: Vec<usize> = (1..freqs.len() - 1)
        .filter(|&i| tot[i] >= tot[i - 1] && tot[i] >= tot[i + 1])
        .collect();
    idx.sort_by(|&a, &b| tot[b].total_cmp(&tot[a]));
    let mut out: Vec<f64> = idx.iter().take(2).map(|&i| freqs[i]).collect();
    if out.is_empty() {
        out.push(0.4);
    }
    out
}

fn detrend(t: &[f64], y: &[f64]) -> Vec<f64> {
    let n = t.len() as f64;
    let mt = t.iter().sum::<f64>() / n;
    let my = y.iter().sum::<f64>() / n;
    let sxy: f64 = t.iter().zip(y).map(|(a, b)| (a - mt) * (b - my)).sum();
    let sxx: f64 = t.iter().map(|a| (a - mt).powi(2)).sum();
    let b = if sxx > 0.0 { sxy / sxx } else { 0.0 };
    t.iter()
        .zip(y)
        .map(|(a, v)| v - my - b * (a - mt))
        .collect()
}
