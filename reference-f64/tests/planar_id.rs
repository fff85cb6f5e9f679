//! Planar identification against an independent simulation: a fine-step (1 ms RK4) rigid
//! yaw model of an 8-thruster air-bearing craft (the layout of
//! `shared/data/real/airbearing-mpc/README.md`), true inertia, CoM and damping different
//! from the model, held random commands at 16.7 Hz, and rate noise that is white plus
//! AR(1)-correlated at the sample rate, optionally with an AR(1) disturbance torque.
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use reference_f64::planar_id::{
    identify, interval_residuals, predict, CovarianceKind, PlanarEstimate, PlanarIdError,
    PlanarModel, PlanarOptions, PlanarParams, PlanarStatus, PlanarThruster,
};

const TABLE: [([f64; 2], [f64; 2], f64); 8] = [
    ([0.145, 0.06], [-1.0, 0.0], 0.441450),
    ([0.145, -0.06], [-1.0, 0.0], 0.430659),
    ([0.06, -0.145], [0.0, 1.0], 0.427716),
    ([-0.06, -0.145], [0.0, 1.0], 0.438017),
    ([-0.145, -0.06], [1.0, 0.0], 0.468918),
    ([-0.145, 0.06], [1.0, 0.0], 0.446846),
    ([-0.06, 0.145], [0.0, -1.0], 0.466956),
    ([0.06, 0.145], [0.0, -1.0], 0.484124),
];

fn model() -> PlanarModel {
    PlanarModel {
        thrusters: TABLE
            .iter()
            .map(|&(pos_m, dir, force_n)| PlanarThruster {
                pos_m,
                dir,
                force_n,
            })
            .collect(),
        izz_kgm2: 0.3237,
        com_m: [0.0, 0.0],
    }
}

#[derive(Clone, Copy)]
struct Truth {
    izz: f64,
    com: [f64; 2],
    b: f64,
    d: f64,
    /// Command delay, ms (a word acts from its sample time plus this).
    delay_ms: u64,
}

const TRUTH: Truth = Truth {
    izz: 0.45,
    com: [0.008, -0.005],
    b: 0.03,
    d: 0.001,
    delay_ms: 0,
};

#[derive(Clone, Copy)]
struct Noise {
    /// White rate noise, rad/s.
    white: f64,
    /// AR(1) rate noise: stationary std, rad/s, and correlation per sample.
    ar: f64,
    rho: f64,
    /// AR(1) disturbance torque about `d`: std N m, correlation time s (0: none).
    dist: f64,
    dist_tau_s: f64,
}

const MEAS: Noise = Noise {
    white: 0.002,
    ar: 0.003,
    rho: 0.7,
    dist: 0.0,
    dist_tau_s: 0.0,
};

struct Record {
    time_ms: Vec<u64>,
    rate: Vec<f64>,
    words: Vec<u16>,
}

const PERIOD_MS: u64 = 60;

/// Independent simulation: torque about the true CoM thruster by thruster, RK4 at 1 ms.
fn simulate(
    seed: u64,
    n: usize,
    truth: Truth,
    noise: Noise,
    mut command: impl FnMut(&mut ChaCha8Rng, usize) -> u16,
) -> Record {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut omega = 0.05;
    let mut dist = 0.0;
    let phi_d = if noise.dist_tau_s > 0.0 {
        (-1e-3 / noise.dist_tau_s).exp()
    } else {
        0.0
    };
    let mut ar = noise.ar * rng.sample::<f64, _>(StandardNormal);
    let mut rec = Record {
        time_ms: Vec::new(),
        rate: Vec::new(),
        words: Vec::new(),
    };
    for k in 0..n {
        let word = command(&mut rng, k);
        let e: f64 = StandardNormal.sample(&mut rng);
        ar = noise.rho * ar + (1.0 - noise.rho * noise.rho).sqrt() * noise.ar * e;
        let w: f64 = StandardNormal.sample(&mut rng);
        rec.time_ms.push(k as u64 * PERIOD_MS);
        rec.rate.push(omega + ar + noise.white * w);
        rec.words.push(word);
        let torque_of = |word: u16| {
            let mut torque = 0.0;
            for (i, &(p, dir, f)) in TABLE.iter().enumerate() {
                if word >> i & 1 == 1 {
                    let r = [p[0] - truth.com[0], p[1] - truth.com[1]];
                    torque += f * (r[0] * dir[1] - r[1] * dir[0]);
                }
            }
            torque
        };
        for ms in 0..PERIOD_MS {
            let t = k as u64 * PERIOD_MS + ms;
            let torque = match t.checked_sub(truth.delay_ms) {
                Some(td) => torque_of(rec.words[(td / PERIOD_MS) as usize]),
                None => 0.0,
            };
            if noise.dist > 0.0 {
                let e: f64 = StandardNormal.sample(&mut rng);
                dist = phi_d * dist + (1.0 - phi_d * phi_d).sqrt() * noise.dist * e;
            }
            let f = |om: f64| (torque - truth.b * om + truth.d + dist) / truth.izz;
            let h = 1e-3;
            let k1 = f(omega);
            let k2 = f(omega + h / 2.0 * k1);
            let k3 = f(omega + h / 2.0 * k2);
            let k4 = f(omega + h * k3);
            omega += h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
        }
    }
    rec
}

/// Random held words: in blocks of 50 samples (3 s) the craft is spun one way, the other, or
/// not preferentially (thrusters 1, 3, 5, 7 turn it positive, 2, 4, 6, 8 negative); each
/// thruster opens at random with the block's probability.
fn random_words(rng: &mut ChaCha8Rng, k: usize) -> u16 {
    let block = (k / 50) % 4;
    let (pos, neg) = match block {
        0 => (0.45, 0.15),
        2 => (0.15, 0.45),
        _ => (0.3, 0.3),
    };
    let mut w = 0u16;
    for i in 0..8 {
        if rng.gen_bool(if i % 2 == 0 { pos } else { neg }) {
            w |= 1 << i;
        }
    }
    w
}

fn run(rec: &Record, opts: &PlanarOptions) -> Result<PlanarEstimate, PlanarIdError> {
    identify(&model(), &rec.time_ms, &rec.rate, &rec.words, opts)
}

/// Noise of the coverage test: the measurement noise above plus a disturbance torque that
/// varies with a 0.3 s correlation time (3 mN m, e.g. table tilt under translation).
const MIXED: Noise = Noise {
    dist: 0.003,
    dist_tau_s: 0.3,
    ..MEAS
};

/// Per term (Izz, cm_x, damping): coverage = fraction of all trials with the term reported
/// and |est - truth| < 2 stderr; mean stderr / empirical sd of the reported estimates; and
/// the number of trials in which the term was reported unobservable.
struct Coverage {
    cover: [f64; 3],
    se_over_sd: [f64; 3],
    dropped: [usize; 3],
}

fn coverage(trials: u64, noise: Noise, kind: CovarianceKind) -> Coverage {
    let opts = PlanarOptions {
        covariance: kind,
        ..PlanarOptions::default()
    };
    let truth = [TRUTH.izz, TRUTH.com[0], TRUTH.b];
    let mut est: [Vec<(f64, f64)>; 3] = Default::default();
    let mut dropped = [0usize; 3];
    for seed in 0..trials {
        let rec = simulate(1000 + seed, 1000, TRUTH, noise, random_words);
        let e = run(&rec, &opts).expect("every trial identifies");
        let terms = [
            (Some(e.izz_kgm2), Some(e.izz_stderr)),
            (e.com_offset_m[0], e.com_stderr_m[0]),
            (e.damping_nms, e.damping_stderr),
        ];
        for (j, t) in terms.iter().enumerate() {
            match t {
                (Some(v), Some(s)) => est[j].push((*v, *s)),
                _ => dropped[j] += 1,
            }
        }
    }
    let mut c = Coverage {
        cover: [0.0; 3],
        se_over_sd: [f64::NAN; 3],
        dropped,
    };
    for j in 0..3 {
        let v = &est[j];
        let hits = v
            .iter()
            .filter(|(e, s)| (e - truth[j]).abs() < 2.0 * s)
            .count();
        c.cover[j] = hits as f64 / trials as f64;
        if v.len() > 2 {
            let n = v.len() as f64;
            let m = v.iter().map(|r| r.0).sum::<f64>() / n;
            let sd = (v.iter().map(|r| (r.0 - m).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
            c.se_over_sd[j] = v.iter().map(|r| r.1).sum::<f64>() / n / sd;
        }
    }
    println!(
        "{kind:?}: coverage Izz/cm_x/damping {:?}, stderr/sd {:.2?}, unobservable {:?}",
        c.cover, c.se_over_sd, c.dropped
    );
    c
}

#[test]
fn recovers_the_truth_within_three_standard_errors() {
    let rec = simulate(7, 1000, TRUTH, MEAS, random_words);
    let e = run(&rec, &PlanarOptions::default()).expect("identifies");
    println!("{e:?}");
    assert_eq!(e.status, PlanarStatus::Ok);
    assert!(e.unobservable.is_empty());
    let check = |name: &str, v: Option<f64>, s: Option<f64>, t: f64| {
        let (v, s) = (v.expect(name), s.expect(name));
        assert!((v - t).abs() < 3.0 * s, "{name}: {v} +- {s}, truth {t}");
        assert!(s > 0.0 && s.is_finite());
    };
    check("Izz", Some(e.izz_kgm2), Some(e.izz_stderr), TRUTH.izz);
    check("cm_x", e.com_offset_m[0], e.com_stderr_m[0], TRUTH.com[0]);
    check("cm_y", e.com_offset_m[1], e.com_stderr_m[1], TRUTH.com[1]);
    check("damping", e.damping_nms, e.damping_stderr, TRUTH.b);
    check(
        "disturbance",
        e.disturbance_nm,
        e.disturbance_stderr,
        TRUTH.d,
    );
    // Izz to a few per cent on one minute of data.
    assert!(e.izz_stderr < 0.05 * TRUTH.izz);
}

/// The honesty check: over 200 seeded trials the 2-stderr intervals of Izz, cm_x and the
/// damping hold the truth 85-99 % of the time (nominal 95.4 %).
#[test]
fn coverage_of_two_standard_errors_is_honest() {
    let c = coverage(200, MIXED, CovarianceKind::Parzen);
    for (j, name) in ["Izz", "cm_x", "damping"].iter().enumerate() {
        assert!(
            (0.85..=0.99).contains(&c.cover[j]),
            "{name}: coverage {}",
            c.cover[j]
        );
    }
}

/// The plain-LS covariance is wrong for this noise. With the increments of time-correlated
/// rate noise (over-differenced: their sum telescopes) it overstates the damping's stderr
/// several-fold, so the damping is declared unobservable and lost; coverage 0 < 0.8.
/// Newey-West (Bartlett) keeps it but is still conservative for it (see README).
#[test]
fn plain_ls_covariance_fails_the_honesty_check() {
    let ols = coverage(200, MIXED, CovarianceKind::Ols);
    assert!(ols.cover[2] < 0.8, "OLS damping coverage {}", ols.cover[2]);
    assert!(ols.dropped[2] > 150);
    let nw = coverage(200, MIXED, CovarianceKind::NeweyWest);
    assert!(nw.dropped[2] < 20);
    assert!(nw.cover[0] > 0.85 && nw.cover[1] > 0.85);
}

/// Measurement noise alone (no disturbance): Izz and CoM are honest, the damping's stderr
/// is conservative (its score sum telescopes; a lag window cannot see that fully).
#[test]
fn measurement_noise_only_damping_stderr_is_conservative_not_optimistic() {
    let c = coverage(200, MEAS, CovarianceKind::Parzen);
    assert!((0.85..=0.99).contains(&c.cover[0]), "{:?}", c.cover);
    assert!((0.85..=0.99).contains(&c.cover[1]), "{:?}", c.cover);
    assert!(c.se_over_sd[2] > 1.0 && c.se_over_sd[2] < 4.0);
    assert!(c.cover[2] >= 0.95);
}

fn couple_words(rng: &mut ChaCha8Rng, k: usize) -> u16 {
    // Pure couples: 1+5 and 3+7 turn positive, 2+6 and 4+8 negative (zero net force for
    // equal thrusts).
    let sign_pos = (k / 50) % 2 == 0;
    let mut w = 0u16;
    let pairs: [(usize, usize); 2] = if sign_pos {
        [(0, 4), (2, 6)]
    } else {
        [(1, 5), (3, 7)]
    };
    for (a, b) in pairs {
        if rng.gen_bool(0.5) {
            w |= (1 << a) | (1 << b);
        }
    }
    w
}

#[test]
fn couples_only_leave_the_com_unobservable() {
    let mut m = model();
    for t in &mut m.thrusters {
        t.force_n = 0.45;
    }
    let rec = simulate(11, 1000, TRUTH, MEAS, couple_words);
    let e = identify(
        &m,
        &rec.time_ms,
        &rec.rate,
        &rec.words,
        &PlanarOptions::default(),
    )
    .expect("Izz is identified");
    println!("{e:?}");
    assert_eq!(e.status, PlanarStatus::UnobservableTerms);
    assert!(e.unobservable.contains(&"cm_x") && e.unobservable.contains(&"cm_y"));
    assert_eq!(e.com_offset_m, [None, None]);
    assert_eq!(e.com_stderr_m, [None, None]);
    // The real (unequal) thrust table leaves small net forces: still not a usable CoM.
    let e = run(&rec, &PlanarOptions::default()).expect("Izz is identified");
    println!("{e:?}");
    assert!(e.unobservable.contains(&"cm_x") && e.unobservable.contains(&"cm_y"));
    assert_eq!(e.com_offset_m, [None, None]);
}

#[test]
fn no_rotation_or_too_few_samples_is_an_error() {
    // Nothing fired, no rotation: only noise.
    let quiet = Truth { d: 0.0, ..TRUTH };
    let mut rec = simulate(5, 500, quiet, MEAS, |_, _| 0);
    let w0 = rec.rate[0];
    // Start at rest.
    for (r, k) in rec.rate.iter_mut().zip(0..) {
        *r -= w0 * (-(TRUTH.b / TRUTH.izz) * 0.06 * k as f64).exp();
    }
    let e = run(&rec, &PlanarOptions::default());
    assert_eq!(
        e.map(|_| ()).map_err(|e| e.status()),
        Err("insufficient_excitation")
    );
    // Translations only (opposed pairs): the nominal torque is only the thrust mismatch.
    let translate = |rng: &mut ChaCha8Rng, _: usize| -> u16 {
        [0b11u16, 0b1100, 0b11_0000, 0b1100_0000][rng.gen_range(0..4)]
    };
    let rec = simulate(6, 500, TRUTH, MEAS, translate);
    let e = run(&rec, &PlanarOptions::default());
    println!("{e:?}");
    assert!(e.is_err(), "{e:?}");
    // Too few samples.
    let rec = simulate(7, 20, TRUTH, MEAS, random_words);
    let e = run(&rec, &PlanarOptions::default());
    assert_eq!(
        e.map(|_| ()).map_err(|e| e.status()),
        Err("too_few_samples")
    );
}

#[test]
fn sign_flipped_rates_give_negative_inertia() {
    let mut rec = simulate(8, 1000, TRUTH, MEAS, random_words);
    for r in &mut rec.rate {
        *r = -*r;
    }
    let e = run(&rec, &PlanarOptions::default());
    assert_eq!(
        e.map(|_| ()).map_err(|e| e.status()),
        Err("negative_inertia")
    );
}

#[test]
fn missing_samples_break_the_chain_and_prediction_beats_the_model() {
    let rec = simulate(9, 2000, TRUTH, MEAS, random_words);
    let (fit, held) = (1000, 1000..2000);
    let mut rate = rec.rate[..fit].to_vec();
    for k in (50..fit).step_by(97) {
        rate[k] = f64::NAN;
    }
    let e = identify(
        &model(),
        &rec.time_ms[..fit],
        &rate,
        &rec.words[..fit],
        &PlanarOptions::default(),
    )
    .expect("identifies");
    // Each missing sample removes the two intervals touching it.
    assert_eq!(
        e.intervals_used,
        fit - 1 - 2 * (50..fit).step_by(97).count()
    );
    assert!((e.izz_kgm2 - TRUTH.izz).abs() < 3.0 * e.izz_stderr);
    let (t, r, w) = (
        &rec.time_ms[held.clone()],
        &rec.rate[held.clone()],
        &rec.words[held],
    );
    let o = PlanarOptions::default();
    let rms = |v: &[f64]| (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt();
    let nominal = PlanarParams::nominal(&model());
    let one_nom = interval_residuals(&model(), &nominal, &o, t, r, w).expect("valid");
    let one_fit = interval_residuals(&model(), &e.params(), &o, t, r, w).expect("valid");
    let sim_nom = predict(&model(), &nominal, &o, t, w, r[0]).expect("valid");
    let sim_fit = predict(&model(), &e.params(), &o, t, w, r[0]).expect("valid");
    let err = |p: &[f64]| rms(&p.iter().zip(r).map(|(a, b)| a - b).collect::<Vec<_>>());
    println!(
        "one-step rms nominal {} fitted {}; simulation rms nominal {} fitted {}",
        rms(&one_nom),
        rms(&one_fit),
        err(&sim_nom),
        err(&sim_fit)
    );
    assert!(rms(&one_fit) < rms(&one_nom));
    assert!(err(&sim_fit) < 0.5 * err(&sim_nom));
    // Against the truth's own prediction.
    let truth = PlanarParams {
        izz_kgm2: TRUTH.izz,
        com_offset_m: TRUTH.com,
        damping_nms: TRUTH.b,
        disturbance_nm: TRUTH.d,
    };
    let sim_true = predict(&model(), &truth, &o, t, w, r[0]).expect("valid");
    assert!(err(&sim_true) < 0.02, "{}", err(&sim_true));
}

#[test]
fn a_known_command_delay_is_taken_into_account() {
    let delayed = Truth {
        delay_ms: 40,
        ..TRUTH
    };
    let rec = simulate(12, 1000, delayed, MEAS, random_words);
    let with = run(
        &rec,
        &PlanarOptions {
            delay_ms: 40.0,
            ..PlanarOptions::default()
        },
    )
    .expect("identifies");
    let without = run(&rec, &PlanarOptions::default()).expect("identifies");
    println!("delay 40: {with:?}\ndelay 0: {without:?}");
    assert!((with.izz_kgm2 - TRUTH.izz).abs() < 3.0 * with.izz_stderr);
    assert!(with.residual_rms_rad_s < 0.9 * without.residual_rms_rad_s);
}
