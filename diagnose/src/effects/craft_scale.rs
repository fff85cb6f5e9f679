//! How large a craft is against SPHERES, for the search bounds and plausibility limits that
//! were first set on SPHERES: each grows with the quantity it bounds (a length with the
//! craft's size, a force with its weakest thrust, a torque with both) and never falls below
//! SPHERES' own, so a craft up to SPHERES' size, thrust and inertia keeps them. Fixed
//! SPHERES-sized bounds clamped a larger craft's effect at the bound or called it
//! implausible, and the diagnosis named something else (`diagnose_random_craft`: a CoM
//! offset, a disturbance torque, an inertia whose products of inertia the box left out).

use super::Context;
use crate::model::Plant;

/// SPHERES' size (its CoM to its farthest thruster: 0.109 m on sph2, rounded up; the other
/// built-in models' CoMs put it at up to 0.1112 m).
const SPHERES_SIZE_M: f64 = 0.11;

/// SPHERES' thrust (its strongest thruster in the built-in models, 0.134 N, rounded up).
const SPHERES_THRUST_N: f64 = 0.14;

/// SPHERES' largest principal moment (0.0275 kg m^2 in the built-in models, rounded up).
const SPHERES_MOMENT_KGM2: f64 = 0.03;

/// An inertia bound's factor: the model's largest principal moment against SPHERES'.
pub fn moment(nominal_inertia: &[f64; 6]) -> f64 {
    let largest = nominal_inertia[..3].iter().copied().fold(0.0, f64::max);
    (largest / SPHERES_MOMENT_KGM2).max(1.0)
}

/// A length bound's factor: the craft's size against SPHERES'.
pub fn length(plant: &Plant) -> f64 {
    (plant.size_m() / SPHERES_SIZE_M).max(1.0)
}

/// A force bound's factor: the craft's weakest thrust against SPHERES' thrust.
pub fn force(cx: &Context) -> f64 {
    (cx.min_thrust_n / SPHERES_THRUST_N).max(1.0)
}

/// A torque bound's factor: the weakest thrust at the craft's size against SPHERES'.
pub fn torque(cx: &Context) -> f64 {
    (cx.min_thrust_n * cx.plant.size_m() / (SPHERES_THRUST_N * SPHERES_SIZE_M)).max(1.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use reference_f64::satellite::Satellite;

    fn factors(sat: &Satellite) -> [f64; 4] {
        let plant = Plant::new(sat);
        let fired = [true; crate::model::NT];
        let cx = Context {
            duration_s: 60.0,
            nominal_inertia: sat.inertia_kgm2,
            min_thrust_n: sat.thrust_n.iter().copied().fold(f64::MAX, f64::min),
            n_thrusters: sat.n_thrusters(),
            fired: &fired,
            slosh_hint_hz: &[],
            sample_rate_hz: 1000.0,
            command_step_ms: 200.0,
            inertia_start: None,
            plant: &plant,
        };
        [
            length(&plant),
            force(&cx),
            torque(&cx),
            moment(&sat.inertia_kgm2),
        ]
    }

    /// Every built-in SPHERES model keeps the force, torque and inertia bounds set on SPHERES (a
    /// factor of exactly 1) and its length bounds within 2 % (sph1's and sph3's CoMs are up to
    /// 1.2 mm farther from a thruster than the constant's 0.11 m). SPHERES grown four times in
    /// size and given four times SPHERES' thrust and moment gets each bound in proportion, the
    /// torque's by both. Planted: a factor that is not floored at 1 shrinks SPHERES' own.
    #[test]
    fn spheres_keeps_its_bounds_and_a_larger_craft_scales_them() {
        for name in Satellite::BUILTIN_NAMES {
            let sat = Satellite::builtin(name).expect("built in");
            let [l, f, t, m] = factors(&sat);
            assert!((1.0..1.02).contains(&l), "{name}: {l}");
            assert_eq!([f, t, m], [1.0; 3], "{name}");
        }
        let sph2 = Satellite::builtin("sph2").expect("built in");
        let mut big = sph2.clone();
        for p in &mut big.thruster_pos_m {
            *p = p.map(|v| 4.0 * v);
        }
        big.com_offset_mm = big.com_offset_mm.map(|v| 4.0 * v);
        big.thrust_n = vec![4.0 * SPHERES_THRUST_N; big.thrust_n.len()];
        big.inertia_kgm2 = [4.0 * SPHERES_MOMENT_KGM2, 0.01, 0.01, 0.0, 0.0, 0.0];
        let [l, f, t, m] = factors(&big);
        let size = 4.0 * Plant::new(&sph2).size_m();
        assert!((l - size / SPHERES_SIZE_M).abs() < 1e-12, "{l}");
        assert!((f - 4.0).abs() < 1e-12, "{f}");
        assert!((t - l * f).abs() < 1e-9, "{t} against {}", l * f);
        assert!((m - 4.0).abs() < 1e-12, "{m}");
    }
}
