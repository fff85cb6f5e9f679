//! The seed's equations in nalgebra f64, written the straightforward way (seed eqs. 3.1-3.12,
//! App. E flight code structure): a two-pole low-pass per gyro axis, a scalar Kalman filter per
//! axis with H = k dt reset at each thruster-word change, and after a batch over the first two
//! firings, one RLS update (eqs. 3.9-3.10) per Kalman update that re-inverts the whole
//! information matrix with a full LU inverse. This is the speed baseline, not an oracle.
use nalgebra::{Matrix3, SMatrix, SVector, Vector3};
use reference_f64::recording::Sample;
use reference_f64::satellite::{Satellite, N_THRUSTERS};

type M6 = SMatrix<f64, 6, 6>;
type V6 = SVector<f64, 6>;

/// Seed Fig. 4.5 measurement variance, (rad/s)^2.
const R0: f64 = 1e-7;
/// Kalman covariance at every reset (rad/s^2)^2.
const P0: f64 = 0.5;
/// Valve transient skipped after a word change, s.
const TRANSIENT_S: f64 = 0.010;

/// Straightforward f64 pipeline with a full inverse per RLS update.
pub struct NaiveSeedPipeline {
    sat: Satellite,
    dt: f64,
    lever: [Vector3<f64>; N_THRUSTERS],
    force: [Vector3<f64>; N_THRUSTERS],
    inertia: Matrix3<f64>,
    // two-pole low-pass state per axis (direct form II transposed)
    lp_b: [f64; 3],
    lp_a: [f64; 3],
    lp_z: [[f64; 2]; 3],
    // Kalman filter per axis
    word: u16,
    k: usize,
    omega0: Vector3<f64>,
    x: Vector3<f64>,
    p: Vector3<f64>,
    // batch then RLS
    firings: usize,
    info_c: Matrix3<f64>,
    rhs_c: Vector3<f64>,
    info_i: M6,
    rhs_i: V6,
    /// Current CoM-offset estimate, m.
    pub com: Vector3<f64>,
    /// Current inverse-inertia estimate (xx yy zz xy xz yz).
    pub inv_inertia: V6,
}

impl NaiveSeedPipeline {
    /// A pipeline for `sat` sampled at `rate_hz`.
    pub fn new(sat: &Satellite, rate_hz: f64) -> Self {
        let dt = 1.0 / rate_hz;
        // Tustin two-pole Butterworth at 50 Hz.
        let wc = 2.0 / dt * (std::f64::consts::PI * 50.0 * dt).tan();
        let k = 2.0 / dt;
        let (a0, a1, a2) = (
            k * k + std::f64::consts::SQRT_2 * wc * k + wc * wc,
            2.0 * (wc * wc - k * k),
            k * k - std::f64::consts::SQRT_2 * wc * k + wc * wc,
        );
        let g = wc * wc / a0;
        let inertia = sat.inertia_matrix();
        let inv = inertia.try_inverse().unwrap_or_else(Matrix3::identity);
        NaiveSeedPipeline {
            sat: sat.clone(),
            dt,
            lever: std::array::from_fn(|i| sat.lever_arm_m(i)),
            force: std::array::from_fn(|i| sat.force_n(i)),
            inertia,
            lp_b: [g, 2.0 * g, g],
            lp_a: [1.0, a1 / a0, a2 / a0],
            lp_z: [[0.0; 2]; 3],
            word: 0,
            k: 0,
            omega0: Vector3::zeros(),
            x: Vector3::zeros(),
            p: Vector3::repeat(P0),
            firings: 0,
            info_c: Matrix3::zeros(),
            rhs_c: Vector3::zeros(),
            info_i: M6::zeros(),
            rhs_i: V6::zeros(),
            com: Vector3::zeros(),
            inv_inertia: V6::new(
                inv[(0, 0)],
                inv[(1, 1)],
                inv[(2, 2)],
                inv[(0, 1)],
                inv[(0, 2)],
                inv[(1, 2)],
            ),
        }
    }

    fn filter(&mut self, axis: usize, u: f64) -> f64 {
        let z = &mut self.lp_z[axis];
        let y = self.lp_b[0] * u + z[0];
        z[0] = self.lp_b[1] * u - self.lp_a[1] * y + z[1];
        z[1] = self.lp_b[2] * u - self.lp_a[2] * y;
        y
    }

    fn torque_and_force(&self, word: u16) -> (Vector3<f64>, Vector3<f64>) {
        let mut tau = Vector3::zeros();
        let mut f = Vector3::zeros();
        for i in 0..N_THRUSTERS {
            if word & (1 << i) != 0 {
                tau += self.lever[i].cross(&self.force[i]);
                f += self.force[i];
            }
        }
        (tau, f)
    }

    /// One 1 kHz tick.
    pub fn tick(&mut self, s: &Sample) {
        let mut omega = Vector3::zeros();
        for a in 0..3 {
            let raw = (s.gyro[a] as f64 - self.sat.gyro_bias_counts[a])
                / self.sat.gyro_counts_per_rad_s[a];
            omega[a] = self.filter(a, raw);
        }
        let word = s.thrusters & 0x0fff;
        if word != self.word {
            self.word = word;
            self.k = 0;
            if word != 0 {
                self.firings += 1;
                let (tau, _) = self.torque_and_force(word);
                self.x = self.inertia.try_inverse().unwrap_or_else(Matrix3::identity)
                    * (tau - omega.cross(&(self.inertia * omega)));
                self.p = Vector3::repeat(P0);
                self.omega0 = omega;
            }
            return;
        }
        if word == 0 {
            return;
        }
        self.k += 1;
        let t = self.k as f64 * self.dt;
        if t <= TRANSIENT_S {
            return;
        }
        // Scalar Kalman filter per axis, H = k dt (eq. 3.12).
        for a in 0..3 {
            let z = omega[a] - self.omega0[a];
            let gain = self.p[a] * t / (t * self.p[a] * t + R0);
            self.x[a] += gain * (z - t * self.x[a]);
            self.p[a] *= 1.0 - gain * t;
        }
        let (tau, f) = self.torque_and_force(word);
        // CoM rows: omega_dot = I^-1 (L x F - delta x F - w x Iw)  =>  I^-1 [F]x delta = I^-1 tau - w x.. - omega_dot
        let inv_i = self.inv_matrix();
        let a_c = inv_i * skew(&f);
        let b_c = self.x - inv_i * (tau - omega.cross(&(self.inertia * omega)));
        // Inertia rows: omega_dot = J a, a = tau - w x I w, J symmetric (6 terms).
        let av = tau - omega.cross(&(self.inertia * omega));
        let a_i = SMatrix::<f64, 3, 6>::from_row_slice(&[
            av.x, 0.0, 0.0, av.y, av.z, 0.0, //
            0.0, av.y, 0.0, av.x, 0.0, av.z, //
            0.0, 0.0, av.z, 0.0, av.x, av.y,
        ]);
        let w = 1.0 / self.p.mean().max(1e-30);
        if self.firings <= 2 {
            // batch: accumulate normal equations, solve with a full inverse.
            self.info_c += a_c.transpose() * a_c * w;
            self.rhs_c += a_c.transpose() * b_c * w;
            self.info_i += a_i.transpose() * a_i * w;
            self.rhs_i += a_i.transpose() * self.x * w;
            if let Some(q) = (self.info_c + Matrix3::identity() * 1e-9).try_inverse() {
                self.com = q * self.rhs_c;
            }
            if let Some(q) = (self.info_i + M6::identity() * 1e-9).try_inverse() {
                self.inv_inertia = q * self.rhs_i;
            }
        } else {
            // RLS (eqs. 3.9-3.10) with the full LU inverse of the information matrix.
            self.info_c += a_c.transpose() * a_c * w;
            if let Some(q) = self.info_c.lu().try_inverse() {
                self.com += q * a_c.transpose() * (b_c - a_c * self.com) * w;
            }
            self.info_i += a_i.transpose() * a_i * w;
            if let Some(q) = self.info_i.lu().try_inverse() {
                self.inv_inertia += q * a_i.transpose() * (self.x - a_i * self.inv_inertia) * w;
            }
        }
    }

    fn inv_matrix(&self) -> Matrix3<f64> {
        let j = &self.inv_inertia;
        Matrix3::new(j[0], j[3], j[4], j[3], j[1], j[5], j[4], j[5], j[2])
    }
}

fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}
