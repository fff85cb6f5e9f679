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
use rand::seq::SliceRandom;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use reference_f64::mixer::MIN_PULSE_MS;
use reference_f64::satellite::{N_THRUSTERS, OPPOSING_PAIRS};

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

/// Each thruster alone (1 s rest, then 0.5 s on / 1.5 s off each: 25 s).
pub fn single() -> Vec<u16> {
    let mut w = Vec::new();
    push(&mut w, 0, 1000);
    for i in 0..N_THRUSTERS {
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

fn opposite(i: usize) -> usize {
    OPPOSING_PAIRS
        .iter()
        .find_map(|&(a, b)| {
            if a == i {
                Some(b)
            } else if b == i {
                Some(a)
            } else {
                None
            }
        })
        .unwrap_or(i)
}

/// Random short-pulse combos for about `seconds` of firing (whole 200 ms periods).
pub fn combo(seconds: f64, rng: &mut ChaCha8Rng) -> Vec<u16> {
    let periods = ((seconds * 1000.0) / PERIOD_MS as f64).round().max(1.0) as usize;
    let mut w = Vec::new();
    push(&mut w, 0, 1000);
    for _ in 0..periods {
        let n = rng.gen_range(1..=4);
        let mut all: Vec<usize> = (0..N_THRUSTERS).collect();
        all.shuffle(rng);
        let mut chosen: Vec<usize> = Vec::new();
        for i in all {
            if chosen.len() == n {
                break;
            }
            if !chosen.contains(&opposite(i)) {
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

/// Random PWM excitation: every thruster fires with probability 0.3 per period (opposing
/// pairs excluded), random centred pulse widths.
pub fn random_pwm(seconds: f64, rng: &mut ChaCha8Rng) -> Vec<u16> {
    let periods = ((seconds * 1000.0) / PERIOD_MS as f64).round().max(1.0) as usize;
    let mut w = Vec::new();
    push(&mut w, 0, 1000);
    for _ in 0..periods {
        let mut firing: Vec<(usize, usize)> = Vec::new();
        for i in 0..N_THRUSTERS {
            if rng.gen_bool(0.3) && !firing.iter().any(|&(j, _)| j == opposite(i)) {
                firing.push((i, random_width(rng)));
            }
        }
        w.extend_from_slice(&centred_period(&firing));
    }
    push(&mut w, 0, 1500);
    w
}
