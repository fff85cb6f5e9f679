//! Random craft for held-out Monte Carlo: a craft nobody here has seen, drawn from a seed, with
//! a nominal model (what the user writes) and a truth that differs from it (what the craft
//! is). The identification is then scored on craft it was not developed on, not only on the
//! three model files of `examples/models/`.
//!
//! What is drawn, per seed (all uniform unless said):
//! - the shape: a box of half-extents 0.05-0.5 m (3-D) or a rectangle of 0.1-0.5 m (planar);
//! - the thrusters (a count in the class's range): each on the hull, at a random point of a
//!   face (weighted by area) or side, pushing inwards along the face's normal canted by up to
//!   60 degrees (3-D) or by up to 80 degrees within the plane (planar); thrust 0.05-2 N,
//!   log-uniform;
//! - the mass from a density of 100-1500 kg/m^3 (3-D) or 5-30 kg (planar), the nominal
//!   inertia that of a box of that mass with each moment scaled by 0.7-1.3, turned by up to
//!   30 degrees about a random axis (so products of inertia are not zero), a nominal CoM within
//!   2 % of the size from the centre;
//! - the truth: each principal moment 0.85-1.15 times the model's, products moved by up to
//!   5 % of the geometric mean of their moments (planar: Izz only), the CoM moved by up to 5 %
//!   of the size on each axis (planar: x and y);
//! - half of the craft state each thruster's thrust uncertainty (1-8 % of its thrust, the
//!   seed's Table C.3 spread) and fly true thrusts drawn from it; the others fly the nominal
//!   thrusts;
//! - the flight: single, combo or random PWM; a gyro at 50-1000 Hz with 0.3-4 times the
//!   default noise through a 20-300 Hz first-order band (coloured noise), or rates
//!   differenced from motion-capture attitude (1e-4 to 1e-3 rad per sample) at 50-250 Hz.
use massid_sim::effects::{ComOffset, Effect, Inertia, ThrustScale};
use massid_sim::sensors::RateSensor;
use massid_sim::{Maneuver, SimSpec};
use nalgebra::{Matrix3, Rotation3, Unit, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use reference_f64::mass_id::sym_to_vec6;
use reference_f64::satellite::Satellite;

/// A family of random craft: 3-D or planar, a thruster-count range, a rate sensor.
#[derive(Clone, Debug, PartialEq)]
pub struct CraftClass {
    pub planar: bool,
    /// Fewest and most thrusters (1-16).
    pub thrusters: (usize, usize),
    /// Rates differenced from motion-capture attitude instead of a gyro.
    pub mocap: bool,
}

impl CraftClass {
    pub fn label(&self) -> String {
        format!(
            "random {} craft, {}-{} thrusters, {}",
            if self.planar { "planar" } else { "3-D" },
            self.thrusters.0,
            self.thrusters.1,
            if self.mocap { "motion capture" } else { "gyro" }
        )
    }
}

/// One drawn craft and flight: the simulation to run (its satellite is the nominal model, the
/// truth is in its effects), the model the estimator is given, and the truth of the scored
/// terms (CoM minus the model's in mm, then xx yy zz xy xz yz; NaN where a planar craft
/// cannot show it).
pub struct Drawn {
    pub spec: SimSpec,
    pub model: Satellite,
    pub truth: [f64; 9],
}

fn log_uniform(rng: &mut ChaCha8Rng, lo: f64, hi: f64) -> f64 {
    (lo.ln() + rng.gen::<f64>() * (hi.ln() - lo.ln())).exp()
}

fn unit(rng: &mut ChaCha8Rng) -> Vector3<f64> {
    loop {
        let v = Vector3::new(
            rng.sample::<f64, _>(StandardNormal),
            rng.sample::<f64, _>(StandardNormal),
            rng.sample::<f64, _>(StandardNormal),
        );
        if v.norm() > 1e-6 {
            return v.normalize();
        }
    }
}

/// A thruster of a 3-D box of half-extents `h`: position on a face, force direction.
fn thruster_3d(rng: &mut ChaCha8Rng, h: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let areas = [h[1] * h[2], h[0] * h[2], h[0] * h[1]];
    let pick = rng.gen::<f64>() * areas.iter().sum::<f64>();
    let axis = if pick < areas[0] {
        0
    } else if pick < areas[0] + areas[1] {
        1
    } else {
        2
    };
    let sign = if rng.gen::<bool>() { 1.0 } else { -1.0 };
    let mut pos = [0.0; 3];
    for (a, p) in pos.iter_mut().enumerate() {
        *p = if a == axis {
            sign * h[a]
        } else {
            h[a] * (2.0 * rng.gen::<f64>() - 1.0)
        };
    }
    let mut normal = Vector3::zeros();
    normal[axis] = sign;
    // A tangential direction: a random unit vector with its normal part removed.
    let t = loop {
        let v = unit(rng);
        let t = v - normal * v.dot(&normal);
        if t.norm() > 1e-3 {
            break t.normalize();
        }
    };
    let cant = rng.gen::<f64>() * 60f64.to_radians();
    let dir = -normal * cant.cos() + t * cant.sin();
    (pos, [dir.x, dir.y, dir.z])
}

/// A thruster of a planar rectangle of half-extents `h`: position on a side, force direction
/// in the plane.
fn thruster_planar(rng: &mut ChaCha8Rng, h: [f64; 2]) -> ([f64; 3], [f64; 3]) {
    let axis = usize::from(rng.gen::<f64>() * (h[0] + h[1]) >= h[1]);
    let sign = if rng.gen::<bool>() { 1.0 } else { -1.0 };
    let mut pos = [0.0; 3];
    for (a, p) in pos.iter_mut().take(2).enumerate() {
        *p = if a == axis {
            sign * h[a]
        } else {
            h[a] * (2.0 * rng.gen::<f64>() - 1.0)
        };
    }
    let mut inward = [0.0; 2];
    inward[axis] = -sign;
    let cant = (2.0 * rng.gen::<f64>() - 1.0) * 80f64.to_radians();
    let (s, c) = cant.sin_cos();
    let dir = [
        inward[0] * c - inward[1] * s,
        inward[0] * s + inward[1] * c,
        0.0,
    ];
    (pos, dir)
}

fn to_contract(m: &Matrix3<f64>) -> [f64; 6] {
    sym_to_vec6(m).into()
}

/// Principal moments that a rigid body can have (each at most the sum of the others).
fn triangle_ok(d: [f64; 3]) -> bool {
    d[0] + d[1] >= d[2] && d[0] + d[2] >= d[1] && d[1] + d[2] >= d[0]
}

/// The nominal model of a random craft of `class` (and the rng, for the truth drawn next).
fn nominal(class: &CraftClass, rng: &mut ChaCha8Rng) -> Satellite {
    let n = rng.gen_range(class.thrusters.0..=class.thrusters.1);
    loop {
        let (h, planar) = if class.planar {
            let h = [rng.gen_range(0.1..0.5), rng.gen_range(0.1..0.5), 0.1];
            (h, true)
        } else {
            let mut h = [0.0; 3];
            for v in &mut h {
                *v = rng.gen_range(0.05..0.5);
            }
            (h, false)
        };
        let mut pos = Vec::with_capacity(n);
        let mut dir = Vec::with_capacity(n);
        for _ in 0..n {
            let (p, d) = if planar {
                thruster_planar(rng, [h[0], h[1]])
            } else {
                thruster_3d(rng, h)
            };
            pos.push(p);
            dir.push(d);
        }
        let thrust: Vec<f64> = (0..n).map(|_| log_uniform(rng, 0.05, 2.0)).collect();
        let mass = if planar {
            rng.gen_range(5.0..30.0)
        } else {
            rng.gen_range(100.0..1500.0) * 8.0 * h[0] * h[1] * h[2]
        };
        let box_moment = |a: usize, b: usize| mass * (h[a] * h[a] + h[b] * h[b]) / 3.0;
        let d = [
            box_moment(1, 2) * rng.gen_range(0.7..1.3),
            box_moment(0, 2) * rng.gen_range(0.7..1.3),
            box_moment(0, 1) * rng.gen_range(0.7..1.3),
        ];
        if !triangle_ok(d) {
            continue;
        }
        let inertia = if planar {
            [d[0], d[1], d[2], 0.0, 0.0, 0.0]
        } else {
            let r = Rotation3::from_axis_angle(
                &Unit::new_normalize(unit(rng)),
                rng.gen::<f64>() * 30f64.to_radians(),
            );
            to_contract(&(r.matrix() * Matrix3::from_diagonal(&d.into()) * r.matrix().transpose()))
        };
        let size = h.iter().copied().fold(0.0, f64::max);
        let mut com = [0.0; 3];
        for (a, c) in com.iter_mut().enumerate() {
            if !(planar && a == 2) {
                *c = 0.02 * size * 1e3 * (2.0 * rng.gen::<f64>() - 1.0);
            }
        }
        let stated = rng.gen::<bool>();
        let thrust_sigma_n = if stated {
            thrust
                .iter()
                .map(|f| f * rng.gen_range(0.01..0.08))
                .collect()
        } else {
            Vec::new()
        };
        let sat = Satellite {
            name: format!("random{n}"),
            thruster_pos_m: pos,
            thrust_dir: dir,
            thrust_n: thrust,
            planar,
            inertia_kgm2: inertia,
            com_offset_mm: com,
            mass_kg: mass,
            gyro_bias_counts: [0.0; 3],
            gyro_counts_per_rad_s: [1.0; 3],
            accel_bias_counts: [0.0; 3],
            accel_m_s2_per_count: 1.0,
            pressure_drop_n_per_extra: 0.0,
            thrust_sigma_n,
        };
        if sat.check_plausible().is_ok() {
            return sat;
        }
    }
}

/// The craft and flight of `class` for `seed`.
pub fn draw(class: &CraftClass, seed: u64) -> Drawn {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5EED_C4AF_7000_0000);
    let model = nominal(class, &mut rng);
    let planar = model.planar;
    // The truth: inertia and CoM moved from the model's.
    let true_inertia = loop {
        let m = model.inertia_matrix();
        let mut t = m;
        if planar {
            t[(2, 2)] *= rng.gen_range(0.85..1.15);
        } else {
            for a in 0..3 {
                t[(a, a)] *= rng.gen_range(0.85..1.15);
            }
            for (a, b) in [(0, 1), (0, 2), (1, 2)] {
                let dv = 0.05 * (m[(a, a)] * m[(b, b)]).sqrt() * (2.0 * rng.gen::<f64>() - 1.0);
                t[(a, b)] += dv;
                t[(b, a)] += dv;
            }
        }
        let eig = t.symmetric_eigenvalues();
        if eig.iter().all(|&e| e > 0.0) && triangle_ok([eig[0], eig[1], eig[2]]) {
            break to_contract(&t);
        }
    };
    let size = model
        .thruster_pos_m
        .iter()
        .map(|p| Vector3::from(*p).norm())
        .fold(0.0, f64::max);
    let mut dcom = [0.0; 3];
    for (a, c) in dcom.iter_mut().enumerate() {
        if !(planar && a == 2) {
            *c = 0.05 * size * 1e3 * (2.0 * rng.gen::<f64>() - 1.0);
        }
    }
    let mut effects = vec![
        Effect::Inertia(Inertia {
            inertia_kgm2: true_inertia,
        }),
        Effect::ComOffset(ComOffset { offset_mm: dcom }),
    ];
    if !model.thrust_sigma_n.is_empty() {
        let scale = model
            .thrust_sigma_n
            .iter()
            .zip(&model.thrust_n)
            .map(|(s, f)| (1.0 + s / f * rng.sample::<f64, _>(StandardNormal)).max(0.0))
            .collect();
        effects.push(Effect::ThrustScale(ThrustScale { scale }));
    }
    let maneuver = match rng.gen_range(0..3) {
        0 => Maneuver::Single,
        1 => Maneuver::Combo,
        _ => Maneuver::RandomPwm,
    };
    let mut spec = SimSpec::new(model.clone(), effects, maneuver);
    spec.seed = seed;
    let noise = rng.gen_range(0.3..4.0);
    for s in spec.sensors.gyro_noise_rad_s.iter_mut() {
        *s *= noise;
    }
    if class.mocap {
        spec.rate_hz = [50.0, 100.0, 200.0, 250.0][rng.gen_range(0..4)];
        spec.sensors.rate_sensor = RateSensor::DifferencedAttitude;
        spec.sensors.attitude_noise_rad = log_uniform(&mut rng, 1e-4, 1e-3);
    } else {
        spec.rate_hz = [50.0, 100.0, 250.0, 500.0, 1000.0][rng.gen_range(0..5)];
        spec.sensors.gyro_bandwidth_hz = log_uniform(&mut rng, 20.0, 300.0);
    }
    let mut truth = [f64::NAN; 9];
    truth[0] = dcom[0];
    truth[1] = dcom[1];
    truth[5] = true_inertia[2];
    if !planar {
        truth[2] = dcom[2];
        for (t, v) in truth[3..].iter_mut().zip(true_inertia) {
            *t = v;
        }
    }
    Drawn { spec, model, truth }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn drawn_craft_are_valid_and_differ_from_their_model() {
        for planar in [false, true] {
            let class = CraftClass {
                planar,
                thrusters: (1, 16),
                mocap: planar,
            };
            for seed in 0..50 {
                let d = draw(&class, seed);
                assert!(d.model.check_plausible().is_ok());
                assert_eq!(d.model.planar, planar);
                let n = d.model.n_thrusters();
                assert!((1..=16).contains(&n));
                // The truth is not the model: the identification has something to find.
                assert!((d.truth[5] - d.model.inertia_kgm2[2]).abs() > 0.0);
                assert_eq!(d.truth[2].is_nan(), planar);
            }
        }
    }
}
