//! The Gauss-Newton step of the output-error fit: predicted rates are each window's initial
//! rate plus the accumulated increments of [`Rigid`], seen through the rate sensor's response;
//! residuals and sensitivities are whitened by the noise model and summed into normal
//! equations, with each window's initial rate eliminated on the spot (a Schur complement per
//! window and axis), so the information matrix is the profile information of the parameters.
//! The same sums carry extra columns (per-thruster thrust scale, valve timing) for the
//! consistency test and the thrust-uncertainty term, at no second pass.
use super::flight::{Flight, Interval, Wrench};
use super::noise::ArNoise;
use super::rigid::{Rigid, Term, TrajectoryTerms};
use nalgebra::{DMatrix, DVector, Matrix3, Vector3};

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

    /// The measured value at sample `k` of a quantity that is linear between samples.
    fn at(self, x: &[f64], k: usize) -> f64 {
        match self {
            SensorResponse::Point => x[k],
            SensorResponse::BackwardMean => 0.5 * (x[k - 1] + x[k]),
            SensorResponse::CentralMean => 0.25 * (x[k - 1] + 2.0 * x[k] + x[k + 1]),
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
}

/// What is fitted and how.
pub struct Problem<'a> {
    pub flight: &'a Flight,
    pub intervals: &'a [Interval],
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
    /// Body rate at every sample for the gyroscopic and damping terms: first the measured
    /// rates (zero on unmeasured axes), then the fitted model's: a measured rate in the model's
    /// own regressor would correlate it with the same sample's noise.
    pub trajectory: Vec<Vector3<f64>>,
    pub noise: [ArNoise; 3],
}

/// One window's and axis' sums for its initial rate (whitened, unweighted).
#[derive(Clone, Debug)]
struct NuisanceSums {
    nn: f64,
    nx: DVector<f64>,
    ne: f64,
}

/// Normal equations after eliminating the initial rates, weighted by each axis' innovation
/// variance; columns are the terms, then the extras.
#[derive(Clone, Debug)]
pub struct Normal {
    pub info: DMatrix<f64>,
    pub score: DVector<f64>,
    nuisance: Vec<[Option<NuisanceSums>; 3]>,
    /// Per axis: unwhitened residual series per window (for the noise fit).
    pub residuals: [Vec<Vec<f64>>; 3],
    /// Per axis: sum of squared whitened residuals and their count.
    pub innovations: [(f64, usize); 3],
    /// The model's body rate at each fitted sample (before the step).
    pub fitted: Vec<(usize, Vector3<f64>)>,
}

impl Problem<'_> {
    pub fn columns(&self) -> usize {
        self.terms.len() + self.extras.len()
    }

    fn extra_response(&self, rigid: &Rigid, e: Extra, iv: &Interval) -> Vector3<f64> {
        match e {
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

    /// Accumulates the whitened normal equations at `state`.
    pub fn accumulate(&self, state: &State) -> Normal {
        let nc = self.columns();
        let nt = self.terms.len();
        let mut info = DMatrix::<f64>::zeros(nc, nc);
        let mut score = DVector::<f64>::zeros(nc);
        let mut nuisance = Vec::with_capacity(self.windows.len());
        let mut residuals: [Vec<Vec<f64>>; 3] = Default::default();
        let mut innovations = [(0.0, 0usize); 3];
        let mut fitted = Vec::new();
        let i_gyro = state.rigid.inertia_or(&self.inertia_fallback);
        let iei = Rigid::inertia_derivatives(&i_gyro);
        let (t0, t1) = self.sensor.trim();
        for (w, &(s, e)) in self.windows.iter().enumerate() {
            let n = e - s;
            // Accumulated increments (point values) and their sensitivities, per axis.
            let mut cum = [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
            let mut sens: [DMatrix<f64>; 3] = std::array::from_fn(|_| DMatrix::zeros(n, nc));
            let mut c = Vector3::zeros();
            let mut dcol = vec![Vector3::<f64>::zeros(); nc];
            for k in s..e {
                let r = k - s;
                for a in 0..3 {
                    cum[a][r] = c[a];
                    for (col, v) in dcol.iter().enumerate() {
                        sens[a][(r, col)] = v[a];
                    }
                }
                if k + 1 < e {
                    let iv = &self.intervals[k];
                    let tr = TrajectoryTerms::trapezoid(
                        &state.trajectory[k],
                        &state.trajectory[k + 1],
                        &i_gyro,
                        iv.dt,
                    );
                    c += state.rigid.increment(iv, &tr);
                    state.rigid.add_sensitivities(&self.terms, iv, &tr, &iei, &mut dcol[..nt]);
                    for (x, extra) in self.extras.iter().enumerate() {
                        dcol[nt + x] += self.extra_response(&state.rigid, *extra, iv);
                    }
                }
            }
            let w0 = state.omega0[w];
            for k in s..e {
                let r = k - s;
                let model = w0 + Vector3::new(cum[0][r], cum[1][r], cum[2][r]);
                fitted.push((k, Vector3::from_fn(|a, _| if self.axes[a] { model[a] } else { 0.0 })));
            }
            let mut per_axis: [Option<NuisanceSums>; 3] = [None, None, None];
            if n <= t0 + t1 {
                nuisance.push(per_axis);
                continue;
            }
            let rows = t0..n - t1;
            for a in 0..3 {
                if !self.axes[a] {
                    continue;
                }
                let noise = &state.noise[a];
                let res: Vec<f64> = rows
                    .clone()
                    .map(|r| self.flight.rate[s + r][a] - w0[a] - self.sensor.at(&cum[a], r))
                    .collect();
                let cols: Vec<Vec<f64>> = (0..nc)
                    .map(|col| {
                        let x: Vec<f64> = sens[a].column(col).iter().copied().collect();
                        rows.clone().map(|r| self.sensor.at(&x, r)).collect()
                    })
                    .collect();
                let we = noise.whiten(&res);
                if we.is_empty() {
                    continue;
                }
                let wn = noise.whiten(&vec![1.0; res.len()]);
                let wx: Vec<Vec<f64>> = cols.iter().map(|x| noise.whiten(x)).collect();
                let m = we.len();
                let mut sums = NuisanceSums {
                    nn: wn.iter().map(|v| v * v).sum(),
                    nx: DVector::from_fn(nc, |col, _| (0..m).map(|i| wn[i] * wx[col][i]).sum()),
                    ne: (0..m).map(|i| wn[i] * we[i]).sum(),
                };
                if sums.nn <= 0.0 {
                    sums.nn = f64::INFINITY;
                }
                let inv_var = 1.0 / noise.sigma2.max(1e-300);
                for i in 0..nc {
                    let xe: f64 = (0..m).map(|r| wx[i][r] * we[r]).sum();
                    score[i] += inv_var * (xe - sums.nx[i] * sums.ne / sums.nn);
                    for j in 0..=i {
                        let xx: f64 = (0..m).map(|r| wx[i][r] * wx[j][r]).sum();
                        let v = inv_var * (xx - sums.nx[i] * sums.nx[j] / sums.nn);
                        info[(i, j)] += v;
                        if i != j {
                            info[(j, i)] += v;
                        }
                    }
                }
                // Innovations at the optimal initial rate for the current parameters.
                let ss: f64 = we.iter().map(|v| v * v).sum::<f64>() - sums.ne * sums.ne / sums.nn;
                innovations[a].0 += ss.max(0.0);
                innovations[a].1 += m;
                residuals[a].push(res);
                per_axis[a] = Some(sums);
            }
            nuisance.push(per_axis);
        }
        Normal {
            info,
            score,
            nuisance,
            residuals,
            innovations,
            fitted,
        }
    }

    /// Applies the Gauss-Newton step `delta` (one entry per term) and the matching initial
    /// rates; returns the step's size relative to the parameters' standard errors.
    pub fn apply_step(&self, state: &mut State, normal: &Normal, delta: &DVector<f64>) {
        let nt = self.terms.len();
        for (w, per_axis) in normal.nuisance.iter().enumerate() {
            for a in 0..3 {
                if let Some(s) = &per_axis[a] {
                    if s.nn.is_finite() {
                        let dx: f64 = (0..nt).map(|i| s.nx[i] * delta[i]).sum();
                        state.omega0[w][a] += (s.ne - dx) / s.nn;
                    }
                }
            }
        }
        for (i, t) in self.terms.iter().enumerate() {
            state.rigid.step(*t, delta[i]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::flight_id::flight::{intervals, unit_wrench, windows, Command};
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
                    x = x.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                    word = ((x >> 33) as u16) & 0x0fff;
                }
                Command::Word(word)
            })
            .collect();
        let mut flight = Flight {
            time_s: (0..n).map(|k| k as f64 * 1e-3).collect(),
            rate: vec![[0.0; 3]; n],
            axes: [true; 3],
            commands,
            period_s: 1e-3,
            from_gyro_counts: false,
        };
        let ivs = intervals(&flight, &sat, 0.0);
        let wins = windows(&flight, 20);
        let j_nom = sat.inertia_matrix().try_inverse().unwrap();
        let truth = Rigid {
            dynamics: Dynamics::Full,
            j: j_nom * 1.1,
            dc: Vector3::new(0.002, -0.001, 0.003),
            d: Vector3::zeros(),
            b: 0.0,
        };
        let terms: Vec<Term> = (0..6).map(Term::InvInertia).chain((0..3).map(Term::Com)).collect();
        let problem = |f: &Flight, ivs: &[Interval], wins: &[(usize, usize)]| -> (Vec<Term>, Matrix3<f64>) {
            let _ = (f, ivs, wins);
            (terms.clone(), sat.inertia_matrix())
        };
        let (terms, i_nom) = problem(&flight, &ivs, &wins);
        let unit: Vec<_> = (0..12).map(|i| unit_wrench(&sat, i)).collect();
        // Data from the truth (trajectory zero: no gyroscopic term).
        let mut st = State {
            rigid: truth,
            omega0: vec![Vector3::new(0.1, -0.2, 0.05)],
            trajectory: vec![Vector3::zeros(); n],
            noise: std::array::from_fn(|_| ArNoise::white(1.0)),
        };
        let p = Problem { flight: &flight, intervals: &ivs, windows: &wins, sensor: SensorResponse::Point, axes: [true; 3], terms: terms.clone(), extras: vec![], inertia_fallback: i_nom, unit_wrenches: unit.clone() };
        // Noise-free rates of the truth, by the same model: omega0 + accumulated increments.
        let tr0 = crate::flight_id::rigid::TrajectoryTerms::trapezoid(&Vector3::zeros(), &Vector3::zeros(), &i_nom, 1e-3);
        let mut w = st.omega0[0];
        for k in 0..n {
            flight.rate[k] = [w.x, w.y, w.z];
            if k + 1 < n {
                w += truth.increment(&ivs[k], &tr0);
            }
        }
        let p = Problem { flight: &flight, intervals: &ivs, windows: &wins, sensor: SensorResponse::Point, axes: [true; 3], terms, extras: vec![], inertia_fallback: i_nom, unit_wrenches: unit };
        let mut st = State {
            rigid: Rigid { j: j_nom, dc: Vector3::zeros(), ..truth },
            omega0: vec![Vector3::zeros()],
            trajectory: vec![Vector3::zeros(); n],
            noise: std::array::from_fn(|_| ArNoise::white(1.0)),
        };
        for _ in 0..6 {
            let normal = p.accumulate(&st);
            let delta = normal.info.clone().lu().solve(&normal.score).unwrap();
            p.apply_step(&mut st, &normal, &delta);
        }
        assert!((st.rigid.j - truth.j).norm() < 1e-6 * truth.j.norm(), "{:?}", st.rigid.j);
        assert!((st.rigid.dc - truth.dc).norm() < 1e-9);
    }
}
