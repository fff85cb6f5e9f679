//! The Cramér–Rao bound of the CoM offset and the principal inertias for a flight, from the
//! Fisher information of the rate-output model `y_k = omega(t_k; theta) + v_k`: the gyro
//! noise `v` is the simulator's (a first-order Gauss-Markov process, so the model is whitened
//! by its AR(1) coefficient), the sensitivities `d omega / d theta` are central differences
//! of the simulator's noise-free body rate with the truth's CoM and inertia moved. Unknowns:
//! CoM offset (3, mm) and inertia (6, kg m^2); the initial rate and the gyro bias are taken as
//! known (the bound is then a little optimistic; ADC quantisation, 1 % of the noise variance,
//! is left out).
use massid_sim::{simulate, Maneuver, SimSpec};
use nalgebra::{DMatrix, SMatrix};
use reference_f64::pipeline::{estimate_offline, estimate_online, Estimate, PipelineConfig};
use reference_f64::satellite::Satellite;

/// Unknowns: cm_x cm_y cm_z (mm), Ixx Iyy Izz Ixy Ixz Iyz (kg m^2).
pub const N: usize = 9;

/// The CRLB (variances) of the nine unknowns for the flight `spec` (its noise seed is
/// irrelevant: the bound uses the noise-free trajectory).
pub fn crlb(spec: &SimSpec) -> [f64; N] {
    let rates = |sat: &Satellite| -> Vec<[f64; 3]> {
        let mut s = spec.clone();
        s.satellite = sat.clone();
        simulate(&s).expect("simulation").body_rate
    };
    let base = &spec.satellite;
    let n = rates(base).len();
    // Sensitivities, one column per unknown: rows are (sample, axis).
    let mut jac = DMatrix::<f64>::zeros(3 * n, N);
    for j in 0..N {
        let h = if j < 3 {
            0.5
        } else {
            1e-4 * base.inertia_kgm2[0]
        };
        let moved = |sign: f64| {
            let mut s = base.clone();
            if j < 3 {
                s.com_offset_mm[j] += sign * h;
            } else {
                s.inertia_kgm2[j - 3] += sign * h;
            }
            rates(&s)
        };
        let (up, down) = (moved(1.0), moved(-1.0));
        for k in 0..n.min(up.len()).min(down.len()) {
            for a in 0..3 {
                jac[(3 * k + a, j)] = (up[k][a] - down[k][a]) / (2.0 * h);
            }
        }
    }
    whitened_bound::<N>(spec, &jac, n)
}

/// The diagonal, for the nine unknowns (the first [`N`] of `M` columns), of the inverse Fisher
/// information of sensitivities `jac` (rows (sample, axis)) under the simulator's AR(1) gyro
/// noise, whitened as `e_k = v_k - rho v_k-1` from the second sample on (variance
/// `sigma^2 (1 - rho^2)`); columns past the nine are profiled out.
fn whitened_bound<const M: usize>(spec: &SimSpec, jac: &DMatrix<f64>, n: usize) -> [f64; N] {
    let rho = gyro_rho(spec);
    let mut fim = SMatrix::<f64, M, M>::zeros();
    for a in 0..3 {
        let var_e = spec.sensors.gyro_noise_rad_s[a].powi(2) * (1.0 - rho * rho);
        for k in 1..n {
            let row = SMatrix::<f64, 1, M>::from_fn(|_, j| {
                jac[(3 * k + a, j)] - rho * jac[(3 * (k - 1) + a, j)]
            });
            fim += row.transpose() * row / var_e;
        }
    }
    let cov = fim
        .try_inverse()
        .unwrap_or_else(|| SMatrix::<f64, M, M>::from_element(f64::NAN));
    core::array::from_fn(|j| cov[(j, j)])
}

/// The estimators compared with the bound.
pub const ESTIMATORS: [&str; 4] = [
    "f64 offline (batch)",
    "f64 online",
    "f32 kernel",
    "fixed kernel",
];

/// Monte Carlo variance of each estimator's error for the nine unknowns over `flights` rga12
/// flights of the nominal SPH2 (seeds from `seed0`), and the CRLB; `(mc_var, crlb)`.
pub fn mc_against_crlb(flights: u64, seed0: u64) -> ([[f64; N]; 4], [f64; N]) {
    let sat = Satellite::builtin("sph2").expect("sph2");
    let cfg = PipelineConfig {
        keep_history: false,
        ..PipelineConfig::default()
    };
    let mut sum_sq = [[0.0f64; N]; 4];
    let errors = |e: &Estimate| -> [f64; N] {
        core::array::from_fn(|j| {
            if j < 3 {
                e.com_offset_mm[j]
            } else {
                e.inertia_kgm2[j - 3] - sat.inertia_kgm2[j - 3]
            }
        })
    };
    for seed in seed0..seed0 + flights {
        let mut spec = SimSpec::new(sat.clone(), Vec::new(), Maneuver::Rga12);
        spec.seed = seed;
        let rec = simulate(&spec).expect("simulation").recording;
        let ests = [
            Some(estimate_offline(&rec, &sat, &cfg)),
            Some(estimate_online(&rec, &sat, &cfg)),
            massid_kernel_host::estimate::<f32>(&rec, &sat).ok(),
            massid_kernel_host::estimate::<massid_kernel::Q8_24>(&rec, &sat).ok(),
        ];
        for (k, e) in ests.iter().enumerate() {
            let err = e.as_ref().map_or([f64::NAN; N], errors);
            for j in 0..N {
                sum_sq[k][j] += err[j] * err[j];
            }
        }
    }
    let mc = sum_sq.map(|row| row.map(|s| s / flights as f64));
    let spec = SimSpec::new(sat.clone(), Vec::new(), Maneuver::Rga12);
    (mc, crlb(&spec))
}

/// The table: per estimator and unknown, the Monte Carlo variance over the CRLB.
pub fn markdown(mc: &[[f64; N]; 4], bound: &[f64; N]) -> String {
    const NAMES: [&str; N] = [
        "cm_x", "cm_y", "cm_z", "Ixx", "Iyy", "Izz", "Ixy", "Ixz", "Iyz",
    ];
    let mut s = String::from("| estimator |");
    for n in NAMES {
        s += &format!(" {n} |");
    }
    s += "\n|---|";
    s += &"---|".repeat(N);
    s += "\n| CRLB sigma |";
    for (j, b) in bound.iter().enumerate() {
        s += &if j < 3 {
            format!(" {:.3} mm |", b.sqrt())
        } else {
            format!(" {:.1e} |", b.sqrt())
        };
    }
    s += "\n";
    for (k, name) in ESTIMATORS.iter().enumerate() {
        s += &format!("| {name}: MC variance / CRLB |");
        for j in 0..N {
            s += &format!(" {:.1} |", mc[k][j] / bound[j]);
        }
        s += "\n";
    }
    s
}

/// Finite-difference steps of [`crlb_fd_with_initial_rate_steps`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FdSteps {
    /// CoM offset step, mm.
    pub com_mm: f64,
    /// Inertia step (every component) as a fraction of Ixx.
    pub inertia_rel: f64,
    /// Initial-rate step, rad/s.
    pub rate_rad_s: f64,
}

impl Default for FdSteps {
    fn default() -> Self {
        FdSteps {
            com_mm: 0.5,
            inertia_rel: 1e-4,
            rate_rad_s: 1e-3,
        }
    }
}

/// The AR(1) coefficient of the simulator's gyro noise between two samples of `spec`.
pub fn gyro_rho(spec: &SimSpec) -> f64 {
    let dt = 1.0 / spec.rate_hz;
    (-2.0 * std::f64::consts::PI * spec.sensors.gyro_bandwidth_hz * dt).exp()
}

/// [`crlb`] with the initial rate (3, rad/s) unknown as well: the CRLB (variances) of the
/// nine unknowns with the initial rate profiled out (the full 12 x 12 Fisher information
/// inverted). Sensitivities are central differences of the simulator's noise-free body rate
/// (steps [`FdSteps::default`]); the noise is the simulator's AR(1) gyro noise of level
/// `spec.sensors.gyro_noise_rad_s`, whitened as in [`crlb`] (`e_k = v_k - rho v_k-1` from
/// the second sample on, the first sample left out, as the analytic bound does too).
pub fn crlb_fd_with_initial_rate(spec: &SimSpec) -> [f64; N] {
    crlb_fd_with_initial_rate_steps(spec, &FdSteps::default())
}

/// [`crlb_fd_with_initial_rate`] with the given steps (for step-size checks).
pub fn crlb_fd_with_initial_rate_steps(spec: &SimSpec, steps: &FdSteps) -> [f64; N] {
    const M: usize = N + 3;
    let mut base = spec.clone();
    base.sensors.noiseless = true;
    let rates = |s: &SimSpec| -> Vec<[f64; 3]> { simulate(s).expect("simulation").body_rate };
    let n = rates(&base).len();
    let mut jac = DMatrix::<f64>::zeros(3 * n, M);
    for j in 0..M {
        let h = match j {
            0..=2 => steps.com_mm,
            3..=8 => steps.inertia_rel * base.satellite.inertia_kgm2[0],
            _ => steps.rate_rad_s,
        };
        let moved = |sign: f64| {
            let mut s = base.clone();
            match j {
                0..=2 => s.satellite.com_offset_mm[j] += sign * h,
                3..=8 => s.satellite.inertia_kgm2[j - 3] += sign * h,
                _ => s.initial_rate[j - N] += sign * h,
            }
            rates(&s)
        };
        let (up, down) = (moved(1.0), moved(-1.0));
        assert!(
            up.len() == n && down.len() == n,
            "perturbed flights differ in length"
        );
        for k in 0..n {
            for a in 0..3 {
                jac[(3 * k + a, j)] = (up[k][a] - down[k][a]) / (2.0 * h);
            }
        }
    }
    whitened_bound::<M>(spec, &jac, n)
}

/// The CRLB (variances, the nine unknowns in [`crlb`]'s order) from the estimator's own
/// information, `reference_f64::flight_id::cramer_rao_bound`: the flight is simulated
/// noise-free, read as the estimator reads it (`Flight::from_v1`) and its rates replaced by
/// the simulator's true body rate at every sample (so neither the 12-bit quantisation nor
/// the gyro's saturation enters); the noise is the simulator's AR(1) gyro noise, `phi = rho`,
/// innovation variance `sigma^2 (1 - rho^2)`. The model is the truth (CoM offset 0, inertia
/// `spec.satellite`'s).
pub fn crlb_analytic(spec: &SimSpec) -> [f64; N] {
    analytic(spec, None)
}

/// [`crlb_analytic`] on the samples a recording delivered: the true rate of sample `k`
/// counts only where `delivered.rate[k]` is finite on every axis. A saturated gyro count
/// (0 or 4095, about 1.45 rad/s on SPH2) is a missing sample to the estimator, which starts
/// a new window, with a new initial rate, after it; a bound on every sample is then far too
/// optimistic (combo flights that spin up past saturation lose up to half their samples,
/// and with them most of the products' gyroscopic information). `delivered` is the flight the
/// estimator read (same samples as `spec` flies).
pub fn crlb_analytic_delivered(
    spec: &SimSpec,
    delivered: &reference_f64::flight_id::flight::Flight,
) -> [f64; N] {
    analytic(spec, Some(delivered))
}

fn analytic(
    spec: &SimSpec,
    delivered: Option<&reference_f64::flight_id::flight::Flight>,
) -> [f64; N] {
    use reference_f64::flight_id::{cramer_rao_bound, flight::Flight, noise::ArNoise};
    let mut s = spec.clone();
    s.sensors.noiseless = true;
    let out = simulate(&s).expect("simulation");
    let sat = &spec.satellite;
    let mut flight = Flight::from_v1(&out.recording, sat);
    assert_eq!(
        flight.rate.len(),
        out.body_rate.len(),
        "recording and true rates differ in length (artefacts?)"
    );
    flight.rate = out.body_rate.into();
    if let Some(d) = delivered {
        assert_eq!(
            d.rate.len(),
            flight.rate.len(),
            "delivered flight differs in length"
        );
        let rates = flight.rate.rad_s_mut().expect("true rates, rad/s");
        for (r, dr) in rates.iter_mut().zip(d.rate.iter()) {
            if dr.iter().any(|v| !v.is_finite()) {
                *r = [f64::NAN; 3];
            }
        }
    }
    let rho = gyro_rho(spec);
    let noise: [ArNoise; 3] = core::array::from_fn(|a| ArNoise {
        phi: vec![rho],
        ..ArNoise::white(spec.sensors.gyro_noise_rad_s[a].powi(2) * (1.0 - rho * rho))
    });
    let cov = cramer_rao_bound(&flight, sat, &sat.inertia_kgm2, &[0.0; 3], &noise)
        .expect("cramer_rao_bound");
    core::array::from_fn(|j| {
        if j < 3 {
            cov[(6 + j, 6 + j)]
        } else {
            cov[(j - 3, j - 3)]
        }
    })
}
