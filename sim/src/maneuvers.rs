//! Maneuver scripts: commanded thruster words, one per millisecond from t = 0 (the 1 ms
//! resolution of the SPHERES thruster commands, seed 3.3-3.4). Bit i = thruster i+1.
//!
//! - `rga12`: the seed's RGA sets as in the open data: 1 s rest, then for the x, y, z axes a
//!   +/- rotation pair (1 s spin-up, 0.5 s coast, 1 s spin-down, 1.5 s rest), then the same for
//!   translations, then 3 s more rest (28 s).
//! - `single`: each thruster alone for 0.5 s, 1.5 s apart.
//! - `combo`: 1 s rest, then 200 ms periods each firing 1-4 random thrusters (never both of
//!   an opposing pair) with random pulses of 10-190 ms centred in the period (as the PWM
//!   mixer centres them), then 1.5 s rest.
//! - `random_pwm`: like combo, but every thruster independently fires with probability 0.3.
//!
//! `single`, `combo` and `random_pwm` are built from a craft's own thrusters ([`Layout`]):
//! any count, planar or 3-D. `rga12` (and the closed loop's mixer) fly the SPHERES layout
//! only; [`Layout::is_spheres`] says whether a craft has it.
use rand::seq::SliceRandom;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use reference_f64::mixer::MIN_PULSE_MS;
use reference_f64::satellite::{Satellite, N_THRUSTERS, OPPOSING_PAIRS};

/// What a script needs of a craft: how many thrusters, and which thruster undoes which
/// (firing both of such a pair wastes gas and excites nothing, so the random scripts never do).
#[derive(Clone, Debug, PartialEq)]
pub struct Layout {
    /// Number of thrusters (bit i of a word = thruster i+1).
    pub n: usize,
    /// For each thruster, the one whose force and torque cancel its own, if any.
    pub opposite: Vec<Option<usize>>,
}

/// Two thrusters oppose when the sum of their wrenches is under this fraction of their
/// sizes (SPHERES' measured thrusts differ by up to a few percent).
const OPPOSING_TOLERANCE: f64 = 0.1;

impl Layout {
    /// The SPHERES layout: 12 thrusters in the six opposing pairs of the seed.
    pub fn spheres() -> Layout {
        let mut opposite = vec![None; N_THRUSTERS];
        for (a, b) in OPPOSING_PAIRS {
            opposite[a] = Some(b);
            opposite[b] = Some(a);
        }
        Layout {
            n: N_THRUSTERS,
            opposite,
        }
    }

    /// A craft's layout from its geometry: thruster j opposes i when their forces and their
    /// torques about the CoM both cancel (same line of action, opposite sense); torques are
    /// scaled by the farthest thruster's lever arm so both parts weigh alike.
    pub fn of(sat: &Satellite) -> Layout {
        let n = sat.n_thrusters();
        let reach = (0..n)
            .map(|i| sat.lever_arm_m(i).norm())
            .fold(1e-3, f64::max);
        let wrench = |i: usize| -> [f64; 6] {
            let (f, t) = (sat.force_n(i), sat.torque_nm(i) / reach);
            [f.x, f.y, f.z, t.x, t.y, t.z]
        };
        let norm = |w: [f64; 6]| w.iter().map(|v| v * v).sum::<f64>().sqrt();
        let opposite = (0..n)
            .map(|i| {
                let wi = wrench(i);
                (0..n)
                    .filter(|&j| j != i)
                    .map(|j| {
                        let wj = wrench(j);
                        let sum = norm(std::array::from_fn(|k| wi[k] + wj[k]));
                        (j, sum / (norm(wi) + norm(wj)).max(f64::MIN_POSITIVE))
                    })
                    .filter(|&(_, r)| r < OPPOSING_TOLERANCE)
                    .min_by(|a, b| a.1.total_cmp(&b.1))
                    .map(|(j, _)| j)
            })
            .collect();
        Layout { n, opposite }
    }

    /// Whether `sat` has the SPHERES layout the `rga12` pairs and the PWM mixer assume:
    /// a 3-D craft with 12 thrusters in the seed's opposing pairs.
    pub fn is_spheres(sat: &Satellite) -> bool {
        !sat.planar && Layout::of(sat) == Layout::spheres()
    }

    fn opposite(&self, i: usize) -> Option<usize> {
        self.opposite.get(i).copied().flatten()
    }
}

/// Thruster pairs (0-based) of the RGA set: (+x, -x, +y, -y, +z, -z) rotations, and
/// (+x, -x, +y, -y, +z, -z) translations. Each pair's torques add and forces cancel (rotation)
/// or forces add and torques cancel (translation); the tests check this against the geometry.
pub const RGA_ROTATIONS: [(usize, usize); 6] = [(4, 11), (5, 10), (0, 7), (1, 6), (2, 9), (3, 8)];
pub const RGA_TRANSLATIONS: [(usize, usize); 6] =
    [(0, 1), (6, 7), (2, 3), (8, 9), (4, 5), (10, 11)];

/// The control / PWM period, ms.
pub const PERIOD_MS: usize = 200;

fn word_of(thrusters: &[usize]) -> u16 {
    thrusters.iter().fold(0, |w, &i| w | (1 << i))
}

fn push(words: &mut Vec<u16>, word: u16, ms: usize) {
    words.extend(std::iter::repeat_n(word, ms));
}

/// The RGA set (28 s).
pub fn rga12() -> Vec<u16> {
    let mut w = Vec::with_capacity(28_000);
    push(&mut w, 0, 1000);
    for pairs in [RGA_ROTATIONS, RGA_TRANSLATIONS] {
        for axis in 0..3 {
            let (a, b) = pairs[2 * axis];
            let (c, d) = pairs[2 * axis + 1];
            push(&mut w, word_of(&[a, b]), 1000);
            push(&mut w, 0, 500);
            push(&mut w, word_of(&[c, d]), 1000);
            push(&mut w, 0, 1500);
        }
    }
    push(&mut w, 0, 3000);
    w
}

/// Each SPHERES thruster alone (1 s rest, then 0.5 s on / 1.5 s off each: 25 s).
pub fn single() -> Vec<u16> {
    single_for(&Layout::spheres())
}

/// Each of the craft's thrusters alone, in turn (1 s rest, then 0.5 s on / 1.5 s coast
/// each): every thruster's torque shows on its own, which identifies inertia and CoM.
pub fn single_for(layout: &Layout) -> Vec<u16> {
    let mut w = Vec::new();
    push(&mut w, 0, 1000);
    for i in 0..layout.n {
        push(&mut w, 1 << i, 500);
        push(&mut w, 0, 1500);
    }
    w
}

/// One PWM period with pulses of `widths` (ms) centred in it.
fn centred_period(thrusters: &[(usize, usize)]) -> [u16; PERIOD_MS] {
    let mut p = [0u16; PERIOD_MS];
    for &(i, width) in thrusters {
        let on = (PERIOD_MS - width) / 2;
        for slot in p.iter_mut().skip(on).take(width) {
            *slot |= 1 << i;
        }
    }
    p
}

fn random_width(rng: &mut ChaCha8Rng) -> usize {
    rng.gen_range(MIN_PULSE_MS as usize..=PERIOD_MS - MIN_PULSE_MS as usize)
}

/// Random short-pulse combos of SPHERES thrusters for about `seconds` of firing.
pub fn combo(seconds: f64, rng: &mut ChaCha8Rng) -> Vec<u16> {
    combo_for(&Layout::spheres(), seconds, rng)
}

/// Random short-pulse combos for about `seconds` of firing (whole 200 ms periods): 1-4 of
/// the craft's thrusters per period, never both of an opposing pair.
pub fn combo_for(layout: &Layout, seconds: f64, rng: &mut ChaCha8Rng) -> Vec<u16> {
    let periods = ((seconds * 1000.0) / PERIOD_MS as f64).round().max(1.0) as usize;
    let mut w = Vec::new();
    push(&mut w, 0, 1000);
    for _ in 0..periods {
        let n = rng.gen_range(1..=4.min(layout.n.max(1)));
        let mut all: Vec<usize> = (0..layout.n).collect();
        all.shuffle(rng);
        let mut chosen: Vec<usize> = Vec::new();
        for i in all {
            if chosen.len() == n {
                break;
            }
            if layout.opposite(i).is_none_or(|o| !chosen.contains(&o)) {
                chosen.push(i);
            }
        }
        let firing: Vec<(usize, usize)> =
            chosen.into_iter().map(|i| (i, random_width(rng))).collect();
        w.extend_from_slice(&centred_period(&firing));
    }
    push(&mut w, 0, 1500);
    w
}

/// Random PWM excitation of the SPHERES thrusters for about `seconds`.
pub fn random_pwm(seconds: f64, rng: &mut ChaCha8Rng) -> Vec<u16> {
    random_pwm_for(&Layout::spheres(), seconds, rng)
}

/// Random PWM excitation: every one of the craft's thrusters fires with probability 0.3
/// per period (opposing pairs excluded), random centred pulse widths.
pub fn random_pwm_for(layout: &Layout, seconds: f64, rng: &mut ChaCha8Rng) -> Vec<u16> {
    let periods = ((seconds * 1000.0) / PERIOD_MS as f64).round().max(1.0) as usize;
    let mut w = Vec::new();
    push(&mut w, 0, 1000);
    for _ in 0..periods {
        let mut firing: Vec<(usize, usize)> = Vec::new();
        for i in 0..layout.n {
            if rng.gen_bool(0.3) && !firing.iter().any(|&(j, _)| layout.opposite(i) == Some(j)) {
                firing.push((i, random_width(rng)));
            }
        }
        w.extend_from_slice(&centred_period(&firing));
    }
    push(&mut w, 0, 1500);
    w
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_spheres_layout_is_found_from_every_builtin_geometry() {
        // What keeps the SPHERES scripts' bytes: the geometry gives the seed's pairs.
        for name in Satellite::BUILTIN_NAMES {
            let sat = Satellite::builtin(name).unwrap();
            assert_eq!(Layout::of(&sat), Layout::spheres(), "{name}");
            assert!(Layout::is_spheres(&sat));
        }
    }

    #[test]
    fn an_8_thruster_craft_gets_every_one_of_its_thrusters_in_its_scripts() {
        let mut sat = Satellite::builtin("sph2").unwrap();
        sat.thruster_pos_m.truncate(8);
        sat.thrust_dir.truncate(8);
        sat.thrust_n.truncate(8);
        let layout = Layout::of(&sat);
        assert_eq!(layout.n, 8);
        assert!(!Layout::is_spheres(&sat));
        let w = single_for(&layout);
        assert_eq!(w.iter().fold(0, |a, b| a | b), 0xff);
        let mut rng = <ChaCha8Rng as rand::SeedableRng>::seed_from_u64(1);
        let w = random_pwm_for(&layout, 20.0, &mut rng);
        assert_eq!(w.iter().fold(0, |a, b| a | b), 0xff);
    }
}
