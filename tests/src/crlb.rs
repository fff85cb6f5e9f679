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
    // Whitening of the AR(1) noise: e_k = v_k - rho v_{k-1}, variance sigma^2 (1 - rho^2).
    let dt = 1.0 / spec.rate_hz;
    let rho = (-2.0 * std::f64::consts::PI * spec.sensors.gyro_bandwidth_hz * dt).exp();
    let mut fim = SMatrix::<f64, N, N>::zeros();
    for a in 0..3 {
        let var_e = spec.sensors.gyro_noise_rad_s[a].powi(2) * (1.0 - rho * rho);
        for k in 1..n {
            let row = SMatrix::<f64, 1, N>::from_fn(|_, j| {
                jac[(3 * k + a, j)] - rho * jac[(3 * (k - 1) + a, j)]
            });
            fim += row.transpose() * row / var_e;
        }
    }
    let cov = fim
        .try_inverse()
        .unwrap_or_else(|| SMatrix::<f64, N, N>::from_element(f64::NAN));
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
