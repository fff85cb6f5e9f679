//! A linear estimate of the inertia from the recording itself: an inertia fit's start
//! besides the model's. Euler's equation summed over a window, `I dw + sum (w x I w) dt =
//! T` (`dw` the rate change across it, `T` the commanded torque's integral), is linear in
//! the inertia's six terms: least squares over the flight's windows gives them without a
//! start (the identification's equation-error form, where the diagnosis fits the output
//! error). The rates are noisy regressors here, so the windows are long (1 s): over one
//! sample pair the noise took 95 % off the moments (seed 86022 below, 100 Hz), over 1 s
//! they are within 0.1 % of a noiseless flight's, which this form gives to within the
//! trapezoid rule (the mean rate over each sample pair).
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
/// A window cut short (by an invalid sample, a gap or the end of a train block) counts only
/// if it holds at least this share of a full one: over a short window the rate noise is as
/// large as over a long one while the rate change it measures is smaller, so it would pull
/// the moments down as the one-sample pairs did.
const MIN_WINDOW_SHARE: f64 = 0.5;
/// Fewest windows an estimate is made from: each gives three equations in six unknowns.
const MIN_WINDOWS: usize = 3;

/// The inertia (xx, yy, zz, xy, xz, yz, kg m^2) the recording's rate changes give with the
/// model's thrusters, or `None` for a planar craft (its one term is fitted from the model's
/// start without trouble), fewer than three usable windows or a result that is
/// not positive definite. Only pairs of consecutive valid samples the fit may use, with no
/// gap between them, count.
pub fn inertia(prob: &Problem) -> Option<[f64; 6]> {
    let plant = prob.plant;
    let series = prob.series;
    if plant.planar || series.len() < 2 {
        return None;
    }
    let duty = prob.duty(0.0, 0.0, 0.0);
    let (torques, pd) = plant.nominal_torques();
    let ones = [1.0; NT];
    // the longest spacing of a pair: what `Series` does not call a gap
    let max_dt_ms = 1.5e3 / series.sample_rate_hz.max(1e-9);
    let per_window = ((WINDOW_S * series.sample_rate_hz).round() as usize).max(1);
    let min_pairs = ((per_window as f64 * MIN_WINDOW_SHARE).ceil() as usize).max(1);
    // a torque residual on axis a in rate units: over the model's moment, at the noise's
    // weight
    let nominal = plant.nominal_inertia();
    let weight: [f64; 3] = std::array::from_fn(|a| (prob.weight[a] / nominal[a]).powi(2));
    let (mut normal, mut rhs) = (Matrix6::zeros(), Vector6::zeros());
    let mut windows = 0;
    // the window being summed: I dw + sum (w x I w) dt = T over its pairs
    let (mut a_win, mut t_win, mut n) = (Matrix3x6::zeros(), Vector3::zeros(), 0);
    let mut close = |a_win: &mut Matrix3x6<f64>, t_win: &mut Vector3<f64>, n: &mut usize| {
        if *n >= min_pairs {
            for a in 0..3 {
                let row = a_win.row(a).transpose();
                normal += row * row.transpose() * weight[a];
                rhs += row * (t_win[a] * weight[a]);
            }
            windows += 1;
        }
        (*a_win, *t_win, *n) = (Matrix3x6::zeros(), Vector3::zeros(), 0);
    };
    for i in 0..series.len() - 1 {
        let (t0, t1) = (series.t_ms[i], series.t_ms[i + 1]);
        let usable = t1 > t0
            && (t1 - t0) as f64 <= max_dt_ms
            && t0 >= 0
            && series.valid[i]
                .iter()
                .chain(&series.valid[i + 1])
                .all(|&v| v)
            && prob.in_fit(i)
            && prob.in_fit(i + 1)
            && !series.gap_resets.contains(&(i + 1));
        if !usable {
            close(&mut a_win, &mut t_win, &mut n);
            continue;
        }
        for k in t0 as usize..t1 as usize {
            let mut tau = Vector3::zeros();
            plant.add_row_torque(&mut tau, &torques, duty.row(k), &ones, pd, 1.0);
            t_win += tau * 1e-3;
        }
        let (w0, w1) = (
            Vector3::from(series.rate[i]),
            Vector3::from(series.rate[i + 1]),
        );
        let w = (w0 + w1) * 0.5;
        a_win += times(&(w1 - w0)) + w.cross_matrix() * times(&w) * ((t1 - t0) as f64 * 1e-3);
        n += 1;
        if n == per_window {
            close(&mut a_win, &mut t_win, &mut n);
        }
    }
    close(&mut a_win, &mut t_win, &mut n);
    if windows < MIN_WINDOWS {
        return None;
    }
    let th = normal.cholesky()?.solve(&rhs);
    let inertia = inertia_matrix(&[th[0], th[1], th[2], th[3], th[4], th[5]]);
    let terms: [f64; 6] = reference_f64::mass_id::sym_to_vec6(&inertia).into();
    let positive_definite = terms.iter().all(|v| v.is_finite())
        && inertia
            .symmetric_eigen()
            .eigenvalues
            .iter()
            .all(|&e| e > 0.0);
    positive_definite.then_some(terms)
}

/// `I v` as a matrix on the six terms (xx, yy, zz, xy, xz, yz): linear in the inertia.
fn times(v: &Vector3<f64>) -> Matrix3x6<f64> {
    Matrix3x6::new(
        v.x, 0.0, 0.0, v.y, v.z, 0.0, //
        0.0, v.y, 0.0, v.x, 0.0, v.z, //
        0.0, 0.0, v.z, 0.0, v.x, v.y,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Params;
    use crate::noise::NoiseModel;
    use crate::series::Series;
    use reference_f64::satellite::Satellite;

    /// SPHERES' inertia with the moments 10 % up and products of its own: what the
    /// recordings below are flown with.
    fn truth(sat: &Satellite) -> [f64; 6] {
        let mut t = sat.inertia_kgm2;
        for v in t.iter_mut().take(3) {
            *v *= 1.1;
        }
        t[3] += 4e-4;
        t[5] -= 3e-4;
        t
    }

    /// A noiseless 1 kHz recording of `ms` milliseconds: four thruster pairs pulsing in turn
    /// while the body tumbles, its rates predicted with the true inertia `truth(sat)`.
    fn tumbling(sat: &Satellite, ms: usize) -> Series {
        let plant = crate::model::Plant::new(sat);
        let words: Vec<u16> = (0..ms)
            .map(|k| match (k / 150) % 6 {
                0 => 0b0000_0000_0011,
                2 => 0b0000_0100_0100,
                3 => 0b0001_1000_0000,
                4 => 0b0110_0000_0000,
                _ => 0,
            })
            .collect();
        let mut series = crate::model::tests::commanded(sat, &words);
        let noise = NoiseModel::white([1e-4; 3]);
        let rates = Problem::new(&plant, &series, &noise)
            .predict(&Params {
                inertia: Some(truth(sat)),
                omega0: [0.4, -0.6, 0.5],
                ..Params::default()
            })
            .unwrap();
        series.rate = rates;
        series
    }

    /// The estimate from `series` with SPHERES' model and white noise.
    fn estimate(series: &Series) -> Option<[f64; 6]> {
        let sat = Satellite::builtin("sph2").unwrap();
        let plant = crate::model::Plant::new(&sat);
        inertia(&Problem::new(&plant, series, &NoiseModel::white([1e-4; 3])))
    }

    /// Each of the six terms within 1e-6 of the largest moment (the trapezoid rule's error at
    /// 1 kHz is 4e-9 here). Summed without the gyroscopic term the terms come out up to 60 %
    /// off, and this fails.
    #[test]
    fn a_noiseless_tumble_gives_the_true_inertia() {
        let sat = Satellite::builtin("sph2").unwrap();
        let got = estimate(&tumbling(&sat, 8000)).expect("eight full windows");
        let want = truth(&sat);
        let scale = want[..3].iter().cloned().fold(0.0, f64::max);
        for (g, w) in got.iter().zip(&want) {
            assert!((g - w).abs() <= 1e-6 * scale, "{got:?} against {want:?}");
        }
    }

    /// Fewer than three windows give no estimate rather than a poor one: 2.4 s make two
    /// full windows and a 0.4 s rest, which is too short to count.
    #[test]
    fn fewer_than_three_windows_give_no_estimate() {
        let sat = Satellite::builtin("sph2").unwrap();
        assert!(estimate(&tumbling(&sat, 2400)).is_none());
        assert!(estimate(&tumbling(&sat, 3000)).is_some());
    }

    /// Windows cut short everywhere (an invalid sample every 0.4 s) do not count: the same
    /// recording with every sample valid is estimated.
    #[test]
    fn windows_cut_short_do_not_count() {
        let sat = Satellite::builtin("sph2").unwrap();
        let whole = tumbling(&sat, 8000);
        assert!(estimate(&whole).is_some());
        let mut cut = whole.clone();
        for i in (400..cut.len()).step_by(400) {
            cut.valid[i][1] = false;
        }
        assert!(estimate(&cut).is_none());
    }
}
