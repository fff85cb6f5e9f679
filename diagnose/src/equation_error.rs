//! A linear estimate of the inertia from the recording itself: an inertia fit's start
//! besides the model's. Euler's equation summed over a window, `I dw + sum (w x I w) dt =
//! T` (`dw` the rate change across it, `T` the commanded torque's integral), is linear in
//! the inertia's six terms: least squares over the flight's windows gives them without a
//! start (the identification's equation-error form, where the diagnosis fits the output
//! error). The rates are noisy regressors here, so the windows are long (1 s): over one
//! sample pair the noise took 95 % off the moments (seed 86022 below, 100 Hz), over 1 s
//! they are within 0.1 % of a noiseless flight's, which this form gives exactly.
//!
//! Why a second start: a long tumbling flight's rates depend on the inertia so unevenly
//! that a fit started at the model's alone can stop in another minimum. A 3-D craft whose
//! moments were 10 % up (`diagnose_random_craft`, seed 86022: 40 s, rates up to 1 rad/s)
//! had its inertia named 30-90 standard errors from the truth, the residual left 4 times
//! the noise.

use nalgebra::{Matrix3x6, Matrix6, Vector3, Vector6};

use crate::fit::Problem;
use crate::model::{inertia_matrix, NT};

/// Length of the windows the equation is summed over, s.
const WINDOW_S: f64 = 1.0;

/// The inertia (xx, yy, zz, xy, xz, yz, kg m^2) the recording's rate changes give with the
/// model's thrusters, or `None` for a planar craft (its one term is fitted from the model's
/// start without trouble), too few usable sample pairs or a result that is not a body.
/// Only pairs of valid samples the fit may use, with no gap between them, count.
pub fn inertia(prob: &Problem) -> Option<[f64; 6]> {
    let plant = prob.plant;
    let series = prob.series;
    if plant.planar || series.len() < 2 {
        return None;
    }
    let duty = prob.duty(0.0, 0.0, 0.0);
    let (torques, pd) = plant.nominal_torques();
    let ones = [1.0; NT];
    // the longest spacing counted: twice the nominal sample period (a gap breaks the pair)
    let max_dt = (2e3 / series.sample_rate_hz.max(1e-9)).ceil() as i64;
    // per usable pair: its first sample, the rate change, the mean rate, the torque's
    // integral (N m s) and the time between the samples (s)
    let mut pairs: Vec<(usize, Vector3<f64>, Vector3<f64>, Vector3<f64>, f64)> = vec![];
    for i in 0..series.len() - 1 {
        let (t0, t1) = (series.t_ms[i], series.t_ms[i + 1]);
        let usable = t1 > t0
            && t1 - t0 <= max_dt
            && t0 >= 0
            && series.valid[i]
                .iter()
                .chain(&series.valid[i + 1])
                .all(|&v| v)
            && prob.in_fit(i)
            && prob.in_fit(i + 1)
            && !series.gap_resets.contains(&(i + 1));
        if !usable {
            continue;
        }
        let mut integral = Vector3::zeros();
        for k in t0 as usize..t1 as usize {
            let mut tau = Vector3::zeros();
            plant.add_row_torque(&mut tau, &torques, duty.row(k), &ones, pd, 1.0);
            integral += tau * 1e-3;
        }
        let (w0, w1) = (
            Vector3::from(series.rate[i]),
            Vector3::from(series.rate[i + 1]),
        );
        pairs.push((
            i,
            w1 - w0,
            (w0 + w1) * 0.5,
            integral,
            (t1 - t0) as f64 * 1e-3,
        ));
    }
    if pairs.len() < 12 {
        return None;
    }
    let per_window = ((WINDOW_S * series.sample_rate_hz).round() as usize).max(1);
    // a torque residual on axis a in rate units: over the model's moment, at the noise's
    // weight
    let nominal = plant.nominal_inertia();
    let weight: [f64; 3] = std::array::from_fn(|a| (prob.weight[a] / nominal[a]).powi(2));
    let (mut normal, mut rhs) = (Matrix6::zeros(), Vector6::zeros());
    let mut add = |a_win: &Matrix3x6<f64>, t_win: &Vector3<f64>| {
        for a in 0..3 {
            let row = a_win.row(a).transpose();
            normal += row * row.transpose() * weight[a];
            rhs += row * (t_win[a] * weight[a]);
        }
    };
    // windows of consecutive pairs: over each, I dw + sum (w x I w) dt = T
    let (mut a_win, mut t_win) = (Matrix3x6::zeros(), Vector3::zeros());
    let (mut n, mut next) = (0, usize::MAX);
    for (i, dw, w, integral, dt) in &pairs {
        if n > 0 && (*i != next || n == per_window) {
            add(&a_win, &t_win);
            (a_win, t_win, n) = (Matrix3x6::zeros(), Vector3::zeros(), 0);
        }
        a_win += times(dw) + w.cross_matrix() * times(w) * *dt;
        t_win += integral;
        n += 1;
        next = i + 1;
    }
    if n > 0 {
        add(&a_win, &t_win);
    }
    let th = normal.cholesky()?.solve(&rhs);
    let inertia = inertia_matrix(&[th[0], th[1], th[2], th[3], th[4], th[5]]);
    let terms: [f64; 6] = reference_f64::mass_id::sym_to_vec6(&inertia).into();
    let body = terms.iter().all(|v| v.is_finite())
        && inertia
            .symmetric_eigen()
            .eigenvalues
            .iter()
            .all(|&e| e > 0.0);
    body.then_some(terms)
}

/// `I v` as a matrix on the six terms (xx, yy, zz, xy, xz, yz): linear in the inertia.
fn times(v: &Vector3<f64>) -> Matrix3x6<f64> {
    Matrix3x6::new(
        v.x, 0.0, 0.0, v.y, v.z, 0.0, //
        0.0, v.y, 0.0, v.x, 0.0, v.z, //
        0.0, 0.0, v.z, 0.0, v.x, v.y,
    )
}
