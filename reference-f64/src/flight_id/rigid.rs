//! The rigid-body rate model between two samples, and its derivatives: the one place the
//! identification states Euler's equation.
//!
//! Over an interval the commanded wrench is known (its integral, [`Interval`]); the rate
//! increment is
//! `Delta omega = J (U_tau + U_F x dc + d dt - G)`, `J = I^-1`,
//! with `dc` the CoM minus the model's (torque about the true CoM is `tau_nom + F x dc`),
//! `d` a constant disturbance torque and `G = integral omega x I omega`, the trapezoid of the
//! model's own rate (Heun's predictor for the end) with `I = J^-1`, differentiated through `J`
//! and through the rate ([`Rigid::rate_jacobian`]; without it the initial rate's and the
//! products' cross-axis effects were missing from the sensitivities and the products' errors
//! were 1.3-1.5x their reported sigma) (near gyro saturation `G` is half the thrust torque,
//! and leaving its derivative out made Gauss-Newton diverge). A planar craft turns about z only:
//! `Delta omega_z = (U_tau,z + (U_F x dc)_z + d_z dt - b integral omega_z) / Izz`.
//! The parameters enter through `J` (inverse inertia) so the model is linear in them but for
//! the CoM term; Gauss-Newton converges in a few steps.
use super::intervals::{Interval, Wrench};
use nalgebra::{Matrix3, Vector3};

/// Euler's full equation, or yaw only (an air-bearing craft).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Dynamics {
    Full,
    Yaw,
}

/// One free parameter of the fit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Term {
    /// Inverse-inertia entry, contract order xx yy zz xy xz yz.
    InvInertia(usize),
    /// CoM minus the model's, m, on an axis.
    Com(usize),
    /// Constant disturbance torque, N m, on an axis.
    Disturbance(usize),
    /// Yaw rate damping, N m s/rad.
    Damping,
}

/// The symmetric basis matrix of inverse-inertia entry `m` (xx yy zz xy xz yz).
pub fn sym_basis(m: usize) -> Matrix3<f64> {
    let (r, c) = [(0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)][m];
    let mut e = Matrix3::zeros();
    e[(r, c)] = 1.0;
    e[(c, r)] = 1.0;
    e
}

/// Current values of every parameter (free or held).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rigid {
    pub dynamics: Dynamics,
    /// Inverse inertia, 1/(kg m^2).
    pub j: Matrix3<f64>,
    /// CoM minus the model's, m.
    pub dc: Vector3<f64>,
    /// Constant disturbance torque, N m.
    pub d: Vector3<f64>,
    /// Yaw damping, N m s/rad.
    pub b: f64,
}

/// Per-interval inputs that depend on the measured rates.
#[derive(Clone, Copy, Debug)]
pub struct TrajectoryTerms {
    /// `integral omega x I omega dt` (full dynamics).
    pub gyro: Vector3<f64>,
    /// `integral omega_z dt` (yaw damping).
    pub yaw_angle: f64,
    /// The rates at both ends, the inertia used and the length (for the gyroscopic term's
    /// derivative).
    pub ends: (Vector3<f64>, Vector3<f64>),
    pub inertia: Matrix3<f64>,
    pub dt: f64,
}

impl TrajectoryTerms {
    /// `integral omega x (M omega) dt` by the same trapezoid.
    fn gyro_with(&self, m: &Matrix3<f64>) -> Vector3<f64> {
        let g = |w: &Vector3<f64>| w.cross(&(m * w));
        (g(&self.ends.0) + g(&self.ends.1)) * (0.5 * self.dt)
    }
}

impl TrajectoryTerms {
    /// Trapezoid between the point rates at both ends, with the inertia `i`.
    pub fn trapezoid(w0: &Vector3<f64>, w1: &Vector3<f64>, i: &Matrix3<f64>, dt: f64) -> Self {
        let g = |w: &Vector3<f64>| w.cross(&(i * w));
        TrajectoryTerms {
            gyro: (g(w0) + g(w1)) * (0.5 * dt),
            yaw_angle: 0.5 * dt * (w0.z + w1.z),
            ends: (*w0, *w1),
            inertia: *i,
            dt,
        }
    }
}

impl Rigid {
    /// The body-frame "generalised torque integral" the inverse inertia multiplies.
    fn drive(&self, iv: &Interval, tr: &TrajectoryTerms) -> Vector3<f64> {
        let u = &iv.impulse;
        let mut v = u.torque + u.force.cross(&self.dc) + self.d * iv.dt;
        match self.dynamics {
            Dynamics::Full => v -= tr.gyro,
            Dynamics::Yaw => v.z -= self.b * tr.yaw_angle,
        }
        v
    }

    /// `J v` (full) or `(0, 0, v_z Jzz)` (yaw).
    fn apply_j(&self, v: &Vector3<f64>) -> Vector3<f64> {
        match self.dynamics {
            Dynamics::Full => self.j * v,
            Dynamics::Yaw => Vector3::new(0.0, 0.0, self.j[(2, 2)] * v.z),
        }
    }

    /// Rate increment over the interval.
    pub fn increment(&self, iv: &Interval, tr: &TrajectoryTerms) -> Vector3<f64> {
        self.apply_j(&self.drive(iv, tr))
    }

    /// Rate increment an extra wrench integral `w` would add (thrust-scale and valve-timing
    /// sensitivities).
    pub fn wrench_response(&self, w: &Wrench) -> Vector3<f64> {
        self.apply_j(&(w.torque + w.force.cross(&self.dc)))
    }

    /// d increment / d term, for every term of `terms`, into `out` (added to it). `iei[m]` is
    /// `I E_m I` for the inertia `tr.inertia` (see [`Rigid::inertia_derivatives`]).
    pub fn add_sensitivities(
        &self,
        terms: &[Term],
        iv: &Interval,
        tr: &TrajectoryTerms,
        iei: &[Matrix3<f64>; 6],
        out: &mut [Vector3<f64>],
    ) {
        let drive = self.drive(iv, tr);
        for (o, &term) in out.iter_mut().zip(terms) {
            *o += match term {
                // The gyroscopic term's inertia is J^-1: d(J^-1)/dJ_m = -I E_m I.
                Term::InvInertia(m) => match self.dynamics {
                    Dynamics::Full => sym_basis(m) * drive + self.j * tr.gyro_with(&iei[m]),
                    Dynamics::Yaw => Vector3::new(0.0, 0.0, drive.z),
                },
                Term::Com(a) => {
                    let mut e = Vector3::zeros();
                    e[a] = 1.0;
                    self.apply_j(&iv.impulse.force.cross(&e))
                }
                Term::Disturbance(a) => {
                    let mut e = Vector3::zeros();
                    e[a] = iv.dt;
                    self.apply_j(&e)
                }
                Term::Damping => Vector3::new(0.0, 0.0, -self.j[(2, 2)] * tr.yaw_angle),
            };
        }
    }

    /// `d increment / d omega` over an interval of length `dt` at the rate `w`: the gyroscopic
    /// term's `-J dt (d (w x I w) / dw) = -J dt ([w]x I - [I w]x)`, or the yaw damping's
    /// `-Jzz b dt`. It carries the initial rate's and the parameters' effect along the flight.
    pub fn rate_jacobian(&self, w: &Vector3<f64>, i: &Matrix3<f64>, dt: f64) -> Matrix3<f64> {
        match self.dynamics {
            Dynamics::Full => {
                let skew =
                    |v: &Vector3<f64>| Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0);
                -(self.j * (skew(w) * i - skew(&(i * w)))) * dt
            }
            Dynamics::Yaw => {
                let mut m = Matrix3::zeros();
                m[(2, 2)] = -self.j[(2, 2)] * self.b * dt;
                m
            }
        }
    }

    /// `I E_m I` for each inverse-inertia entry `m`.
    pub fn inertia_derivatives(i: &Matrix3<f64>) -> [Matrix3<f64>; 6] {
        std::array::from_fn(|m| i * sym_basis(m) * i)
    }

    /// These values with `terms` taken from `other`.
    pub fn with_terms_of(&self, other: &Rigid, terms: &[Term]) -> Rigid {
        let mut out = *self;
        for &t in terms {
            match t {
                Term::InvInertia(m) => {
                    let (r, c) = [(0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)][m];
                    out.j[(r, c)] = other.j[(r, c)];
                    out.j[(c, r)] = other.j[(c, r)];
                }
                Term::Com(a) => out.dc[a] = other.dc[a],
                Term::Disturbance(a) => out.d[a] = other.d[a],
                Term::Damping => out.b = other.b,
            }
        }
        out
    }

    /// Adds `delta` to a term.
    pub fn step(&mut self, term: Term, delta: f64) {
        match term {
            Term::InvInertia(m) => self.j += sym_basis(m) * delta,
            Term::Com(a) => self.dc[a] += delta,
            Term::Disturbance(a) => self.d[a] += delta,
            Term::Damping => self.b += delta,
        }
    }

    /// The inertia the gyroscopic term uses: `J^-1`, or `fallback` while `J` is not positive
    /// definite (early steps on a flight with little excitation).
    pub fn inertia_or(&self, fallback: &Matrix3<f64>) -> Matrix3<f64> {
        match self.j.cholesky() {
            Some(c) => c.inverse(),
            None => *fallback,
        }
    }
}
