//! Satellite models: the nominal SPHERES flight satellites `sph1`..`sph5` of
//! `contracts/satellites.md` (seed Appendix C, Table 3.2) and user model files (TOML).
//!
//! Conventions (seed App. D listings):
//! - thruster positions are from the geometric centre; the lever arm about the centre of
//!   mass is `pos - com` (seed: `L = Lnom - cm_nom*ones(1,12)`);
//! - the inertia matrix is `[[Ixx, Ixy, Ixz], [Ixy, Iyy, Iyz], [Ixz, Iyz, Izz]]` with the
//!   products of inertia entered as tabulated (seed: `I_nom`, `I_inv_mat`), about the CoM;
//! - thrust directions are used as given (their norms are 0.997..1.000).
use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Number of thrusters on a SPHERES satellite (the built-in models and the PWM mixer, whose
/// opposing-pair logic is SPHERES-specific).
pub const N_THRUSTERS: usize = 12;
/// Most thrusters a model may describe: a thruster word is 16 bits wide.
pub const MAX_THRUSTERS: usize = 16;

/// Opposing thruster pairs (same line of action, opposite force), 0-based indices:
/// thrusters (1,7) (2,8) (3,9) (4,10) (5,11) (6,12) in the seed's 1-based numbering.
pub const OPPOSING_PAIRS: [(usize, usize); 6] = [(0, 6), (1, 7), (2, 8), (3, 9), (4, 10), (5, 11)];

/// Largest thrust of one thruster a model may state, N (small thruster craft).
pub const MAX_THRUST_N: f64 = 100.0;
/// A thrust direction's norm may differ from 1 by this much.
pub const DIR_NORM_TOLERANCE: f64 = 0.01;
/// Farthest a thruster may be from the geometric centre, m.
pub const MAX_SIZE_M: f64 = 10.0;
/// Heaviest craft a model may describe, kg.
pub const MAX_MASS_KG: f64 = 10_000.0;

/// Default gyro scale, counts per rad/s, every axis and satellite (seed App. D: `conversion = 1412.79`).
pub const GYRO_COUNTS_PER_RAD_S: f64 = 1412.79;
/// Standard gravity used for the accelerometer scale, m/s^2.
pub const STANDARD_GRAVITY: f64 = 9.80665;
/// Accelerometer scale: 12.5e-6 g per count (satellites.md).
pub const ACCEL_M_S2_PER_COUNT: f64 = 12.5e-6 * STANDARD_GRAVITY;
/// Accelerometer bias, counts (satellites.md).
pub const ACCEL_BIAS_COUNTS: f64 = 2048.0;
/// Satellite mass with a full tank, kg (seed: "7.7 lb").
pub const MASS_KG: f64 = 3.5;
/// Pressure drop per extra open thruster that the seed's flight code assumed, N. The
/// built-in nominal models do NOT use it (0.0); a model file may set it.
pub const SEED_PRESSURE_DROP_N_PER_EXTRA: f64 = 0.0106;

/// Thruster locations from the geometric centre, m (satellites.md, seed Table 3.2).
pub const THRUSTER_POS_M: [[f64; 3]; N_THRUSTERS] = [
    [-0.0516, 0.0, 0.0965],
    [-0.0516, 0.0, -0.0965],
    [0.0965, -0.0516, 0.0],
    [-0.0965, -0.0516, 0.0],
    [0.0, 0.0965, -0.0516],
    [0.0, -0.0965, -0.0516],
    [0.0516, 0.0, 0.0965],
    [0.0516, 0.0, -0.0965],
    [0.0965, 0.0516, 0.0],
    [-0.0965, 0.0516, 0.0],
    [0.0, 0.0965, 0.0516],
    [0.0, -0.0965, 0.0516],
];

/// A satellite model: everything the nominal physics and the estimators need.
/// A model file (TOML) is exactly this struct serialized (see the crate README); unknown
/// keys are errors (a typo must not silently leave a parameter at its default).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Satellite {
    /// Name used in recordings' `satellite` metadata (e.g. "sph2").
    pub name: String,
    /// Thruster positions from the geometric centre, m; one entry per thruster (1 to
    /// [`MAX_THRUSTERS`]; thruster i is bit i-1 of a thruster word).
    pub thruster_pos_m: Vec<[f64; 3]>,
    /// Thrust force directions (body axes), used as given; as many as positions.
    pub thrust_dir: Vec<[f64; 3]>,
    /// Thrust magnitude of each thruster when it fires alone, N; as many as positions.
    pub thrust_n: Vec<f64>,
    /// A planar craft (an air-bearing table): it turns about body z only, its gyro (or
    /// motion capture) measures z only, and only Izz and the CoM's x and y are
    /// identifiable; every other inertia and CoM term is held at the model and reported
    /// unidentifiable. Absent in a model file means a 3-D craft.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub planar: bool,
    /// Inertia about the CoM, kg m^2, in contract order xx yy zz xy xz yz.
    pub inertia_kgm2: [f64; 6],
    /// Centre of mass minus geometric centre, mm.
    pub com_offset_mm: [f64; 3],
    /// Mass, kg (only the accelerometers need it).
    pub mass_kg: f64,
    /// Gyro zero-rate output, counts, per axis.
    pub gyro_bias_counts: [f64; 3],
    /// Gyro scale, counts per rad/s, per axis.
    pub gyro_counts_per_rad_s: [f64; 3],
    /// Accelerometer zero output, counts, per axis.
    pub accel_bias_counts: [f64; 3],
    /// Accelerometer scale, m/s^2 per count.
    pub accel_m_s2_per_count: f64,
    /// Thrust lost by each open thruster per additional open thruster, N (seed ch. 3
    /// multi-thruster pressure drop). 0.0 in the built-in nominal models.
    pub pressure_drop_n_per_extra: f64,
    /// Optional: each thruster's thrust uncertainty, 1 sigma, N (seed Table C.3 measures a
    /// 2-8 % spread). The identification's standard errors then include it; absent, they
    /// cover the rate noise only (a uniform thrust error is an inertia error on rates).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub thrust_sigma_n: Vec<f64>,
}

/// A model file that cannot be used: names the file (or origin) and why.
#[derive(Debug, thiserror::Error)]
#[error("{file}: {reason}")]
pub struct ModelError {
    pub file: String,
    pub reason: String,
}

impl ModelError {
    fn new(file: &str, reason: impl Into<String>) -> Self {
        ModelError {
            file: file.to_string(),
            reason: reason.into(),
        }
    }
}

/// Per-satellite data of satellites.md: (name, thrust N, Dx, Dy, Dz, inertia, com mm, gyro bias).
struct BuiltinTable {
    name: &'static str,
    thrust_n: [f64; 12],
    dx: [f64; 12],
    dy: [f64; 12],
    dz: [f64; 12],
    inertia: [f64; 6],
    com_mm: [f64; 3],
    gyro_bias: [f64; 3],
}

const BUILTINS: [BuiltinTable; 5] = [
    BuiltinTable {
        name: "sph1",
        thrust_n: [
            0.1336, 0.1302, 0.1221, 0.1299, 0.1139, 0.1244, 0.1335, 0.1302, 0.1284, 0.1316, 0.1256,
            0.1095,
        ],
        dx: [
            0.9982, 0.9985, 0.0589, -0.0176, 0.0107, -0.0224, -0.9986, -0.9984, 0.0418, -0.0194,
            0.0041, -0.0018,
        ],
        dy: [
            -0.0221, -0.0008, 0.9961, 0.9994, 0.0337, -0.0121, -0.0077, -0.0095, -0.9990, -0.9997,
            0.0603, -0.0297,
        ],
        dz: [
            0.0249, -0.0248, 0.0324, 0.0036, 0.9991, 0.9994, 0.0445, -0.0367, 0.0088, 0.0044,
            -0.9981, -0.9994,
        ],
        inertia: [0.024517, 0.021529, 0.020309, -8.4e-05, 0.000014, 0.00029],
        com_mm: [0.4549, -1.241, 0.108],
        gyro_bias: [2055.0, 2079.0, 2051.0],
    },
    BuiltinTable {
        name: "sph2",
        thrust_n: [
            0.1085, 0.1117, 0.1131, 0.1120, 0.1120, 0.1116, 0.1117, 0.1151, 0.1170, 0.1137, 0.1058,
            0.1113,
        ],
        dx: [
            0.9988, 0.9995, 0.0126, -0.0209, -0.0011, -0.0076, -0.9996, -0.9989, 0.0391, -0.0292,
            0.0085, -0.0046,
        ],
        dy: [
            -0.0061, -0.0086, 0.9994, 0.9995, 0.0244, -0.0278, 0.0162, 0.0374, -0.9989, -0.9992,
            0.0598, 0.0075,
        ],
        dz: [
            0.0356, -0.0018, 0.0104, -0.0149, 0.9994, 0.9995, 0.0137, -0.0166, 0.0219, 0.0239,
            -0.9981, -0.9999,
        ],
        inertia: [0.0242, 0.0214, 0.0194, 0.000108, 0.000157, 1.23e-05],
        com_mm: [0.8115, -1.2044, -0.0985],
        gyro_bias: [2077.0, 2070.0, 2058.0],
    },
    BuiltinTable {
        name: "sph3",
        thrust_n: [
            0.1065, 0.1096, 0.1164, 0.1097, 0.1060, 0.1048, 0.1051, 0.1128, 0.1184, 0.1160, 0.1089,
            0.1041,
        ],
        dx: [
            0.9996, 0.9986, 0.0100, -0.0393, 0.0084, -0.0166, -0.9988, -0.9983, 0.0078, -0.0310,
            -0.0258, 0.0083,
        ],
        dy: [
            -0.0091, -0.0247, 0.9995, 0.9988, -0.0087, -0.0835, 0.0134, 0.0162, -0.9990, -0.9990,
            0.0426, -0.0462,
        ],
        dz: [
            0.0171, -0.0405, 0.0009, 0.0125, 0.9992, 0.9957, 0.0067, -0.0353, -0.0158, -0.0003,
            -0.9961, -0.9979,
        ],
        inertia: [0.0275, 0.0235, 0.0212, -8.2e-06, 0.000149, -0.00022],
        com_mm: [0.5767, -1.6296, 0.6975],
        gyro_bias: [2055.0, 2061.0, 2053.0],
    },
    BuiltinTable {
        name: "sph4",
        thrust_n: [
            0.1156, 0.1120, 0.1195, 0.1149, 0.1224, 0.1204, 0.1228, 0.1191, 0.1220, 0.1194, 0.1225,
            0.1127,
        ],
        dx: [
            0.9990, 0.9983, 0.0264, -0.0455, -0.0128, -0.0136, -0.9996, -0.9988, 0.0023, -0.0448,
            -0.0279, 0.0231,
        ],
        dy: [
            -0.0331, -0.0351, 0.9992, 0.9985, 0.0264, -0.0660, 0.0020, 0.0149, -0.9995, -0.9986,
            0.0159, -0.0335,
        ],
        dz: [
            0.0196, -0.0451, 0.0085, -0.0212, 0.9991, 0.9975, 0.0092, -0.0408, -0.0114, 0.0079,
            -0.9992, -0.9988,
        ],
        inertia: [0.023, 0.0242, 0.0214, 0.0001, -0.0003, 0.0],
        com_mm: [0.7303, -1.3824, -0.3932],
        gyro_bias: [2048.0, 2048.0, 2048.0],
    },
    BuiltinTable {
        name: "sph5",
        thrust_n: [
            0.1111, 0.1108, 0.1108, 0.1142, 0.1123, 0.1105, 0.1160, 0.1130, 0.1135, 0.1138, 0.1068,
            0.1079,
        ],
        dx: [
            0.9988, 0.9987, 0.0229, -0.0669, -0.0219, -0.0036, -0.9992, -0.9991, 0.0090, -0.0450,
            -0.0108, 0.0136,
        ],
        dy: [
            -0.0108, -0.0276, 0.9993, 0.9975, 0.0272, -0.0662, 0.0101, 0.0110, -0.9989, -0.9985,
            0.0352, -0.0334,
        ],
        dz: [
            0.0452, -0.0406, -0.0202, -0.0225, 0.9991, 0.9977, 0.0003, -0.0255, -0.0250, -0.0089,
            -0.9990, -0.9991,
        ],
        inertia: [0.0242, 0.021529, 0.0212, -0.00022, 0.0, 0.0001],
        com_mm: [0.4045, -1.3294, 0.3113],
        gyro_bias: [2048.0, 2048.0, 2048.0],
    },
];

impl Satellite {
    /// Names accepted by [`Satellite::builtin`].
    pub const BUILTIN_NAMES: [&'static str; 5] = ["sph1", "sph2", "sph3", "sph4", "sph5"];

    /// The nominal model of a SPHERES flight satellite, "sph1".."sph5" (case-insensitive).
    pub fn builtin(name: &str) -> Option<Satellite> {
        let t = BUILTINS
            .iter()
            .find(|t| t.name.eq_ignore_ascii_case(name))?;
        let thrust_dir = (0..N_THRUSTERS)
            .map(|i| [t.dx[i], t.dy[i], t.dz[i]])
            .collect();
        Some(Satellite {
            name: t.name.to_string(),
            thruster_pos_m: THRUSTER_POS_M.to_vec(),
            thrust_dir,
            thrust_n: t.thrust_n.to_vec(),
            planar: false,
            inertia_kgm2: t.inertia,
            com_offset_mm: t.com_mm,
            mass_kg: MASS_KG,
            gyro_bias_counts: t.gyro_bias,
            gyro_counts_per_rad_s: [GYRO_COUNTS_PER_RAD_S; 3],
            accel_bias_counts: [ACCEL_BIAS_COUNTS; 3],
            accel_m_s2_per_count: ACCEL_M_S2_PER_COUNT,
            pressure_drop_n_per_extra: 0.0,
            thrust_sigma_n: Vec::new(),
        })
    }

    /// Reads a model file (TOML of this struct). The error names the file and the reason.
    pub fn from_toml_file(path: &Path) -> Result<Satellite, ModelError> {
        let origin = path.display().to_string();
        let text = std::fs::read_to_string(path)
            .map_err(|e| ModelError::new(&origin, format!("cannot read: {e}")))?;
        Self::from_toml_str(&text, &origin)
    }

    /// Parses and validates a model from TOML text; `origin` names it in errors.
    pub fn from_toml_str(s: &str, origin: &str) -> Result<Satellite, ModelError> {
        let sat: Satellite = toml::from_str(s)
            .map_err(|e| ModelError::new(origin, format!("invalid model: {e}")))?;
        sat.validate()
            .map_err(|reason| ModelError::new(origin, reason))?;
        Ok(sat)
    }

    /// The model as TOML (the model-file format); [`Satellite::from_toml_str`] reads it back.
    pub fn to_toml_string(&self) -> String {
        // Serializing plain numbers and arrays cannot fail.
        toml::to_string_pretty(self).unwrap_or_default()
    }

    /// Checks the physical sanity a model needs before any estimator may use it.
    pub fn validate(&self) -> Result<(), String> {
        let all_finite = self.thruster_pos_m.iter().flatten().all(|v| v.is_finite())
            && self.thrust_dir.iter().flatten().all(|v| v.is_finite())
            && self.thrust_n.iter().all(|v| v.is_finite())
            && self.inertia_kgm2.iter().all(|v| v.is_finite())
            && self.com_offset_mm.iter().all(|v| v.is_finite())
            && self
                .thrust_sigma_n
                .iter()
                .all(|v| v.is_finite() && *v >= 0.0)
            && self.gyro_bias_counts.iter().all(|v| v.is_finite())
            && self.gyro_counts_per_rad_s.iter().all(|v| v.is_finite())
            && self.accel_bias_counts.iter().all(|v| v.is_finite())
            && self.mass_kg.is_finite()
            && self.accel_m_s2_per_count.is_finite()
            && self.pressure_drop_n_per_extra.is_finite();
        if !all_finite {
            return Err("every number must be finite".into());
        }
        if self.name.trim().is_empty() {
            return Err("name must not be empty".into());
        }
        let n = self.thruster_pos_m.len();
        if n == 0 || n > MAX_THRUSTERS {
            return Err(format!(
                "thruster_pos_m has {n} thrusters; a model has 1 to {MAX_THRUSTERS}"
            ));
        }
        if self.thrust_dir.len() != n || self.thrust_n.len() != n {
            return Err(format!(
                "thruster_pos_m, thrust_dir and thrust_n must have one entry per thruster \
                 ({n}, {}, {})",
                self.thrust_dir.len(),
                self.thrust_n.len()
            ));
        }
        if !self.thrust_sigma_n.is_empty() && self.thrust_sigma_n.len() != n {
            return Err(format!(
                "thrust_sigma_n has {} entries; the model has {n} thrusters (or leave it out)",
                self.thrust_sigma_n.len()
            ));
        }
        if self.planar {
            if let Some(i) = (0..n).find(|&i| {
                self.thrust_dir[i][2].abs() > 1e-9 || self.thruster_pos_m[i][2].abs() > 1e-9
            }) {
                return Err(format!(
                    "planar craft: thruster {} must lie in the x-y plane and push in it \
                     (z of position and direction 0)",
                    i + 1
                ));
            }
        }
        if let Some(i) = self.thrust_n.iter().position(|&f| f < 0.0) {
            return Err(format!("thrust_n[{i}] is negative"));
        }
        if let Some(i) = self
            .thrust_dir
            .iter()
            .position(|d| Vector3::from(*d).norm() < 0.5)
        {
            return Err(format!("thrust_dir[{i}] is not a direction (norm < 0.5)"));
        }
        if self.mass_kg <= 0.0 {
            return Err("mass_kg must be positive".into());
        }
        if let Some(a) = self.gyro_counts_per_rad_s.iter().position(|&k| k == 0.0) {
            return Err(format!("gyro_counts_per_rad_s[{a}] must not be zero"));
        }
        if self.pressure_drop_n_per_extra < 0.0 {
            return Err("pressure_drop_n_per_extra must not be negative".into());
        }
        if self.inertia_matrix().cholesky().is_none() {
            return Err("inertia_kgm2 is not positive definite".into());
        }
        Ok(())
    }

    /// Physical plausibility of a model a user wrote (every model file is held to it when it
    /// is read; [`Satellite::validate`] is the weaker check any estimator needs). Each reason
    /// starts with the key it is about. The envelope, and why:
    /// - `thrust_n`: each in (0, [`MAX_THRUST_N`]] N (a dead thruster is the simulator's
    ///   `thrust_scale` effect with 0, not a nominal model);
    /// - `thrust_dir`: unit vectors within [`DIR_NORM_TOLERANCE`] (the seed's calibrated
    ///   directions have norms 0.997..1.000);
    /// - `thruster_pos_m`: within [`MAX_SIZE_M`] of the geometric centre, not all at it;
    /// - `mass_kg`: in (0, [`MAX_MASS_KG`]];
    /// - `inertia_kgm2`: positive definite, principal moments obeying the triangle inequality
    ///   (`I1 + I2 >= I3`, within 1 %) as any rigid body's do, and none above
    ///   `mass_kg * (5 r)^2` with `r` the farthest thruster from the centre (all of the mass
    ///   five times farther out than the thrusters);
    /// - `com_offset_mm`: within `r` of the centre;
    /// - `thrust_sigma_n`: each at most the thruster's thrust;
    /// - `pressure_drop_n_per_extra`: at most the largest thrust;
    /// - gyro and accelerometer scales: non-zero and at most 10^6 in magnitude, biases at most
    ///   65535 counts in magnitude.
    pub fn check_plausible(&self) -> Result<(), String> {
        self.validate()?;
        let n = self.n_thrusters();
        for i in 0..n {
            let f = self.thrust_n[i];
            if !(f > 0.0 && f <= MAX_THRUST_N) {
                return Err(format!(
                    "thrust_n[{i}] = {f} N: a thruster's thrust must be in (0, {MAX_THRUST_N}] N \
                     (a dead thruster is the `thrust_scale` effect with 0)"
                ));
            }
            let norm = Vector3::from(self.thrust_dir[i]).norm();
            if (norm - 1.0).abs() > DIR_NORM_TOLERANCE {
                return Err(format!(
                    "thrust_dir[{i}] has norm {norm:.6}: a direction is a unit vector (norm 1 \
                     within {DIR_NORM_TOLERANCE})"
                ));
            }
            let r = Vector3::from(self.thruster_pos_m[i]).norm();
            if r > MAX_SIZE_M {
                return Err(format!(
                    "thruster_pos_m[{i}] is {r} m from the centre; at most {MAX_SIZE_M} m"
                ));
            }
        }
        let r_max = self.reach_m();
        if r_max <= 0.0 {
            return Err(
                "thruster_pos_m: every thruster is at the centre; they could not turn the craft"
                    .into(),
            );
        }
        if !(self.mass_kg > 0.0 && self.mass_kg <= MAX_MASS_KG) {
            return Err(format!(
                "mass_kg = {}: must be in (0, {MAX_MASS_KG}] kg",
                self.mass_kg
            ));
        }
        let eig = self.inertia_matrix().symmetric_eigenvalues();
        let mut p = [eig[0], eig[1], eig[2]];
        p.sort_by(f64::total_cmp);
        if p[0] <= 0.0 {
            return Err("inertia_kgm2 is not positive definite".into());
        }
        if p[0] + p[1] < p[2] * 0.99 {
            return Err(format!(
                "inertia_kgm2: principal moments {:.4e}, {:.4e}, {:.4e} kg m^2 break the triangle \
                 inequality (the two smaller sum to less than the largest): no rigid body has them",
                p[0], p[1], p[2]
            ));
        }
        let cap = self.mass_kg * (5.0 * r_max).powi(2);
        if p[2] > cap {
            return Err(format!(
                "inertia_kgm2: largest principal moment {:.4e} kg m^2 is above {cap:.4e} = \
                 mass_kg * (5 x the farthest thruster's {r_max:.3} m)^2: outside the craft's envelope",
                p[2]
            ));
        }
        let com = Vector3::from(self.com_offset_mm).norm() * 1e-3;
        if com > r_max {
            return Err(format!(
                "com_offset_mm is {:.1} mm from the centre, outside the thrusters ({:.1} mm)",
                com * 1e3,
                r_max * 1e3
            ));
        }
        if !self.thrust_sigma_n.is_empty() {
            if let Some(i) = (0..n).find(|&i| self.thrust_sigma_n[i] > self.thrust_n[i]) {
                return Err(format!(
                    "thrust_sigma_n[{i}] = {} N is more than thruster {}'s thrust {} N",
                    self.thrust_sigma_n[i],
                    i + 1,
                    self.thrust_n[i]
                ));
            }
        }
        let f_max = self.thrust_n.iter().cloned().fold(0.0, f64::max);
        if self.pressure_drop_n_per_extra > f_max {
            return Err(format!(
                "pressure_drop_n_per_extra = {} N is more than the largest thrust ({f_max} N)",
                self.pressure_drop_n_per_extra
            ));
        }
        for (key, v) in [
            ("gyro_counts_per_rad_s", &self.gyro_counts_per_rad_s[..]),
            ("accel_m_s2_per_count", &[self.accel_m_s2_per_count][..]),
        ] {
            if let Some(x) = v.iter().find(|x| !(x.abs() > 0.0 && x.abs() <= 1e6)) {
                return Err(format!("{key}: {x} must be non-zero and at most 1e6"));
            }
        }
        for (key, v) in [
            ("gyro_bias_counts", &self.gyro_bias_counts),
            ("accel_bias_counts", &self.accel_bias_counts),
        ] {
            if let Some(x) = v.iter().find(|x| x.abs() > 65535.0) {
                return Err(format!("{key}: {x} is more than 65535 counts"));
            }
        }
        Ok(())
    }

    /// Inertia matrix about the CoM, `[[Ixx,Ixy,Ixz],[Ixy,Iyy,Iyz],[Ixz,Iyz,Izz]]` (seed `I_nom`).
    pub fn inertia_matrix(&self) -> Matrix3<f64> {
        let [xx, yy, zz, xy, xz, yz] = self.inertia_kgm2;
        Matrix3::new(xx, xy, xz, xy, yy, yz, xz, yz, zz)
    }

    /// The craft's reach, m: the farthest thruster's distance from the geometric centre. The
    /// thrusters sit on the hull, so a CoM farther out than this is outside the craft: the
    /// one envelope of the model file's `com_offset_mm` and of every CoM estimate. (The box of
    /// the thruster positions, used before, is flat for a craft whose thrusters all sit on one
    /// face, and a few millimetres wide on an axis the thrusters happen to sit near.)
    pub fn reach_m(&self) -> f64 {
        self.thruster_pos_m
            .iter()
            .map(|p| Vector3::from(*p).norm())
            .fold(0.0, f64::max)
    }

    /// Each thruster's relative thrust uncertainty (`thrust_sigma_n / thrust_n`); empty when
    /// the model states none.
    pub fn thrust_sigma_rel(&self) -> Vec<f64> {
        self.thrust_sigma_n
            .iter()
            .zip(&self.thrust_n)
            .map(|(s, f)| if *f > 0.0 { s / f } else { 0.0 })
            .collect()
    }

    /// Number of thrusters the model describes.
    pub fn n_thrusters(&self) -> usize {
        self.thruster_pos_m.len()
    }

    /// The thruster-word bits that name a thruster of this model.
    pub fn word_mask(&self) -> u16 {
        if self.n_thrusters() >= 16 {
            u16::MAX
        } else {
            (1u16 << self.n_thrusters()) - 1
        }
    }

    /// CoM offset from the geometric centre, m.
    pub fn com_m(&self) -> Vector3<f64> {
        Vector3::from(self.com_offset_mm) * 1e-3
    }

    /// Force of thruster `i` (0-based) firing alone, N: `thrust_n[i] * dir[i]`.
    pub fn force_n(&self, i: usize) -> Vector3<f64> {
        Vector3::from(self.thrust_dir[i]) * self.thrust_n[i]
    }

    /// Unit-ish direction of thruster `i` as given.
    pub fn dir(&self, i: usize) -> Vector3<f64> {
        Vector3::from(self.thrust_dir[i])
    }

    /// Position of thruster `i` from the geometric centre, m.
    pub fn pos_m(&self, i: usize) -> Vector3<f64> {
        Vector3::from(self.thruster_pos_m[i])
    }

    /// Lever arm of thruster `i` about the CoM, m (seed `L = Lnom - cm`).
    pub fn lever_arm_m(&self, i: usize) -> Vector3<f64> {
        self.pos_m(i) - self.com_m()
    }

    /// Torque about the CoM of thruster `i` firing alone, N m: `lever x force`.
    pub fn torque_nm(&self, i: usize) -> Vector3<f64> {
        self.lever_arm_m(i).cross(&self.force_n(i))
    }

    /// Gyro counts to rad/s on one axis: `(counts - bias) / scale`.
    pub fn gyro_counts_to_rad_s(&self, axis: usize, counts: f64) -> f64 {
        (counts - self.gyro_bias_counts[axis]) / self.gyro_counts_per_rad_s[axis]
    }

    /// rad/s to (unquantized, unclamped) gyro counts on one axis; inverse of
    /// [`Satellite::gyro_counts_to_rad_s`].
    pub fn rad_s_to_gyro_counts(&self, axis: usize, rate: f64) -> f64 {
        rate * self.gyro_counts_per_rad_s[axis] + self.gyro_bias_counts[axis]
    }

    /// Accelerometer counts to m/s^2 on one axis.
    pub fn accel_counts_to_m_s2(&self, axis: usize, counts: f64) -> f64 {
        (counts - self.accel_bias_counts[axis]) * self.accel_m_s2_per_count
    }

    /// Thrust magnitude of each open thruster when `word` (bit i = thruster i+1) is commanded:
    /// `thrust_n[i] - (n_open - 1) * pressure_drop` (seed flight code), 0 when closed.
    /// Entries past [`Satellite::n_thrusters`] are 0.
    pub fn thrusts_for_word(&self, word: u16) -> [f64; MAX_THRUSTERS] {
        let n_open = (word & self.word_mask()).count_ones() as f64;
        let mut f = [0.0; MAX_THRUSTERS];
        for (i, fi) in f.iter_mut().enumerate().take(self.n_thrusters()) {
            if word & (1 << i) != 0 {
                *fi = (self.thrust_n[i] - (n_open - 1.0) * self.pressure_drop_n_per_extra).max(0.0);
            }
        }
        f
    }

    /// Net body force (N) and torque about the CoM (N m) when thruster word `word` fires.
    pub fn force_torque_for_word(&self, word: u16) -> (Vector3<f64>, Vector3<f64>) {
        let f = self.thrusts_for_word(word);
        let mut force = Vector3::zeros();
        let mut torque = Vector3::zeros();
        for (i, &fi) in f.iter().enumerate() {
            if fi != 0.0 {
                let fv = self.dir(i) * fi;
                force += fv;
                torque += self.lever_arm_m(i).cross(&fv);
            }
        }
        (force, torque)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_reach_holds_the_centre_of_a_craft_with_thrusters_on_one_face() {
        let mut s = Satellite::builtin("sph2").unwrap();
        assert!(s.reach_m() > 0.1);
        // Every thruster on the +z face: the thrusters' own box is flat at z = 0.1 m and held
        // no CoM at the centre; the reach does.
        for p in &mut s.thruster_pos_m {
            p[2] = 0.1;
        }
        let reach = s.reach_m();
        assert!(reach > 0.1);
        assert!(crate::mass_id::physical_validity(&s, &[0.0; 3], &s.inertia_kgm2).is_ok());
        // A CoM past the reach is refused.
        let far = [0.0, 0.0, 1e3 * (reach + 0.01)];
        assert_eq!(
            crate::mass_id::physical_validity(&s, &far, &s.inertia_kgm2),
            Err("implausible_com_outside_envelope")
        );
    }

    #[test]
    fn every_builtin_is_valid_and_named() {
        for n in Satellite::BUILTIN_NAMES {
            let s = Satellite::builtin(n).expect("builtin");
            assert_eq!(s.name, n);
            s.validate().unwrap();
        }
        assert!(Satellite::builtin("sph6").is_none());
        assert!(Satellite::builtin("SPH2").is_some());
    }

    #[test]
    fn opposing_pairs_share_a_line_and_oppose() {
        for (a, b) in OPPOSING_PAIRS {
            let pa = Vector3::from(THRUSTER_POS_M[a]);
            let pb = Vector3::from(THRUSTER_POS_M[b]);
            let s = Satellite::builtin("sph1").unwrap();
            // nominal directions oppose each other
            assert!(s.dir(a).dot(&s.dir(b)) < -0.99);
            // and the line between the two positions is along the force direction
            let d = (pb - pa).normalize();
            assert!(d.dot(&s.dir(a)).abs() > 0.99, "pair ({a},{b})");
        }
    }

    #[test]
    fn toml_round_trip() {
        for n in Satellite::BUILTIN_NAMES {
            let s = Satellite::builtin(n).unwrap();
            let text = s.to_toml_string();
            let back = Satellite::from_toml_str(&text, "mem").unwrap();
            assert_eq!(back, s);
        }
    }

    #[test]
    fn bad_model_names_origin_and_reason() {
        let mut s = Satellite::builtin("sph2").unwrap();
        s.inertia_kgm2[0] = -1.0;
        let e = Satellite::from_toml_str(&s.to_toml_string(), "my.toml").unwrap_err();
        assert!(e.to_string().starts_with("my.toml: "));
        assert!(e.reason.contains("positive definite"), "{e}");
        let e = Satellite::from_toml_str("name = 3", "x.toml").unwrap_err();
        assert!(e.to_string().contains("x.toml"));
        let e = Satellite::from_toml_file(Path::new("/nonexistent/model.toml")).unwrap_err();
        assert!(e.to_string().contains("/nonexistent/model.toml"));
    }

    #[test]
    fn torque_is_lever_cross_force() {
        let s = Satellite::builtin("sph3").unwrap();
        for i in 0..N_THRUSTERS {
            let l = s.pos_m(i) - Vector3::from(s.com_offset_mm) / 1000.0;
            let f = Vector3::from(s.thrust_dir[i]) * s.thrust_n[i];
            assert!((s.torque_nm(i) - l.cross(&f)).norm() < 1e-15);
        }
        // a single thruster word gives the single-thruster force and torque
        let (f, t) = s.force_torque_for_word(1 << 4);
        assert!((f - s.force_n(4)).norm() < 1e-15);
        assert!((t - s.torque_nm(4)).norm() < 1e-15);
    }

    #[test]
    fn pressure_drop_per_extra_thruster() {
        let mut s = Satellite::builtin("sph2").unwrap();
        s.pressure_drop_n_per_extra = SEED_PRESSURE_DROP_N_PER_EXTRA;
        let f = s.thrusts_for_word(0b111);
        for (i, fi) in f.iter().enumerate().take(3) {
            assert!((fi - (s.thrust_n[i] - 2.0 * 0.0106)).abs() < 1e-15);
        }
        assert_eq!(f[3], 0.0);
    }

    #[test]
    fn gyro_conversion_inverts() {
        let s = Satellite::builtin("sph2").unwrap();
        assert_eq!(s.gyro_counts_to_rad_s(0, 2077.0), 0.0);
        let c = s.rad_s_to_gyro_counts(1, 0.3);
        assert!((s.gyro_counts_to_rad_s(1, c) - 0.3).abs() < 1e-15);
        assert!((s.gyro_counts_to_rad_s(2, 2058.0 + 1412.79) - 1.0).abs() < 1e-15);
    }
}
