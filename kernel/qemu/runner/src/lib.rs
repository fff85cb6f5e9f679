//! Runs the kernel, fixed ([`Q8_24`]) then `f32`, over a recorded sequence embedded at build
//! time, and writes its outputs as text lines. The same code runs in the QEMU firmware
//! (output over semihosting) and natively on the host (stdout), so the two outputs can be
//! compared line by line: fixed bit for bit, `f32` within the budget of `massid-qemu-host
//! compare`.
//!
//! Every number is printed as the hex of its raw bits (fixed: the `i32` bits of the Q8.24
//! value, or the integer float's mantissa and exponent words; `f32`: `to_bits`), so the
//! comparison never goes through decimal formatting.
//!
//! Each kernel call of interest is bracketed by [`markers`] so that a QEMU instruction trace
//! can be cut into per-call instruction counts (see `massid-qemu-host count`).
#![no_std]

pub mod crafts;
pub mod markers;
pub mod sequence;

use core::fmt::{self, Write};
use massid_kernel::flight_id::sums::SumScalar;
use massid_kernel::mixer::{Mixer, MixerConfig};
use massid_kernel::model::SPH2;
use massid_kernel::{Estimates, IntFloat, Pipeline, PipelineConfig, Scalar, TickEvent, Q8_24};

use markers::Kind;
use massid_kernel::pipeline::DeferredStage;
use massid_kernel::rls::DetectorConfig;

/// Raw bits of a kernel scalar, for exact printing.
pub trait RawBits: Scalar {
    /// Name printed at the start of each output line.
    const NAME: &'static str;
    /// `true` if the outputs must match the host bit for bit.
    const EXACT: bool;
    /// The value's raw bits.
    fn raw_bits(self) -> u32;
    /// Writes the value's raw bits as one word (` xxxxxxxx`).
    fn write_raw<W: Write>(self, out: &mut W) -> fmt::Result {
        write!(out, " {:08x}", self.raw_bits())
    }
}

impl RawBits for Q8_24 {
    const NAME: &'static str = "fixed";
    const EXACT: bool = true;
    fn raw_bits(self) -> u32 {
        self.0.to_bits() as u32
    }
}

/// The fixed kernel's identification number: mantissa and exponent, `mmmmmmmm:eeeeeeee`.
impl RawBits for IntFloat {
    const NAME: &'static str = "fixed";
    const EXACT: bool = true;
    fn raw_bits(self) -> u32 {
        self.parts().0 as u32
    }
    fn write_raw<W: Write>(self, out: &mut W) -> fmt::Result {
        let (m, e) = self.parts();
        write!(out, " {:08x}:{:08x}", m as u32, e as u32)
    }
}

impl RawBits for f32 {
    const NAME: &'static str = "f32";
    const EXACT: bool = false;
    fn raw_bits(self) -> u32 {
        self.to_bits()
    }
}

/// Whether this core runs the output-error identification: not a 16 kB-RAM Cortex-M0 (the
/// micro:bit), where its state alone (`FlightId<IntFloat>` about 29 kB, `FlightId<f32>`
/// 14.6 kB) does not fit.
pub const RUNS_IDENTIFICATION: bool = !cfg!(all(target_abi = "eabi", target_os = "none"));

/// Runs both kernels over the embedded sequence, writing their outputs to `out` (this core's
/// suite: [`RUNS_IDENTIFICATION`]).
pub fn run_all<W: Write>(out: &mut W) -> fmt::Result {
    run_suite(out, RUNS_IDENTIFICATION)
}

/// [`run_all`] with or without the identification (the host writes both suites, one to
/// compare with each core).
pub fn run_suite<W: Write>(out: &mut W, identification: bool) -> fmt::Result {
    writeln!(
        out,
        "# sequence {} {} {}..{} ms ({} samples)",
        sequence::SOURCE,
        sequence::SATELLITE,
        sequence::START_MS,
        sequence::START_MS as usize + sequence::LEN,
        sequence::LEN
    )?;
    // An empty bracket: the trace counter subtracts its count (the markers' own instructions).
    markers::begin();
    markers::end();
    markers::kind(Kind::Calibration);
    run::<Q8_24, W>(out)?;
    run::<f32, W>(out)?;
    run_craft_mixers::<Q8_24, W>(out)?;
    run_craft_mixers::<f32, W>(out)?;
    if identification {
        // The integer float's result is compared bit for bit; the f32 one is `info` (its
        // fit's rounding is not pinned across cores). The integer float's push is about 25
        // times the f32 one on the M4F, so it runs over the first samples only, and in the
        // count image, whose trace ran at about 0.4 million instructions a second here, over
        // COUNT_INT_FLOAT_SAMPLES: enough for a push's mean and max.
        let (sph2_n, other_n) = if sequence::COUNT_RUN {
            (COUNT_INT_FLOAT_SAMPLES, COUNT_INT_FLOAT_SAMPLES)
        } else {
            (INT_FLOAT_SAMPLES, OTHER_CRAFT_SAMPLES)
        };
        let sph2 = sph2_thrusters();
        run_flight_id::<IntFloat, W>(out, "", &FlightCraft::sph2(&sph2), sph2_n)?;
        run_flight_id::<f32, W>(out, "info ", &FlightCraft::sph2(&sph2), usize::MAX)?;
        for craft in [
            FlightCraft::airbearing(),
            FlightCraft::airbearing_mocap(),
            FlightCraft::freeflyer16(),
        ] {
            run_flight_id::<IntFloat, W>(out, "", &craft, other_n)?;
            run_flight_id::<f32, W>(out, "info ", &craft, OTHER_CRAFT_SAMPLES)?;
        }
    }
    writeln!(out, "# done")
}

/// Runs one kernel over the sequence.
pub fn run<S: RawBits, W: Write>(out: &mut W) -> fmt::Result {
    // The seed's settings plus both options (forgetting, change detector): the most work per
    // firing, so the instruction counts cover every configuration.
    let mut cfg = PipelineConfig::seed(1);
    cfg.rls.forgetting = Some(S::from_f32(0.9999));
    cfg.rls.detector = Some(DetectorConfig::standard());
    let Ok(mut pipeline) = Pipeline::<S>::new(&SPH2, cfg) else {
        return writeln!(out, "{} init-error", S::NAME);
    };
    // Target-dependent (alignment of 64-bit fields): not compared, see `compare`.
    writeln!(
        out,
        "info {} state-bytes {}",
        S::NAME,
        core::mem::size_of::<Pipeline<S>>()
    )?;
    writeln!(
        out,
        "info {} mixer-bytes {}",
        S::NAME,
        core::mem::size_of::<Mixer<S>>()
    )?;
    markers::flavour(S::EXACT);
    let mut prev_word = 0u16;
    let mut firings = 0u32;
    let mut since_edge = u32::MAX;
    for (i, (gyro, word)) in sequence::samples().enumerate() {
        let t = sequence::START_MS as usize + i;
        if word != prev_word && prev_word != 0 {
            // The firing that is ending: its last angular-acceleration estimate.
            if let Some(est) = pipeline.omega_dot() {
                write!(out, "{} t={t} firing={firings} omega_dot", S::NAME)?;
                write_bits(out, &est.omega_dot)?;
                writeln!(out, " updates={}", est.updates)?;
            }
        }
        if word != prev_word && word != 0 {
            firings += 1;
        }
        let stage = pipeline.pending_stage();
        markers::begin();
        let report = pipeline.tick(gyro, word);
        markers::end();
        let rls_active = firings > 2;
        let edge = word != prev_word;
        since_edge = if edge {
            0
        } else {
            since_edge.saturating_add(1)
        };
        markers::kind(match report.event {
            TickEvent::Coasting | TickEvent::Transient if edge => Kind::Edge,
            TickEvent::Coasting | TickEvent::Transient if stage.is_some() => {
                Kind::Stage(stage.unwrap_or(DeferredStage::Measure))
            }
            TickEvent::Coasting | TickEvent::Transient if since_edge <= markers::DEFERRED_TICKS => {
                Kind::Deferred
            }
            TickEvent::Coasting | TickEvent::Transient => Kind::Idle,
            TickEvent::Updated if rls_active => Kind::KfRls,
            TickEvent::Updated => Kind::Kf,
            TickEvent::Solved => Kind::Solve,
            TickEvent::KfOverflow | TickEvent::FiringTooLong | TickEvent::Railed => Kind::Other,
        });
        prev_word = word;
        if report.event == TickEvent::Solved {
            write_estimates(out, t, &pipeline.estimates())?;
            write_mixes(out, t, &pipeline)?;
        }
        if !matches!(
            report.event,
            TickEvent::Coasting | TickEvent::Transient | TickEvent::Updated | TickEvent::Solved
        ) {
            writeln!(
                out,
                "{} t={t} event={:?} status={:?}",
                S::NAME,
                report.event,
                report.status
            )?;
        }
    }
    let status = pipeline.finish();
    let t = sequence::START_MS as usize + sequence::LEN;
    writeln!(out, "{} t={t} finish status={:?}", S::NAME, status)?;
    write_estimates(out, t, &pipeline.estimates())?;
    write_mixes(out, t, &pipeline)
}

/// Samples of the SPHERES sequence the integer-float identification runs over (with its fit).
pub const INT_FLOAT_SAMPLES: usize = 2000;
/// Samples the other craft's identifications run over (sums only).
pub const OTHER_CRAFT_SAMPLES: usize = 500;
/// Samples of each integer-float identification in the instruction-count image.
pub const COUNT_INT_FLOAT_SAMPLES: usize = 150;

/// A craft the identification runs for: its thruster table, model CoM and inertia, and how
/// much of the embedded (SPHERES) sequence it takes.
pub struct FlightCraft<'a> {
    /// Printed on its lines.
    pub name: &'static str,
    /// Thrusters (1-16).
    pub thrusters: &'a [massid_kernel::craft::Thruster],
    /// Model CoM, m.
    pub com_m: [f32; 3],
    /// Model inertia, kg m^2 (xx yy zz xy xz yz).
    pub inertia_kgm2: [f32; 6],
    /// Turns about z only: Izz and the CoM's x and y, the yaw rate, no gyroscopic term.
    pub planar: bool,
    /// Whether the fit runs after the pushes (SPHERES only: its trace is long).
    pub solve: bool,
    /// Spread the 12-bit SPHERES word over 16 thrusters (the embedded sequence's words drive
    /// the craft's own thrusters).
    pub spread_word: bool,
    /// The pushes' kind.
    pub kind: Kind,
    /// The window close's kind.
    pub close_kind: Kind,
    /// The rate sensor's response.
    pub sensor: massid_kernel::flight_id::SensorResponse,
    /// Its noise's moving-average root (0: a gyro's).
    pub ma_root: f32,
}

/// The SPHERES table of the model (the kernel's `SPH2`), as thrusters.
pub fn sph2_thrusters() -> [massid_kernel::craft::Thruster; massid_kernel::model::N_THRUSTERS] {
    core::array::from_fn(|i| massid_kernel::craft::Thruster {
        pos_m: SPH2.thruster_pos_m.get(i).copied().unwrap_or([0.0; 3]),
        dir: SPH2.thrust_dir.get(i).copied().unwrap_or([1.0, 0.0, 0.0]),
        thrust_n: SPH2.thrust_n.get(i).copied().unwrap_or(1.0),
    })
}

impl<'a> FlightCraft<'a> {
    /// SPHERES (`thrusters`: [`sph2_thrusters`]) over the whole sequence, with the fit.
    pub fn sph2(thrusters: &'a [massid_kernel::craft::Thruster]) -> Self {
        FlightCraft {
            name: "sph2",
            thrusters,
            com_m: SPH2.com_offset_mm.map(|v| v * 1e-3),
            inertia_kgm2: SPH2.inertia_kgm2,
            planar: false,
            solve: true,
            spread_word: false,
            kind: Kind::FlightIdPush,
            close_kind: Kind::FlightIdClose,
            sensor: massid_kernel::flight_id::SensorResponse::Point,
            ma_root: 0.0,
        }
    }
    /// The air-bearing craft (planar, 8 thrusters), sums only.
    pub fn airbearing() -> Self {
        FlightCraft {
            name: "airbearing",
            thrusters: &crafts::AIRBEARING,
            com_m: crafts::AIRBEARING_COM_M,
            inertia_kgm2: crafts::AIRBEARING_INERTIA_KGM2,
            planar: true,
            solve: false,
            spread_word: false,
            kind: Kind::FlightIdPushAirbearing,
            close_kind: Kind::FlightIdCloseAirbearing,
            sensor: massid_kernel::flight_id::SensorResponse::Point,
            ma_root: 0.0,
        }
    }
    /// The air-bearing craft with its real sensor, motion capture: rates differenced from
    /// attitude over one sample, the moving-average filter on (root 0.875, the Monte Carlo's
    /// 50 Hz motion capture), sums only.
    pub fn airbearing_mocap() -> Self {
        FlightCraft {
            name: "airbearing_mocap",
            kind: Kind::FlightIdPushAirbearingMocap,
            close_kind: Kind::FlightIdCloseAirbearingMocap,
            sensor: massid_kernel::flight_id::SensorResponse::BackwardMean,
            ma_root: 0.875,
            ..Self::airbearing()
        }
    }
    /// The 16-thruster free-flyer, sums only.
    pub fn freeflyer16() -> Self {
        FlightCraft {
            name: "freeflyer16",
            thrusters: &crafts::FREEFLYER16,
            com_m: crafts::FREEFLYER16_COM_M,
            inertia_kgm2: crafts::FREEFLYER16_INERTIA_KGM2,
            planar: false,
            solve: false,
            spread_word: true,
            kind: Kind::FlightIdPushFreeflyer16,
            close_kind: Kind::FlightIdCloseFreeflyer16,
            sensor: massid_kernel::flight_id::SensorResponse::Point,
            ma_root: 0.0,
        }
    }
}

/// The onboard output-error identification (`massid_kernel::flight_id`) of `craft` over the
/// first `samples` of the embedded sequence, each sample's push measured (kind `craft.kind`); the final fit (SPHERES)
/// runs once, outside the tick (it is not measured: a background task's work). Its sums'
/// counts and a digest of them (every push feeds them), and its fit, are printed on lines
/// starting with `prefix` (`info `: not compared), the kernel's name and the craft's.
pub fn run_flight_id<S: RawBits + SumScalar, W: Write>(
    out: &mut W,
    prefix: &str,
    craft: &FlightCraft<'_>,
    samples: usize,
) -> fmt::Result {
    use massid_kernel::craft::Craft;
    use massid_kernel::flight_id::consider::ThrustUncertainty;
    use massid_kernel::flight_id::exact::Envelope;
    use massid_kernel::flight_id::solve::{inverse_inertia, SolveConfig, NP};
    use massid_kernel::flight_id::{FlightId, FlightIdConfig};
    use massid_kernel::model::SPH2_GYRO_BIAS_COUNTS;
    let name = craft.name;
    let j_f32 = inverse_inertia::<f32>(&craft.inertia_kgm2);
    let (Ok(table), Some(j_f32)) = (
        Craft::<S>::new(craft.thrusters, craft.com_m, SPH2.pressure_drop_n_per_extra),
        j_f32,
    ) else {
        return writeln!(out, "{prefix}{} {name} flight_id init-error", S::NAME);
    };
    let principal = (j_f32[0] + j_f32[1] + j_f32[2]) / 3.0;
    let scale: [S; NP] = core::array::from_fn(|m| {
        S::from_f32(match m {
            0..=2 => 0.5 * j_f32.get(m).copied().unwrap_or(0.0),
            3..=5 => 0.25 * principal,
            _ => 0.025,
        })
    });
    let cfg = FlightIdConfig {
        period_s: S::from_f32(1e-3),
        sensor: craft.sensor,
        rate_noise_ma_root: S::from_f32(craft.ma_root),
        rate_noise_ma_lag: 1,
        delay_periods: 0.0,
        cut_at_changes: false,
        max_window: 8000,
        max_window_turn_rad: S::from_f32(1e9),
        turn_weight: [S::ONE; 3],
        turn_window: 8000,
        max_window_walk: S::from_f32(1e9),
        skip: 2,
        solve: SolveConfig {
            j_nominal: j_f32.map(S::from_f32),
            free: core::array::from_fn(|m| !craft.planar || matches!(m, 2 | 6 | 7)),
            axes: [!craft.planar, !craft.planar, true],
            gyroscopic: !craft.planar,
            max_noise_order: 2,
            scale,
        },
        envelope: Envelope::of_craft(table.wrench_bound()),
        thrust: ThrustUncertainty::none(),
    };
    let Some(mut id) = FlightId::new(cfg) else {
        return writeln!(out, "{prefix}{} {name} flight_id init-error", S::NAME);
    };
    writeln!(
        out,
        "info {} {name} flight-id-bytes {}",
        S::NAME,
        core::mem::size_of::<FlightId<S>>()
    )?;
    markers::flavour(S::EXACT);
    let dt = S::from_f32(1e-3);
    // Mid-flight, one sample is missing: the push that closes the first window (its
    // initial-rate term queued, `flight_id::close`), measured as the close; the pushes after
    // it add that term a few entries each, so their worst includes it.
    let missing = sequence::samples().take(samples).count() / 2;
    for (k, (gyro, word)) in sequence::samples().take(samples).enumerate() {
        let valid = k != missing && gyro.iter().all(|&c| c != 0 && c < 4095);
        let word = if craft.spread_word {
            word | (word << 4)
        } else {
            word
        };
        let rate: [S; 3] = core::array::from_fn(|a| {
            let c = f32::from(gyro.get(a).copied().unwrap_or(0));
            let bias = SPH2_GYRO_BIAS_COUNTS.get(a).copied().unwrap_or(0.0);
            let per = SPH2.gyro_counts_per_rad_s.get(a).copied().unwrap_or(1.0);
            S::from_f32((c - bias) / per)
        });
        markers::begin();
        id.push_word(dt, rate, valid, &table, word);
        markers::end();
        markers::kind(if k == missing {
            craft.close_kind
        } else {
            craft.kind
        });
    }
    // The end of the flight (not a tick): the last window closed and every term added.
    id.finish();
    let sums = id.sums();
    write!(
        out,
        "{prefix}{} {name} flight_id samples={} windows={} cyy",
        S::NAME,
        sums.samples,
        sums.windows
    )?;
    write_bits(out, &sums.cyy)?;
    write!(out, " czz_diagonal")?;
    for (i, row) in sums.czz.iter().enumerate() {
        write_bits(out, row.get(i..=i).unwrap_or(&[]))?;
    }
    writeln!(out)?;
    // the fit is not measured (outside the tick); in the integer float its trace alone ran
    // for minutes, so the count image leaves it out
    if !craft.solve || sequence::COUNT_RUN {
        return Ok(());
    }
    match id.solve() {
        Ok(sol) => {
            write!(out, "{prefix}{} {name} flight_id theta", S::NAME)?;
            write_bits(out, &sol.theta)?;
            writeln!(out, " held={:?}", sol.held)
        }
        Err(e) => writeln!(out, "{prefix}{} {name} flight_id {e:?}", S::NAME),
    }
}

/// Mixer commands as Q8.24 bits (force N x3, torque N m x3); value = bits / 2^24 in both
/// formats (exact). The same set as `kernel/capi-test/capi_run.c`.
pub const COMMANDS: [[i32; 6]; 4] = [
    [838861, 0, 0, 0, 0, 0],
    [0, 0, 0, 0, 0, 83886],
    [335544, -503316, 167772, 33554, -16777, 50331],
    [5033165, 5033165, 5033165, 0, 0, 0],
];

/// Rebuilds the mixer from the current CoM estimate (200 ms period, 10 ms minimum pulse) and
/// mixes [`COMMANDS`], printing the ON/OFF times; both calls are measured.
fn write_mixes<S: RawBits, W: Write>(out: &mut W, t: usize, pipeline: &Pipeline<S>) -> fmt::Result {
    let cfg = MixerConfig {
        period_ms: 200,
        min_pulse_ms: 10,
        pressure_drop_n: S::from_f32(SPH2.pressure_drop_n_per_extra),
    };
    let delta = pipeline.estimates().delta_com_m;
    markers::begin();
    let mixer = Mixer::<S>::new(&SPH2, delta, cfg);
    markers::end();
    markers::kind(Kind::MixerBuild);
    let mixer = match mixer {
        Ok(m) => m,
        Err(e) => return writeln!(out, "{} t={t} mixer-error {:?}", S::NAME, e),
    };
    for (k, c) in COMMANDS.iter().enumerate() {
        let cmd: [S; 6] = c.map(|bits| S::from_int_pow2(bits, -24));
        markers::begin();
        let firing = mixer.mix([cmd[0], cmd[1], cmd[2]], [cmd[3], cmd[4], cmd[5]]);
        markers::end();
        markers::kind(Kind::Mixer);
        match firing {
            Ok(f) => writeln!(
                out,
                "{} t={t} mix{k} on {:?} off {:?}",
                S::NAME,
                f.on_ms,
                f.off_ms
            )?,
            Err(e) => writeln!(out, "{} t={t} mix{k} error {:?}", S::NAME, e)?,
        }
    }
    Ok(())
}

/// The any-craft mixer (`massid_kernel::craft_mixer`) for SPHERES, the air-bearing craft and
/// the 16-thruster free-flyer ([`crafts`]), model CoM, 200 ms period, 10 ms minimum pulse:
/// mixes [`COMMANDS`] (scaled to the craft, a planar craft's off-plane components zeroed),
/// prints the firings
/// (compared host vs QEMU) and counts each mix under its craft's kind.
pub fn run_craft_mixers<S: RawBits, W: Write>(out: &mut W) -> fmt::Result {
    use massid_kernel::craft::Thruster;
    use massid_kernel::craft_mixer::CraftMixer;
    use massid_kernel::model::N_THRUSTERS;
    markers::flavour(S::EXACT);
    let sph2: [Thruster; N_THRUSTERS] = sph2_thrusters();
    let sph2_com = SPH2.com_offset_mm.map(|v| v * 1e-3);
    // The commands scaled by 2^up to each craft's thrusters (0.11 N, 0.44 N, 0.6 N), so that
    // pulses are above the minimum.
    let craft: [(&str, &[Thruster], [f32; 3], bool, i32, Kind); 3] = [
        ("sph2", &sph2, sph2_com, false, 0, Kind::CraftMixerSph2),
        (
            "airbearing",
            &crafts::AIRBEARING,
            crafts::AIRBEARING_COM_M,
            true,
            2,
            Kind::CraftMixerAirbearing,
        ),
        (
            "freeflyer16",
            &crafts::FREEFLYER16,
            crafts::FREEFLYER16_COM_M,
            false,
            3,
            Kind::CraftMixerFreeflyer16,
        ),
    ];
    for (name, thrusters, com, planar, up, kind) in craft {
        let cfg = MixerConfig {
            period_ms: 200,
            min_pulse_ms: 10,
            pressure_drop_n: S::ZERO,
        };
        let mixer = match CraftMixer::<S>::new(thrusters, com.map(S::from_f32), planar, cfg) {
            Ok(m) => m,
            Err(e) => {
                writeln!(out, "{} craft={name} mixer-error {:?}", S::NAME, e)?;
                continue;
            }
        };
        for (k, c) in COMMANDS.iter().enumerate() {
            let mut cmd: [S; 6] = c.map(|bits| S::from_int_pow2(bits, up.saturating_sub(24)));
            if planar {
                for off in [2, 3, 4] {
                    if let Some(v) = cmd.get_mut(off) {
                        *v = S::ZERO;
                    }
                }
            }
            markers::begin();
            let firing = mixer.mix([cmd[0], cmd[1], cmd[2]], [cmd[3], cmd[4], cmd[5]]);
            markers::end();
            markers::kind(kind);
            match firing {
                Ok(f) => writeln!(
                    out,
                    "{} craft={name} mix{k} on {:?} off {:?}",
                    S::NAME,
                    f.on_ms,
                    f.off_ms
                )?,
                Err(e) => writeln!(out, "{} craft={name} mix{k} error {:?}", S::NAME, e)?,
            }
        }
    }
    Ok(())
}

fn write_estimates<S: RawBits, W: Write>(out: &mut W, t: usize, e: &Estimates<S>) -> fmt::Result {
    write!(
        out,
        "{} t={t} estimates status={:?} firings={} updates={} resets={} com",
        S::NAME,
        e.status,
        e.firings,
        e.updates,
        e.resets
    )?;
    write_bits(out, &e.delta_com_m)?;
    write!(out, " theta")?;
    write_bits(out, &e.theta_inertia)?;
    writeln!(
        out,
        " unobs={:?}{:?}",
        e.unobservable_com, e.unobservable_inertia
    )
}

fn write_bits<S: RawBits, W: Write>(out: &mut W, v: &[S]) -> fmt::Result {
    for x in v {
        x.write_raw(out)?;
    }
    Ok(())
}
