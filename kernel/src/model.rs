//! Satellite parameters as plain arrays (what a flight image carries), and the terms the
//! kernel derives from them once at initialisation.
//!
//! Values are those of `shared/contracts/satellites.md` (seed App. C and Table 3.2). Only
//! SPH2 (the satellite of the open recordings) is compiled in; any other craft is passed in
//! as a [`SatelliteParams`] filled by the caller (the ground tools fill it from their model).

use crate::scalar::Scalar;

/// Number of thrusters.
pub const N_THRUSTERS: usize = 12;

/// Opposing thruster pairs (0-based; same line of action, opposite force).
pub const OPPOSING_PAIRS: [(usize, usize); 6] = [(0, 6), (1, 7), (2, 8), (3, 9), (4, 10), (5, 11)];

/// One satellite's nominal parameters (SI units unless named otherwise).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SatelliteParams {
    /// Thruster positions from the geometric centre, m.
    pub thruster_pos_m: [[f32; 3]; N_THRUSTERS],
    /// Force directions (used as given, norms 0.997..1.000).
    pub thrust_dir: [[f32; 3]; N_THRUSTERS],
    /// Thrust strength, N.
    pub thrust_n: [f32; N_THRUSTERS],
    /// Inertia about the CoM, kg m^2, order xx yy zz xy xz yz.
    pub inertia_kgm2: [f32; 6],
    /// CoM minus geometric centre, mm.
    pub com_offset_mm: [f32; 3],
    /// Gyro scale, counts per rad/s, per axis.
    pub gyro_counts_per_rad_s: [f32; 3],
    /// Thrust lost per extra open thruster, N (0 for the built-in models).
    pub pressure_drop_n_per_extra: f32,
}

const POS: [[f32; 3]; 12] = [
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

/// SPH2's gyro zero-rate output, counts (contract `satellites.md`).
pub const SPH2_GYRO_BIAS_COUNTS: [f32; 3] = [2077.0, 2070.0, 2058.0];

/// SPH2 (seed App. C; contract `satellites.md`).
pub const SPH2: SatelliteParams = SatelliteParams {
    thruster_pos_m: POS,
    thrust_dir: transpose_dirs(
        [
            0.9988, 0.9995, 0.0126, -0.0209, -0.0011, -0.0076, -0.9996, -0.9989, 0.0391, -0.0292,
            0.0085, -0.0046,
        ],
        [
            -0.0061, -0.0086, 0.9994, 0.9995, 0.0244, -0.0278, 0.0162, 0.0374, -0.9989, -0.9992,
            0.0598, 0.0075,
        ],
        [
            0.0356, -0.0018, 0.0104, -0.0149, 0.9994, 0.9995, 0.0137, -0.0166, 0.0219, 0.0239,
            -0.9981, -0.9999,
        ],
    ),
    thrust_n: [
        0.1085, 0.1117, 0.1131, 0.1120, 0.1120, 0.1116, 0.1117, 0.1151, 0.1170, 0.1137, 0.1058,
        0.1113,
    ],
    inertia_kgm2: [0.0242, 0.0214, 0.0194, 0.000108, 0.000157, 0.0000123],
    com_offset_mm: [0.8115, -1.2044, -0.0985],
    gyro_counts_per_rad_s: [1412.79, 1412.79, 1412.79],
    pressure_drop_n_per_extra: 0.0,
};

// Evaluated at compile time only (a bad index is a build error, not a runtime panic).
#[allow(clippy::indexing_slicing, clippy::arithmetic_side_effects)]
const fn transpose_dirs(x: [f32; 12], y: [f32; 12], z: [f32; 12]) -> [[f32; 3]; 12] {
    let mut out = [[0.0f32; 3]; 12];
    let mut i = 0;
    while i < 12 {
        out[i] = [x[i], y[i], z[i]];
        i += 1;
    }
    out
}

/// What the kernel derives from the parameters at initialisation, in its own units:
/// torques in cN m (so the inertia regressor is O(1)), CoM offsets in m, inverse inertia
/// in 1/(kg m^2) and the inverse-inertia *parameters* in 1/(kg m^2) / 100 (so the
/// parameter times a cN m torque is rad/s^2). See `kernel/README.md`.
#[derive(Clone, Copy, Debug)]
pub struct ModelTerms<S> {
    /// Force direction per thruster (unit-ish).
    pub dir: [[S; 3]; N_THRUSTERS],
    /// (thruster position - nominal CoM) x direction, per thruster, m (torque per newton).
    pub lever_x_dir: [[S; 3]; N_THRUSTERS],
    /// Thrust strength, N.
    pub thrust_n: [S; N_THRUSTERS],
    /// Thrust lost per extra open thruster, N.
    pub pressure_drop_n: S,
    /// Nominal inverse inertia, 1/(kg m^2), row-major 3x3.
    pub inertia_inv: [[S; 3]; 3],
    /// Nominal inverse-inertia parameters (xx yy zz xy xz yz), 1/(kg m^2)/100.
    pub theta_inertia_nominal: [S; 6],
    /// The same as a matrix: rad/s^2 per cN m.
    pub theta_inertia_matrix: [[S; 3]; 3],
}

/// Why the parameters were rejected.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ModelError {
    /// The inertia matrix is not invertible (or not finite).
    SingularInertia,
    /// A parameter is not finite.
    NotFinite,
}

impl SatelliteParams {
    /// The nominal inverse inertia (f64 on the host side of initialisation; 3x3 adjugate).
    pub fn inertia_inverse(&self) -> Result<[[f64; 3]; 3], ModelError> {
        let [xx, yy, zz, xy, xz, yz] = self.inertia_kgm2.map(f64::from);
        let m = [[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]];
        let c00 = m[1][1] * m[2][2] - m[1][2] * m[2][1];
        let c01 = m[1][2] * m[2][0] - m[1][0] * m[2][2];
        let c02 = m[1][0] * m[2][1] - m[1][1] * m[2][0];
        let det = m[0][0] * c00 + m[0][1] * c01 + m[0][2] * c02;
        if !det.is_finite() || det.abs() < 1e-15 {
            return Err(ModelError::SingularInertia);
        }
        let c10 = m[0][2] * m[2][1] - m[0][1] * m[2][2];
        let c11 = m[0][0] * m[2][2] - m[0][2] * m[2][0];
        let c12 = m[0][1] * m[2][0] - m[0][0] * m[2][1];
        let c20 = m[0][1] * m[1][2] - m[0][2] * m[1][1];
        let c21 = m[0][2] * m[1][0] - m[0][0] * m[1][2];
        let c22 = m[0][0] * m[1][1] - m[0][1] * m[1][0];
        let inv = [
            [c00 / det, c10 / det, c20 / det],
            [c01 / det, c11 / det, c21 / det],
            [c02 / det, c12 / det, c22 / det],
        ];
        Ok(inv)
    }

    /// Derives the kernel's terms in the scalar type `S`.
    pub fn terms<S: Scalar>(&self) -> Result<ModelTerms<S>, ModelError> {
        let all_finite = self.thruster_pos_m.iter().flatten().all(|v| v.is_finite())
            && self.thrust_dir.iter().flatten().all(|v| v.is_finite())
            && self.thrust_n.iter().all(|v| v.is_finite())
            && self.com_offset_mm.iter().all(|v| v.is_finite())
            && self.pressure_drop_n_per_extra.is_finite();
        if !all_finite {
            return Err(ModelError::NotFinite);
        }
        let inv = self.inertia_inverse()?;
        let mut dir = [[S::ZERO; 3]; N_THRUSTERS];
        let mut lxd = [[S::ZERO; 3]; N_THRUSTERS];
        for ((d_out, l_out), (pos, d)) in dir
            .iter_mut()
            .zip(lxd.iter_mut())
            .zip(self.thruster_pos_m.iter().zip(self.thrust_dir.iter()))
        {
            let com_m = self.com_offset_mm.map(|v| f64::from(v) * 1e-3);
            let l = [
                f64::from(pos[0]) - com_m[0],
                f64::from(pos[1]) - com_m[1],
                f64::from(pos[2]) - com_m[2],
            ];
            let d64 = d.map(f64::from);
            let cross = [
                l[1] * d64[2] - l[2] * d64[1],
                l[2] * d64[0] - l[0] * d64[2],
                l[0] * d64[1] - l[1] * d64[0],
            ];
            *d_out = d.map(S::from_f32);
            *l_out = cross.map(|v| S::from_f32(v as f32));
        }
        let inertia_inv = inv.map(|row| row.map(|v| S::from_f32(v as f32)));
        let theta = [
            inv[0][0], inv[1][1], inv[2][2], inv[0][1], inv[0][2], inv[1][2],
        ]
        .map(|v| S::from_f32((v * 0.01) as f32));
        let theta_inertia_matrix = inv.map(|row| row.map(|v| S::from_f32((v * 0.01) as f32)));
        Ok(ModelTerms {
            dir,
            lever_x_dir: lxd,
            thrust_n: self.thrust_n.map(S::from_f32),
            pressure_drop_n: S::from_f32(self.pressure_drop_n_per_extra),
            inertia_inv,
            theta_inertia_nominal: theta,
            theta_inertia_matrix,
        })
    }
}

/// The regressors of one thruster configuration (seed eqs 3.5-3.8): net force `c` (N),
/// nominal torque `a` (N m and cN m), the CoM rows `A1 = I^-1 [c]x` (per m) and the
/// nominal angular acceleration `I^-1 a` (rad/s^2, the Kalman filter's reset value).
#[derive(Clone, Copy, Debug)]
pub struct FiringTerms<S> {
    /// Net force, N.
    pub force_n: [S; 3],
    /// Nominal torque about the model CoM, cN m.
    pub torque_cnm: [S; 3],
    /// Nominal angular acceleration `I^-1 a`, rad/s^2.
    pub omega_dot_nominal: [S; 3],
    /// CoM regressor `I^-1 [c]x`, rad/s^2 per m.
    pub a_com: [[S; 3]; 3],
}

impl<S: Scalar> ModelTerms<S> {
    /// The regressors for thruster word `word` (bit i = thruster i+1 open). Thrust per open
    /// thruster drops by `pressure_drop_n` per other open thruster (seed App. D).
    pub fn firing_terms(&self, word: u16) -> FiringTerms<S> {
        let open = (word & 0x0fff).count_ones();
        let extra = S::from_int_pow2(open.saturating_sub(1) as i32, 0);
        let drop = self.pressure_drop_n.times(extra);
        let mut c = [S::ZERO; 3];
        let mut a_nm = [S::ZERO; 3];
        for (i, ((d, lxd), f)) in self
            .dir
            .iter()
            .zip(self.lever_x_dir.iter())
            .zip(self.thrust_n.iter())
            .enumerate()
        {
            if word & (1u16 << (i as u32)) == 0 {
                continue;
            }
            // The reference clamps a thrust the pressure drop would make negative at zero
            // (a thruster cannot pull; proofs finding 4).
            let f = f.minus(drop);
            let f = if f.lt(S::ZERO) { S::ZERO } else { f };
            for ((cv, av), (dv, lv)) in c
                .iter_mut()
                .zip(a_nm.iter_mut())
                .zip(d.iter().zip(lxd.iter()))
            {
                *cv = cv.mul_add(*dv, f);
                *av = av.mul_add(*lv, f);
            }
        }
        let hundred = S::from_int_pow2(100, 0);
        let torque_cnm = a_nm.map(|v| v.times(hundred));
        let omega_dot_nominal = mat_vec(&self.inertia_inv, &a_nm);
        // [c]x = [[0,-c3,c2],[c3,0,-c1],[-c2,c1,0]]
        let cx = [
            [S::ZERO, c[2].negate(), c[1]],
            [c[2], S::ZERO, c[0].negate()],
            [c[1].negate(), c[0], S::ZERO],
        ];
        let mut a_com = [[S::ZERO; 3]; 3];
        for (row_out, inv_row) in a_com.iter_mut().zip(self.inertia_inv.iter()) {
            for (j, out) in row_out.iter_mut().enumerate() {
                let mut acc = S::ZERO;
                for (iv, cx_row) in inv_row.iter().zip(cx.iter()) {
                    if let Some(cv) = cx_row.get(j) {
                        acc = acc.mul_add(*iv, *cv);
                    }
                }
                *out = acc;
            }
        }
        FiringTerms {
            force_n: c,
            torque_cnm,
            omega_dot_nominal,
            a_com,
        }
    }
}

/// 3x3 matrix times vector.
pub fn mat_vec<S: Scalar>(m: &[[S; 3]; 3], v: &[S; 3]) -> [S; 3] {
    m.map(|row| {
        row.iter()
            .zip(v.iter())
            .fold(S::ZERO, |acc, (a, b)| acc.mul_add(*a, *b))
    })
}

/// The inverse-inertia regressor rows of seed eq. 3.8 for torque `a` (cN m):
/// `[[a1,0,0,a2,a3,0],[0,a2,0,a1,0,a3],[0,0,a3,0,a1,a2]]`.
pub fn inertia_rows<S: Scalar>(a: &[S; 3]) -> [[S; 6]; 3] {
    let z = S::ZERO;
    let [a1, a2, a3] = *a;
    [
        [a1, z, z, a2, a3, z],
        [z, a2, z, a1, z, a3],
        [z, z, a3, z, a1, a2],
    ]
}
