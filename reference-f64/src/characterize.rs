//! Ground characterization tools of seed chapters 2-3: the trifilar torsional pendulum
//! (eq. 2.6, 2.14-2.15) with base-inertia removal, the torsional-spring constant (2.8-2.9),
//! damping from amplitude decay (2.10-2.11), products of inertia from rotated measurements
//! (2.7), CoM from load-cell moments (2.2), thrust magnitude and direction from averaged
//! load-cell forces (3.5), the parallel-axis error (2.12), the small-angle chord error and the
//! rotational/translational oscillation energies of the error analysis (2.3.6, 2.16-2.21).
//!
//! Every fallible function returns `Err(CharacterizeError)` naming the offending input
//! instead of producing NaN or a negative inertia.
use nalgebra::{DMatrix, DVector, Matrix3, Vector3};
use serde::{Deserialize, Serialize};

/// Why a characterization input is rejected.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CharacterizeError {
    /// An input that must be finite and strictly positive is not.
    #[error("{name} must be a finite positive number, got {value}")]
    NotPositive { name: &'static str, value: f64 },
    /// An input that must be finite is not.
    #[error("{name} must be finite, got {value}")]
    NotFinite { name: &'static str, value: f64 },
    /// A structurally wrong input (too few measurements, inconsistent shapes, ...).
    #[error("{0}")]
    Invalid(String),
    /// The computed inertia is not positive: the base inertia exceeds the measured total.
    #[error("measured total inertia {total} kg m^2 does not exceed the base inertia {base} kg m^2 (check period, length and base)")]
    InertiaNotAboveBase { total: f64, base: f64 },
}

type Result<T> = std::result::Result<T, CharacterizeError>;

fn positive(name: &'static str, value: f64) -> Result<f64> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(CharacterizeError::NotPositive { name, value })
    }
}

fn finite(name: &'static str, value: f64) -> Result<f64> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(CharacterizeError::NotFinite { name, value })
    }
}

fn non_negative(name: &'static str, value: f64) -> Result<f64> {
    if value.is_finite() && value >= 0.0 {
        Ok(value)
    } else {
        Err(CharacterizeError::NotPositive { name, value })
    }
}

/// Gravity the seed uses in chapter 2 (9.8 m/s^2, section 2.3.1).
pub const SEED_G: f64 = 9.8;

/// A trifilar torsional pendulum (seed 2.3.1): suspended mass, gravity, radius of the string
/// circle, string length, and the inertia of the empty mounting (base) to remove.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Trifilar {
    /// Mass hanging on the strings (object + plate), kg.
    pub mass_kg: f64,
    /// Gravitational acceleration, m/s^2.
    pub g_m_s2: f64,
    /// Radius of the circle of the three string attachment points, m.
    pub radius_m: f64,
    /// String length, m.
    pub length_m: f64,
    /// Inertia of the base (mounting plate and stand) about the same axis, kg m^2.
    pub base_inertia_kgm2: f64,
}

impl Trifilar {
    /// The seed's setup printed under eq. 2.6: m = 7.172 kg, g = 9.8 m/s^2, r = 0.1461 m,
    /// l ~ 2.47 m, I_0 = 0.0448 kg m^2.
    pub const SEED: Trifilar = Trifilar {
        mass_kg: 7.172,
        g_m_s2: SEED_G,
        radius_m: 0.1461,
        length_m: 2.47,
        base_inertia_kgm2: 0.0448,
    };

    fn check(&self) -> Result<()> {
        positive("mass", self.mass_kg)?;
        positive("gravity", self.g_m_s2)?;
        positive("radius", self.radius_m)?;
        positive("string length", self.length_m)?;
        non_negative("base inertia", self.base_inertia_kgm2)?;
        Ok(())
    }

    /// Eq. 2.9: the pendulum's effective torsional spring constant `kappa = m g r^2 / l`, N m/rad.
    pub fn kappa(&self) -> Result<f64> {
        self.check()?;
        Ok(self.mass_kg * self.g_m_s2 * self.radius_m.powi(2) / self.length_m)
    }

    /// Total inertia of everything on the strings at angular frequency `omega` (rad/s),
    /// eq. 2.6 before removing the base: `m g r^2 / (l omega^2)`.
    pub fn total_inertia(&self, omega_rad_s: f64) -> Result<f64> {
        let w = positive("angular frequency", omega_rad_s)?;
        Ok(self.kappa()? / (w * w))
    }

    /// Eq. 2.6: the test object's inertia, `I = m g r^2 / (l omega^2) - I_0`. Err when the
    /// result would not be positive.
    pub fn inertia(&self, omega_rad_s: f64) -> Result<f64> {
        let total = self.total_inertia(omega_rad_s)?;
        let i = total - self.base_inertia_kgm2;
        if i > 0.0 {
            Ok(i)
        } else {
            Err(CharacterizeError::InertiaNotAboveBase {
                total,
                base: self.base_inertia_kgm2,
            })
        }
    }

    /// Eq. 2.6 from a period `T` (s): `omega = 2 pi / T`.
    pub fn inertia_from_period(&self, period_s: f64) -> Result<f64> {
        self.inertia(omega_from_period(period_s)?)
    }

    /// Eq. 2.14-2.15: inertia from a stopwatch time `T` (s) over `n` oscillations,
    /// `omega = 2 pi n / T`.
    pub fn inertia_from_stopwatch(&self, elapsed_s: f64, oscillations: u32) -> Result<f64> {
        self.inertia(omega_from_stopwatch(elapsed_s, oscillations)?)
    }

    /// Sensitivity of the eq. 2.15 inertia (base included) to a stopwatch error `dT`:
    /// `|I(T + dT) - I(T)|` for `n` oscillations over `T` seconds (seed 2.3.6).
    pub fn stopwatch_inertia_error(
        &self,
        elapsed_s: f64,
        oscillations: u32,
        error_s: f64,
    ) -> Result<f64> {
        let e = finite("stopwatch error", error_s)?;
        let a = self.total_inertia(omega_from_stopwatch(elapsed_s, oscillations)?)?;
        let b = self.total_inertia(omega_from_stopwatch(elapsed_s + e, oscillations)?)?;
        Ok((b - a).abs())
    }

    /// Eq. 2.16-2.18, case A: energy of the rotational oscillation of amplitude `theta`
    /// (rad), `E_A = (1/2) (m g r^2 / l) theta^2` J.
    pub fn rotational_energy(&self, amplitude_rad: f64) -> Result<f64> {
        let a = finite("rotation amplitude", amplitude_rad)?;
        Ok(0.5 * self.kappa()? * a * a)
    }

    /// Eq. 2.19-2.20, case B: energy of a sideways swing of amplitude `A` (m) as a simple
    /// pendulum, `E_B = (1/2) (m g / l) A^2` J.
    pub fn translational_energy(&self, amplitude_m: f64) -> Result<f64> {
        let a = finite("swing amplitude", amplitude_m)?;
        self.check()?;
        Ok(0.5 * self.mass_kg * self.g_m_s2 / self.length_m * a * a)
    }

    /// Seed 2.3.6 "Orthogonal Rotational/Translational Motion": the fraction of the
    /// oscillation energy hidden in the swing, `E_B / E_A`, which the seed reads as the
    /// inertia error (3.845 % for 1 cm and 20 deg).
    pub fn swing_inertia_error_fraction(&self, rotation_rad: f64, swing_m: f64) -> Result<f64> {
        let ea = self.rotational_energy(rotation_rad)?;
        if ea <= 0.0 {
            return Err(CharacterizeError::NotPositive {
                name: "rotation amplitude",
                value: rotation_rad,
            });
        }
        Ok(self.translational_energy(swing_m)? / ea)
    }
}

/// `omega = 2 pi / T`.
pub fn omega_from_period(period_s: f64) -> Result<f64> {
    Ok(2.0 * std::f64::consts::PI / positive("period", period_s)?)
}

/// Eq. 2.14: `omega = 2 pi n / T` for `n` oscillations timed over `T` seconds.
pub fn omega_from_stopwatch(elapsed_s: f64, oscillations: u32) -> Result<f64> {
    if oscillations == 0 {
        return Err(CharacterizeError::Invalid(
            "number of oscillations must be at least 1".into(),
        ));
    }
    Ok(2.0 * std::f64::consts::PI * oscillations as f64 / positive("stopwatch time", elapsed_s)?)
}

/// Eq. 2.8: linear torsional spring, `kappa = I omega^2` (N m/rad) from a known inertia.
pub fn torsion_kappa(inertia_kgm2: f64, omega_rad_s: f64) -> Result<f64> {
    let i = positive("inertia", inertia_kgm2)?;
    let w = positive("angular frequency", omega_rad_s)?;
    Ok(i * w * w)
}

/// Eq. 2.8 inverted: the inertia a calibrated spring `kappa` implies, `I = kappa / omega^2`.
pub fn inertia_from_kappa(kappa: f64, omega_rad_s: f64) -> Result<f64> {
    let k = positive("spring constant", kappa)?;
    let w = positive("angular frequency", omega_rad_s)?;
    Ok(k / (w * w))
}

/// Eq. 2.10: damping ratio from the amplitude decay over `n` oscillations,
/// `zeta = ln(a_0 / a_n) / (2 pi n)`. A growing amplitude is rejected.
pub fn damping_ratio(a0: f64, an: f64, oscillations: u32) -> Result<f64> {
    let a0 = positive("initial amplitude", a0)?;
    let an = positive("final amplitude", an)?;
    if oscillations == 0 {
        return Err(CharacterizeError::Invalid(
            "number of oscillations must be at least 1".into(),
        ));
    }
    if an > a0 {
        return Err(CharacterizeError::Invalid(format!(
            "final amplitude {an} exceeds initial amplitude {a0}: not a decay"
        )));
    }
    Ok((a0 / an).ln() / (2.0 * std::f64::consts::PI * oscillations as f64))
}

/// Seed 2.3.6 (after eq. 2.10): ignoring damping `zeta` errs the inertia by `100 zeta^2` %.
pub fn damping_inertia_error_percent(zeta: f64) -> Result<f64> {
    let z = non_negative("damping ratio", zeta)?;
    Ok(100.0 * z * z)
}

/// Seed 2.3.6 "Mathematical Approximation": the arc `r theta` against its chord
/// `2 r sin(theta/2)`; returns `(arc, chord, arc - chord)` in m.
pub fn chord_error(radius_m: f64, theta_rad: f64) -> Result<(f64, f64, f64)> {
    let r = positive("radius", radius_m)?;
    let t = positive("angle", theta_rad)?;
    if t >= std::f64::consts::PI {
        // A swing of half a turn or more has no chord that measures it (at 360 deg the chord
        // is 0, beyond it negative).
        return Err(CharacterizeError::Invalid(format!(
            "angle must be below 180 deg, got {:.1} deg",
            t.to_degrees()
        )));
    }
    let arc = r * t;
    let chord = 2.0 * r * (t / 2.0).sin();
    Ok((arc, chord, arc - chord))
}

/// Eq. 2.12 (parallel-axis theorem): `I_B = I_A + m d^2`; returns the added `m d^2`, the
/// inertia error of measuring about an axis `d` m from the CoM.
pub fn parallel_axis_error(mass_kg: f64, offset_m: f64) -> Result<f64> {
    let m = positive("mass", mass_kg)?;
    let d = finite("axis offset", offset_m)?;
    Ok(m * d * d)
}

/// Eq. 2.12: inertia about a parallel axis at `offset` (m) from the CoM axis.
pub fn parallel_axis(inertia_com_kgm2: f64, mass_kg: f64, offset_m: f64) -> Result<f64> {
    Ok(non_negative("inertia", inertia_com_kgm2)? + parallel_axis_error(mass_kg, offset_m)?)
}

/// Eq. 2.7: inertia measured about the axis at angle `B` in the Y-Z plane,
/// `I_B = I_zz sin^2 B + I_yy cos^2 B - P_yz sin 2B`, with `P_yz = integral y z dm` the product
/// of inertia (the inertia TENSOR's off-diagonal is `-P_yz`). Axis = `(0, cos B, sin B)`.
pub fn rotated_inertia(iyy: f64, izz: f64, pyz: f64, angle_rad: f64) -> f64 {
    let (s, c) = angle_rad.sin_cos();
    izz * s * s + iyy * c * c - pyz * (2.0 * angle_rad).sin()
}

/// Fit of eq. 2.7 over rotated measurements.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PlaneInertia {
    pub iyy: f64,
    pub izz: f64,
    /// Product of inertia `integral y z dm` (tensor off-diagonal is its negative).
    pub pyz: f64,
    /// Root-mean-square residual of the fit, kg m^2 (0 for exactly three angles).
    pub rms_residual: f64,
    /// Standard errors of `iyy`, `izz`, `pyz` (kg m^2): the residual variance
    /// `|r|^2 / (n - 3)` times the diagonal of `(A^T A)^-1`, the usual least-squares
    /// covariance for measurements with equal, independent errors. `None` with exactly three
    /// angles (no residual degree of freedom to estimate the error from).
    #[serde(default)]
    pub standard_errors: Option<[f64; 3]>,
    /// Residual degrees of freedom, `n - 3`.
    #[serde(default)]
    pub dof: usize,
}

/// A linear least-squares solution with its standard errors (see [`least_squares`]).
#[derive(Clone, Debug, PartialEq)]
pub struct LeastSquares {
    pub x: DVector<f64>,
    /// Residual `A x - b`.
    pub residual: DVector<f64>,
    /// Residual degrees of freedom, rows minus unknowns.
    pub dof: usize,
    /// `sqrt(s^2 diag((A^T A)^-1))` with `s^2 = |r|^2 / dof`; `None` when `dof == 0`.
    pub standard_errors: Option<DVector<f64>>,
}

/// Least squares `A x ~ b` by SVD with the parameter standard errors from the residual
/// variance and `(A^T A)^-1 = V S^-2 V^T` (equal, independent errors on every row assumed).
/// Err when `A` is rank deficient (smallest singular value below `1e-9` of the largest).
pub fn least_squares(a: &DMatrix<f64>, b: &DVector<f64>, what: &str) -> Result<LeastSquares> {
    let (m, p) = a.shape();
    if m < p {
        return Err(CharacterizeError::Invalid(format!(
            "{what}: {m} equations for {p} unknowns"
        )));
    }
    let svd = a.clone().svd(true, true);
    let smax = svd.singular_values.max();
    if svd.singular_values.len() < p || svd.singular_values.min() <= 1e-9 * smax {
        return Err(CharacterizeError::Invalid(what.to_string()));
    }
    let x = svd
        .solve(b, 0.0)
        .map_err(|e| CharacterizeError::Invalid(e.to_string()))?;
    let residual = a * &x - b;
    let dof = m - p;
    let standard_errors = (dof > 0).then(|| {
        let s2 = residual.norm_squared() / dof as f64;
        let v_t = svd.v_t.as_ref().expect("svd computed with V");
        // (A^T A)^-1 = V diag(1/s_i^2) V^T; its diagonal entry j is sum_i V_ji^2 / s_i^2
        DVector::from_fn(p, |j, _| {
            let d: f64 = (0..p)
                .map(|i| v_t[(i, j)].powi(2) / svd.singular_values[i].powi(2))
                .sum();
            (s2 * d).sqrt()
        })
    });
    Ok(LeastSquares {
        x,
        residual,
        dof,
        standard_errors,
    })
}

/// Seed 2.3.3: least-squares fit of eq. 2.7 to inertias measured about axes rotated by `B`
/// (rad) in one plane. At least three angles distinct modulo pi are needed.
pub fn products_of_inertia_from_rotations(measurements: &[(f64, f64)]) -> Result<PlaneInertia> {
    if measurements.len() < 3 {
        return Err(CharacterizeError::Invalid(format!(
            "need at least 3 rotated measurements, got {}",
            measurements.len()
        )));
    }
    let n = measurements.len();
    let mut a = DMatrix::<f64>::zeros(n, 3);
    let mut b = DVector::<f64>::zeros(n);
    for (k, &(angle, inertia)) in measurements.iter().enumerate() {
        finite("rotation angle", angle)?;
        positive("measured inertia", inertia)?;
        let (s, c) = angle.sin_cos();
        a[(k, 0)] = c * c;
        a[(k, 1)] = s * s;
        a[(k, 2)] = -(2.0 * angle).sin();
        b[k] = inertia;
    }
    let fit = least_squares(
        &a,
        &b,
        "rotation angles do not determine Iyy, Izz and Pyz (need 3 angles distinct modulo 180 deg)",
    )?;
    let x = &fit.x;
    Ok(PlaneInertia {
        iyy: x[0],
        izz: x[1],
        pyz: x[2],
        rms_residual: (fit.residual.norm_squared() / n as f64).sqrt(),
        standard_errors: fit.standard_errors.map(|se| [se[0], se[1], se[2]]),
        dof: fit.dof,
    })
}

/// Seed 2.3.3: the six-measurement scheme (about X, Y, Z and the 45-degree axes between
/// X-Y, Y-Z, Z-X). From eq. 2.7 at `B = 45 deg`: `P_ab = (I_a + I_b)/2 - I_ab45`. Returns the
/// inertia TENSOR about the measurement origin, off-diagonals `-P`.
pub fn inertia_tensor_from_six(
    ixx: f64,
    iyy: f64,
    izz: f64,
    i_xy45: f64,
    i_yz45: f64,
    i_zx45: f64,
) -> Result<Matrix3<f64>> {
    for (name, v) in [
        ("Ixx", ixx),
        ("Iyy", iyy),
        ("Izz", izz),
        ("I(45 X-Y)", i_xy45),
        ("I(45 Y-Z)", i_yz45),
        ("I(45 Z-X)", i_zx45),
    ] {
        positive(name, v)?;
    }
    let pxy = (ixx + iyy) / 2.0 - i_xy45;
    let pyz = (iyy + izz) / 2.0 - i_yz45;
    let pzx = (izz + ixx) / 2.0 - i_zx45;
    let t = Matrix3::new(ixx, -pxy, -pzx, -pxy, iyy, -pyz, -pzx, -pyz, izz);
    if t.cholesky().is_none() {
        return Err(CharacterizeError::Invalid(
            "measurements give a tensor that is not positive definite".into(),
        ));
    }
    Ok(t)
}

/// One CoM test on the load cell (seed 2.2): the satellite mounted with rotation
/// `body_to_cell` (body vector -> load-cell frame, cell z up), its averaged moments and the
/// averaged moments of the empty stand (the bias), N m, load-cell frame about the cell centre
/// which coincides with the geometric centre.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LoadCellMoments {
    pub body_to_cell: Matrix3<f64>,
    pub moment_nm: Vector3<f64>,
    pub bias_nm: Vector3<f64>,
}

/// Seed 2.2: CoM offset from the geometric centre (body axes, m) from load-cell moments.
/// Weight `W = m g` acts at `R c` in the cell frame along `-z`, so the horizontal moments are
/// `M_x = -W (R c)_y`, `M_y = W (R c)_x`; each mounting gives two equations and the stack is
/// solved by least squares. One upright mounting gives x and y; "the satellite is rotated so
/// it's mounted on its side" for z. Err when the mountings leave an axis unobserved.
pub fn com_from_load_cell(
    tests: &[LoadCellMoments],
    mass_kg: f64,
    g_m_s2: f64,
) -> Result<Vector3<f64>> {
    Ok(com_from_load_cell_with_uncertainty(tests, mass_kg, g_m_s2)?.com_m)
}

/// [`com_from_load_cell`] with the standard errors of the least-squares solution.
pub fn com_from_load_cell_with_uncertainty(
    tests: &[LoadCellMoments],
    mass_kg: f64,
    g_m_s2: f64,
) -> Result<ComEstimate> {
    let w = positive("mass", mass_kg)? * positive("gravity", g_m_s2)?;
    if tests.is_empty() {
        return Err(CharacterizeError::Invalid(
            "no load-cell measurements".into(),
        ));
    }
    let n = tests.len();
    let mut a = DMatrix::<f64>::zeros(2 * n, 3);
    let mut b = DVector::<f64>::zeros(2 * n);
    for (k, t) in tests.iter().enumerate() {
        let vals = t
            .body_to_cell
            .iter()
            .chain(t.moment_nm.iter())
            .chain(t.bias_nm.iter());
        if !vals.clone().all(|v| v.is_finite()) {
            return Err(CharacterizeError::Invalid(format!(
                "load-cell test {}: non-finite value",
                k + 1
            )));
        }
        let r = t.body_to_cell;
        if ((r.transpose() * r) - Matrix3::identity()).abs().max() > 1e-6 {
            return Err(CharacterizeError::Invalid(format!(
                "load-cell test {}: mounting is not a rotation",
                k + 1
            )));
        }
        let m = t.moment_nm - t.bias_nm;
        // M_x = -W * (row1 of R) . c ; M_y = W * (row0 of R) . c
        for j in 0..3 {
            a[(2 * k, j)] = -w * r[(1, j)];
            a[(2 * k + 1, j)] = w * r[(0, j)];
        }
        b[2 * k] = m.x;
        b[2 * k + 1] = m.y;
    }
    if 2 * n < 3 {
        return Err(CharacterizeError::Invalid(UNOBSERVED_COM.into()));
    }
    let fit = least_squares(&a, &b, UNOBSERVED_COM)?;
    let x = &fit.x;
    Ok(ComEstimate {
        com_m: Vector3::new(x[0], x[1], x[2]),
        standard_errors_m: fit
            .standard_errors
            .map(|se| Vector3::new(se[0], se[1], se[2])),
        dof: fit.dof,
    })
}

const UNOBSERVED_COM: &str = "mountings leave a CoM axis unobserved (the vertical axis of every mounting); add a mounting on its side";

/// CoM from load-cell moments with its least-squares standard errors.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ComEstimate {
    /// CoM offset from the geometric centre, body axes, m.
    pub com_m: Vector3<f64>,
    /// Standard errors (m) from the residual of the redundant equations (equal, independent
    /// errors on every averaged moment); `None` when no equation is redundant.
    pub standard_errors_m: Option<Vector3<f64>>,
    /// Residual degrees of freedom: equations (2 per mounting) minus 3.
    pub dof: usize,
}

/// A thruster's nominal thrust: magnitude (N) and direction (the seed's `Dx Dy Dz`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ThrustVector {
    pub magnitude_n: f64,
    pub direction: [f64; 3],
}

/// Seed 3.5: "Force components were averaged over the one-second pulse to create a nominal
/// vector of applied force"; bias (stand alone, valve closed) removed. Magnitude = norm,
/// direction = unit vector.
pub fn thrust_from_load_cell(
    forces_during_pulse_n: &[Vector3<f64>],
    bias_n: Vector3<f64>,
) -> Result<ThrustVector> {
    if forces_during_pulse_n.is_empty() {
        return Err(CharacterizeError::Invalid(
            "no load-cell samples during the pulse".into(),
        ));
    }
    if !forces_during_pulse_n
        .iter()
        .chain(std::iter::once(&bias_n))
        .all(|v| v.iter().all(|x| x.is_finite()))
    {
        return Err(CharacterizeError::Invalid(
            "non-finite load-cell sample".into(),
        ));
    }
    let mean = forces_during_pulse_n
        .iter()
        .fold(Vector3::zeros(), |s, v| s + v)
        / forces_during_pulse_n.len() as f64;
    let f = mean - bias_n;
    let mag = f.norm();
    if mag == 0.0 {
        return Err(CharacterizeError::Invalid(
            "mean force equals the bias: the thruster did not fire".into(),
        ));
    }
    Ok(ThrustVector {
        magnitude_n: mag,
        direction: (f / mag).into(),
    })
}

/// [`thrust_from_load_cell`] with the standard uncertainties that the spread of the samples
/// gives.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ThrustEstimate {
    pub thrust: ThrustVector,
    /// Number of load-cell samples averaged.
    pub samples: usize,
    /// Standard errors of the mean force components FX, FY, FZ (N): sample standard deviation
    /// (n - 1) over `sqrt(n)`. `None` for a single sample.
    pub mean_force_se_n: Option<[f64; 3]>,
    /// Standard error of the magnitude (N), the mean's covariance `C / n` propagated to first
    /// order: `sqrt(d^T (C / n) d)` with `d` the unit direction.
    pub magnitude_se_n: Option<f64>,
    /// Standard errors of the unit direction's components, through the Jacobian
    /// `(I - d d^T) / |f|` of `f / |f|`.
    pub direction_se: Option<[f64; 3]>,
}

/// Seed 3.5 with uncertainties: the mean force's standard error from the spread of the
/// samples (sample covariance over n; the samples are taken as independent, the bias as
/// exact), propagated to the magnitude and direction to first order.
pub fn thrust_from_load_cell_with_uncertainty(
    forces_during_pulse_n: &[Vector3<f64>],
    bias_n: Vector3<f64>,
) -> Result<ThrustEstimate> {
    let thrust = thrust_from_load_cell(forces_during_pulse_n, bias_n)?;
    let n = forces_during_pulse_n.len();
    let mut out = ThrustEstimate {
        thrust,
        samples: n,
        mean_force_se_n: None,
        magnitude_se_n: None,
        direction_se: None,
    };
    if n < 2 {
        return Ok(out);
    }
    let nf = n as f64;
    let mean = forces_during_pulse_n
        .iter()
        .fold(Vector3::zeros(), |s, v| s + v)
        / nf;
    let cov = forces_during_pulse_n.iter().fold(Matrix3::zeros(), |s, v| {
        s + (v - mean) * (v - mean).transpose()
    }) / (nf - 1.0);
    let cov_mean = cov / nf;
    let d = Vector3::from(thrust.direction);
    let j = (Matrix3::identity() - d * d.transpose()) / thrust.magnitude_n;
    let cov_dir = j * cov_mean * j.transpose();
    out.mean_force_se_n = Some(std::array::from_fn(|k| cov_mean[(k, k)].sqrt()));
    out.magnitude_se_n = Some((d.transpose() * cov_mean * d)[0].max(0.0).sqrt());
    out.direction_se = Some(std::array::from_fn(|k| cov_dir[(k, k)].max(0.0).sqrt()));
    Ok(out)
}

/// Seed 3.5 with the mounting taken into account ("change coordinate frames"; the two
/// thrusters pointing into the stand are measured with the satellite rotated 90 deg): the
/// bias-free mean force is rotated from the load-cell frame to body axes with
/// `body_to_cell^T` before taking magnitude and direction.
pub fn thrust_from_load_cell_in_body(
    forces_during_pulse_n: &[Vector3<f64>],
    bias_n: Vector3<f64>,
    body_to_cell: Matrix3<f64>,
) -> Result<ThrustVector> {
    if !body_to_cell.iter().all(|v| v.is_finite())
        || ((body_to_cell.transpose() * body_to_cell) - Matrix3::identity())
            .abs()
            .max()
            > 1e-6
    {
        return Err(CharacterizeError::Invalid(
            "mounting is not a rotation".into(),
        ));
    }
    let in_cell = thrust_from_load_cell(forces_during_pulse_n, bias_n)?;
    let d = body_to_cell.transpose() * Vector3::from(in_cell.direction);
    Ok(ThrustVector {
        magnitude_n: in_cell.magnitude_n,
        direction: d.into(),
    })
}

/// Seed 3.5 / Tables 3.3, C.3-C.4: the nominal values are averages over many tests: mean
/// magnitude, and the component-wise mean of the unit directions (NOT renormalised, which is
/// why the tabulated norms are 0.997..1.000), with the standard deviations (sample, n-1).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ThrustAverage {
    pub mean: ThrustVector,
    pub magnitude_stdev_n: f64,
    pub direction_stdev: [f64; 3],
}

/// Averages repeated thrust tests (seed 3.5). At least two tests.
pub fn average_thrust_tests(tests: &[ThrustVector]) -> Result<ThrustAverage> {
    if tests.len() < 2 {
        return Err(CharacterizeError::Invalid(format!(
            "need at least 2 thrust tests, got {}",
            tests.len()
        )));
    }
    let n = tests.len() as f64;
    let mean_mag = tests.iter().map(|t| t.magnitude_n).sum::<f64>() / n;
    let mean_dir: [f64; 3] =
        std::array::from_fn(|j| tests.iter().map(|t| t.direction[j]).sum::<f64>() / n);
    let var = |f: &dyn Fn(&ThrustVector) -> f64, m: f64| {
        tests.iter().map(|t| (f(t) - m).powi(2)).sum::<f64>() / (n - 1.0)
    };
    let magnitude_stdev_n = var(&|t| t.magnitude_n, mean_mag).sqrt();
    let direction_stdev =
        std::array::from_fn(|j| var(&|t: &ThrustVector| t.direction[j], mean_dir[j]).sqrt());
    Ok(ThrustAverage {
        mean: ThrustVector {
            magnitude_n: mean_mag,
            direction: mean_dir,
        },
        magnitude_stdev_n,
        direction_stdev,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nonsense_inputs_are_rejected_with_reasons() {
        assert!(matches!(
            omega_from_period(-1.0),
            Err(CharacterizeError::NotPositive { name: "period", .. })
        ));
        assert!(Trifilar::SEED.inertia(f64::NAN).is_err());
        assert!(matches!(
            Trifilar::SEED.inertia(100.0),
            Err(CharacterizeError::InertiaNotAboveBase { .. })
        ));
        assert!(damping_ratio(299.0, 306.0, 13).is_err());
        assert!(damping_ratio(306.0, 299.0, 0).is_err());
        assert!(products_of_inertia_from_rotations(&[
            (0.0, 1.0),
            (std::f64::consts::PI, 1.0),
            (0.0, 1.0)
        ])
        .is_err());
        assert!(thrust_from_load_cell(&[], Vector3::zeros()).is_err());
    }

    #[test]
    fn rotated_fit_recovers_a_known_plane() {
        let (iyy, izz, pyz) = (0.0242, 0.0214, 3.1e-4);
        let ms: Vec<(f64, f64)> = (0..7)
            .map(|k| {
                let b = k as f64 * 0.4;
                (b, rotated_inertia(iyy, izz, pyz, b))
            })
            .collect();
        let fit = products_of_inertia_from_rotations(&ms).unwrap();
        assert!(
            (fit.iyy - iyy).abs() < 1e-14
                && (fit.izz - izz).abs() < 1e-14
                && (fit.pyz - pyz).abs() < 1e-14
        );
    }

    #[test]
    fn six_measurement_scheme_recovers_a_tensor() {
        // tensor with off-diagonals -P; axis inertia n^T I n
        let t = Matrix3::new(
            0.0245, -1e-4, 2e-4, -1e-4, 0.0215, -3e-4, 2e-4, -3e-4, 0.0203,
        );
        let s = std::f64::consts::FRAC_1_SQRT_2;
        let about = |n: Vector3<f64>| (n.transpose() * t * n)[0];
        let got = inertia_tensor_from_six(
            t[(0, 0)],
            t[(1, 1)],
            t[(2, 2)],
            about(Vector3::new(s, s, 0.0)),
            about(Vector3::new(0.0, s, s)),
            about(Vector3::new(s, 0.0, s)),
        )
        .unwrap();
        assert!((got - t).abs().max() < 1e-15);
    }

    #[test]
    fn com_from_two_mountings() {
        let c = Vector3::new(0.4549e-3, -1.241e-3, 0.108e-3);
        let (m, g) = (3.5, 9.8);
        let w = m * g;
        let cell = |r: Matrix3<f64>| {
            let rc = r * c;
            LoadCellMoments {
                body_to_cell: r,
                moment_nm: Vector3::new(-w * rc.y + 0.01, w * rc.x - 0.02, 0.3),
                bias_nm: Vector3::new(0.01, -0.02, 0.0),
            }
        };
        let upright = cell(Matrix3::identity());
        // on its side: body z -> cell x (rotation about y by +90 deg)
        let side = cell(Matrix3::new(0.0, 0.0, 1.0, 0.0, 1.0, 0.0, -1.0, 0.0, 0.0));
        assert!(com_from_load_cell(&[upright], m, g).is_err());
        let got = com_from_load_cell(&[upright, side], m, g).unwrap();
        assert!((got - c).norm() < 1e-12);
    }

    proptest::proptest! {
        /// eq. 2.6 inverts: the frequency a given object inertia produces gives it back.
        #[test]
        fn trifilar_round_trip(i in 1e-3f64..1.0, m in 1.0f64..20.0, r in 0.05f64..0.5, l in 0.5f64..5.0, base in 0.0f64..0.1) {
            let p = Trifilar { mass_kg: m, g_m_s2: SEED_G, radius_m: r, length_m: l, base_inertia_kgm2: base };
            let w = (p.kappa().unwrap() / (i + base)).sqrt();
            let got = p.inertia(w).unwrap();
            proptest::prop_assert!((got - i).abs() <= 1e-12 * (i + base));
            // eq. 2.8 with the total inertia gives eq. 2.9's kappa
            let k = torsion_kappa(i + base, w).unwrap();
            proptest::prop_assert!((k - p.kappa().unwrap()).abs() <= 1e-12 * k);
        }

        /// Any CoM is recovered from an upright and a random second mounting that tilts the
        /// vertical axis away from body z.
        #[test]
        fn com_round_trip(cx in -0.01f64..0.01, cy in -0.01f64..0.01, cz in -0.01f64..0.01,
                          ax in -1.0f64..1.0, ay in -1.0f64..1.0, ang in 0.5f64..2.6) {
            let axis = nalgebra::Unit::new_normalize(Vector3::new(ax, ay, 0.0) + Vector3::new(1e-3, 0.0, 0.0));
            let r2 = *nalgebra::Rotation3::from_axis_angle(&axis, ang).matrix();
            let c = Vector3::new(cx, cy, cz);
            let w = 3.5 * SEED_G;
            let meas = |r: Matrix3<f64>| {
                let rc = r * c;
                LoadCellMoments { body_to_cell: r, moment_nm: Vector3::new(-w * rc.y, w * rc.x, 0.0), bias_nm: Vector3::zeros() }
            };
            let got = com_from_load_cell(&[meas(Matrix3::identity()), meas(r2)], 3.5, SEED_G).unwrap();
            proptest::prop_assert!((got - c).norm() < 1e-10);
        }
    }

    /// Spread of `xs` (sample standard deviation).
    fn stdev(xs: &[f64]) -> f64 {
        let n = xs.len() as f64;
        let m = xs.iter().sum::<f64>() / n;
        (xs.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0)).sqrt()
    }

    #[test]
    fn thrust_standard_errors_match_the_spread_of_repeated_pulses() {
        // 400 simulated pulses of 50 samples each, noise 0.02 N per component: the reported
        // standard errors (mean over pulses) equal the spread of the estimates to ~10 %.
        use rand::SeedableRng;
        use rand_distr::{Distribution, Normal};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(26);
        let noise = Normal::new(0.0, 0.02).unwrap();
        let f = Vector3::new(0.12, 0.03, -0.01);
        let (mut mags, mut dys, mut se_mag, mut se_dy) = (vec![], vec![], 0.0, 0.0);
        for _ in 0..400 {
            let s: Vec<Vector3<f64>> = (0..50)
                .map(|_| f + Vector3::from_fn(|_, _| noise.sample(&mut rng)))
                .collect();
            let t = thrust_from_load_cell_with_uncertainty(&s, Vector3::zeros()).unwrap();
            mags.push(t.thrust.magnitude_n);
            dys.push(t.thrust.direction[1]);
            se_mag += t.magnitude_se_n.unwrap() / 400.0;
            se_dy += t.direction_se.unwrap()[1] / 400.0;
        }
        let (sm, sd) = (stdev(&mags), stdev(&dys));
        assert!(
            (se_mag / sm - 1.0).abs() < 0.1,
            "magnitude: se {se_mag} spread {sm}"
        );
        assert!(
            (se_dy / sd - 1.0).abs() < 0.1,
            "direction y: se {se_dy} spread {sd}"
        );
        assert!((se_mag / (0.02 / 50f64.sqrt()) - 1.0).abs() < 0.05);
        let one = thrust_from_load_cell_with_uncertainty(&[f], Vector3::zeros()).unwrap();
        assert!(one.magnitude_se_n.is_none() && one.direction_se.is_none());
    }

    #[test]
    fn plane_fit_standard_errors_match_the_spread_of_repeated_fits() {
        use rand::SeedableRng;
        use rand_distr::{Distribution, Normal};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(27);
        let noise = Normal::new(0.0, 2e-4).unwrap();
        let (iyy, izz, pyz) = (0.0242, 0.0214, 3.1e-4);
        let mut est: [Vec<f64>; 3] = Default::default();
        let mut se = [0.0; 3];
        for _ in 0..400 {
            let ms: Vec<(f64, f64)> = (0..6)
                .map(|k| {
                    let b = (k as f64 * 30.0).to_radians();
                    (
                        b,
                        rotated_inertia(iyy, izz, pyz, b) + noise.sample(&mut rng),
                    )
                })
                .collect();
            let fit = products_of_inertia_from_rotations(&ms).unwrap();
            assert_eq!(fit.dof, 3);
            for (k, v) in [fit.iyy, fit.izz, fit.pyz].into_iter().enumerate() {
                est[k].push(v);
                se[k] += fit.standard_errors.unwrap()[k] / 400.0;
            }
        }
        for k in 0..3 {
            // the mean of s over 3 dof is c4(4) = 0.921 of sigma
            let ratio = se[k] / stdev(&est[k]);
            assert!((0.8..1.05).contains(&ratio), "term {k}: se/spread {ratio}");
        }
        let three =
            products_of_inertia_from_rotations(&[(0.0, 0.02), (1.0, 0.021), (2.0, 0.022)]).unwrap();
        assert!(three.standard_errors.is_none() && three.dof == 0);
    }

    #[test]
    fn thrust_measured_on_its_side_is_rotated_to_body_axes() {
        // thruster 5 pushes +z (body); mounted with body z along cell x
        let r = Matrix3::new(0.0, 0.0, 1.0, 0.0, 1.0, 0.0, -1.0, 0.0, 0.0);
        let f_body = Vector3::new(0.01, 0.03, 0.11);
        let samples = [r * f_body + Vector3::new(0.2, 0.0, -34.0)];
        let t = thrust_from_load_cell_in_body(&samples, Vector3::new(0.2, 0.0, -34.0), r).unwrap();
        assert!((t.magnitude_n - f_body.norm()).abs() < 1e-12);
        assert!((Vector3::from(t.direction) - f_body / f_body.norm()).norm() < 1e-12);
        assert!(thrust_from_load_cell_in_body(&samples, Vector3::zeros(), r * 2.0).is_err());
    }

    #[test]
    fn thrust_average_keeps_unnormalised_mean_direction() {
        let a = thrust_from_load_cell(
            &[
                Vector3::new(0.13, 0.0, 0.01),
                Vector3::new(0.13, 0.0, -0.01),
            ],
            Vector3::zeros(),
        )
        .unwrap();
        assert!((a.magnitude_n - 0.13).abs() < 1e-15 && (a.direction[0] - 1.0).abs() < 1e-15);
        let t1 = ThrustVector {
            magnitude_n: 0.13,
            direction: [0.6, 0.8, 0.0],
        };
        let t2 = ThrustVector {
            magnitude_n: 0.11,
            direction: [0.8, 0.6, 0.0],
        };
        let avg = average_thrust_tests(&[t1, t2]).unwrap();
        assert!((avg.mean.magnitude_n - 0.12).abs() < 1e-15);
        assert!((avg.mean.direction[0] - 0.7).abs() < 1e-15);
        assert!((avg.magnitude_stdev_n - (2.0f64 * 0.01 * 0.01).sqrt()).abs() < 1e-15);
    }
}
