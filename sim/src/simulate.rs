//! The full simulation: maneuver -> 6-DOF plant with effects -> sensors -> recording + truth.
//! Deterministic: the same spec and seed give the same bytes (ChaCha8 streams, fixed order).
//! A craft whose rates v1 cannot hold (see [`needs_v2`]) is also recorded in format v2.
use crate::dynamics::{Plant, State};
use crate::effects::{DelayLine, Effect, PlantConfig, Truth};
use crate::maneuvers;
use crate::predict::RingingStream;
use crate::propagate::{Propagator, StepOptions};
use crate::sensors::{accel_noise, quantise, Artefacts, GyroNoise, SensorConfig};
use nalgebra::{UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use reference_f64::mixer::Mixer;
use reference_f64::rate_recording::{Commands, RateRecording};
use reference_f64::recording::{Recording, Sample};
use reference_f64::satellite::Satellite;
use std::io::Write;

/// Which commands to fly.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Maneuver {
    Rga12,
    Single,
    Combo,
    RandomPwm,
    /// Rate commands about each axis through the PWM mixer, then attitude hold.
    ClosedLoop,
}

impl Maneuver {
    pub const NAMES: [&'static str; 5] = ["rga12", "single", "combo", "random-pwm", "closed-loop"];
    /// The maneuvers built from any craft's own thrusters ([`maneuvers::Layout`]); the
    /// others fly the SPHERES layout.
    pub const ANY_CRAFT: [&'static str; 3] = ["single", "combo", "random-pwm"];

    /// Whether the script needs the SPHERES thruster layout (the RGA pairs, the PWM mixer).
    pub fn spheres_only(&self) -> bool {
        matches!(self, Maneuver::Rga12 | Maneuver::ClosedLoop)
    }

    pub fn parse(s: &str) -> Option<Maneuver> {
        Some(match s {
            "rga12" => Maneuver::Rga12,
            "single" => Maneuver::Single,
            "combo" => Maneuver::Combo,
            "random-pwm" | "random_pwm" => Maneuver::RandomPwm,
            "closed-loop" | "closed_loop" => Maneuver::ClosedLoop,
            _ => return None,
        })
    }

    pub fn name(&self) -> &'static str {
        match self {
            Maneuver::Rga12 => "rga12",
            Maneuver::Single => "single",
            Maneuver::Combo => "combo",
            Maneuver::RandomPwm => "random-pwm",
            Maneuver::ClosedLoop => "closed-loop",
        }
    }

    /// Default length, s (rga12 and single have a fixed script length).
    pub fn default_seconds(&self) -> f64 {
        match self {
            Maneuver::Rga12 => 28.0,
            Maneuver::Single => 25.0,
            Maneuver::Combo | Maneuver::RandomPwm => 40.0,
            Maneuver::ClosedLoop => 30.0,
        }
    }
}

/// Everything a simulation needs.
#[derive(Clone, Debug)]
pub struct SimSpec {
    pub satellite: Satellite,
    pub effects: Vec<Effect>,
    pub sensors: SensorConfig,
    pub artefacts: Artefacts,
    pub maneuver: Maneuver,
    /// Recording sample rate, Hz; must divide 1000 (1000, 500, 100, 50, ...).
    pub rate_hz: f64,
    /// Length, s: firing time for combo / random-pwm / closed-loop; rga12 and single are
    /// truncated to it when shorter.
    pub seconds: Option<f64>,
    pub seed: u64,
    /// Largest RK4 step, ms.
    pub max_step_ms: f64,
    pub initial_rate: [f64; 3],
}

impl SimSpec {
    /// Defaults: 1 kHz, the maneuver's own length, seed 0, 1 ms steps, at rest.
    pub fn new(satellite: Satellite, effects: Vec<Effect>, maneuver: Maneuver) -> Self {
        SimSpec {
            satellite,
            effects,
            sensors: SensorConfig::default(),
            artefacts: Artefacts::default(),
            maneuver,
            rate_hz: 1000.0,
            seconds: None,
            seed: 0,
            max_step_ms: 1.0,
            initial_rate: [0.0; 3],
        }
    }
}

/// Why a simulation cannot run.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    #[error("sample rate {0} Hz: must be a divisor of 1000 (e.g. 1000, 100, 50)")]
    BadRate(f64),
    #[error("length {0} s: must be positive and at most 86400 s")]
    BadSeconds(f64),
    #[error("effect {0}")]
    BadEffect(String),
    #[error("satellite model: {0}")]
    BadSatellite(String),
    #[error("closed loop: mixer: {0}")]
    Mixer(String),
    #[error(
        "satellite {satellite} is a {kind} craft with {n} thrusters; the {maneuver} script flies the SPHERES layout (12 thrusters in six opposing pairs, 3-D); maneuvers built from this craft's own thrusters: {}",
        Maneuver::ANY_CRAFT.join(", ")
    )]
    SpheresOnly {
        satellite: String,
        kind: &'static str,
        n: usize,
        maneuver: &'static str,
    },
    /// Writing a streamed recording failed ([`simulate_to`]).
    #[error("{0}")]
    Write(#[from] std::io::Error),
    #[error(
        "a largest integration step of {step_ms:e} ms over {span_ms} ms of flight is {steps:.3e} steps; at most {max:.0e} are run (a step of at least {min_step_ms:.3e} ms for this length)",
        max = MAX_STEPS
    )]
    TooManySteps {
        step_ms: f64,
        span_ms: f64,
        steps: f64,
        min_step_ms: f64,
    },
}

/// Most integration steps one simulation runs (about 10 s of work here); bounds the work by
/// the recording's length, not by the step a user types.
pub const MAX_STEPS: f64 = 1e8;

/// A finished simulation.
#[derive(Clone, Debug)]
pub struct SimOutput {
    /// Format v1 (gyro counts, a 12-bit word): meaningful for a craft whose gyro gives counts.
    pub recording: Recording,
    /// Format v2 (rates in rad/s on the craft's axes; rows as in `recording`, re-sent rows
    /// included): present when the craft [`needs_v2`], and then the recording to write.
    pub rate_recording: Option<RateRecording>,
    pub truth: Truth,
    /// Commanded word per millisecond from t = 0.
    pub commands: Vec<u16>,
    /// True body rate at every recorded sample (before artefacts), rad/s.
    pub body_rate: Vec<[f64; 3]>,
    /// Final attitude and CoM position/velocity (inertial).
    pub final_state: State,
}

/// ChaCha stream numbers: one per random purpose, so adding one never shifts another.
const STREAM_MANEUVER: u64 = 1;
const STREAM_GYRO: u64 = 2;
const STREAM_ACCEL: u64 = 3;
const STREAM_RINGING: u64 = 4;
const STREAM_ARTEFACTS: u64 = 5;
const STREAM_CONTROLLER: u64 = 6;

fn rng(seed: u64, stream: u64) -> ChaCha8Rng {
    let mut r = ChaCha8Rng::seed_from_u64(seed);
    r.set_stream(stream);
    r
}

/// Whether a craft's recording must be format v2: v1 holds a 3-D rate in 12-bit counts and
/// a 12-thruster word, so a planar craft, another thruster count, or a rate sensor that
/// gives rad/s (under 10 counts per rad/s: every rate would quantise to a few counts) does
/// not fit it.
pub fn needs_v2(sat: &Satellite) -> bool {
    sat.planar
        || sat.n_thrusters() != reference_f64::satellite::N_THRUSTERS
        || sat.gyro_counts_per_rad_s.iter().any(|k| k.abs() < 10.0)
}

/// One simulated sample, as the simulator hands it over (before telemetry artefacts).
#[derive(Clone, Copy, Debug, PartialEq)]
struct SimSample {
    /// The format v1 row (gyro and accelerometer counts, the commanded word).
    row: Sample,
    /// The sensed rate in rad/s on the craft's axes, as a format v2 row holds it (a gyro
    /// bias effect in the sensor's units included).
    rate_rad_s: [f64; 3],
    /// True body rate (before artefacts), rad/s.
    body_rate: [f64; 3],
}

/// Where a running simulation's output goes, as it is produced.
trait Sink {
    /// The word commanded over the next millisecond (every millisecond from t = 0).
    fn command(&mut self, _word: u16) {}
    /// The next sample, and how many times the recording holds it (telemetry artefacts: 0
    /// for a row lost in a gap, 2 or more for a re-sent one).
    fn sample(&mut self, s: &SimSample, copies: usize) -> Result<(), SimError>;
}

/// A sink that keeps nothing (the pass that counts the shocks).
struct Discard;

impl Sink for Discard {
    fn sample(&mut self, _: &SimSample, _: usize) -> Result<(), SimError> {
        Ok(())
    }
}

/// A spec checked and turned into what the flight loop needs.
struct Prepared {
    plant: Plant,
    period_ms: usize,
    open_loop: Option<Vec<u16>>,
    total_ms: usize,
}

fn prepare(spec: &SimSpec) -> Result<Prepared, SimError> {
    let period_ms = 1000.0 / spec.rate_hz;
    if !(spec.rate_hz.is_finite()
        && spec.rate_hz > 0.0
        && period_ms >= 1.0
        && (period_ms - period_ms.round()).abs() < 1e-9)
    {
        return Err(SimError::BadRate(spec.rate_hz));
    }
    let period_ms = period_ms.round() as usize;
    if let Some(s) = spec.seconds {
        if !(s.is_finite() && s > 0.0 && s <= 86_400.0) {
            return Err(SimError::BadSeconds(s));
        }
    }
    spec.satellite.validate().map_err(SimError::BadSatellite)?;
    for e in &spec.effects {
        e.validate().map_err(SimError::BadEffect)?;
    }
    let sat = &spec.satellite;
    if spec.maneuver.spheres_only() && !maneuvers::Layout::is_spheres(sat) {
        return Err(SimError::SpheresOnly {
            satellite: sat.name.clone(),
            kind: if sat.planar { "planar" } else { "3-D" },
            n: sat.n_thrusters(),
            maneuver: spec.maneuver.name(),
        });
    }
    let plant = Plant::new(sat, PlantConfig::new(sat, &spec.effects));
    let seconds = spec.seconds.unwrap_or(spec.maneuver.default_seconds());

    let layout = maneuvers::Layout::of(sat);
    let mut maneuver_rng = rng(spec.seed, STREAM_MANEUVER);
    let open_loop: Option<Vec<u16>> = match spec.maneuver {
        Maneuver::Rga12 => Some(maneuvers::rga12()),
        Maneuver::Single => Some(maneuvers::single_for(&layout)),
        Maneuver::Combo => Some(maneuvers::combo_for(&layout, seconds, &mut maneuver_rng)),
        Maneuver::RandomPwm => Some(maneuvers::random_pwm_for(
            &layout,
            seconds,
            &mut maneuver_rng,
        )),
        Maneuver::ClosedLoop => None,
    };
    let total_ms = match (&open_loop, spec.maneuver) {
        (Some(w), Maneuver::Rga12 | Maneuver::Single) => match spec.seconds {
            Some(s) => ((s * 1000.0).round() as usize).min(w.len()),
            None => w.len(),
        },
        (Some(w), _) => w.len(),
        (None, _) => (seconds * 1000.0).round() as usize,
    };
    // The flight lasts the script plus its coast; bound the steps before any work.
    let span_ms = total_ms as f64 + 2000.0;
    let steps = span_ms / spec.max_step_ms;
    if !(spec.max_step_ms.is_finite() && spec.max_step_ms > 0.0 && steps <= MAX_STEPS) {
        return Err(SimError::TooManySteps {
            step_ms: spec.max_step_ms,
            span_ms,
            steps,
            min_step_ms: span_ms / MAX_STEPS,
        });
    }
    if spec.maneuver == Maneuver::ClosedLoop {
        // the mixer's error now, before anything is written
        Controller::new(sat, total_ms)?;
    }
    Ok(Prepared {
        plant,
        period_ms,
        open_loop,
        total_ms,
    })
}

/// What the flight loop leaves besides its samples.
struct Flown {
    final_state: State,
    /// Distinct valve-edge instants that reached a sample (each drew 3 ringing phases per
    /// ringing effect).
    shocks: usize,
}

/// Flies the prepared spec, handing each millisecond's command and each sample to `sink`
/// as they are made; nothing grows with the flight's length but the sink. With several
/// ringing effects the phases of ringing `ri` are the random stream's draws after those of
/// the `ri` before it, `3 x shocks` each (the order of the whole-flight computation):
/// `shocks` must then be the count a first pass returned.
fn fly(
    spec: &SimSpec,
    prep: &Prepared,
    sink: &mut impl Sink,
    shocks: Option<usize>,
) -> Result<Flown, SimError> {
    let sat = &spec.satellite;
    let plant = &prep.plant;
    let (period_ms, total_ms) = (prep.period_ms, prep.total_ms);
    let open_loop = &prep.open_loop;
    let mut controller = match spec.maneuver {
        Maneuver::ClosedLoop => Some(Controller::new(sat, total_ms)?),
        _ => None,
    };

    let mut gyro_rng = rng(spec.seed, STREAM_GYRO);
    let mut accel_rng = rng(spec.seed, STREAM_ACCEL);
    let mut ctrl_rng = rng(spec.seed, STREAM_CONTROLLER);
    let mut gyro_noise = GyroNoise::new(&spec.sensors);
    let mut ctrl_noise = GyroNoise::new(&spec.sensors);
    let r_acc = Vector3::from(spec.sensors.accel_location_m);
    let c = &plant.cfg;
    // Ringing at the sample instants with a random phase per shock and axis, one stream
    // position per ringing effect (see above).
    let mut ring_rngs: Vec<ChaCha8Rng> = (0..c.ringing.len())
        .map(|ri| {
            let mut r = rng(spec.seed, STREAM_RINGING);
            for _ in 0..3 * ri * shocks.unwrap_or(0) {
                let _: f64 = r.gen_range(0.0..std::f64::consts::TAU);
            }
            r
        })
        .collect();
    let mut ringing = RingingStream::new(c);
    let mut last_edge: Option<f64> = None;
    let mut edge_batch: Vec<f64> = Vec::new();
    // Telemetry artefacts: which rows are lost or re-sent, drawn before the flight from the
    // number of samples (the same draws as on the whole recording).
    let mut art_rng = rng(spec.seed, STREAM_ARTEFACTS);
    let mut copies = spec
        .artefacts
        .plan(total_ms.div_ceil(period_ms), &mut art_rng);

    let mut prop = Propagator::new(
        plant,
        State::with_rates(spec.initial_rate),
        0.0,
        StepOptions {
            max_step_ms: spec.max_step_ms,
            full: true,
        },
    );
    let mut word = 0u16;
    // A v2 row's command holds until the next row, so a v2 craft's commands change only at
    // sample instants: its file then says exactly what was flown (a 1 ms pulse edge between
    // two rows would read as up to a sample period of valve latency).
    let hold = needs_v2(sat);
    let mut delay = DelayLine::new(c.measurement_delay_ms);
    let mut k = 0usize;
    for t in 0..total_ms {
        prop.advance_to(t as f64);
        // what the rate sensor sees now (the body rate a measurement delay ago)
        let seen = delay.push(prop.state().w.into());
        let is_sample = t % period_ms == 0;
        let noise = if is_sample {
            Some(gyro_noise.sample(t as f64, &mut gyro_rng))
        } else {
            None
        };
        if let Some(ctl) = controller.as_mut() {
            if t % maneuvers::PERIOD_MS == 0 {
                // The controller reads the same gyro as the recording (converted with the
                // nominal bias and scale, so gyro bias/scale effects fool it like in flight).
                let n = noise.unwrap_or_else(|| ctrl_noise.sample(t as f64, &mut ctrl_rng));
                let x = prop.state();
                let sensed = Vector3::from(std::array::from_fn::<f64, 3, _>(|a| {
                    c.gyro_scale[a] * (seen[a] + n[a])
                        + c.gyro_bias_counts[a] / sat.gyro_counts_per_rad_s[a]
                }));
                ctl.plan(t, &sensed, &x.attitude())?;
            }
            if is_sample || !hold {
                word = ctl.word_at(t);
            }
        } else if let Some(w) = open_loop {
            if is_sample || !hold {
                word = w[t];
            }
        }
        prop.command(word);
        sink.command(word);
        if let Some(n) = noise {
            let d = prop.derivative_now();
            // The valve edges so far, as shocks: every edge up to now (t) is in, and every
            // later one is later than each of these, so sorting each batch sorts them all.
            edge_batch.clear();
            edge_batch.extend(prop.take_edges().map(|e| e.t_ms));
            edge_batch.sort_by(f64::total_cmp);
            for &te in &edge_batch {
                if last_edge.is_some_and(|l| (te - l).abs() < 1e-9) {
                    continue;
                }
                last_edge = Some(te);
                // the sensor sees the ringing as late as the rate (a measurement delay)
                ringing.push_shock(te + c.measurement_delay_ms);
            }
            let ring = ringing.at(t as u64, |ri, _, _| {
                ring_rngs[ri].gen_range(0.0..std::f64::consts::TAU)
            });
            let x = prop.state();
            // Specific force at the accelerometer: thrust / m + w_dot x r + w x (w x r).
            let f = d.specific_force + d.w_dot.cross(&r_acc) + x.w.cross(&x.w.cross(&r_acc));
            let accel: [f64; 3] = f.into();
            let sensed: [f64; 3] =
                std::array::from_fn(|a| c.gyro_scale[a] * (seen[a] + ring[a] + n[a]));
            // What a rad/s sensor reports: a gyro bias effect (counts) in the sensor's units.
            let rate_rad_s = std::array::from_fn::<f64, 3, _>(|a| {
                sensed[a] + c.gyro_bias_counts[a] / sat.gyro_counts_per_rad_s[a]
            });
            let gyro: [u16; 3] = std::array::from_fn(|a| {
                let bias = sat.gyro_bias_counts[a] + c.gyro_bias_counts[a];
                quantise(bias + sensed[a] * sat.gyro_counts_per_rad_s[a])
            });
            let an = accel_noise(&spec.sensors, &mut accel_rng);
            let acc: [u16; 3] = std::array::from_fn(|a| {
                quantise(sat.accel_bias_counts[a] + (accel[a] + an[a]) / sat.accel_m_s2_per_count)
            });
            let s = SimSample {
                row: Sample {
                    time_ms: t as u64,
                    gyro,
                    accel: acc,
                    thrusters: word,
                },
                rate_rad_s,
                body_rate: x.w.into(),
            };
            sink.sample(&s, copies.next(k))?;
            k += 1;
        }
    }
    prop.advance_to(total_ms as f64);
    Ok(Flown {
        final_state: *prop.state(),
        shocks: ringing.shocks_reached(),
    })
}

/// Flies with a second pass when the ringing phases need the first's shock count.
fn fly_all(spec: &SimSpec, prep: &Prepared, sink: &mut impl Sink) -> Result<Flown, SimError> {
    let shocks = if prep.plant.cfg.ringing.len() > 1 {
        Some(fly(spec, prep, &mut Discard, None)?.shocks)
    } else {
        None
    };
    fly(spec, prep, sink, shocks)
}

/// The v1 recording of `rows` (after the artefacts), with the simulator's metadata.
fn v1_recording(spec: &SimSpec, rows: Vec<Sample>) -> Recording {
    let sat = &spec.satellite;
    let mut recording = if spec.artefacts.gaps > 0 || spec.artefacts.duplicates > 0 {
        // a re-sent row stays in (a reader drops it and counts it in the issues)
        let mut r = Recording::new(
            "massid-sim",
            Some(&sat.name),
            Some(spec.rate_hz),
            rows.clone(),
        );
        r.samples = rows;
        r
    } else {
        Recording::new("massid-sim", Some(&sat.name), Some(spec.rate_hz), rows)
    };
    recording.set_meta("generator", "massid-sim");
    recording.set_meta("maneuver", spec.maneuver.name());
    recording.set_meta("seed", &spec.seed.to_string());
    recording
}

/// Keeps what [`simulate`] returns.
#[derive(Default)]
struct Collect {
    commands: Vec<u16>,
    rows: Vec<Sample>,
    row_rates: Vec<[f64; 3]>,
    body_rate: Vec<[f64; 3]>,
}

impl Sink for Collect {
    fn command(&mut self, word: u16) {
        self.commands.push(word);
    }
    fn sample(&mut self, s: &SimSample, copies: usize) -> Result<(), SimError> {
        self.body_rate.push(s.body_rate);
        for _ in 0..copies {
            self.rows.push(s.row);
            self.row_rates.push(s.rate_rad_s);
        }
        Ok(())
    }
}

/// Runs the simulation, the whole recording in memory; [`simulate_to`] writes the same
/// recording's bytes as it flies, holding none of it.
pub fn simulate(spec: &SimSpec) -> Result<SimOutput, SimError> {
    let prep = prepare(spec)?;
    let mut out = Collect {
        commands: Vec::with_capacity(prep.total_ms),
        ..Collect::default()
    };
    let flown = fly_all(spec, &prep, &mut out)?;
    let sat = &spec.satellite;
    let recording = v1_recording(spec, out.rows);
    let rate_recording = needs_v2(sat).then(|| v2_of(&recording, sat, spec, out.row_rates));
    Ok(SimOutput {
        recording,
        rate_recording,
        truth: Truth {
            satellite: sat.name.clone(),
            effects: spec.effects.clone(),
        },
        commands: out.commands,
        body_rate: out.body_rate,
        final_state: flown.final_state,
    })
}

/// What [`simulate_to`] wrote.
#[derive(Clone, Debug)]
pub struct Streamed {
    /// Rows written (re-sent rows included, rows lost in gaps not).
    pub rows: usize,
    /// `time_ms` of the first and the last row written.
    pub first_ms: Option<u64>,
    pub last_ms: Option<u64>,
    /// Whether the recording is format v2 (the craft [`needs_v2`]), else v1.
    pub v2: bool,
    /// Milliseconds of commands flown (the length of [`SimOutput::commands`]).
    pub commanded_ms: usize,
    pub truth: Truth,
    /// Final attitude and CoM position/velocity (inertial).
    pub final_state: State,
}

/// Writes rows of one format as they come.
struct Writer<W: Write> {
    w: W,
    /// The measured axes of a v2 recording; None for v1.
    v2_axes: Option<[bool; 3]>,
    rows: usize,
    first_ms: Option<u64>,
    last_ms: Option<u64>,
}

impl<W: Write> Sink for Writer<W> {
    fn sample(&mut self, s: &SimSample, copies: usize) -> Result<(), SimError> {
        let r = &s.row;
        for _ in 0..copies {
            match self.v2_axes {
                // as `Recording::write_to` writes a row
                None => writeln!(
                    self.w,
                    "{},{},{},{},{},{},{},{}",
                    r.time_ms,
                    r.gyro[0],
                    r.gyro[1],
                    r.gyro[2],
                    r.accel[0],
                    r.accel[1],
                    r.accel[2],
                    r.thrusters
                )?,
                // as `RateRecording::write_to` writes a row of thruster words
                Some(axes) => {
                    write!(self.w, "{}", r.time_ms)?;
                    for (a, &on) in axes.iter().enumerate() {
                        if on {
                            let v = s.rate_rad_s[a];
                            if v.is_finite() {
                                write!(self.w, ",{v}")?;
                            } else {
                                write!(self.w, ",")?;
                            }
                        }
                    }
                    writeln!(self.w, ",{}", r.thrusters)?;
                }
            }
            self.rows += 1;
            self.first_ms.get_or_insert(r.time_ms);
            self.last_ms = Some(r.time_ms);
        }
        Ok(())
    }
}

/// Runs the simulation and writes its recording (format v2 when the craft [`needs_v2`],
/// else v1) to `w` row by row as the samples are made: the bytes [`simulate`]'s recording
/// writes, in memory that does not grow with the flight's length (the open-loop script, 2
/// bytes a millisecond, aside). Nothing is written before the spec is found good.
pub fn simulate_to<W: Write>(spec: &SimSpec, w: W) -> Result<Streamed, SimError> {
    simulate_into(spec, || Ok(w)).map(|(s, _)| s)
}

/// [`simulate_to`] into a writer opened by `open` once the spec is found good (e.g. a
/// file that a bad spec should not leave behind); gives the writer back, flushed.
pub fn simulate_into<W: Write>(
    spec: &SimSpec,
    open: impl FnOnce() -> std::io::Result<W>,
) -> Result<(Streamed, W), SimError> {
    let prep = prepare(spec)?;
    let sat = &spec.satellite;
    let v2 = needs_v2(sat);
    let mut w = std::io::BufWriter::new(open()?);
    // the header: an empty recording of the same metadata
    let v1 = v1_recording(spec, Vec::new());
    let v2_axes = if v2 {
        let r = v2_of(&v1, sat, spec, Vec::new());
        r.write_to(&mut w)?;
        Some(r.axes)
    } else {
        v1.write_to(&mut w)?;
        None
    };
    let mut writer = Writer {
        w,
        v2_axes,
        rows: 0,
        first_ms: None,
        last_ms: None,
    };
    let flown = fly_all(spec, &prep, &mut writer)?;
    let mut w = writer.w.into_inner().map_err(|e| e.into_error())?;
    w.flush()?;
    Ok((
        Streamed {
            rows: writer.rows,
            first_ms: writer.first_ms,
            last_ms: writer.last_ms,
            v2,
            commanded_ms: prep.total_ms,
            truth: Truth {
                satellite: sat.name.clone(),
                effects: spec.effects.clone(),
            },
            final_state: flown.final_state,
        },
        w,
    ))
}

/// The v2 form of `v1`'s rows (after the artefacts): each row's sensed rate in rad/s on the
/// craft's axes (z alone for a planar craft) and its thruster word, the same metadata.
/// `row_rates` holds each row's sensed rate.
fn v2_of(
    v1: &Recording,
    sat: &Satellite,
    spec: &SimSpec,
    row_rates: Vec<[f64; 3]>,
) -> RateRecording {
    let axes = if sat.planar {
        [false, false, true]
    } else {
        [true; 3]
    };
    let rows = &v1.samples;
    let rate = row_rates
        .into_iter()
        .map(|v| std::array::from_fn(|a| if axes[a] { v[a] } else { f64::NAN }))
        .collect();
    let commands = Commands::Thrusters {
        n: sat.n_thrusters(),
        words: rows.iter().map(|r| r.thrusters).collect(),
    };
    let mut metadata = RateRecording::base_metadata(&sat.name, axes, &commands, Some(spec.rate_hz));
    metadata.extend(
        v1.metadata
            .iter()
            .filter(|(k, _)| !matches!(k.as_str(), "format" | "satellite" | "sample_rate_hz"))
            .cloned(),
    );
    RateRecording {
        source: v1.source.clone(),
        metadata,
        axes,
        time_ms: rows.iter().map(|r| r.time_ms).collect(),
        rate,
        commands,
        issues: v1.issues.clone(),
    }
}

/// The closed-loop maneuver's controller (runs every 200 ms control period, seed 3.3): rate
/// commands about x, y, z in turn (see `target`), then attitude hold on the starting
/// attitude; torque = I * gain * error, through the nominal model's PWM mixer (the
/// controller knows only the nominal satellite, like flight software). It senses the body
/// rate with gyro noise and the attitude exactly (SPHERES' global metrology is not modelled).
struct Controller {
    mixer: Mixer,
    inertia: nalgebra::Matrix3<f64>,
    total_ms: usize,
    firing: Option<(usize, reference_f64::mixer::Firing)>,
}

/// Rate command, rad/s.
const RATE_CMD: f64 = 0.15;

impl Controller {
    fn new(sat: &Satellite, total_ms: usize) -> Result<Self, SimError> {
        let mixer = Mixer::from_satellite(sat, None, maneuvers::PERIOD_MS as u32)
            .map_err(|e| SimError::Mixer(e.to_string()))?;
        Ok(Controller {
            mixer,
            inertia: sat.inertia_matrix(),
            total_ms,
            firing: None,
        })
    }

    /// Rate command at `t` (None = attitude hold): the first 60% of the run is split into
    /// six legs (+x, -x, +y, -y, +z, -z), the rest holds attitude.
    fn target(&self, t: usize) -> Option<Vector3<f64>> {
        let leg_ms = (self.total_ms * 6 / 10 / 6).max(1);
        let leg = t / leg_ms;
        if leg >= 6 {
            return None;
        }
        let mut w = Vector3::zeros();
        w[leg / 2] = if leg % 2 == 0 { RATE_CMD } else { -RATE_CMD };
        Some(w)
    }

    fn plan(
        &mut self,
        t: usize,
        w: &Vector3<f64>,
        q: &UnitQuaternion<f64>,
    ) -> Result<(), SimError> {
        let period_s = maneuvers::PERIOD_MS as f64 * 1e-3;
        let alpha = match self.target(t) {
            // Remove half the rate error per period.
            Some(cmd) => (cmd - w) * (0.5 / period_s),
            // PD on the attitude error (small-angle vector part), ~2 s time constant.
            None => {
                let e = q.quaternion().vector() * (2.0 * q.w.signum());
                -(e * 0.8 + w * 1.6)
            }
        };
        let torque = self.inertia * alpha;
        let firing = self
            .mixer
            .mix(Vector3::zeros(), torque)
            .map_err(|e| SimError::Mixer(e.to_string()))?;
        self.firing = Some((t, firing));
        Ok(())
    }

    fn word_at(&self, t: usize) -> u16 {
        match &self.firing {
            Some((t0, f)) => f.word_at((t - t0) as u32),
            None => 0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::effects::MeasurementDelay;

    /// Replays the closed-loop controller over the rate legs of `out` from the control
    /// instant `from_ms`, feeding it the body rate `lag_ms` before each control instant;
    /// the number of control periods whose commanded words differ from the flight's.
    fn mismatched_periods(
        sat: &Satellite,
        out: &SimOutput,
        from_ms: usize,
        lag_ms: usize,
    ) -> usize {
        let total_ms = out.commands.len();
        let mut ctl = Controller::new(sat, total_ms).unwrap();
        let mut bad = 0;
        let legs_end = total_ms * 6 / 10;
        for t0 in (from_ms..legs_end).step_by(maneuvers::PERIOD_MS) {
            let w = Vector3::from(out.body_rate[t0 - lag_ms]);
            // the rate legs use no attitude
            ctl.plan(t0, &w, &UnitQuaternion::identity()).unwrap();
            let end = (t0 + maneuvers::PERIOD_MS).min(legs_end);
            if (t0..end).any(|t| ctl.word_at(t) != out.commands[t]) {
                bad += 1;
            }
        }
        bad
    }

    /// A closed-loop controller reads the rate sensor, so with a measurement delay it acts
    /// on the body rate that long ago, as flight software behind a slow sensor does: its
    /// commands are those of the nominal controller fed the late rate, and not those it
    /// would give from the current rate (the planted fault).
    #[test]
    fn a_closed_loop_controller_acts_on_the_late_rate() {
        let sat = Satellite::builtin("sph2").unwrap();
        let delay_ms: usize = 300;
        let delay = Effect::MeasurementDelay(MeasurementDelay {
            delay_ms: delay_ms as f64,
        });
        let mut spec = SimSpec::new(sat.clone(), vec![delay], Maneuver::ClosedLoop);
        spec.seconds = Some(12.0);
        spec.sensors.noiseless = true;
        let out = simulate(&spec).unwrap();
        let total_ms = out.commands.len();
        // 1 kHz: sample k is t = k ms
        assert_eq!(out.body_rate.len(), total_ms);
        // the first control instant with a delayed rate in hand
        let start = delay_ms.div_ceil(maneuvers::PERIOD_MS) * maneuvers::PERIOD_MS;
        let periods = (start..total_ms * 6 / 10)
            .step_by(maneuvers::PERIOD_MS)
            .count();
        assert!(periods >= 30);
        assert_eq!(mismatched_periods(&sat, &out, start, delay_ms), 0);
        // the current rate would have commanded other firings in most periods
        let wrong = mismatched_periods(&sat, &out, start, 0);
        assert!(wrong * 2 > periods, "{wrong} of {periods} periods differ");
    }
}
