//! Identification from any flight: centre of mass and inertia (3-D craft) or yaw inertia and
//! the CoM's x and y (planar craft) from measured rates and the commands, by an output-error
//! (prediction-error) fit. An improvement on the seed's per-firing Kalman filter + RLS (seed
//! 4.4), which measured each firing's acceleration from the rate change since one noisy
//! sample and threw the coasts away: here every sample is a measurement of
//! `omega_0 + sum of the model's increments` seen through the rate sensor, so the rate is
//! continuous across word changes, coasts count, short closed-loop pulses count, the
//! gyroscopic term is in the model, and the noise colour is fitted (`noise`). The result is
//! the maximum-likelihood estimate under the fitted noise model, with its Fisher-information
//! covariance; a score test (`consistency`) says when the data disagree with the model.
//!
//! Layout: [`flight`] (what a recording delivered), [`intervals`] (what each interval's commands
//! delivered), [`rigid`] (Euler's equation and its
//! derivatives), [`noise`] (the rate noise model), [`fit`] (the whitened Gauss-Newton
//! normal equations), [`consistency`] (the score tests), and [`identify`] here.
pub mod consistency;
pub mod fit;
pub mod flight;
pub mod intervals;
pub mod noise;
pub mod rigid;

use crate::mass_id::{physical_validity, COM_TERMS, INERTIA_TERMS};
use crate::satellite::Satellite;
use consistency::{score_test, ScoreTest};
use fit::{Extra, Normal, Problem, SensorResponse, State};
use flight::{split_turns, windows, Flight};
use intervals::{unit_wrench, Intervals};
use nalgebra::{DMatrix, DVector, Matrix3, Vector3};
use noise::ArNoise;
use rigid::{sym_basis, Dynamics, Rigid, Term};

/// Settings of [`identify`].
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// Known command-to-thrust delay, ms (a measurement delay is the same on rates).
    pub latency_ms: f64,
    /// The rate sensor's response; None: a point sample for gyro counts (v1), otherwise the
    /// response with the highest likelihood.
    pub sensor: Option<SensorResponse>,
    /// Fit a constant disturbance torque.
    pub disturbance: bool,
    /// Fit a yaw rate damping (planar craft).
    pub damping: bool,
    /// Highest order of the rate-noise model.
    pub max_noise_order: usize,
    /// Level of each consistency test.
    pub consistency_alpha: f64,
    /// Which consistency tests decide to cut a coarse v1 recording's windows at word changes
    /// (see [`identify`]).
    pub cut_rule: CutRule,
    /// Gauss-Newton steps per round of the noise-model fit, at most (3 rounds). A fit whose
    /// next step would still be over [`NOT_CONVERGED_STEP`] sigma has status `not_converged`.
    pub max_steps_per_round: usize,
}

/// When [`identify`] cuts a coarse v1 recording's windows at every word change.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CutRule {
    /// When any consistency test of the fit over whole windows rejects at 5 % (the default).
    AnyTest,
    /// When the valve-timing test alone rejects at 5 %: the rule before issue 22's fix, kept
    /// so that a test can show what it got wrong (closed loop below 1 kHz: flights left
    /// uncut several sigma off with status `ok`).
    TimingOnly,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            latency_ms: 0.0,
            sensor: None,
            disturbance: false,
            damping: false,
            max_noise_order: 10,
            consistency_alpha: 1e-3,
            cut_rule: CutRule::AnyTest,
            max_steps_per_round: 15,
        }
    }
}

/// Why no estimate could be made.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum IdError {
    #[error("invalid input: {0}")]
    Invalid(String),
    #[error("too few samples: no run of {0} consecutive samples with every measured axis")]
    TooFewSamples(usize),
    #[error("singular information: the commands excite none of the terms")]
    Singular,
}

/// The estimate, in the contract's units.
#[derive(Clone, Debug)]
pub struct FlightEstimate {
    /// xx yy zz xy xz yz, kg m^2 (the model's value for terms not identified).
    pub inertia_kgm2: [f64; 6],
    pub inertia_stderr_kgm2: [f64; 6],
    /// CoM minus the model's, mm.
    pub com_offset_mm: [f64; 3],
    pub com_offset_stderr_mm: [f64; 3],
    /// Constant disturbance torque (N m) and its standard error, when fitted.
    pub disturbance_nm: Option<([f64; 3], [f64; 3])>,
    /// Yaw damping (N m s/rad) and its standard error, when fitted.
    pub damping_nms: Option<(f64, f64)>,
    /// Covariance of (inertia 6, CoM mm 3), the stated thrust uncertainty and the held terms'
    /// scales included (consider covariance).
    pub covariance: DMatrix<f64>,
    /// Terms the data do not determine (held at the model), and those a planar craft never
    /// determines.
    pub unobservable: Vec<&'static str>,
    /// Terms a planar craft cannot identify (a subset of `unobservable`).
    pub not_planar: Vec<&'static str>,
    pub sensor: SensorResponse,
    /// Noise model per measured axis.
    pub noise: [Option<ArNoise>; 3],
    pub consistency: Vec<ScoreTest>,
    /// The valve timing between samples was unknown: the windows were cut at word changes.
    pub command_timing_unknown: bool,
    /// Rate samples in the fit (summed over axes).
    pub samples_used: usize,
    pub status: &'static str,
}

/// Level of the consistency tests (any of them) below which a v1 recording's windows are cut
/// at word changes (see [`identify`]).
const CUT_LEVEL: f64 = 0.05;

/// Largest angle, rad, a 3-D craft may turn through in one window of its fit: longer windows
/// are split ([`flight::split_turns`]). Measured on cubesat8 random-PWM flights at 1 kHz
/// (`massid simulate --model examples/models/cubesat8.toml --maneuver random-pwm --seed 1`),
/// one window each: the first 100 s (39 rad) took 4 Gauss-Newton steps a round, 1,000 s
/// (795 rad) up to 13, and 10,000 s (up to 4,254 rad per 1,000 s) did not converge (status
/// `inconsistent`, inertia left at the model's with zero sigma); 1,000 s windows of it did
/// not converge in 15 minutes either. Time alone is not the measure: the phase error a wrong
/// inertia makes grows with the angle turned. A split is not free: the rate's continuity
/// across it carries information (the 1,000 s flight cut into ten 100 s windows had a 1.7x
/// larger Izz sigma), so the limit is what converged. A planar craft's yaw model has no such
/// coupling (10,000 s converged): not split.
pub const MAX_TURN_3D_RAD: f64 = 800.0;

/// Terms a planar craft never identifies.
pub const NOT_PLANAR: [&str; 6] = ["Ixx", "Iyy", "Ixy", "Ixz", "Iyz", "cm_z"];

fn term_name(t: Term) -> &'static str {
    match t {
        Term::InvInertia(m) => INERTIA_TERMS[m],
        Term::Com(a) => COM_TERMS[a],
        Term::Disturbance(a) => ["dist_x", "dist_y", "dist_z"][a],
        Term::Damping => "damping",
    }
}

/// The size beyond which a term's standard error says the data do not determine it.
pub fn term_scale(sat: &Satellite, j_nom: &Matrix3<f64>, t: Term, duration_s: f64) -> f64 {
    let radius = (0..sat.n_thrusters())
        .map(|i| sat.lever_arm_m(i).norm())
        .fold(0.0, f64::max);
    let min_torque = (0..sat.n_thrusters())
        .map(|i| sat.torque_nm(i).norm())
        .filter(|v| *v > 0.0)
        .fold(f64::INFINITY, f64::min);
    let mean_principal = (j_nom[(0, 0)] + j_nom[(1, 1)] + j_nom[(2, 2)]) / 3.0;
    match t {
        Term::InvInertia(m) if m < 3 => 0.5 * j_nom[(m, m)].abs(),
        Term::InvInertia(_) => 0.25 * mean_principal,
        Term::Com(_) => 0.25 * radius,
        Term::Disturbance(_) => {
            0.1 * if min_torque.is_finite() {
                min_torque
            } else {
                1.0
            }
        }
        Term::Damping => sat.inertia_kgm2[2] / duration_s.max(1e-3),
    }
}

fn solve_spd(m: &DMatrix<f64>, b: &DVector<f64>) -> Option<DVector<f64>> {
    m.clone()
        .cholesky()
        .map(|c| c.solve(b))
        .or_else(|| m.clone().lu().solve(b))
}

/// Largest Gauss-Newton step, in its term's sigma, still to take at a fit reported as
/// converged; past it the estimate would still move and the status is `not_converged`.
pub const NOT_CONVERGED_STEP: f64 = 0.1;

/// The Gauss-Newton step at `normal`'s state and its largest size in the terms' sigmas. None
/// when the information is singular or the step not finite.
fn gauss_newton_step(normal: &Normal, nt: usize) -> Option<(DVector<f64>, f64)> {
    let ntt = normal.info.view((0, 0), (nt, nt)).into_owned();
    let delta = solve_spd(&ntt, &normal.score.rows(0, nt).into_owned())?;
    let inv = ntt.try_inverse()?;
    let size = (0..nt)
        .map(|i| delta[i].abs() / inv[(i, i)].max(1e-300).sqrt())
        .fold(0.0, f64::max);
    size.is_finite().then_some((delta, size))
}

/// Smallest eigenvalue, relative to the largest, of the information scaled by the terms'
/// physical scales below which the information is numerically singular: its inverse is then
/// rounding error, not a covariance (a one-thruster planar craft, whose Izz and CoM across the
/// thrust give the same rates: eigenvalues 1e10, -9e-6 and -5e-5, an "inverse" whose diagonal
/// said every term was known to 0.05 %, status `ok` at 86 sigma).
const SINGULAR_INFORMATION: f64 = 1e-12;

/// When the information `ntt` of terms with physical `scales` is numerically singular, the
/// term that takes most part in its least determined combination (to hold at the model).
fn degenerate_term(ntt: &DMatrix<f64>, scales: &[f64]) -> Option<usize> {
    let n = ntt.nrows();
    let scaled = DMatrix::from_fn(n, n, |i, j| ntt[(i, j)] * scales[i] * scales[j]);
    if !scaled.iter().all(|v| v.is_finite()) {
        return n.checked_sub(1);
    }
    let eig = scaled.symmetric_eigen();
    let (k_min, lambda_min) = eig
        .eigenvalues
        .iter()
        .copied()
        .enumerate()
        .min_by(|a, b| a.1.total_cmp(&b.1))?;
    let lambda_max = eig.eigenvalues.iter().copied().fold(0.0, f64::max);
    if lambda_min > SINGULAR_INFORMATION * lambda_max {
        return None;
    }
    eig.eigenvectors
        .column(k_min)
        .iter()
        .map(|v| v.abs())
        .enumerate()
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(i, _)| i)
}

/// Gauss-Newton steps smaller than this (in sigma) are taken whole: the linearisation holds
/// over them. A larger step is taken only as far as it lowers the cost ([`descend`]).
const TRUSTED_STEP: f64 = 1.0;

/// Halvings of a step that does not lower the cost before the round gives up.
const MAX_HALVINGS: usize = 30;

/// The cost the fit minimises: the whitened residuals' sum of squares, each axis weighted
/// by its innovation variance as the normal equations weight it.
fn cost(normal: &Normal, state: &State) -> f64 {
    normal
        .innovations
        .iter()
        .zip(&state.noise)
        .map(|((ss, _), noise)| ss / noise.sigma2.max(1e-300))
        .sum()
}

/// Backtracking along the Gauss-Newton step `delta` (halving it) until the cost is lower than
/// at `normal`'s state. A step far from the estimate can overshoot where the model is not
/// linear in its terms (a heavy craft turned slowly, long windows, a model inertia far off):
/// taken whole, such a step left a random craft's inverse inertia negative and the fit NaN.
/// Gives the sums at the new state, or None (the state unchanged) when no step length
/// lowers the cost.
fn descend(
    problem: &Problem,
    state: &mut State,
    normal: &Normal,
    delta: &DVector<f64>,
) -> Option<Normal> {
    let (start, cost0) = (state.clone(), cost(normal, state));
    if !cost0.is_finite() {
        return None;
    }
    let mut alpha = 1.0;
    for _ in 0..MAX_HALVINGS {
        problem.apply_step(state, normal, delta, alpha);
        let next = problem.accumulate(state);
        if cost(&next, state) < cost0 {
            return Some(next);
        }
        state.clone_from(&start);
        alpha *= 0.5;
    }
    None
}

/// Iterates Gauss-Newton steps and noise-model fits to convergence. Also gives the size (in
/// sigma) of the step still to take at the state returned: small when it converged.
fn converge(problem: &Problem, state: &mut State, opts: &Options) -> Option<(Normal, f64)> {
    let nt = problem.terms.len();
    for round in 0..3 {
        // The sums at the current state when a checked step has computed them already.
        let mut current: Option<Normal> = None;
        for _ in 0..opts.max_steps_per_round {
            let normal = match current.take() {
                Some(n) => n,
                None => problem.accumulate(state),
            };
            let (delta, size) = gauss_newton_step(&normal, nt)?;
            if size < TRUSTED_STEP {
                problem.apply_step(state, &normal, &delta, 1.0);
            } else {
                match descend(problem, state, &normal, &delta) {
                    Some(next) => current = Some(next),
                    None => break,
                }
            }
            if size < 1e-3 {
                break;
            }
        }
        if round == 2 {
            let normal = problem.accumulate(state);
            let pending = gauss_newton_step(&normal, nt).map_or(f64::INFINITY, |(_, size)| size);
            return Some((normal, pending));
        }
        for a in 0..3 {
            if problem.axes[a] {
                let residuals = problem.residuals(state, a);
                let longest = residuals.iter().map(Vec::len).max().unwrap_or(0);
                state.noise[a] = ArNoise::fit(&residuals, opts.max_noise_order.min(longest / 8));
            }
        }
    }
    None
}

/// Identifies the mass properties of `sat`'s craft from `flight`.
pub fn identify(
    flight: &Flight,
    sat: &Satellite,
    opts: &Options,
) -> Result<FlightEstimate, IdError> {
    flight
        .check(sat)
        .map_err(|e| IdError::Invalid(e.to_string()))?;
    if !(opts.latency_ms.is_finite() && (0.0..=10_000.0).contains(&opts.latency_ms)) {
        return Err(IdError::Invalid(format!(
            "latency {} ms: must be in 0..=10000",
            opts.latency_ms
        )));
    }
    let dynamics = if sat.planar {
        Dynamics::Yaw
    } else {
        Dynamics::Full
    };
    let axes: [bool; 3] = match dynamics {
        Dynamics::Full => flight.axes,
        Dynamics::Yaw => [false, false, flight.axes[2]],
    };
    if !axes.iter().any(|&a| a) {
        return Err(IdError::Invalid(if sat.planar {
            "a planar craft needs the z rate".into()
        } else {
            "no measured rate axis".into()
        }));
    }
    let min_len = 20;
    // The fit's windows: runs of samples, a 3-D craft's split by the angle turned.
    let fit_windows = |min_len: usize, cut_at_changes: bool| {
        let w = windows(flight, min_len, cut_at_changes);
        match dynamics {
            Dynamics::Full => split_turns(flight, &w, MAX_TURN_3D_RAD, min_len),
            Dynamics::Yaw => w,
        }
    };
    let wins = fit_windows(min_len, false);
    if wins.is_empty() {
        return Err(IdError::TooFewSamples(min_len));
    }
    let fit = Fit {
        flight,
        sat,
        opts,
        dynamics,
        axes,
    };
    let start = warm_start(&fit, &wins, min_len);
    let (first, _) = identify_in(&fit, &wins, start.as_ref())?;
    // Format v1 logs the thruster word at each sample while SPHERES valves switch on a 1 ms
    // grid: below 1 kHz the recording does not say when in an interval a word changed. When
    // the fit over whole windows then fails any of its consistency tests at a liberal level,
    // the windows are cut at every word change (each change's interval left out, a new
    // initial rate after it): unbiased, at the cost of the impulse information those
    // intervals held. (Format v2 defines each command as held until the next row, so its
    // edges are at the samples.) Every test counts, not the valve-timing one alone: an edge
    // that falls anywhere inside an interval is a per-pulse impulse error, which the
    // per-thruster thrust test (and, summed over pulses, the disturbance test) sees at least
    // as well as a common valve delay. Measured before this rule (cut on the timing test
    // alone; closed loop at 50-250 Hz, 4x gyro noise, seeds 20000-20099): the 2-11 % of
    // flights left uncut all had thrust or disturbance p < 0.05, inertia terms up to 4.4
    // sigma off (RMS error/sigma) and a CoM that looked observable only through the
    // mis-timed pulses (in none of the cut flights), some with status `ok`.
    let coarse = flight.from_gyro_counts && flight.period_s > 1.5e-3;
    // Cutting costs efficiency, not cutting costs bias: the decision uses a liberal level.
    let misfit = first.consistency.iter().any(|t| {
        t.p_value < CUT_LEVEL && (opts.cut_rule == CutRule::AnyTest || t.name == "valve_timing")
    });
    if coarse && misfit {
        let cut = fit_windows(4, true);
        if !cut.is_empty() {
            if let Ok((mut e, _)) = identify_in(&fit, &cut, None) {
                e.command_timing_unknown = true;
                return Ok(e);
            }
        }
    }
    Ok(first)
}

/// Turn limit of the windows whose fit gives a 3-D craft's long windows their starting point
/// (the fit starts there when a window turns more than this).
pub const WARM_TURN_3D_RAD: f64 = 8.0;

/// Where the fit over long windows of a fast-turning 3-D craft starts: the estimate over the
/// same samples in windows of at most [`WARM_TURN_3D_RAD`]. The precession a wrong inertia
/// causes grows with the angle turned, so over hundreds of radians the cost has minima other
/// than the estimate's and Gauss-Newton from the model's inertia (15 % off) does not reach it:
/// on random 3-D craft spinning at 4-11 rad/s (`random_craft_flights 3d-many 30 60000`, seeds
/// 60011, 60016, 60021 and 60028) it stopped `not_converged` 2-15 sigma away, and with 64 rad
/// windows it settled on a wrong minimum (one of them `ok` at 9 sigma). Over windows of 8 rad
/// the same flights converge from the model, and that estimate is close enough for the long
/// windows. None when the split leaves the windows as they are (no window turns more than
/// that, or the runs would be too short), or the short-window fit did not settle or gives no
/// physical inertia.
fn warm_start(fit: &Fit, wins: &[(usize, usize)], min_len: usize) -> Option<Rigid> {
    if fit.dynamics != Dynamics::Full {
        return None;
    }
    let short = split_turns(fit.flight, wins, WARM_TURN_3D_RAD, min_len);
    if short == wins {
        return None;
    }
    let (e, rigid) = identify_in(fit, &short, None).ok()?;
    // Only a settled short fit is a starting point (one that stopped on its step limit is
    // where Gauss-Newton gave up, not an estimate: the model's inertia is then no worse).
    (e.status != "not_converged"
        && e.inertia_kgm2.iter().all(|v| v.is_finite())
        && rigid.j.cholesky().is_some())
    .then_some(rigid)
}

/// What every fit of one [`identify`] call shares: the flight, the model, the options, the
/// dynamics and the measured axes it uses.
#[derive(Clone, Copy)]
struct Fit<'a> {
    flight: &'a Flight,
    sat: &'a Satellite,
    opts: &'a Options,
    dynamics: Dynamics,
    axes: [bool; 3],
}

/// [`identify`] over the given windows, from the model's values or from `start`'s (the terms
/// the flight does not determine always held at the model's); also gives the fitted values.
fn identify_in(
    fit: &Fit,
    wins: &[(usize, usize)],
    start: Option<&Rigid>,
) -> Result<(FlightEstimate, Rigid), IdError> {
    let Fit {
        flight,
        sat,
        opts,
        dynamics,
        axes,
    } = *fit;
    let ivs = Intervals::new(flight, sat, opts.latency_ms * 1e-3);
    let i_nom = sat.inertia_matrix();
    let j_nom = i_nom
        .try_inverse()
        .ok_or_else(|| IdError::Invalid("model inertia is singular".into()))?;
    let duration = flight.time_s.last().unwrap_or(&0.0) - flight.time_s.first().unwrap_or(&0.0);

    let mut terms: Vec<Term> = match dynamics {
        Dynamics::Full => (0..6)
            .map(Term::InvInertia)
            .chain((0..3).map(Term::Com))
            .collect(),
        Dynamics::Yaw => vec![Term::InvInertia(2), Term::Com(0), Term::Com(1)],
    };
    if opts.disturbance {
        match dynamics {
            Dynamics::Full => terms.extend((0..3).map(Term::Disturbance)),
            Dynamics::Yaw => terms.push(Term::Disturbance(2)),
        }
    }
    if opts.damping && dynamics == Dynamics::Yaw {
        terms.push(Term::Damping);
    }
    let sensors: Vec<SensorResponse> = match opts.sensor {
        Some(s) => vec![s],
        None if flight.from_gyro_counts => vec![SensorResponse::Point],
        None => SensorResponse::ALL.to_vec(),
    };
    let nominal = Rigid {
        dynamics,
        j: j_nom,
        dc: Vector3::zeros(),
        d: Vector3::zeros(),
        b: 0.0,
    };
    let initial_state = |sensor: SensorResponse, pinned: &[Term]| -> State {
        let t0 = usize::from(sensor != SensorResponse::Point);
        State {
            rigid: start.map_or(nominal, |s| s.with_terms_of(&nominal, pinned)),
            omega0: wins
                .iter()
                .map(|&(s, _)| {
                    let r = flight.rate.at((s + t0).min(flight.time_s.len() - 1));
                    Vector3::from_fn(|a, _| {
                        if axes[a] && r[a].is_finite() {
                            r[a]
                        } else {
                            0.0
                        }
                    })
                })
                .collect(),
            noise: std::array::from_fn(|_| ArNoise::white(1e-6)),
        }
    };
    let unit_wrenches: Vec<_> = (0..sat.n_thrusters())
        .map(|i| unit_wrench(sat, i))
        .collect();
    let make_problem = |sensor, terms: Vec<Term>, extras: Vec<Extra>| Problem {
        flight,
        intervals: &ivs,
        windows: wins,
        sensor,
        axes,
        terms,
        extras,
        inertia_fallback: i_nom,
        unit_wrenches: unit_wrenches.clone(),
    };

    // Observability: pin (hold at the model) the least determined term until every free term
    // is determined within its physical scale.
    let mut pinned: Vec<Term> = Vec::new();
    let (sensor, state, free, pending_step) = loop {
        let free: Vec<Term> = terms
            .iter()
            .copied()
            .filter(|t| !pinned.contains(t))
            .collect();
        if free.is_empty() {
            return Err(IdError::Singular);
        }
        let mut best: Option<(f64, SensorResponse, State, Normal, f64)> = None;
        for &sensor in &sensors {
            let problem = make_problem(sensor, free.clone(), Vec::new());
            let mut state = initial_state(sensor, &pinned);
            let Some((normal, pending_step)) = converge(&problem, &mut state, opts) else {
                continue;
            };
            // Gaussian log-likelihood per sample, and BIC's price for choosing a response other
            // than the plain sample (a gyro) so that a tie does not smooth a gyro's data.
            let used: Vec<usize> = (0..3)
                .filter(|&a| axes[a] && normal.innovations[a].1 > 0)
                .collect();
            let n: usize = used.iter().map(|&a| normal.innovations[a].1).sum();
            let loglik: f64 = used
                .iter()
                .map(|&a| {
                    let (ss, m) = normal.innovations[a];
                    -0.5 * m as f64 * (ss / m as f64).ln()
                })
                .sum::<f64>()
                - if sensor == SensorResponse::Point {
                    0.0
                } else {
                    0.5 * (n.max(1) as f64).ln()
                };
            if best.as_ref().is_none_or(|b| loglik > b.0) {
                best = Some((loglik, sensor, state, normal, pending_step));
            }
        }
        let Some((_, sensor, state, normal, pending_step)) = best else {
            // Singular: pin the term with the least information and retry.
            let worst = free[free.len() - 1];
            pinned.push(worst);
            continue;
        };
        let nt = free.len();
        let ntt = normal.info.view((0, 0), (nt, nt)).into_owned();
        let cov = ntt.clone().try_inverse();
        let scales: Vec<f64> = free
            .iter()
            .map(|&t| term_scale(sat, &j_nom, t, duration))
            .collect();
        let worst = match (&cov, degenerate_term(&ntt, &scales)) {
            (_, Some(i)) => Some(free[i]),
            (None, None) => Some(free[nt - 1]),
            (Some(cov), None) => (0..nt)
                .map(|i| {
                    let se = cov[(i, i)].max(0.0).sqrt();
                    (se / scales[i], i)
                })
                .filter(|(r, _)| r.is_nan() || *r > 1.0)
                .fold(None, |acc: Option<(f64, usize)>, x| match acc {
                    Some(a) if a.0 >= x.0 || x.0.is_nan() => Some(a),
                    _ => Some(x),
                })
                .map(|(_, i)| free[i]),
        };
        match worst {
            Some(t) => pinned.push(t),
            None => break (sensor, state, free, pending_step),
        }
    };

    // Final pass with the extra directions: consistency and thrust uncertainty.
    let mut fires = [false; crate::satellite::MAX_THRUSTERS];
    for iv in ivs.iter() {
        for (f, impulse) in fires.iter_mut().zip(&iv.thruster_impulse) {
            *f |= *impulse > 0.0;
        }
    }
    let firing: Vec<usize> = (0..sat.n_thrusters()).filter(|&i| fires[i]).collect();
    // The model is the one home of each thruster's stated thrust uncertainty.
    let thrust_sigma_rel = sat.thrust_sigma_rel();
    let mut extras: Vec<Extra> = firing.iter().map(|&i| Extra::ThrustScale(i)).collect();
    extras.push(Extra::OpenDelay);
    extras.push(Extra::CloseDelay);
    // Effects a rigid model leaves out that act on every craft: a constant disturbance torque
    // (gravity gradient, a tilted table) and a yaw rate damping (air-bearing drag).
    let held: Vec<Term> = match dynamics {
        Dynamics::Full => (0..3).map(Term::Disturbance).collect(),
        Dynamics::Yaw => vec![Term::Disturbance(2), Term::Damping],
    }
    .into_iter()
    .filter(|t| !terms.contains(t))
    .collect();
    let disturbance_idx: Vec<usize> = held
        .iter()
        .enumerate()
        .filter(|(_, t)| matches!(t, Term::Disturbance(_)))
        .map(|(k, _)| extras.len() + k)
        .collect();
    let damping_idx: Vec<usize> = held
        .iter()
        .enumerate()
        .filter(|(_, t)| matches!(t, Term::Damping))
        .map(|(k, _)| extras.len() + k)
        .collect();
    extras.extend(held.iter().map(|&t| Extra::Held(t)));
    // The terms held at the model because the flight does not determine them: their error is
    // not zero, and what it does to the other terms is part of their uncertainty (below).
    let pinned_first = extras.len();
    extras.extend(pinned.iter().map(|&t| Extra::Held(t)));
    let problem = make_problem(sensor, free.clone(), extras.clone());
    let full = problem.accumulate(&state);
    let nt = free.len();
    let t_idx: Vec<usize> = (0..nt).collect();
    let thrust_idx: Vec<usize> = (0..firing.len()).map(|k| nt + k).collect();
    let timing_idx = vec![nt + firing.len(), nt + firing.len() + 1];
    // Consider covariance (Schmidt): the fitted terms' covariance grows by what the errors of
    // the quantities held at the model do to them, `G S G^T` with `G = N_tt^-1 N_tz` and `S`
    // those errors' variances: each firing thruster's stated thrust uncertainty, and each
    // pinned term's physical scale (a term the flight does not determine is known to no
    // better than that; held at the model, a CoM 25 mm off on an axis the flight cannot see
    // biased a random 3-D craft's inertia by 9 sigma of the variance-only standard error).
    let mut consider: Vec<(usize, f64)> = Vec::new();
    if !thrust_sigma_rel.is_empty() {
        consider.extend(
            firing
                .iter()
                .zip(&thrust_idx)
                .map(|(&i, &c)| (c, thrust_sigma_rel.get(i).copied().unwrap_or(0.0).powi(2))),
        );
    }
    consider.extend(pinned.iter().enumerate().map(|(k, &t)| {
        (
            nt + pinned_first + k,
            term_scale(sat, &j_nom, t, duration).powi(2),
        )
    }));
    let mut tests = Vec::new();
    if !thrust_idx.is_empty() {
        tests.extend(score_test(
            "thrust",
            &full.info,
            &full.score,
            &t_idx,
            &thrust_idx,
            &consider,
        ));
    }
    tests.extend(score_test(
        "valve_timing",
        &full.info,
        &full.score,
        &t_idx,
        &timing_idx,
        &consider,
    ));
    for (name, idx) in [
        ("disturbance", &disturbance_idx),
        ("rate_damping", &damping_idx),
    ] {
        if !idx.is_empty() {
            let cols: Vec<usize> = idx.iter().map(|k| nt + k).collect();
            tests.extend(score_test(
                name,
                &full.info,
                &full.score,
                &t_idx,
                &cols,
                &consider,
            ));
        }
    }

    let ntt = full.info.view((0, 0), (nt, nt)).into_owned();
    let mut cov_t = ntt.clone().try_inverse().ok_or(IdError::Singular)?;
    if !consider.is_empty() {
        let ntz = DMatrix::from_fn(nt, consider.len(), |i, k| full.info[(i, consider[k].0)]);
        let g = &cov_t * ntz;
        let s2 = DMatrix::from_fn(consider.len(), consider.len(), |a, b| {
            if a == b {
                consider[a].1
            } else {
                0.0
            }
        });
        cov_t += &g * s2 * g.transpose();
    }

    // Physical terms: inverse inertia -> inertia by I = J^-1, dI = -I dJ I.
    let rigid = state.rigid;
    let pos = |t: Term| free.iter().position(|&f| f == t);
    let (inertia, inertia_cov_rows): ([f64; 6], DMatrix<f64>) = match dynamics {
        Dynamics::Full => {
            let i_est = rigid
                .j
                .try_inverse()
                .unwrap_or(Matrix3::from_element(f64::NAN));
            let mut g = DMatrix::<f64>::zeros(6, nt);
            for m in 0..6 {
                if let Some(c) = pos(Term::InvInertia(m)) {
                    let d = -(i_est * sym_basis(m) * i_est);
                    let v = crate::mass_id::sym_to_vec6(&d);
                    for r in 0..6 {
                        g[(r, c)] = v[r];
                    }
                }
            }
            let v = crate::mass_id::sym_to_vec6(&i_est);
            (std::array::from_fn(|r| v[r]), g)
        }
        Dynamics::Yaw => {
            let jzz = rigid.j[(2, 2)];
            let mut g = DMatrix::<f64>::zeros(6, nt);
            if let Some(c) = pos(Term::InvInertia(2)) {
                g[(2, c)] = -1.0 / (jzz * jzz);
            }
            let mut v = sat.inertia_kgm2;
            v[2] = 1.0 / jzz;
            (v, g)
        }
    };
    let mut g_all = DMatrix::<f64>::zeros(9, nt);
    g_all.view_mut((0, 0), (6, nt)).copy_from(&inertia_cov_rows);
    for a in 0..3 {
        if let Some(c) = pos(Term::Com(a)) {
            g_all[(6 + a, c)] = 1e3;
        }
    }
    let covariance = &g_all * &cov_t * g_all.transpose();
    let se = |t: Term| pos(t).map(|c| cov_t[(c, c)].max(0.0).sqrt());

    let not_planar: Vec<&'static str> = if sat.planar {
        NOT_PLANAR.to_vec()
    } else {
        Vec::new()
    };
    let mut unobservable: Vec<&'static str> = not_planar.clone();
    for t in &pinned {
        let name = term_name(*t);
        if !unobservable.contains(&name) {
            unobservable.push(name);
        }
    }
    let mut inertia_stderr = [0.0; 6];
    for m in 0..6 {
        inertia_stderr[m] = if unobservable.contains(&INERTIA_TERMS[m]) {
            // The model's value with the observability scale as its uncertainty.
            let scale = term_scale(sat, &j_nom, Term::InvInertia(m), duration);
            scale
                * inertia[m.min(2)]
                    .powi(2)
                    .max(sat.inertia_kgm2[m.min(2)].powi(2))
        } else {
            covariance[(m, m)].max(0.0).sqrt()
        };
    }
    let mut com_stderr = [0.0; 3];
    for a in 0..3 {
        com_stderr[a] = if unobservable.contains(&COM_TERMS[a]) {
            term_scale(sat, &j_nom, Term::Com(a), duration) * 1e3
        } else {
            covariance[(6 + a, 6 + a)].max(0.0).sqrt()
        };
    }
    let com_offset_mm: [f64; 3] = std::array::from_fn(|a| rigid.dc[a] * 1e3);
    let disturbance_nm = opts.disturbance.then(|| {
        (
            std::array::from_fn(|a| rigid.d[a]),
            std::array::from_fn(|a| se(Term::Disturbance(a)).unwrap_or(f64::NAN)),
        )
    });
    let damping_nms = (opts.damping && dynamics == Dynamics::Yaw)
        .then(|| (rigid.b, se(Term::Damping).unwrap_or(f64::NAN)));

    // Status, most serious first.
    let principal_j: Vec<f64> = match dynamics {
        Dynamics::Full => (0..3).map(|a| rigid.j[(a, a)] / j_nom[(a, a)]).collect(),
        Dynamics::Yaw => vec![rigid.j[(2, 2)] / j_nom[(2, 2)]],
    };
    let inconsistent = tests.iter().any(|t| t.p_value < opts.consistency_alpha);
    let only_planar_unobservable = unobservable.len() == not_planar.len();
    // An estimate that would still move says so before what it implies: its validity and its
    // score tests are evaluated away from the optimum.
    let status = if principal_j.iter().all(|r| r.abs() < 0.125) {
        "no_gyro_response"
    } else if pending_step > NOT_CONVERGED_STEP {
        "not_converged"
    } else if let Err(why) = physical_validity(sat, &com_offset_mm, &inertia) {
        why
    } else if inconsistent {
        "inconsistent"
    } else if !only_planar_unobservable {
        "unobservable_terms"
    } else if tests.is_empty() {
        // No direction was left to test after the fitted terms (as the kernel says it).
        "consistency_untested"
    } else {
        "ok"
    };
    let noise: [Option<ArNoise>; 3] =
        std::array::from_fn(|a| axes[a].then(|| state.noise[a].clone()));
    let estimate = FlightEstimate {
        inertia_kgm2: inertia,
        inertia_stderr_kgm2: inertia_stderr,
        com_offset_mm,
        com_offset_stderr_mm: com_stderr,
        disturbance_nm,
        damping_nms,
        covariance,
        unobservable,
        not_planar,
        sensor,
        noise,
        consistency: tests,
        command_timing_unknown: false,
        samples_used: full.innovations.iter().map(|x| x.1).sum(),
        status,
    };
    Ok((estimate, rigid))
}

/// The Cramér–Rao bound of (inertia xx yy zz xy xz yz in kg m^2, CoM offset in mm) for this
/// flight's commands and sampling, at the true inertia and CoM offset, with the rate noise
/// `noise` per axis and each window's initial rate unknown: the inverse of the same profile
/// information the fit uses, evaluated at the truth instead of at the estimate (the analytic
/// half of the two-way check against finite differences through the simulator). Its windows
/// are the fit's, split past [`MAX_TURN_3D_RAD`] as the fit's are: the bound of this
/// estimator, which is the bound of the whole flight only below that turn.
pub fn cramer_rao_bound(
    flight: &Flight,
    sat: &Satellite,
    truth_inertia: &[f64; 6],
    truth_com_offset_mm: &[f64; 3],
    noise: &[ArNoise; 3],
) -> Result<DMatrix<f64>, IdError> {
    flight
        .check(sat)
        .map_err(|e| IdError::Invalid(e.to_string()))?;
    if sat.planar {
        return Err(IdError::Invalid("the bound is for 3-D craft".into()));
    }
    let wins = split_turns(flight, &windows(flight, 20, false), MAX_TURN_3D_RAD, 20);
    if wins.is_empty() {
        return Err(IdError::TooFewSamples(20));
    }
    let ivs = Intervals::new(flight, sat, 0.0);
    let i_true = Matrix3::new(
        truth_inertia[0],
        truth_inertia[3],
        truth_inertia[4],
        truth_inertia[3],
        truth_inertia[1],
        truth_inertia[5],
        truth_inertia[4],
        truth_inertia[5],
        truth_inertia[2],
    );
    let j = i_true
        .try_inverse()
        .ok_or_else(|| IdError::Invalid("singular inertia".into()))?;
    let terms: Vec<Term> = (0..6)
        .map(Term::InvInertia)
        .chain((0..3).map(Term::Com))
        .collect();
    let problem = Problem {
        flight,
        intervals: &ivs,
        windows: &wins,
        sensor: SensorResponse::Point,
        axes: flight.axes,
        terms,
        extras: Vec::new(),
        inertia_fallback: i_true,
        unit_wrenches: (0..sat.n_thrusters())
            .map(|i| unit_wrench(sat, i))
            .collect(),
    };
    let state = State {
        rigid: Rigid {
            dynamics: Dynamics::Full,
            j,
            dc: Vector3::from(*truth_com_offset_mm) * 1e-3,
            d: Vector3::zeros(),
            b: 0.0,
        },
        // The initial rates only set the trajectory the sensitivities follow: take the
        // measured ones (a noise-free flight gives the true ones).
        omega0: wins
            .iter()
            .map(|&(s, _)| Vector3::from_fn(|a, _| flight.rate.at(s)[a]))
            .collect(),
        noise: noise.clone(),
    };
    let normal = problem.accumulate(&state);
    let cov = normal.info.try_inverse().ok_or(IdError::Singular)?;
    let mut g = DMatrix::<f64>::zeros(9, 9);
    for m in 0..6 {
        let v = crate::mass_id::sym_to_vec6(&(-(i_true * sym_basis(m) * i_true)));
        for r in 0..6 {
            g[(r, m)] = v[r];
        }
    }
    for a in 0..3 {
        g[(6 + a, 6 + a)] = 1e3;
    }
    Ok(&g * cov * g.transpose())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numerically_singular_information_names_the_term_to_hold() {
        // Columns 0 and 2 of the sensitivities proportional (two terms giving the same
        // rates): singular. Term 0 moves the rates half as much as term 2, so it is the less
        // determined one at equal scales; at a scale 4x smaller, term 2 is.
        let cols = [[1.0, 0.0], [0.3, 1.0], [2.0, 0.0]];
        let info = DMatrix::from_fn(3, 3, |i, j| {
            1e6 * (cols[i][0] * cols[j][0] + cols[i][1] * cols[j][1])
        });
        assert_eq!(degenerate_term(&info, &[1.0, 1.0, 1.0]), Some(0));
        assert_eq!(degenerate_term(&info, &[1.0, 1.0, 0.25]), Some(2));
        // Well determined: nothing to hold.
        let spd = DMatrix::from_row_slice(2, 2, &[4.0, 1.0, 1.0, 3.0]);
        assert_eq!(degenerate_term(&spd, &[1.0, 1.0]), None);
    }
}
