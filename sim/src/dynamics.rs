//! 6-DOF rigid body with an optional liquid slosh mode, integrated with fixed-step RK4.
//!
//! Body rates follow Euler's equations with the gyroscopic term,
//!   I w_dot = tau - w x (I w)                                (seed eq. 4.1)
//! the attitude quaternion q (body to inertial, scalar first) follows q_dot = q (x) (0, w) / 2,
//! and position/velocity are inertial: v_dot = R(q) F / m. Inputs (thrust, mass properties)
//! are constant over a step except the blowdown factor and the thrust-rise transient
//! (`effects/thrust_rise.rs`), evaluated at every RK4 stage; the caller splits steps at
//! every valve edge so edges fall exactly on step boundaries.
use crate::effects::PlantConfig;
use nalgebra::{Matrix3, Quaternion, UnitQuaternion, Vector3};
use reference_f64::satellite::{Satellite, MAX_THRUSTERS};

/// The simulated state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct State {
    /// Body rates, rad/s, body axes.
    pub w: Vector3<f64>,
    /// Liquid angle relative to the body per axis (slosh), rad.
    pub phi: Vector3<f64>,
    /// Its rate, rad/s.
    pub dphi: Vector3<f64>,
    /// Attitude, body to inertial (kept normalised after each step).
    pub q: Quaternion<f64>,
    /// CoM position, inertial, m.
    pub pos: Vector3<f64>,
    /// CoM velocity, inertial, m/s.
    pub vel: Vector3<f64>,
}

impl State {
    /// At rest at the origin with body rates `w`.
    pub fn with_rates(w: [f64; 3]) -> Self {
        State {
            w: Vector3::from(w),
            phi: Vector3::zeros(),
            dphi: Vector3::zeros(),
            q: Quaternion::identity(),
            pos: Vector3::zeros(),
            vel: Vector3::zeros(),
        }
    }

    /// The attitude as a unit quaternion.
    pub fn attitude(&self) -> UnitQuaternion<f64> {
        UnitQuaternion::from_quaternion(self.q)
    }
}

/// Inputs held constant over an integration step (recomputed when a valve or the mass
/// properties change).
#[derive(Clone, Copy, Debug)]
pub struct Segment {
    /// Inertia of the rigid part (total minus liquid), and its inverse.
    pub i_body: Matrix3<f64>,
    pub i_body_inv: Matrix3<f64>,
    /// Liquid inertia, spring and damper per axis (all 0 without slosh).
    pub slosh_j: Vector3<f64>,
    pub slosh_k: Vector3<f64>,
    pub slosh_c: Vector3<f64>,
    pub has_slosh: bool,
    /// Thruster torque about the true CoM and net force, body axes, before blowdown.
    pub torque0: Vector3<f64>,
    pub force0: Vector3<f64>,
    /// External torque, N m.
    pub disturbance: Vector3<f64>,
    pub mass_kg: f64,
    /// Thrust rise (`effects/thrust_rise.rs`): the thrusters' force differs from the steady
    /// `torque0`/`force0` by `rise_torque`/`rise_force` * exp(-(t - rise_t0_ms) / rise_tau_ms)
    /// (before blowdown). `rise_tau_ms = 0`: no transient (the nominal arithmetic, unchanged).
    pub rise_torque: Vector3<f64>,
    pub rise_force: Vector3<f64>,
    pub rise_t0_ms: f64,
    pub rise_tau_ms: f64,
    /// Torque against the rate per axis, N m s/rad (`effects/rate_damping.rs`).
    pub damping: Vector3<f64>,
    /// A planar craft: the bearing holds x and y, only the yaw equation moves.
    pub planar: bool,
}

/// The satellite with its effects, ready to produce [`Segment`]s.
#[derive(Clone, Debug)]
pub struct Plant {
    pub cfg: PlantConfig,
    pub mass_kg: f64,
    /// Nominal CoM from the geometric centre, m.
    com_nominal: Vector3<f64>,
    pos: [Vector3<f64>; MAX_THRUSTERS],
    dir: [Vector3<f64>; MAX_THRUSTERS],
    thrust_n: [f64; MAX_THRUSTERS],
    /// The word bits that are thrusters of this satellite (others never fire).
    word_mask: u16,
    planar: bool,
}

impl Plant {
    pub fn new(sat: &Satellite, cfg: PlantConfig) -> Self {
        let n = sat.n_thrusters();
        let dir = std::array::from_fn(|i| match (i < n, cfg.thrust_dir[i]) {
            // a tilted thruster keeps the model's force magnitude
            (true, Some(d)) => Vector3::from(d) * sat.dir(i).norm(),
            (true, None) => sat.dir(i),
            _ => Vector3::zeros(),
        });
        Plant {
            cfg,
            mass_kg: sat.mass_kg,
            com_nominal: sat.com_m(),
            pos: std::array::from_fn(|i| {
                if i < n {
                    sat.pos_m(i)
                } else {
                    Vector3::zeros()
                }
            }),
            dir,
            thrust_n: std::array::from_fn(|i| sat.thrust_n.get(i).copied().unwrap_or(0.0)),
            word_mask: sat.word_mask(),
            planar: sat.planar,
        }
    }

    /// Force magnitude of each thruster for the actual valve state `valves` (before
    /// blowdown): scale_i * max(0, F_i - pressure_drop * (n_open - 1)).
    pub fn thrusts(&self, valves: u16) -> [f64; MAX_THRUSTERS] {
        let valves = valves & self.word_mask;
        let n_open = valves.count_ones() as f64;
        let drop = self.cfg.pressure_drop_n * (n_open - 1.0).max(0.0);
        std::array::from_fn(|i| {
            if valves & (1 << i) != 0 {
                self.cfg.thrust_scale[i] * (self.thrust_n[i] - drop).max(0.0)
            } else {
                0.0
            }
        })
    }

    /// Constant inputs for valve state `valves` with the mass properties in force at `t_ms`.
    pub fn segment(&self, valves: u16, t_ms: f64) -> Segment {
        let phase = self.cfg.mass_at(t_ms * 1e-3);
        let [xx, yy, zz, xy, xz, yz] = phase.inertia_kgm2;
        let i_total = Matrix3::new(xx, xy, xz, xy, yy, yz, xz, yz, zz);
        let com = self.com_nominal + Vector3::from(phase.com_offset_m);
        let f = self.thrusts(valves);
        let mut torque0 = Vector3::zeros();
        let mut force0 = Vector3::zeros();
        for i in 0..MAX_THRUSTERS {
            if f[i] != 0.0 {
                let fv = self.dir[i] * f[i];
                force0 += fv;
                torque0 += (self.pos[i] - com).cross(&fv);
            }
        }
        let mut slosh_j = Vector3::zeros();
        let mut slosh_k = Vector3::zeros();
        let mut slosh_c = Vector3::zeros();
        let mut has_slosh = false;
        if let Some(s) = self.cfg.slosh.first() {
            let wn = 2.0 * std::f64::consts::PI * s.freq_hz;
            for a in 0..3 {
                let ia = i_total[(a, a)];
                let j = s.inertia_fraction[a].clamp(0.0, 0.5) * ia;
                if j > 0.0 {
                    let mu = j * (ia - j) / ia;
                    slosh_j[a] = j;
                    slosh_k[a] = mu * wn * wn;
                    slosh_c[a] = 2.0 * s.damping_ratio * mu * wn;
                    has_slosh = true;
                }
            }
        }
        let i_body = i_total - Matrix3::from_diagonal(&slosh_j);
        let i_body_inv = i_body.try_inverse().unwrap_or_else(Matrix3::zeros);
        Segment {
            i_body,
            i_body_inv,
            slosh_j,
            slosh_k,
            slosh_c,
            has_slosh,
            torque0,
            force0,
            disturbance: Vector3::from(self.cfg.disturbance_torque_nm),
            mass_kg: self.mass_kg,
            rise_torque: Vector3::zeros(),
            rise_force: Vector3::zeros(),
            rise_t0_ms: 0.0,
            rise_tau_ms: 0.0,
            damping: Vector3::from(self.cfg.rate_damping_nms),
            planar: self.planar,
        }
    }

    /// [`Plant::segment`] with a thrust-rise transient: at `t0_ms` thruster i delivers
    /// `steady_i + excess_n[i]` (N, before blowdown), the excess decaying with the plant's
    /// `thrust_rise_tau_ms` (lever arms of the mass properties in force at `t_ms`).
    pub fn segment_with_rise(
        &self,
        valves: u16,
        t_ms: f64,
        excess_n: &[f64; MAX_THRUSTERS],
        t0_ms: f64,
    ) -> Segment {
        let mut s = self.segment(valves, t_ms);
        let tau = self.cfg.thrust_rise_tau_ms;
        if tau > 0.0 && excess_n.iter().any(|&x| x != 0.0) {
            let com = self.com_nominal + Vector3::from(self.cfg.mass_at(t_ms * 1e-3).com_offset_m);
            for i in 0..MAX_THRUSTERS {
                if excess_n[i] != 0.0 {
                    let fv = self.dir[i] * excess_n[i];
                    s.rise_force += fv;
                    s.rise_torque += (self.pos[i] - com).cross(&fv);
                }
            }
            s.rise_t0_ms = t0_ms;
            s.rise_tau_ms = tau;
        }
        s
    }
}

/// Time derivative of the state, plus the body's angular acceleration.
#[derive(Clone, Copy, Debug)]
pub struct Derivative {
    pub w_dot: Vector3<f64>,
    pub phi_dot: Vector3<f64>,
    pub phi_ddot: Vector3<f64>,
    pub q_dot: Quaternion<f64>,
    pub vel: Vector3<f64>,
    pub acc: Vector3<f64>,
    /// Specific force (thrust / mass), body axes, m/s^2 (what an accelerometer at the CoM feels).
    pub specific_force: Vector3<f64>,
}

/// The equations of motion at `x`, time `t_ms`. `full` also computes attitude and translation.
#[inline]
pub fn derivative(
    x: &State,
    t_ms: f64,
    seg: &Segment,
    cfg: &PlantConfig,
    full: bool,
) -> Derivative {
    let b = if cfg.blowdowns.is_empty() {
        1.0
    } else {
        cfg.blowdown_factor(t_ms * 1e-3)
    };
    let (torque0, force0) = if seg.rise_tau_ms > 0.0 {
        let e = (-(t_ms - seg.rise_t0_ms) / seg.rise_tau_ms).exp();
        (
            seg.torque0 + seg.rise_torque * e,
            seg.force0 + seg.rise_force * e,
        )
    } else {
        (seg.torque0, seg.force0)
    };
    let mut tau = torque0 * b + seg.disturbance - x.w.cross(&(seg.i_body * x.w));
    if seg.damping != Vector3::zeros() {
        tau -= seg.damping.component_mul(&x.w);
    }
    let mut phi_ddot = Vector3::zeros();
    let w_dot;
    if seg.planar {
        // the bearing supplies whatever x/y torque keeps the craft level: yaw only
        // (the table's slosh, if any, is not modelled for a planar craft)
        w_dot = Vector3::new(0.0, 0.0, tau.z / seg.i_body[(2, 2)]);
    } else if seg.has_slosh {
        let spring = seg.slosh_k.component_mul(&x.phi) + seg.slosh_c.component_mul(&x.dphi);
        // The gyroscopic term carries the liquid's angular momentum too (see fuel_slosh.rs).
        let liquid_momentum = seg.slosh_j.component_mul(&(x.w + x.dphi));
        tau += spring - x.w.cross(&liquid_momentum);
        w_dot = seg.i_body_inv * tau;
        for a in 0..3 {
            if seg.slosh_j[a] > 0.0 {
                phi_ddot[a] = -spring[a] / seg.slosh_j[a] - w_dot[a];
            }
        }
    } else {
        w_dot = seg.i_body_inv * tau;
    }
    let specific_force = force0 * (b / seg.mass_kg);
    let (q_dot, vel, acc) = if full {
        let qd = x.q * Quaternion::new(0.0, x.w.x, x.w.y, x.w.z) * 0.5;
        let r = UnitQuaternion::new_unchecked(x.q);
        (qd, x.vel, r * specific_force)
    } else {
        (
            Quaternion::new(0.0, 0.0, 0.0, 0.0),
            Vector3::zeros(),
            Vector3::zeros(),
        )
    };
    Derivative {
        w_dot,
        phi_dot: x.dphi,
        phi_ddot,
        q_dot,
        vel,
        acc,
        specific_force,
    }
}

fn add(x: &State, d: &Derivative, h: f64) -> State {
    State {
        w: x.w + d.w_dot * h,
        phi: x.phi + d.phi_dot * h,
        dphi: x.dphi + d.phi_ddot * h,
        q: x.q + d.q_dot * h,
        pos: x.pos + d.vel * h,
        vel: x.vel + d.acc * h,
    }
}

/// One classical RK4 step of `h_ms` from `t_ms`.
#[inline]
pub fn rk4_step(
    x: &State,
    t_ms: f64,
    h_ms: f64,
    seg: &Segment,
    cfg: &PlantConfig,
    full: bool,
) -> State {
    let h = h_ms * 1e-3;
    let k1 = derivative(x, t_ms, seg, cfg, full);
    let k2 = derivative(&add(x, &k1, h / 2.0), t_ms + h_ms / 2.0, seg, cfg, full);
    let k3 = derivative(&add(x, &k2, h / 2.0), t_ms + h_ms / 2.0, seg, cfg, full);
    let k4 = derivative(&add(x, &k3, h), t_ms + h_ms, seg, cfg, full);
    let w6 = h / 6.0;
    let mut y = State {
        w: x.w + (k1.w_dot + (k2.w_dot + k3.w_dot) * 2.0 + k4.w_dot) * w6,
        phi: x.phi + (k1.phi_dot + (k2.phi_dot + k3.phi_dot) * 2.0 + k4.phi_dot) * w6,
        dphi: x.dphi + (k1.phi_ddot + (k2.phi_ddot + k3.phi_ddot) * 2.0 + k4.phi_ddot) * w6,
        q: x.q,
        pos: x.pos,
        vel: x.vel,
    };
    if full {
        y.q = (x.q + (k1.q_dot + (k2.q_dot + k3.q_dot) * 2.0 + k4.q_dot) * w6).normalize();
        y.pos = x.pos + (k1.vel + (k2.vel + k3.vel) * 2.0 + k4.vel) * w6;
        y.vel = x.vel + (k1.acc + (k2.acc + k3.acc) * 2.0 + k4.acc) * w6;
    }
    y
}
