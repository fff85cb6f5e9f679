//! Output-error fitting: Levenberg-Marquardt over the prediction of the whole recording,
//! with a forward-difference Jacobian (the model is a simulation, not a formula), and
//! standard errors from the Gauss-Newton normal matrix scaled by the noise's long-run
//! variance (so coloured noise does not make them too small).

use nalgebra::{DMatrix, DVector};

use crate::model::{self, Params, Plant};
use crate::noise::NoiseModel;
use crate::response::Response;
use crate::series::Series;

/// Everything needed to evaluate a model against the recording.
pub struct Problem<'a> {
    pub plant: &'a Plant,
    pub series: &'a Series,
    /// Per-axis weight 1/sqrt(long-run variance).
    pub weight: [f64; 3],
    /// What the rate sensor reports of the predicted rates (the noise model's sensor).
    pub response: Response,
    /// Use every `stride`-th sample in the fit (speed); the fit's predictions give only
    /// those ([`model::predict_every`]), still on the 1 ms command grid.
    pub stride: usize,
    /// Samples the fit may use (None: all): the training blocks of an out-of-sample check.
    pub train: Option<std::rc::Rc<Vec<bool>>>,
    /// The last few duty grids by (open, close, rise) ms: a fit's Jacobian alternates
    /// between the current latencies and a perturbed one. Bounded in bytes like `recent`.
    duty_cache:
        std::cell::RefCell<std::collections::VecDeque<((f64, f64, f64), std::rc::Rc<model::Duty>)>>,
    /// The last few predictions and their parameters: the stages ask for the same model's
    /// rates more than once (a fit's end and the check after it), and a repeat is shared
    /// instead of simulated again. Bounded in bytes, so a long recording keeps none.
    /// Each kept with the stride it was predicted at (1: every sample), and answers only
    /// requests at that stride: a fit must not difference a strided prediction against one
    /// of every sample (they differ in rounding, and a parameter nothing depends on would
    /// get a column of rounding instead of an exact zero).
    #[allow(clippy::type_complexity)]
    recent:
        std::cell::RefCell<std::collections::VecDeque<(Params, usize, std::rc::Rc<Vec<[f64; 3]>>)>>,
    /// The recording's own inertia estimate, once computed (`select::context` fills it
    /// from `equation_error.rs`, which reads this problem: kept here, computed there).
    pub(crate) inertia_start: std::cell::OnceCell<Option<[f64; 6]>>,
}

/// Bytes of predictions (and of duty grids) [`Problem`] keeps for repeats.
const RECENT_BYTES: usize = 64 << 20;
/// Predictions [`Problem`] keeps for repeats, at most.
const RECENT_MAX: usize = 4;
/// Duty grids [`Problem`] keeps, at most: a fit with a latency (two, and central
/// differences) alternates between five, and a grid is a few kilobytes per thousand edges.
const DUTY_MAX: usize = 8;

/// How many predictions were answered from [`Problem`]'s recent ones (for profiling).
pub static REPEATS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);

impl<'a> Problem<'a> {
    pub fn new(plant: &'a Plant, series: &'a Series, noise: &NoiseModel) -> Problem<'a> {
        let weight = std::array::from_fn(|a| 1.0 / noise.long_run_var[a].sqrt());
        Problem {
            plant,
            series,
            weight,
            response: Response::of_noise(noise),
            stride: 1,
            train: None,
            duty_cache: Default::default(),
            recent: Default::default(),
            inertia_start: Default::default(),
        }
    }

    pub(crate) fn duty(&self, open: f64, close: f64, rise: f64) -> std::rc::Rc<model::Duty> {
        let key = (open, close, rise);
        let mut cache = self.duty_cache.borrow_mut();
        if let Some(at) = cache.iter().position(|(k, _)| *k == key) {
            let hit = cache.remove(at).expect("present");
            cache.push_front(hit.clone());
            return hit.1;
        }
        let d = std::rc::Rc::new(model::duty_grid(self.series, open, close, rise));
        let keep = (RECENT_BYTES / d.bytes().max(1)).clamp(1, DUTY_MAX);
        while cache.len() >= keep {
            cache.pop_back();
        }
        cache.push_front((key, d.clone()));
        d
    }

    /// Predicted rate-sensor output per sample.
    pub fn predict(&self, p: &Params) -> Option<Vec<[f64; 3]>> {
        Some(self.predict_every(p, 1)?.as_ref().clone())
    }

    /// Predicted rate-sensor output at samples `0, every, 2 every, ...` only, in that order
    /// ([`model::predict_every`], through the sensor's [`Response`]; a response that reads
    /// the neighbours predicts every sample), shared with the kept ones, so that a repeat (or
    /// a reader) copies nothing.
    fn predict_every(&self, p: &Params, every: usize) -> Option<std::rc::Rc<Vec<[f64; 3]>>> {
        let kept = self
            .recent
            .borrow()
            .iter()
            .find(|(q, e, _)| *e == every && q.same(p))
            .map(|(_, _, y)| y.clone());
        if let Some(y) = kept {
            REPEATS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            return Some(y);
        }
        let d = self.duty(p.open_ms + p.delay_ms, p.close_ms + p.delay_ms, p.rise_ms);
        let y = match self.response {
            Response::Point => model::predict_every(self.plant, self.series, &d, p, every)?,
            response => {
                let (all, integral) = model::predict_with_integral(self.plant, self.series, &d, p)?;
                let seen = response.apply(self.series, &all, &integral);
                seen.into_iter().step_by(every.max(1)).collect()
            }
        };
        let y = std::rc::Rc::new(y);
        let keep =
            (RECENT_BYTES / (y.len() * std::mem::size_of::<[f64; 3]>()).max(1)).min(RECENT_MAX);
        if keep > 0 {
            let mut recent = self.recent.borrow_mut();
            if recent.len() >= keep {
                recent.pop_back();
            }
            recent.push_front((p.clone(), every, y.clone()));
        }
        Some(y)
    }

    /// Unweighted residual (measured minus predicted) per sample; zero where the sample
    /// is not a measurement (railed or stuck gyro), so nothing downstream can mistake a
    /// rail for a rate.
    pub fn residual(&self, p: &Params) -> Option<Vec<[f64; 3]>> {
        let y = self.predict_every(p, 1)?;
        let s = self.series;
        Some(
            s.rate
                .iter()
                .zip(y.iter())
                .zip(s.valid.iter())
                .map(|((m, y), v)| std::array::from_fn(|a| if v[a] { m[a] - y[a] } else { 0.0 }))
                .collect(),
        )
    }

    /// The same problem fitted only on the samples where `train` is true.
    pub fn restricted(&self, train: std::rc::Rc<Vec<bool>>) -> Problem<'a> {
        Problem {
            plant: self.plant,
            series: self.series,
            weight: self.weight,
            response: self.response,
            stride: self.stride,
            train: Some(train),
            duty_cache: Default::default(),
            recent: Default::default(),
            inertia_start: Default::default(),
        }
    }

    pub(crate) fn in_fit(&self, i: usize) -> bool {
        self.train.as_ref().map(|t| t[i]).unwrap_or(true)
    }

    /// Weighted residual vector over the usable samples (stride applied).
    /// Only the samples it reads are predicted ([`model::predict_every`]).
    pub fn weighted(&self, p: &Params) -> Option<DVector<f64>> {
        let y = self.predict_every(p, self.stride)?;
        let s = self.series;
        let mut v = Vec::with_capacity(y.len() * 3 + 3);
        for (i, yi) in (0..).step_by(self.stride).zip(y.iter()) {
            if !self.in_fit(i) {
                continue;
            }
            for a in 0..3 {
                if s.valid[i][a] {
                    v.push((s.rate[i][a] - yi[a]) * self.weight[a]);
                }
            }
        }
        Some(DVector::from_vec(v))
    }

    /// The fit's own cost at `p`: the weighted squares of the samples it reads (of every
    /// `stride`-th sample, those it may use), a strided prediction. What scores starts and
    /// scans a change time, where the full-resolution [`Problem::chi2`] would cost a
    /// prediction of every sample for the same comparison.
    pub fn cost(&self, p: &Params) -> Option<f64> {
        Some(self.weighted(p)?.norm_squared())
    }

    /// Chi-square per block of samples (`block[i]`, blocks numbered from 0 up to
    /// `blocks`), all samples, full resolution: the held-out score.
    pub fn chi2_by_block(&self, p: &Params, block: &[usize], blocks: usize) -> Option<Vec<f64>> {
        let r = self.residual(p)?;
        let mut out = vec![0.0; blocks];
        for (i, ri) in r.iter().enumerate() {
            for a in 0..3 {
                if self.series.valid[i][a] {
                    out[block[i]] += (ri[a] * self.weight[a]).powi(2);
                }
            }
        }
        Some(out)
    }

    /// Chi-square (sum of weighted squares) of `p` at full resolution, over the samples
    /// the fit may use.
    pub fn chi2(&self, p: &Params) -> Option<f64> {
        let r = self.residual(p)?;
        let mut s = 0.0;
        for (i, ri) in r.iter().enumerate() {
            if !self.in_fit(i) {
                continue;
            }
            for a in 0..3 {
                if self.series.valid[i][a] {
                    s += (ri[a] * self.weight[a]).powi(2);
                }
            }
        }
        Some(s)
    }

    /// Chi-square between the predictions of `p` and `q` at full resolution, over the
    /// samples the fit may use, weighted as [`Problem::chi2`]: how far apart the recording
    /// sees the two models.
    pub fn chi2_between(&self, p: &Params, q: &Params) -> Option<f64> {
        let (a, b) = (self.predict_every(p, 1)?, self.predict_every(q, 1)?);
        let mut s = 0.0;
        for (i, (ya, yb)) in a.iter().zip(b.iter()).enumerate() {
            if !self.in_fit(i) {
                continue;
            }
            for k in 0..3 {
                if self.series.valid[i][k] {
                    s += ((ya[k] - yb[k]) * self.weight[k]).powi(2);
                }
            }
        }
        Some(s)
    }

    /// Number of usable scalar residuals at full resolution.
    pub fn n_obs(&self) -> usize {
        self.series
            .valid
            .iter()
            .map(|v| v.iter().filter(|&&b| b).count())
            .sum()
    }
}

/// A parameterised family of models: `theta -> Params`.
pub struct Family<'f> {
    pub apply: Box<dyn Fn(&[f64]) -> Option<Params> + 'f>,
    /// Finite-difference step per parameter.
    pub step: Vec<f64>,
    /// Lower and upper bounds per parameter (the fit is clamped inside them).
    pub lo: Vec<f64>,
    pub hi: Vec<f64>,
    /// Parameters whose Jacobian columns are computed once per fit, at its start: a joint
    /// fit's nuisances (their effect hardly depends on the others).
    pub frozen: Vec<bool>,
    /// Parameters from this index on are the state nuisances, three per reset (x, y, z
    /// rate). On a planar craft the x and y ones move nothing (the bearing holds those
    /// axes), so their columns are known to be zero without a prediction.
    pub nuisance_from: usize,
    /// Parameters whose Jacobian column is taken by central differences (an effect whose
    /// rates have kinks in them, `Effect::kinked`); the others by forward differences.
    pub two_sided: Vec<bool>,
    /// Parameters the fit never steps: held where they start, their Jacobian columns
    /// taken once, at the end, for the errors (the checks' Wald tests read those; the
    /// report's errors of a held change time and of the effects named with it come from
    /// its profile instead, `crate::profile`). A mass-property change's time is searched
    /// outside the fit (`select::fit_with_starts`): its column is a difference across
    /// whatever firing the step happens to cross, so a fit that stepped it moved it by
    /// as much as a second on a change of rounding.
    pub held: Vec<bool>,
}

impl Family<'_> {
    /// Whether parameter `j`'s column is computed once per fit ([`Family::frozen`]).
    pub fn frozen(&self, j: usize) -> bool {
        self.frozen.get(j).copied().unwrap_or(false)
    }

    /// Whether parameter `j` is held where it starts ([`Family::held`]).
    pub fn held(&self, j: usize) -> bool {
        self.held.get(j).copied().unwrap_or(false)
    }

    /// Moves `theta` inside the bounds: where every fit starts and steps.
    pub fn clamp(&self, theta: &mut [f64]) {
        for (j, t) in theta.iter_mut().enumerate() {
            *t = t.clamp(self.lo[j], self.hi[j]);
        }
    }
}

/// Result of a fit.
#[derive(Clone, Debug)]
pub struct FitResult {
    pub theta: Vec<f64>,
    pub stderr: Vec<f64>,
    /// The parameters' covariance, scaled like `stderr` (NaN rows and columns for the dead
    /// ones): a test of several parameters at once needs their correlations.
    pub cov: DMatrix<f64>,
    pub params: Params,
    /// Chi-square at full resolution.
    pub chi2: f64,
    pub iterations: usize,
    /// The fit at its end, linear in the parameters it stepped, when it held some
    /// ([`Family::held`]): what a scan of a held parameter profiles the others with.
    pub linearised: Option<std::rc::Rc<crate::profile::Linearised>>,
}

/// Levenberg-Marquardt from `theta0`. Returns None when the start is not predictable.
pub fn fit(prob: &Problem, fam: &Family, theta0: &[f64], max_iter: usize) -> Option<FitResult> {
    let k = theta0.len();
    let mut theta = theta0.to_vec();
    fam.clamp(&mut theta);
    let mut r = prob.weighted(&(fam.apply)(&theta)?)?;
    let mut cost = r.norm_squared();
    let mut lambda = 1e-3;
    let mut it = 0;
    let mut jac = DMatrix::zeros(r.len(), k);
    let mut have_jac = false;
    // Parameters no usable sample depends on (an axis the craft cannot turn about, a
    // masked gyro): held where they start and reported with an unknown (NaN) error.
    let mut dead = vec![false; k];
    // what the steps leave where it is: the dead and the held parameters
    let held: Vec<bool> = (0..k).map(|j| fam.held(j)).collect();
    let mut pinned = held.clone();
    while it < max_iter {
        it += 1;
        if !have_jac {
            let first = it == 1;
            let new = jacobian(prob, fam, &theta, &r, first)?;
            if first {
                jac = new;
                for (j, d) in dead.iter_mut().enumerate() {
                    *d = !held[j] && jac.column(j).iter().all(|&v| v == 0.0);
                    pinned[j] |= *d;
                }
            } else {
                for j in (0..k).filter(|&j| !fam.frozen(j)) {
                    jac.set_column(j, &new.column(j));
                }
            }
            have_jac = true;
        }
        let jtj = pin_dead(jac.transpose() * &jac, &pinned);
        let mut jtr = jac.transpose() * &r;
        for (j, _) in pinned.iter().enumerate().filter(|d| *d.1) {
            jtr[j] = 0.0;
        }
        let mut improved = false;
        for _ in 0..8 {
            let mut a = jtj.clone();
            for j in 0..k {
                a[(j, j)] += lambda * jtj[(j, j)].max(1e-12);
            }
            let Some(delta) = a.cholesky().map(|c| c.solve(&(-&jtr))) else {
                lambda *= 10.0;
                continue;
            };
            let mut cand: Vec<f64> = theta.iter().zip(delta.iter()).map(|(t, d)| t + d).collect();
            fam.clamp(&mut cand);
            let rc = (fam.apply)(&cand).and_then(|p| prob.weighted(&p));
            if let Some(rc) = rc {
                let c = rc.norm_squared();
                if c < cost {
                    let rel = (cost - c) / cost.max(1e-300);
                    theta = cand;
                    r = rc;
                    cost = c;
                    lambda = (lambda / 5.0).max(1e-9);
                    improved = true;
                    have_jac = false;
                    if rel < 1e-7 {
                        it = max_iter;
                    }
                    break;
                }
            }
            lambda *= 10.0;
        }
        if !improved {
            break;
        }
    }
    if !have_jac {
        let new = jacobian(prob, fam, &theta, &r, false)?;
        for j in (0..k).filter(|&j| !fam.frozen(j)) {
            jac.set_column(j, &new.column(j));
        }
    }
    // the held parameters' columns, for the errors only; one no sample depends on is dead
    for j in (0..k).filter(|&j| held[j]) {
        let col = column(prob, fam, &theta, &r, j)?;
        dead[j] = col.iter().all(|&v| v == 0.0);
        jac.set_column(j, &col);
    }
    let jtj = pin_dead(jac.transpose() * &jac, &dead);
    let cov = jtj
        .clone()
        .try_inverse()
        .unwrap_or_else(|| DMatrix::from_diagonal_element(k, k, f64::INFINITY));
    // weights already use the long-run variance; the stride thins the data, so the
    // information is scaled back up by the stride; residual excess over 1 inflates.
    let dof = (r.len() as f64 - k as f64).max(1.0);
    let excess = (cost / dof).max(1.0);
    let scale = excess / prob.stride as f64;
    let stderr = (0..k)
        .map(|j| {
            if dead[j] {
                f64::NAN
            } else {
                (cov[(j, j)] * scale).max(0.0).sqrt()
            }
        })
        .collect();
    let mut cov = cov * scale;
    for (j, _) in dead.iter().enumerate().filter(|d| *d.1) {
        cov.row_mut(j).fill(f64::NAN);
        cov.column_mut(j).fill(f64::NAN);
    }
    let params = (fam.apply)(&theta)?;
    // with every sample in the fit, `r` holds the same weighted residuals `chi2` sums, in
    // its order: the sum is the same number without predicting again
    let chi2 = if prob.stride == 1 && prob.train.is_none() {
        r.iter().map(|x| x * x).sum()
    } else {
        prob.chi2(&params)?
    };
    Some(FitResult {
        theta,
        stderr,
        cov,
        params,
        chi2,
        iterations: it,
        linearised: held
            .iter()
            .any(|&h| h)
            .then(|| {
                let stepped: Vec<usize> = (0..k).filter(|&j| !held[j] && !dead[j]).collect();
                crate::profile::Linearised::new(&jac, &stepped, scale)
            })
            .flatten()
            .map(std::rc::Rc::new),
    })
}

/// The covariance of parameters `from..from + n` of `cov` (empty when `cov` does not hold
/// them: a fit that failed).
pub fn cov_block(cov: &DMatrix<f64>, from: usize, n: usize) -> DMatrix<f64> {
    if from + n <= cov.nrows() && from + n <= cov.ncols() {
        cov.view((from, from), (n, n)).into_owned()
    } else {
        DMatrix::zeros(0, 0)
    }
}

/// How many of the parameters with these standard errors the data could identify: those
/// some sample depends on (a dead parameter's error is NaN, see [`fit`]). This, not the
/// layout's length, is the BIC's k and the Wald test's degrees of freedom: a planar craft's
/// inertia has one identifiable term (Izz) of six, and charging it six would let a
/// thruster-scale family of eight stand in for it.
pub fn identifiable(stderr: &[f64]) -> usize {
    stderr.iter().filter(|s| !s.is_nan()).count()
}

/// The normal matrix with every dead parameter's row and column replaced by the identity's,
/// so the step leaves it where it is and the others' covariance is that of the live ones.
fn pin_dead(mut jtj: DMatrix<f64>, dead: &[bool]) -> DMatrix<f64> {
    for (j, _) in dead.iter().enumerate().filter(|d| *d.1) {
        jtj.row_mut(j).fill(0.0);
        jtj.column_mut(j).fill(0.0);
        jtj[(j, j)] = 1.0;
    }
    jtj
}

/// Finite-difference Jacobian, every column (`all`) or those not [`Family::frozen`]; the
/// others and the [`Family::held`] ones are left zero. See [`column`].
fn jacobian(
    prob: &Problem,
    fam: &Family,
    theta: &[f64],
    r0: &DVector<f64>,
    all: bool,
) -> Option<DMatrix<f64>> {
    let k = theta.len();
    let mut jac = DMatrix::zeros(r0.len(), k);
    for j in (0..k).filter(|&j| !fam.held(j) && (all || !fam.frozen(j))) {
        jac.set_column(j, &column(prob, fam, theta, r0, j)?);
    }
    Some(jac)
}

/// Finite-difference column `j` of the Jacobian at `theta` (weighted residuals `r0`):
/// forward differences, central ones for the [`Family::two_sided`] parameters whose step
/// fits inside the bounds both ways; zero without a prediction for a planar craft's x
/// and y rate nuisances.
fn column(
    prob: &Problem,
    fam: &Family,
    theta: &[f64],
    r0: &DVector<f64>,
    j: usize,
) -> Option<DVector<f64>> {
    if prob.plant.planar && j >= fam.nuisance_from && (j - fam.nuisance_from) % 3 != 2 {
        return Some(DVector::zeros(r0.len()));
    }
    let mut t = theta.to_vec();
    let mut h = fam.step[j];
    let central = fam.two_sided.get(j).copied().unwrap_or(false)
        && t[j] - h >= fam.lo[j]
        && t[j] + h <= fam.hi[j];
    if t[j] + h > fam.hi[j] {
        h = -h;
    }
    // the weighted residuals at `t`, None unless they are `r0`'s samples
    let at = |t: &[f64]| {
        prob.weighted(&(fam.apply)(t)?)
            .filter(|r| r.len() == r0.len())
    };
    t[j] += h;
    let rj = at(&t)?;
    Some(if central {
        t[j] = theta[j] - h;
        (rj - at(&t)?) / (2.0 * h)
    } else {
        (rj - r0) / h
    })
}
