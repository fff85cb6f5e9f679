//! Monte Carlo of the output-error identification (`reference_f64::flight_id`) over flights it
//! was not developed on: every maneuver the simulator flies, sample rates 50-1000 Hz, 1x and
//! 4x the gyro noise, and a planar craft whose yaw rate comes from motion capture (attitude
//! with white noise differenced over one sample), open and closed loop. Each flight's error is
//! divided by its reported standard error: bias in sigma, RMS error/sigma, 1- and 2-sigma
//! coverage, share of status `ok`.
use crate::random_craft::{self, CraftClass};
use massid_sim::{simulate, Maneuver, SimSpec};
use reference_f64::flight_id::flight::{Command, Flight};
use reference_f64::flight_id::{identify, FlightEstimate, Options};
use reference_f64::satellite::Satellite;
use std::path::Path;

/// Terms scored: CoM x y z (mm), Ixx Iyy Izz, Ixy Ixz Iyz.
pub const TERMS: [&str; 9] = [
    "cm_x", "cm_y", "cm_z", "Ixx", "Iyy", "Izz", "Ixy", "Ixz", "Iyz",
];

/// A flight condition.
#[derive(Clone, Debug, PartialEq)]
pub enum Condition {
    /// SPH2 in our simulator: maneuver, sample rate (Hz), gyro noise multiple.
    Spheres {
        maneuver: Maneuver,
        rate_hz: f64,
        noise: f64,
    },
    /// The planar air-bearing craft with motion-capture yaw rate: sample period (ms),
    /// control step (ms), closed loop or random open loop.
    PlanarMocap {
        step_ms: u64,
        control_ms: u64,
        closed_loop: bool,
    },
    /// The same with the attitude central-differenced (over the previous and next samples:
    /// noise correlated at lag 2, as in the independent simulator's `open3` pl6).
    PlanarMocapCentral {
        step_ms: u64,
        control_ms: u64,
        closed_loop: bool,
    },
    /// A craft of `examples/models/` (the file's stem) in our simulator with a gyro, no effect:
    /// maneuver (single, combo and random-pwm fly any craft) and sample rate (Hz).
    Craft {
        model: &'static str,
        maneuver: Maneuver,
        rate_hz: f64,
    },
    /// A craft drawn at random for each flight (`random_craft`): its geometry, thrusters,
    /// mass properties, the truth's departure from its model, the maneuver, rate and noise.
    RandomCraft(CraftClass),
}

impl Condition {
    pub fn label(&self) -> String {
        match self {
            Condition::Spheres {
                maneuver,
                rate_hz,
                noise,
            } => {
                format!("sph2 {} {} Hz {}x", maneuver.name(), rate_hz, noise)
            }
            Condition::PlanarMocap {
                step_ms,
                control_ms,
                closed_loop,
            }
            | Condition::PlanarMocapCentral {
                step_ms,
                control_ms,
                closed_loop,
            } => format!(
                "planar mocap{} {} Hz, {} ms steps, {}",
                if matches!(self, Condition::PlanarMocapCentral { .. }) {
                    " central"
                } else {
                    ""
                },
                1000 / step_ms,
                control_ms,
                if *closed_loop {
                    "closed loop"
                } else {
                    "open loop"
                }
            ),
            Condition::Craft {
                model,
                maneuver,
                rate_hz,
            } => format!("craft {model} {} {rate_hz} Hz", maneuver.name()),
            Condition::RandomCraft(class) => class.label(),
        }
    }
}

/// One simulated flight: what the estimator reads, the model it is given, and the truth of
/// the scored terms (NaN where the craft cannot show it).
pub struct Simulated {
    pub flight: Flight,
    pub model: Satellite,
    pub truth: [f64; 9],
}

/// Simulates one flight of `cond` with noise seed `seed`.
pub fn fly(cond: &Condition, seed: u64) -> Simulated {
    match cond {
        Condition::Spheres {
            maneuver,
            rate_hz,
            noise,
        } => {
            let sat = Satellite::builtin("sph2").expect("sph2");
            let mut spec = SimSpec::new(sat.clone(), Vec::new(), *maneuver);
            spec.rate_hz = *rate_hz;
            spec.seed = seed;
            for s in spec.sensors.gyro_noise_rad_s.iter_mut() {
                *s *= noise;
            }
            let out = simulate(&spec).expect("simulation");
            let mut truth = [0.0; 9];
            truth[3..].copy_from_slice(&sat.inertia_kgm2);
            Simulated {
                flight: Flight::from_v1(&out.recording, &sat),
                model: sat,
                truth,
            }
        }
        Condition::PlanarMocap {
            step_ms,
            control_ms,
            closed_loop,
        } => planar_mocap(*step_ms, *control_ms, *closed_loop, false, seed),
        Condition::PlanarMocapCentral {
            step_ms,
            control_ms,
            closed_loop,
        } => planar_mocap(*step_ms, *control_ms, *closed_loop, true, seed),
        Condition::Craft {
            model,
            maneuver,
            rate_hz,
        } => {
            let sat = model_of(model);
            let mut spec = SimSpec::new(sat.clone(), Vec::new(), *maneuver);
            spec.rate_hz = *rate_hz;
            spec.seed = seed;
            let out = simulate(&spec).expect("simulation");
            let mut truth = [0.0; 9];
            truth[3..].copy_from_slice(&sat.inertia_kgm2);
            let flight = match &out.rate_recording {
                Some(r) => Flight::from_v2(r),
                None => Flight::from_v1(&out.recording, &sat),
            };
            Simulated {
                flight,
                model: sat,
                truth,
            }
        }
        Condition::RandomCraft(class) => {
            let drawn = random_craft::draw(class, seed);
            let out = simulate(&drawn.spec).expect("simulation");
            let flight = match &out.rate_recording {
                Some(r) => Flight::from_v2(r),
                None => Flight::from_v1(&out.recording, &drawn.model),
            };
            Simulated {
                flight,
                model: drawn.model,
                truth: drawn.truth,
            }
        }
    }
}

/// The craft of `examples/models/NAME.toml`.
pub fn model_of(name: &str) -> Satellite {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("workspace");
    massid_sim::model_file::ModelFile::read(&root.join(format!("examples/models/{name}.toml")))
        .expect("model")
        .satellite
}

/// The air-bearing craft's nominal model (`examples/models/airbearing-mpc.toml`).
pub fn airbearing_model() -> Satellite {
    model_of("airbearing-mpc")
}

struct Lcg(u64);

impl Lcg {
    fn uniform(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
    fn normal(&mut self) -> f64 {
        let (u, v) = (self.uniform().max(1e-300), self.uniform());
        (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
    }
}

/// Motion-capture noise: attitude noise (rad) differenced over one sample, plus white rate noise.
pub const MOCAP_ANGLE_RAD: f64 = 0.0003;
pub const MOCAP_WHITE_RAD_S: f64 = 0.002;

/// A planar flight integrated exactly on a 1 ms grid (yaw only: `Izz omega_dot = tau_z` with
/// torque about the true CoM), written independently of the estimator. True Izz 0.36 and CoM
/// (+6, -4) mm from the model's: the model is wrong, as on a real table. Closed loop: every
/// control step a proportional controller on the measured rate towards a random target fires
/// the thrusters whose yaw torque has the wanted sign for a pulse proportional to the error.
/// `central`: the recorded rate is the attitude central-differenced, `(a_(k+1) - a_(k-1)) /
/// 2 dt`, plus the same white rate noise (the controller still acts on the backward
/// difference, the rate it has at the time; every random draw is the same as without).
fn planar_mocap(
    step_ms: u64,
    control_ms: u64,
    closed_loop: bool,
    central: bool,
    seed: u64,
) -> Simulated {
    let model = airbearing_model();
    let izz = 0.36;
    let dc = [6e-3, -4e-3];
    let n = model.n_thrusters();
    let yaw_torque = |i: usize| {
        let p = model.pos_m(i) - model.com_m();
        let f = model.force_n(i);
        (p.x - dc[0]) * f.y - (p.y - dc[1]) * f.x
    };
    let model_yaw = |i: usize| model.torque_nm(i).z;
    let mut rng = Lcg(seed.wrapping_mul(0x9E3779B97F4A7C15) ^ 0x1234_5678);
    let seconds = 90u64;
    let total = seconds * 1000;
    let (mut omega, mut angle) = (0.0f64, 0.0f64);
    let mut word = 0u16;
    let mut target = 0.0;
    let mut meas_angle_prev: Option<f64> = None;
    let (mut time_s, mut rate, mut commands) = (Vec::new(), Vec::new(), Vec::new());
    let mut last_meas = 0.0;
    let (mut angles, mut whites) = (Vec::new(), Vec::new());
    for t in 0..total {
        if t % step_ms == 0 {
            let meas_angle = angle + MOCAP_ANGLE_RAD * rng.normal();
            let r = match meas_angle_prev {
                Some(prev) => {
                    let white = MOCAP_WHITE_RAD_S * rng.normal();
                    whites.push(white);
                    (meas_angle - prev) / (step_ms as f64 * 1e-3) + white
                }
                None => {
                    whites.push(f64::NAN);
                    f64::NAN
                }
            };
            angles.push(meas_angle);
            meas_angle_prev = Some(meas_angle);
            if r.is_finite() {
                last_meas = r;
            }
            if t % control_ms == 0 {
                if closed_loop {
                    if t % 3000 == 0 {
                        target = 0.3 * (2.0 * rng.uniform() - 1.0);
                    }
                    // Torque wanted to remove the error within two control steps.
                    let want = 0.3237 * (target - last_meas) / (2.0 * control_ms as f64 * 1e-3);
                    let sign = want.signum();
                    let candidates: Vec<usize> =
                        (0..n).filter(|&i| model_yaw(i) * sign > 0.0).collect();
                    let per = candidates.iter().map(|&i| model_yaw(i).abs()).sum::<f64>()
                        / candidates.len().max(1) as f64;
                    let k = ((want.abs() / per.max(1e-9)).round() as usize).min(candidates.len());
                    word = candidates.iter().take(k).fold(0u16, |w, &i| w | (1 << i));
                } else {
                    word = (0..n)
                        .filter(|_| rng.uniform() < 0.25)
                        .fold(0u16, |w, i| w | (1 << i));
                }
            }
            time_s.push(t as f64 * 1e-3);
            rate.push([f64::NAN, f64::NAN, r]);
            commands.push(Command::Word(word));
        }
        // Exact 1 ms step: constant torque.
        let f = model.thrusts_for_word(word);
        let tau: f64 = (0..n)
            .filter(|&i| f[i] > 0.0)
            .map(|i| yaw_torque(i) * f[i] / model.thrust_n[i])
            .sum();
        let a = tau / izz;
        angle += omega * 1e-3 + 0.5 * a * 1e-6;
        omega += a * 1e-3;
    }
    if central {
        let dt = step_ms as f64 * 1e-3;
        for (k, r) in rate.iter_mut().enumerate() {
            r[2] = match (
                k.checked_sub(1).and_then(|b| angles.get(b)),
                angles.get(k + 1),
            ) {
                (Some(before), Some(after)) => (after - before) / (2.0 * dt) + whites[k],
                _ => f64::NAN,
            };
        }
    }
    let mut truth = [f64::NAN; 9];
    truth[0] = (dc[0]) * 1e3;
    truth[1] = (dc[1]) * 1e3;
    truth[5] = izz;
    Simulated {
        flight: Flight {
            time_s,
            rate: rate.into(),
            axes: [false, false, true],
            commands: commands.into(),
            period_s: step_ms as f64 * 1e-3,
            from_gyro_counts: false,
        },
        model,
        truth,
    }
}

/// Scores of one term over a cell's flights.
#[derive(Clone, Copy, Debug, Default)]
pub struct Score {
    pub n: u32,
    pub in1: u32,
    pub in2: u32,
    pub z_sum: f64,
    pub z_sq: f64,
    pub err_sq: f64,
}

impl Score {
    pub fn add(&mut self, err: f64, sigma: f64) {
        let z = err / sigma;
        if !z.is_finite() {
            return;
        }
        self.n += 1;
        self.in1 += (z.abs() <= 1.0) as u32;
        self.in2 += (z.abs() <= 2.0) as u32;
        self.z_sum += z;
        self.z_sq += z * z;
        self.err_sq += err * err;
    }
    pub fn bias(&self) -> f64 {
        self.z_sum / self.n.max(1) as f64
    }
    pub fn rms(&self) -> f64 {
        (self.z_sq / self.n.max(1) as f64).sqrt()
    }
    pub fn cover1(&self) -> f64 {
        100.0 * self.in1 as f64 / self.n.max(1) as f64
    }
    pub fn cover2(&self) -> f64 {
        100.0 * self.in2 as f64 / self.n.max(1) as f64
    }
}

/// Each scored term of an estimate (one the flight shows and the estimator determined):
/// index into [`TERMS`], error against the truth, reported sigma.
pub fn scored_errors(sim: &Simulated, e: &FlightEstimate) -> Vec<(usize, f64, f64)> {
    (0..9)
        .filter(|&t| !(sim.truth[t].is_nan() || e.unobservable.contains(&TERMS[t])))
        .map(|t| {
            let (v, s) = if t < 3 {
                (e.com_offset_mm[t], e.com_offset_stderr_mm[t])
            } else {
                (e.inertia_kgm2[t - 3], e.inertia_stderr_kgm2[t - 3])
            };
            (t, v - sim.truth[t], s)
        })
        .collect()
}

/// A cell's outcome.
#[derive(Clone, Debug, Default)]
pub struct Cell {
    pub flights: u32,
    pub ok: u32,
    /// Flights the estimator flagged (inconsistent, implausible, no response): not scored,
    /// since it does not vouch for them.
    pub flagged: u32,
    pub failed: u32,
    pub terms: [Score; 9],
    pub statuses: Vec<String>,
}

impl Cell {
    pub fn add(&mut self, sim: &Simulated, est: &Result<FlightEstimate, String>) {
        self.flights += 1;
        let e = match est {
            Ok(e) => e,
            Err(why) => {
                self.failed += 1;
                self.statuses.push(why.clone());
                return;
            }
        };
        if e.status == "ok" {
            self.ok += 1;
        } else {
            self.statuses.push(e.status.to_string());
        }
        // An estimate whose consistency could not be tested still states its sigmas: scored.
        if !matches!(
            e.status,
            "ok" | "unobservable_terms" | "consistency_untested"
        ) {
            self.flagged += 1;
            return;
        }
        for (t, err, sigma) in scored_errors(sim, e) {
            self.terms[t].add(err, sigma);
        }
    }

    /// The worst term on each criterion: (max |bias|, min RMS, max RMS, min 1-sigma, max
    /// 1-sigma, min 2-sigma, max 2-sigma).
    pub fn worst(&self) -> [f64; 7] {
        let scored: Vec<&Score> = self.terms.iter().filter(|s| s.n > 0).collect();
        let f = |g: &dyn Fn(&Score) -> f64, max: bool| {
            scored.iter().map(|s| g(s)).fold(
                if max {
                    f64::NEG_INFINITY
                } else {
                    f64::INFINITY
                },
                |a, b| if max { a.max(b) } else { a.min(b) },
            )
        };
        [
            f(&|s| s.bias().abs(), true),
            f(&|s| s.rms(), false),
            f(&|s| s.rms(), true),
            f(&|s| s.cover1(), false),
            f(&|s| s.cover1(), true),
            f(&|s| s.cover2(), false),
            f(&|s| s.cover2(), true),
        ]
    }
}

/// Runs `flights` flights of `cond` from seed `seed0` through the f64 identification.
pub fn run_cell(cond: &Condition, flights: u64, seed0: u64, opts: &Options) -> Cell {
    run_cell_with(cond, flights, seed0, opts, |_| {})
}

/// Which implementation identifies the flights.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Implementation {
    /// `reference_f64::flight_id`.
    F64,
    /// The onboard kernel's `flight_id` in f32.
    F32,
    /// The onboard kernel's `flight_id` in the fixed kernel's integer floating point
    /// (`massid_kernel::IntFloat`).
    Fixed,
    /// The onboard kernel's `flight_id` in f64 (its algorithm without f32 rounding).
    KernelF64,
}

impl Implementation {
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "f64" => Some(Implementation::F64),
            "f32" => Some(Implementation::F32),
            "fixed" => Some(Implementation::Fixed),
            "kernel-f64" => Some(Implementation::KernelF64),
            _ => None,
        }
    }
}

/// One flight's estimate by `imp`. The kernels are told the rate sensor's response the
/// reference chose for a flight without gyro counts (a point sample for gyro counts).
pub fn estimate_with(
    imp: Implementation,
    sim: &Simulated,
    opts: &Options,
) -> Result<FlightEstimate, String> {
    let response = || {
        if sim.flight.from_gyro_counts {
            Ok(None)
        } else {
            identify(&sim.flight, &sim.model, opts)
                .map(|e| Some(e.sensor))
                .map_err(|e| e.to_string())
        }
    };
    match imp {
        Implementation::F64 => identify(&sim.flight, &sim.model, opts).map_err(|e| e.to_string()),
        Implementation::F32 => massid_kernel_host::flight_id::identify::<f32>(
            &sim.flight,
            &sim.model,
            response()?,
            opts.latency_ms,
        )
        .map_err(|e| e.to_string()),
        Implementation::KernelF64 => massid_kernel_host::flight_id::identify::<f64>(
            &sim.flight,
            &sim.model,
            response()?,
            opts.latency_ms,
        )
        .map_err(|e| e.to_string()),
        Implementation::Fixed => {
            massid_kernel_host::flight_id::identify::<massid_kernel::IntFloat>(
                &sim.flight,
                &sim.model,
                response()?,
                opts.latency_ms,
            )
            .map_err(|e| e.to_string())
        }
    }
}

/// [`run_cell`] by any implementation.
pub fn run_cell_by(
    cond: &Condition,
    flights: u64,
    seed0: u64,
    opts: &Options,
    imp: Implementation,
) -> Cell {
    let mut cell = Cell::default();
    for seed in seed0..seed0 + flights {
        let sim = fly(cond, seed);
        cell.add(&sim, &estimate_with(imp, &sim, opts));
    }
    cell
}

/// [`run_cell`] with `fault` applied to every estimate before it is scored (the tests plant
/// faults this way to show each check can fail).
pub fn run_cell_with(
    cond: &Condition,
    flights: u64,
    seed0: u64,
    opts: &Options,
    fault: impl Fn(&mut FlightEstimate),
) -> Cell {
    let mut cell = Cell::default();
    for seed in seed0..seed0 + flights {
        let sim = fly(cond, seed);
        let est = identify(&sim.flight, &sim.model, opts)
            .map(|mut e| {
                fault(&mut e);
                e
            })
            .map_err(|e| e.to_string());
        cell.add(&sim, &est);
    }
    cell
}

/// The bars a cell of `n` flights must meet when the sigmas are right, wide enough that a
/// calibrated estimator fails them by chance about once in a thousand terms: |mean z| <= 3.3 /
/// sqrt(n), RMS z within the chi-square 0.05 %-99.95 % range, and every flight estimated.
pub fn small_sample_check(c: &Cell) -> Result<(), String> {
    if c.failed > 0 {
        return Err(format!(
            "{} of {} flights not estimated: {:?}",
            c.failed, c.flights, c.statuses
        ));
    }
    for (name, s) in TERMS.iter().zip(&c.terms) {
        if s.n == 0 {
            continue;
        }
        let n = s.n as f64;
        let bias_bar = 3.3 / n.sqrt();
        // Wilson-Hilferty quantiles of chi-square(n)/n at 0.05 % and 99.95 %.
        let q = |z: f64| (1.0 - 2.0 / (9.0 * n) + z * (2.0 / (9.0 * n)).sqrt()).powi(3);
        let (lo, hi) = (q(-3.29).sqrt(), q(3.29).sqrt());
        if !(lo..=hi).contains(&s.rms()) {
            return Err(format!(
                "{name}: RMS error/sigma {:.2} outside [{lo:.2}, {hi:.2}] over {} flights",
                s.rms(),
                s.n
            ));
        }
        if s.bias().abs() > bias_bar {
            return Err(format!(
                "{name}: bias {:+.2} sigma over {} flights (bar {bias_bar:.2})",
                s.bias(),
                s.n
            ));
        }
    }
    Ok(())
}

/// The grid: every maneuver x 50/100/250/500/1000 Hz x 1x/4x gyro noise on SPH2, plus
/// the planar craft with motion-capture rates (25 and 50 Hz, open and closed loop).
pub fn grid() -> Vec<Condition> {
    let mut out = Vec::new();
    for m in [
        Maneuver::Rga12,
        Maneuver::Single,
        Maneuver::Combo,
        Maneuver::RandomPwm,
        Maneuver::ClosedLoop,
    ] {
        for rate_hz in [50.0, 100.0, 250.0, 500.0, 1000.0] {
            for noise in [1.0, 4.0] {
                out.push(Condition::Spheres {
                    maneuver: m,
                    rate_hz,
                    noise,
                });
            }
        }
    }
    for (step_ms, control_ms) in [(40, 80), (20, 60)] {
        for closed_loop in [false, true] {
            out.push(Condition::PlanarMocap {
                step_ms,
                control_ms,
                closed_loop,
            });
        }
    }
    out
}

/// Motion capture central-differenced (the sensor of `open3`'s pl6): the planar cells of
/// [`grid`] with the rate `(a_(k+1) - a_(k-1)) / 2 dt`.
pub fn mocap_central_grid() -> Vec<Condition> {
    grid()
        .into_iter()
        .filter_map(|c| match c {
            Condition::PlanarMocap {
                step_ms,
                control_ms,
                closed_loop,
            } => Some(Condition::PlanarMocapCentral {
                step_ms,
                control_ms,
                closed_loop,
            }),
            _ => None,
        })
        .collect()
}

/// Other craft with a gyro (issue 22 item 2, 23): the 8-thruster cubesat and the 16-thruster
/// free-flyer (3-D) and the air-bearing craft (planar), x single/combo/random-pwm x 100 and
/// 1000 Hz.
pub fn craft_grid() -> Vec<Condition> {
    let mut out = Vec::new();
    for model in ["cubesat8", "freeflyer16", "airbearing-mpc"] {
        for maneuver in [Maneuver::Single, Maneuver::Combo, Maneuver::RandomPwm] {
            for rate_hz in [100.0, 1000.0] {
                out.push(Condition::Craft {
                    model,
                    maneuver,
                    rate_hz,
                });
            }
        }
    }
    out
}

/// Craft nobody developed on (`random_craft`): 3-D with few (1-4), some (5-8) and many (9-16)
/// thrusters, planar with a gyro and with motion-capture rates.
pub fn random_craft_grid() -> Vec<Condition> {
    let class = |planar, thrusters, mocap| {
        Condition::RandomCraft(CraftClass {
            planar,
            thrusters,
            mocap,
        })
    };
    vec![
        class(false, (1, 4), false),
        class(false, (5, 8), false),
        class(false, (9, 16), false),
        class(true, (1, 16), false),
        class(true, (1, 16), true),
    ]
}

/// Whether a cell meets the bars: |bias| <= 0.3 sigma, RMS error/sigma in
/// [0.8, 1.25], 1-sigma coverage in [60, 76] %, 2-sigma in [90, 98] %, for every scored term.
pub fn meets_bars(c: &Cell) -> bool {
    let [b, rlo, rhi, c1lo, c1hi, c2lo, c2hi] = c.worst();
    c.failed == 0
        && c.terms.iter().any(|s| s.n > 0)
        && b <= 0.3
        && rlo >= 0.8
        && rhi <= 1.25
        && c1lo >= 60.0
        && c1hi <= 76.0
        && c2lo >= 90.0
        && c2hi <= 98.0
}

/// One markdown row per cell.
pub fn markdown_row(cond: &Condition, c: &Cell) -> String {
    let [b, rlo, rhi, c1lo, c1hi, c2lo, c2hi] = c.worst();
    format!(
        "| {} | {} | {:.0} | {:.0} | {:.2} | {:.2}-{:.2} | {:.0}-{:.0} | {:.0}-{:.0} | {} |",
        cond.label(),
        c.flights,
        100.0 * c.ok as f64 / c.flights.max(1) as f64,
        100.0 * c.flagged as f64 / c.flights.max(1) as f64,
        b,
        rlo,
        rhi,
        c1lo,
        c1hi,
        c2lo,
        c2hi,
        if meets_bars(c) { "yes" } else { "**no**" }
    )
}

pub const MARKDOWN_HEADER: &str = "| condition | flights | ok % | flagged % | worst abs bias (sigma) | RMS err/sigma | 1-sigma % | 2-sigma % | bars met |\n|---|---|---|---|---|---|---|---|---|";
