//! The Gauss-Newton step of the output-error fit: predicted rates are each window's initial
//! rate plus the accumulated increments of [`Rigid`], seen through the rate sensor's response;
//! residuals and sensitivities are whitened by the noise model and summed into normal
//! equations, with each window's initial rate eliminated on the spot (a Schur complement per
//! window and axis), so the information matrix is the profile information of the parameters.
//! The same sums carry extra columns (per-thruster thrust scale, valve timing) for the
//! consistency test and the thrust-uncertainty term, at no second pass.
use super::flight::Flight;
use super::intervals::{Interval, Intervals, Wrench};
use super::noise::{ArNoise, Whitener};
use super::rigid::{Dynamics, Rigid, Term, TrajectoryTerms};
use nalgebra::{DMatrix, DVector, Matrix3, Vector3};

/// Largest angle (rad) a 3-D craft turns in one step of the fit's integration. Heun's
/// trapezoid for the gyroscopic term errs by about `(omega dt)^3` per step, which a long,
/// fast-turning flight sees: a random 3-D craft spinning at 10.7 rad/s sampled at 250 Hz
/// (0.043 rad a sample; `random_craft_flights 3d-many 1 60021`) came out `inconsistent`
/// with its inertia 3-4 sigma off. At 1 kHz this leaves craft turning below 2.5 rad/s, and
/// so every SPHERES maneuver, at one step a sample.
pub const MAX_STEP_TURN_RAD: f64 = 2.5e-3;

/// Most substeps of one interval (the cost of a sample grows with them).
pub const MAX_SUBSTEPS: usize = 64;

/// Substeps for an interval of `dt` s starting at the measured rate `measured` (axes not
/// measured are NaN, and the model's rate `model` stands in on them): enough that each turns
/// through at most [`MAX_STEP_TURN_RAD`], but never more than [`MAX_SUBSTEPS`] (past
/// 64 x 2.5 mrad a sample, e.g. 7.8 rad/s at 50 Hz, the steps turn farther). From the data
/// where there are data, so that the model does not change its steps while the fit moves.
fn substeps(measured: &[f64; 3], model: &Vector3<f64>, dt: f64) -> usize {
    let rate = (0..3)
        .map(|a| {
            let v = if measured[a].is_finite() {
                measured[a]
            } else {
                model[a]
            };
            v * v
        })
        .sum::<f64>()
        .sqrt();
    let m = (rate * dt / MAX_STEP_TURN_RAD).ceil();
    if m.is_finite() && m > 1.0 {
        (m as usize).min(MAX_SUBSTEPS)
    } else {
        1
    }
}

/// How the measured rate relates to the body rate.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SensorResponse {
    /// The rate at the sample instant (a gyro).
    Point,
    /// The mean rate over the previous interval: attitude differenced over one sample.
    BackwardMean,
    /// The mean rate over the previous and next intervals: attitude central-differenced.
    CentralMean,
}

impl SensorResponse {
    pub const ALL: [SensorResponse; 3] = [
        SensorResponse::Point,
        SensorResponse::BackwardMean,
        SensorResponse::CentralMean,
    ];

    pub fn name(self) -> &'static str {
        match self {
            SensorResponse::Point => "point",
            SensorResponse::BackwardMean => "backward_mean",
            SensorResponse::CentralMean => "central_mean",
        }
    }

    /// Samples lost at the start and the end of a window.
    fn trim(self) -> (usize, usize) {
        match self {
            SensorResponse::Point => (0, 0),
            SensorResponse::BackwardMean => (1, 0),
            SensorResponse::CentralMean => (1, 1),
        }
    }

    /// The measured value at sample `k` of a quantity that is linear between samples and is
    /// `x(i)` at sample `i` (asked at most one sample either side, within the trim).
    fn at(self, k: usize, x: impl Fn(usize) -> f64) -> f64 {
        match self {
            SensorResponse::Point => x(k),
            SensorResponse::BackwardMean => 0.5 * (x(k - 1) + x(k)),
            SensorResponse::CentralMean => 0.25 * (x(k - 1) + 2.0 * x(k) + x(k + 1)),
        }
    }
}

/// An extra column: a direction the model leaves out, for the consistency test and the
/// thrust-uncertainty term.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Extra {
    /// Thruster `i`'s thrust scaled (d rate / d relative thrust).
    ThrustScale(usize),
    /// Every valve opening later (per second of delay).
    OpenDelay,
    /// Every valve closing later.
    CloseDelay,
    /// A term the fit holds where it is (a disturbance torque or a yaw damping at zero, a term
    /// the flight does not determine at the model's value) moved off it: for the score tests
    /// and the consider covariance.
    Held(Term),
}

/// What is fitted and how.
pub struct Problem<'a> {
    pub flight: &'a Flight,
    pub intervals: &'a Intervals<'a>,
    pub windows: &'a [(usize, usize)],
    pub sensor: SensorResponse,
    /// Axes whose measured rate enters the fit.
    pub axes: [bool; 3],
    pub terms: Vec<Term>,
    pub extras: Vec<Extra>,
    /// Inertia for the gyroscopic term while the estimate is not positive definite.
    pub inertia_fallback: Matrix3<f64>,
    /// Each thruster's wrench per newton (for [`Extra::ThrustScale`]).
    pub unit_wrenches: Vec<Wrench>,
}

/// Everything that changes during the fit.
#[derive(Clone, Debug)]
pub struct State {
    pub rigid: Rigid,
    /// Initial rate of each window.
    pub omega0: Vec<Vector3<f64>>,
    pub noise: [ArNoise; 3],
}

/// One window's information on its initial rates (measured axes), their cross-information
/// with the columns, and their score: what the step needs to move them with the parameters.
#[derive(Clone, Debug)]
struct NuisanceSums {
    nn_inv: DMatrix<f64>,
    nx: DMatrix<f64>,
    gn: DVector<f64>,
}

/// Normal equations after eliminating the initial rates, weighted by each axis' innovation
/// variance; columns are the terms, then the extras.
#[derive(Clone, Debug)]
pub struct Normal {
    pub info: DMatrix<f64>,
    pub score: DVector<f64>,
    nuisance: Vec<Option<NuisanceSums>>,
    /// Per axis: sum of squared whitened residuals and their count (at the current initial
    /// rates, which converge with the parameters).
    pub innovations: [(f64, usize); 3],
}

/// The model rate's sensitivities at one sample: one column per fitted column.
type Sensitivities = nalgebra::OMatrix<f64, nalgebra::U3, nalgebra::Dyn>;

/// One axis' whitened sums over one window, built a row at a time. Each sum starts where
/// `Iterator::sum` starts and adds in row order, so it equals the sum over whole series.
struct WindowSums<'a> {
    whitener: Whitener<'a>,
    width: usize,
    /// Lower triangle of the whitened columns' products, row-major `width x width`.
    products: Vec<f64>,
    /// Whitened columns times the whitened residual.
    score: Vec<f64>,
    /// Squared whitened residuals.
    squares: f64,
    /// Whitened rows so far.
    rows: usize,
    /// Columns with a whitened value other than zero.
    nonzero: Vec<bool>,
}

impl<'a> WindowSums<'a> {
    fn new(noise: &'a ArNoise, width: usize) -> Self {
        let zero: f64 = std::iter::empty::<f64>().sum();
        WindowSums {
            whitener: noise.whitener(width + 1),
            width,
            products: vec![zero; width * width],
            score: vec![zero; width],
            squares: zero,
            rows: 0,
            nonzero: vec![false; width],
        }
    }

    /// Takes one row: the residual, then each column's response (`row`, `width + 1` long);
    /// `white` is scratch of the same length.
    fn push(&mut self, row: &[f64], white: &mut [f64]) {
        if !self.whitener.push(row, white) {
            return;
        }
        let (e, x) = (white[0], &white[1..]);
        self.squares += e * e;
        self.rows += 1;
        for (i, &xi) in x.iter().enumerate() {
            self.nonzero[i] |= xi != 0.0;
            self.score[i] += xi * e;
            let products = &mut self.products[i * self.width..i * self.width + i + 1];
            for (p, &xj) in products.iter_mut().zip(&x[..=i]) {
                *p += xi * xj;
            }
        }
    }
}

impl Problem<'_> {
    pub fn columns(&self) -> usize {
        self.terms.len() + self.extras.len()
    }

    fn extra_response(
        &self,
        rigid: &Rigid,
        e: Extra,
        iv: &Interval,
        tr: &TrajectoryTerms,
        iei: &[Matrix3<f64>; 6],
    ) -> Vector3<f64> {
        match e {
            Extra::Held(term) => {
                let mut out = [Vector3::zeros()];
                rigid.add_sensitivities(&[term], iv, tr, iei, &mut out);
                out[0]
            }
            Extra::ThrustScale(i) => {
                let u = &self.unit_wrenches[i];
                let s = iv.thruster_impulse[i];
                rigid.wrench_response(&Wrench {
                    torque: u.torque * s,
                    force: u.force * s,
                })
            }
            Extra::OpenDelay => rigid.wrench_response(&iv.open_edges),
            Extra::CloseDelay => rigid.wrench_response(&iv.close_edges),
        }
    }

    /// Integrates window `w` from its initial rate with its sensitivities (columns: terms,
    /// extras, initial rates of the measured axes), handing each sample's model rate and
    /// sensitivities to `each` in order. Heun's trapezoid for the gyroscopic and damping terms,
    /// in [`substeps`] equal parts of an interval where the craft turns fast; the
    /// sensitivities follow the variational equation, so the initial rates and the
    /// parameters act on every axis through the gyroscopic coupling as they do on the craft.
    /// Without `with_sensitivities` they stay at their start (the rates are the same).
    fn propagate(
        &self,
        state: &State,
        w: usize,
        with_sensitivities: bool,
        mut each: impl FnMut(&Vector3<f64>, &Sensitivities),
    ) {
        let i_gyro = &state.rigid.inertia_or(&self.inertia_fallback);
        let iei = &Rigid::inertia_derivatives(i_gyro);
        let nc = self.columns();
        let nt = self.terms.len();
        let rigid = &state.rigid;
        let (s, e) = self.windows[w];
        let mut wk = state.omega0[w];
        let mut sk = Sensitivities::zeros(nc + self.measured_axes().len());
        for (j, &a) in self.measured_axes().iter().enumerate() {
            sk[(a, nc + j)] = 1.0;
        }
        let mut direct = vec![Vector3::<f64>::zeros(); nc];
        for k in s..e {
            each(&wk, &sk);
            if k + 1 == e {
                break;
            }
            let whole = self.intervals.at(k);
            let m = match rigid.dynamics {
                Dynamics::Full => substeps(&self.flight.rate.at(k), &wk, whole.dt),
                Dynamics::Yaw => 1,
            };
            let part = if m == 1 { whole } else { whole.part(m) };
            let iv = &part;
            for _ in 0..m {
                let euler = TrajectoryTerms::trapezoid(&wk, &wk, i_gyro, iv.dt);
                let predicted = wk + rigid.increment(iv, &euler);
                let tr = TrajectoryTerms::trapezoid(&wk, &predicted, i_gyro, iv.dt);
                let delta = rigid.increment(iv, &tr);
                if !with_sensitivities {
                    wk += delta;
                    continue;
                }
                direct.iter_mut().for_each(|d| *d = Vector3::zeros());
                rigid.add_sensitivities(&self.terms, iv, &tr, iei, &mut direct[..nt]);
                for (x, extra) in self.extras.iter().enumerate() {
                    direct[nt + x] = self.extra_response(rigid, *extra, iv, &tr, iei);
                }
                let a_k = rigid.rate_jacobian(&(0.5 * (wk + predicted)), i_gyro, iv.dt);
                let propagated = a_k * &sk;
                sk += propagated;
                for (col, d) in direct.iter().enumerate() {
                    for r in 0..3 {
                        sk[(r, col)] += d[r];
                    }
                }
                wk += delta;
            }
        }
    }

    /// The axes whose measured rate enters the fit, in order.
    fn measured_axes(&self) -> Vec<usize> {
        (0..3).filter(|&a| self.axes[a]).collect()
    }

    /// The model's body rate at every sample of every window (unmeasured axes zero), at `state`.
    pub fn model_rates(&self, state: &State) -> Vec<(usize, Vector3<f64>)> {
        let mut out = Vec::new();
        for (w, &(s, _)) in self.windows.iter().enumerate() {
            let mut k = s;
            self.propagate(state, w, false, |omega, _| {
                out.push((
                    k,
                    Vector3::from_fn(|a, _| if self.axes[a] { omega[a] } else { 0.0 }),
                ));
                k += 1;
            });
        }
        out
    }

    /// Accumulates the whitened normal equations at `state`, in one pass over each window:
    /// every sample's residual and sensitivities go through the sensor response and the
    /// whitening filter as they are integrated, so the memory is a few samples, not the window
    /// (the sums are the same, term by term and in the same order, as over whole series).
    pub fn accumulate(&self, state: &State) -> Normal {
        let nc = self.columns();
        let used = self.measured_axes();
        let q = used.len();
        let nall = nc + q;
        let mut info = DMatrix::<f64>::zeros(nc, nc);
        let mut score = DVector::<f64>::zeros(nc);
        let mut nuisance = Vec::with_capacity(self.windows.len());
        let mut innovations = [(0.0, 0usize); 3];
        let (t0, t1) = self.sensor.trim();
        // The last three samples of the model (the sensor responses look one sample around).
        let mut recent_omega = [Vector3::<f64>::zeros(); 3];
        let mut recent_sens: [Sensitivities; 3] =
            std::array::from_fn(|_| Sensitivities::zeros(nall));
        let mut row = vec![0.0; nall + 1];
        let mut white = vec![0.0; nall + 1];
        for (w, &(s, e)) in self.windows.iter().enumerate() {
            let n = e - s;
            if n <= t0 + t1 {
                nuisance.push(None);
                continue;
            }
            let mut axis_sums: Vec<WindowSums> = used
                .iter()
                .map(|&a| WindowSums::new(&state.noise[a], nall))
                .collect();
            let mut k = 0usize;
            self.propagate(state, w, true, |omega, sens| {
                recent_omega[k % 3] = *omega;
                recent_sens[k % 3].copy_from(sens);
                // Row r's response is complete once sample r + t1 is in.
                if k >= t0 + t1 {
                    let r = k - t1;
                    for (sums, &a) in axis_sums.iter_mut().zip(&used) {
                        row[0] = self.flight.rate.at(s + r)[a]
                            - self.sensor.at(r, |i| recent_omega[i % 3][a]);
                        for (col, v) in row[1..].iter_mut().enumerate() {
                            *v = self.sensor.at(r, |i| recent_sens[i % 3][(a, col)]);
                        }
                        sums.push(&row, &mut white);
                    }
                }
                k += 1;
            });
            let mut wn = DMatrix::<f64>::zeros(nall, nall);
            let mut wg = DVector::<f64>::zeros(nall);
            let mut any = false;
            for (sums, &a) in axis_sums.into_iter().zip(&used) {
                if sums.rows == 0 {
                    continue;
                }
                any = true;
                let inv_var = 1.0 / state.noise[a].sigma2.max(1e-300);
                let nonzero: Vec<usize> = (0..nall).filter(|&c| sums.nonzero[c]).collect();
                for (ii, &i) in nonzero.iter().enumerate() {
                    wg[i] += inv_var * sums.score[i];
                    for &j in &nonzero[..=ii] {
                        let v = inv_var * sums.products[i * nall + j];
                        wn[(i, j)] += v;
                        if i != j {
                            wn[(j, i)] += v;
                        }
                    }
                }
                innovations[a].0 += sums.squares;
                innovations[a].1 += sums.rows;
            }
            if !any {
                nuisance.push(None);
                continue;
            }
            // Eliminate the window's initial rates (Schur complement).
            let nn = wn.view((nc, nc), (q, q)).into_owned();
            let nn_inv = match nn.clone().try_inverse() {
                Some(m) => m,
                None => {
                    let ridge = 1e-12 * nn.trace().abs().max(1e-300);
                    (nn + DMatrix::identity(q, q) * ridge)
                        .try_inverse()
                        .unwrap_or(DMatrix::zeros(q, q))
                }
            };
            let nx = wn.view((nc, 0), (q, nc)).into_owned();
            let gn = wg.rows(nc, q).into_owned();
            let ktx = nx.transpose() * &nn_inv;
            info += wn.view((0, 0), (nc, nc)) - &ktx * &nx;
            score += wg.rows(0, nc) - &ktx * &gn;
            nuisance.push(Some(NuisanceSums { nn_inv, nx, gn }));
        }
        Normal {
            info,
            score,
            nuisance,
            innovations,
        }
    }

    /// The unwhitened residuals of `axis` at `state`, window by window, for the noise fit: the
    /// same rows [`Problem::accumulate`] whitens, from windows that have rows past the noise
    /// model's order. One axis at a time, without sensitivities: a whole-flight window holds
    /// one series, not three.
    pub fn residuals(&self, state: &State, axis: usize) -> Vec<Vec<f64>> {
        let (t0, t1) = self.sensor.trim();
        let order = state.noise[axis].order();
        let mut out = Vec::new();
        for (w, &(s, e)) in self.windows.iter().enumerate() {
            let n = e - s;
            if n <= t0 + t1 + order {
                continue;
            }
            let mut series = Vec::with_capacity(n - t0 - t1);
            let mut recent = [0.0; 3];
            let mut k = 0usize;
            self.propagate(state, w, false, |omega, _| {
                recent[k % 3] = omega[axis];
                if k >= t0 + t1 {
                    let r = k - t1;
                    series.push(
                        self.flight.rate.at(s + r)[axis] - self.sensor.at(r, |i| recent[i % 3]),
                    );
                }
                k += 1;
            });
            out.push(series);
        }
        out
    }

    /// Moves the state by `alpha` times the Gauss-Newton step `delta` (the initial rates by
    /// `alpha` times the step that goes with it).
    pub fn apply_step(&self, state: &mut State, normal: &Normal, delta: &DVector<f64>, alpha: f64) {
        let nt = self.terms.len();
        let used: Vec<usize> = (0..3).filter(|&a| self.axes[a]).collect();
        for (w, sums) in normal.nuisance.iter().enumerate() {
            if let Some(s) = sums {
                let dx = s.nx.columns(0, nt) * delta;
                let d0 = &s.nn_inv * (&s.gn - dx);
                for (j, &a) in used.iter().enumerate() {
                    state.omega0[w][a] += alpha * d0[j];
                }
            }
        }
        for (i, t) in self.terms.iter().enumerate() {
            state.rigid.step(*t, alpha * delta[i]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::flight_id::flight::{windows, Command};
    use crate::flight_id::intervals::{unit_wrench, Intervals};
    use crate::flight_id::noise::ArNoise;
    use crate::flight_id::rigid::{Dynamics, Rigid};
    use crate::satellite::Satellite;

    /// The sensitivities are the derivatives of the predicted rates: a Gauss-Newton step
    /// from a perturbed start lands on the truth of noise-free data generated by the model.
    #[test]
    fn gauss_newton_recovers_noise_free_model_data() {
        let sat = Satellite::builtin("sph2").unwrap();
        let n = 3000;
        let mut x = 7u64;
        let mut word = 0u16;
        let commands: Vec<Command> = (0..n)
            .map(|k| {
                if k % 50 == 0 {
                    x = x
                        .wrapping_mul(6364136223846793005)
                        .wrapping_add(1442695040888963407);
                    word = ((x >> 33) as u16) & 0x0fff;
                }
                Command::Word(word)
            })
            .collect();
        let mut flight = Flight {
            time_s: (0..n).map(|k| k as f64 * 1e-3).collect(),
            rate: vec![[0.0; 3]; n].into(),
            axes: [true; 3],
            commands: commands.into(),
            period_s: 1e-3,
            from_gyro_counts: false,
        };
        let ivs = Intervals::new(&flight, &sat, 0.0);
        let wins = windows(&flight, 20, false);
        let j_nom = sat.inertia_matrix().try_inverse().unwrap();
        let truth = Rigid {
            dynamics: Dynamics::Full,
            j: j_nom * 1.1,
            dc: Vector3::new(0.002, -0.001, 0.003),
            d: Vector3::zeros(),
            b: 0.0,
        };
        let terms: Vec<Term> = (0..6)
            .map(Term::InvInertia)
            .chain((0..3).map(Term::Com))
            .collect();
        let i_nom = sat.inertia_matrix();
        let unit: Vec<_> = (0..12).map(|i| unit_wrench(&sat, i)).collect();
        // Noise-free rates of the truth, by the model itself (gyroscopic term included).
        let st = State {
            rigid: truth,
            omega0: vec![Vector3::new(0.5, -0.4, 0.3)],
            noise: std::array::from_fn(|_| ArNoise::white(1.0)),
        };
        let p = Problem {
            flight: &flight,
            intervals: &ivs,
            windows: &wins,
            sensor: SensorResponse::Point,
            axes: [true; 3],
            terms: terms.clone(),
            extras: vec![],
            inertia_fallback: i_nom,
            unit_wrenches: unit.clone(),
        };
        let fitted = p.model_rates(&st);
        for (k, w) in fitted {
            flight.rate.rad_s_mut().unwrap()[k] = [w.x, w.y, w.z];
        }
        // The intervals read the commands and times only; the rates changed.
        let ivs = Intervals::new(&flight, &sat, 0.0);
        let p = Problem {
            flight: &flight,
            intervals: &ivs,
            windows: &wins,
            sensor: SensorResponse::Point,
            axes: [true; 3],
            terms,
            extras: vec![],
            inertia_fallback: i_nom,
            unit_wrenches: unit,
        };
        let mut st = State {
            rigid: Rigid {
                j: j_nom,
                dc: Vector3::zeros(),
                ..truth
            },
            omega0: vec![Vector3::new(0.45, -0.35, 0.25)],
            noise: std::array::from_fn(|_| ArNoise::white(1.0)),
        };
        for _ in 0..8 {
            let normal = p.accumulate(&st);
            let delta = normal.info.clone().lu().solve(&normal.score).unwrap();
            p.apply_step(&mut st, &normal, &delta, 1.0);
        }
        assert!(
            (st.omega0[0] - Vector3::new(0.5, -0.4, 0.3)).norm() < 1e-9,
            "{:?}",
            st.omega0
        );
        assert!(
            (st.rigid.j - truth.j).norm() < 1e-6 * truth.j.norm(),
            "{:?}",
            st.rigid.j
        );
        assert!((st.rigid.dc - truth.dc).norm() < 1e-9);
    }
}
