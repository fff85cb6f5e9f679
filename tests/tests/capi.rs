//! The kernel's C ABI, exercised from C: builds the static library (`kernel/capi-test`,
//! crate `massid-kernel-capi`) with cargo, compiles `kernel/capi-test/capi_run.c` with gcc
//! against `kernel/include/massid_kernel.h`, runs its self-test (layout, NULL pointers,
//! uninitialised blocks, bad parameters), then runs it over open recordings and requires
//! its output to equal, line for line, the same run made here through the Rust API (fixed
//! and f32 estimates at every solve, mixer times from the mixer rebuilt from each estimate).
//!
//! Requires gcc (installed by `scripts/setup.sh`).
use massid_kernel::mixer::{Firing, Mixer, MixerConfig, MixerError};
use massid_kernel::model::SPH2;
use massid_kernel::pipeline::Estimates;
use massid_kernel::{Pipeline, PipelineConfig, Scalar, TickEvent, Q8_24};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;

/// Mixer commands as Q8.24 bits (force N, torque N m); must equal `COMMANDS` in capi_run.c.
const COMMANDS: [[i32; 6]; 4] = [
    [838861, 0, 0, 0, 0, 0],
    [0, 0, 0, 0, 0, 83886],
    [335544, -503316, 167772, 33554, -16777, 50331],
    [5033165, 5033165, 5033165, 0, 0, 0],
];
const PERIOD_MS: u32 = 200;
const MIN_PULSE_MS: u32 = 10;

fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn open_data() -> PathBuf {
    repo_root().join("../shared/data/open")
}

/// Scalar-specific formatting and command conversion, mirroring the C program.
trait Flavour: Scalar {
    const NAME: &'static str;
    fn bits(self) -> u32;
    /// The command value `bits / 2^24` (exact in both formats for these commands).
    fn command(bits: i32) -> Self {
        Self::from_int_pow2(bits, -24)
    }
}

impl Flavour for Q8_24 {
    const NAME: &'static str = "fixed";
    fn bits(self) -> u32 {
        self.0.to_bits() as u32
    }
}

impl Flavour for f32 {
    const NAME: &'static str = "f32";
    fn bits(self) -> u32 {
        self.to_bits()
    }
}

/// C `massid_status` code of a mixer error (as `massid_kernel.h` documents them).
fn mixer_status(e: MixerError) -> i32 {
    match e {
        MixerError::BadPeriod | MixerError::BadThruster => 3,
        MixerError::SingularMixingMatrix => 4,
        MixerError::Overflow => 5,
        MixerError::BadCommand => 6,
        MixerError::PressureDropExceedsThrust => 7,
        MixerError::OutOfReach | MixerError::OffPlane => 8,
    }
}

fn write_solve<S: Flavour>(
    out: &mut String,
    t: i64,
    e: &Estimates<S>,
    mixer: Result<Mixer<S>, i32>,
) {
    let _ = write!(
        out,
        "{} t={t} estimates status={} firings={} updates={} resets={} com",
        S::NAME,
        e.status as u8,
        e.firings,
        e.updates,
        e.resets
    );
    for v in e.delta_com_m {
        let _ = write!(out, " {:08x}", v.bits());
    }
    out.push_str(" theta");
    for v in e.theta_inertia {
        let _ = write!(out, " {:08x}", v.bits());
    }
    out.push_str(" unobs ");
    for f in e
        .unobservable_com
        .iter()
        .chain(e.unobservable_inertia.iter())
    {
        out.push(if *f { '1' } else { '0' });
    }
    out.push('\n');
    for (k, c) in COMMANDS.iter().enumerate() {
        let cmd: [S; 6] = c.map(S::command);
        let result: Result<Firing, i32> = match &mixer {
            Ok(m) => m
                .mix([cmd[0], cmd[1], cmd[2]], [cmd[3], cmd[4], cmd[5]])
                .map_err(mixer_status),
            Err(s) => Err(*s),
        };
        let (status, f) = match result {
            Ok(f) => (0, f),
            Err(s) => (
                s,
                Firing {
                    on_ms: [0; 12],
                    off_ms: [0; 12],
                },
            ),
        };
        let _ = write!(out, "{} t={t} mix{k} status={status} on", S::NAME);
        for v in f.on_ms {
            let _ = write!(out, " {v}");
        }
        out.push_str(" off");
        for v in f.off_ms {
            let _ = write!(out, " {v}");
        }
        out.push('\n');
    }
}

/// (time_ms, gyro counts, thruster word) rows of a recording.
fn read_rows(path: &Path) -> Vec<(i64, [u16; 3], u16)> {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut rows = Vec::new();
    let mut header = false;
    for (n, line) in text.lines().enumerate() {
        if line.starts_with('#') {
            continue;
        }
        if !header {
            header = true;
            continue;
        }
        let f: Vec<i64> = line
            .trim()
            .split(',')
            .map(|v| {
                v.parse()
                    .unwrap_or_else(|_| panic!("{}:{}: bad field {v:?}", path.display(), n + 1))
            })
            .collect();
        assert_eq!(f.len(), 8, "{}:{}", path.display(), n + 1);
        rows.push((f[0], [f[1] as u16, f[2] as u16, f[3] as u16], f[7] as u16));
    }
    rows
}

/// The run of `capi_run.c`, made through the Rust API.
fn rust_run<S: Flavour>(rows: &[(i64, [u16; 3], u16)], out: &mut String) {
    rust_run_with(PipelineConfig::<S>::seed(1), false, rows, out)
}

/// The run of `capi_run --options`: change detector, gyroscopic correction at SPH2's bias,
/// forgetting 0.9999, gaps as one `tick_gaps` call each (the C side's `OPTIONS`).
fn rust_run_options<S: Flavour>(rows: &[(i64, [u16; 3], u16)], out: &mut String) {
    let mut cfg = PipelineConfig::<S>::with_gyroscopic(1, [2077.0, 2070.0, 2058.0]);
    cfg.rls.detector = Some(massid_kernel::rls::DetectorConfig::standard());
    cfg.rls.forgetting = Some(S::from_f32(0.9999));
    rust_run_with(cfg, true, rows, out)
}

fn rust_run_with<S: Flavour>(
    cfg: PipelineConfig<S>,
    gaps_at_once: bool,
    rows: &[(i64, [u16; 3], u16)],
    out: &mut String,
) {
    let mut p = Pipeline::<S>::new(&SPH2, cfg).expect("SPH2 is valid");
    let rebuild = |p: &Pipeline<S>| {
        let cfg = MixerConfig {
            period_ms: PERIOD_MS,
            min_pulse_ms: MIN_PULSE_MS,
            pressure_drop_n: S::from_f32(SPH2.pressure_drop_n_per_extra),
        };
        Mixer::new(&SPH2, p.estimates().delta_com_m, cfg).map_err(mixer_status)
    };
    let mut last: i64 = -1;
    for &(t, g, w) in rows {
        if last >= 0 && t <= last {
            continue;
        }
        let mut solved = false;
        if gaps_at_once && last >= 0 && last + 1 < t {
            solved |= p.tick_gaps((t - last - 1) as u64).event == TickEvent::Solved;
            last = t - 1;
        }
        while last >= 0 && last + 1 < t {
            solved |= p.tick_gap().event == TickEvent::Solved;
            last += 1;
        }
        solved |= p.tick(g, w).event == TickEvent::Solved;
        last = t;
        if solved {
            let m = rebuild(&p);
            write_solve(out, t, &p.estimates(), m);
        }
    }
    p.finish();
    let m = rebuild(&p);
    write_solve(out, last + 1, &p.estimates(), m);
}

fn run(cmd: &mut Command, what: &str) -> std::process::Output {
    let out = cmd
        .output()
        .unwrap_or_else(|e| panic!("{what}: cannot start: {e}"));
    assert!(
        out.status.success(),
        "{what} failed ({}):\n{}\n{}",
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// Builds the static library and the C program once per test process; returns the
/// program's path. (Each test building its own copy at the same path raced: gcc rewrote the
/// program while another test ran it, "Text file busy", CI at d493707.)
fn build_c_program() -> PathBuf {
    static BUILT: std::sync::OnceLock<PathBuf> = std::sync::OnceLock::new();
    BUILT.get_or_init(build_c_program_now).clone()
}

fn build_c_program_now() -> PathBuf {
    let root = repo_root();
    let tmp = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("capi");
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    run(
        Command::new(cargo)
            .current_dir(&root)
            .args(["build", "--release", "-p", "massid-kernel-capi"])
            .env("CARGO_TARGET_DIR", tmp.join("target")),
        "cargo build -p massid-kernel-capi",
    );
    let lib = tmp.join("target/release/libmassid_kernel_capi.a");
    assert!(lib.exists(), "{} was not built", lib.display());
    let exe = tmp.join("capi_run");
    run(
        Command::new("gcc")
            .args([
                "-std=c99",
                "-O2",
                "-Wall",
                "-Wextra",
                "-Werror",
                "-pedantic",
                "-I",
            ])
            .arg(root.join("kernel/include"))
            .arg(root.join("kernel/capi-test/capi_run.c"))
            .arg(&lib)
            .args(["-lpthread", "-ldl", "-lm", "-o"])
            .arg(&exe),
        "gcc capi_run.c (is gcc installed? scripts/setup.sh installs it)",
    );
    exe
}

#[test]
fn c_program_matches_the_rust_api_on_open_recordings() {
    let exe = build_c_program();
    let selftest = run(Command::new(&exe).arg("--selftest"), "capi_run --selftest");
    assert!(String::from_utf8_lossy(&selftest.stdout).contains("all checks passed"));

    // A 1 s-firing recording, a random-PWM one with pressure drop, and one with gaps and duplicates.
    for name in [
        "o01_nominal_rga12.csv",
        "o03_pressure_drop_combo.csv",
        "o09_nominal_artefacts_combo.csv",
    ] {
        let path = open_data().join(name);
        let c_out = String::from_utf8(run(Command::new(&exe).arg(&path), name).stdout)
            .expect("utf-8 output");
        let rows = read_rows(&path);
        let mut expected = String::new();
        rust_run::<Q8_24>(&rows, &mut expected);
        rust_run::<f32>(&rows, &mut expected);
        let solves = expected
            .lines()
            .filter(|l| l.contains(" estimates "))
            .count();
        assert!(solves >= 4, "{name}: expected several solves, got {solves}");
        assert!(
            expected.lines().any(|l| l.contains(" mix0 status=0 ")),
            "{name}: no successful mix"
        );
        for (n, (c, r)) in c_out.lines().zip(expected.lines()).enumerate() {
            assert_eq!(c, r, "{name}: line {} differs (C vs Rust)", n + 1);
        }
        assert_eq!(
            c_out.lines().count(),
            expected.lines().count(),
            "{name}: line counts differ"
        );
    }
    // C callers choose the options Rust callers can (detector, forgetting, gyroscopic
    // correction) and skip a gap in one call: the same output as the Rust API.
    for name in ["o09_nominal_artefacts_combo.csv", "o01_nominal_rga12.csv"] {
        let path = open_data().join(name);
        let c_out =
            String::from_utf8(run(Command::new(&exe).arg("--options").arg(&path), name).stdout)
                .expect("utf-8");
        let rows = read_rows(&path);
        let mut expected = String::new();
        rust_run_options::<Q8_24>(&rows, &mut expected);
        rust_run_options::<f32>(&rows, &mut expected);
        let mut plain = String::new();
        rust_run::<Q8_24>(&rows, &mut plain);
        rust_run::<f32>(&rows, &mut plain);
        assert_ne!(expected, plain, "{name}: the options must change the run");
        for (n, (c, r)) in c_out.lines().zip(expected.lines()).enumerate() {
            assert_eq!(c, r, "{name} --options: line {} differs (C vs Rust)", n + 1);
        }
        assert_eq!(
            c_out.lines().count(),
            expected.lines().count(),
            "{name} --options: line counts differ"
        );
    }
}

// ---- any craft: the craft mixer and the identification through the C ABI ----

use massid_kernel::craft::{Craft, Thruster};
use massid_kernel::craft_mixer::CraftMixer;
use massid_kernel::flight_id::consider::ThrustUncertainty;
use massid_kernel::flight_id::exact::Envelope;
use massid_kernel::flight_id::solve::{inverse_inertia, SolveConfig};
use massid_kernel::flight_id::sums::SumScalar;
use massid_kernel::flight_id::{FlightId, FlightIdConfig, SensorResponse};
use massid_kernel::IntFloat;
use rand::{Rng, SeedableRng};
use reference_f64::satellite::Satellite;

fn example_satellite(name: &str) -> Satellite {
    massid_sim::model_file::ModelFile::read(&massid_tests::allocation_check::example_model(name))
        .unwrap_or_else(|e| panic!("{name}: {e}"))
        .satellite
}

/// The `craft` and `thruster` lines of a craft file (`run_craft_file` in capi_run.c).
fn craft_lines(sat: &Satellite, thrusters: &[Thruster]) -> String {
    let mut s = format!(
        "craft {} {} {:08x}\n",
        thrusters.len(),
        u8::from(sat.planar),
        (sat.pressure_drop_n_per_extra as f32).to_bits()
    );
    for t in thrusters {
        s.push_str("thruster");
        for v in t
            .pos_m
            .iter()
            .chain(t.dir.iter())
            .chain([t.thrust_n].iter())
        {
            let _ = write!(s, " {:08x}", v.to_bits());
        }
        s.push('\n');
    }
    s
}

/// Q8.24 bits of `v` (rounded).
fn q24(v: f64) -> i32 {
    (v * 16_777_216.0).round() as i32
}

/// Commands for a craft, as Q8.24 bits (force N, torque N m): random non-negative
/// combinations of its thrusters' wrenches (some beyond its reach, which the mixer scales
/// down), a zero command, and for a planar craft one off its plane (status 8).
fn craft_commands(sat: &Satellite, seed: u64) -> Vec<[i32; 6]> {
    let n = sat.n_thrusters();
    let cols: Vec<[f64; 6]> = (0..n)
        .map(|i| {
            let f = sat.dir(i) * sat.thrust_n[i];
            let t = sat.lever_arm_m(i).cross(&f);
            [f.x, f.y, f.z, t.x, t.y, t.z]
        })
        .collect();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut out = vec![[0; 6]];
    for k in 0..60 {
        let mut c = [0.0f64; 6];
        for col in &cols {
            if rng.gen_bool(0.5) {
                let d = rng.gen_range(0.0..if k % 10 == 9 { 3.0 } else { 1.0 });
                for (ci, v) in c.iter_mut().zip(col) {
                    *ci += d * v;
                }
            }
        }
        if sat.planar {
            c[2] = 0.0;
            c[3] = 0.0;
            c[4] = 0.0;
        }
        out.push(c.map(q24));
    }
    if sat.planar {
        out.push([0, 0, q24(0.1), 0, 0, 0]);
    }
    out
}

/// What `capi_run --craft` prints for this craft, made through the Rust API.
fn rust_craft_run(
    thrusters: &[Thruster],
    planar: bool,
    pdrop: f32,
    com: [i32; 3],
    cmds: &[[i32; 6]],
) -> String {
    fn one<S: Flavour>(
        out: &mut String,
        thrusters: &[Thruster],
        planar: bool,
        pdrop: f32,
        com: [i32; 3],
        cmds: &[[i32; 6]],
    ) {
        let cfg = MixerConfig {
            period_ms: PERIOD_MS,
            min_pulse_ms: MIN_PULSE_MS,
            pressure_drop_n: S::from_f32(pdrop),
        };
        let m = match CraftMixer::<S>::new(thrusters, com.map(S::command), planar, cfg) {
            Ok(m) => m,
            Err(e) => {
                let _ = writeln!(out, "{} init status={} pairs=0", S::NAME, mixer_status(e));
                return;
            }
        };
        let pairs = u8::from(matches!(m, CraftMixer::OpposingPairs(_)));
        let _ = writeln!(out, "{} init status=0 pairs={pairs}", S::NAME);
        for (k, c) in cmds.iter().enumerate() {
            let cmd = c.map(S::command);
            let (status, on, off) = match m.mix([cmd[0], cmd[1], cmd[2]], [cmd[3], cmd[4], cmd[5]])
            {
                Ok(f) => (0, f.on_ms, f.off_ms),
                Err(e) => (mixer_status(e), [0; 16], [0; 16]),
            };
            let _ = write!(out, "{} cmd{k} status={status} on", S::NAME);
            for v in on {
                let _ = write!(out, " {v}");
            }
            out.push_str(" off");
            for v in off {
                let _ = write!(out, " {v}");
            }
            out.push('\n');
        }
    }
    let mut out = String::new();
    one::<Q8_24>(&mut out, thrusters, planar, pdrop, com, cmds);
    one::<f32>(&mut out, thrusters, planar, pdrop, com, cmds);
    out
}

fn compare_lines(what: &str, c_out: &str, expected: &str) {
    for (n, (c, r)) in c_out.lines().zip(expected.lines()).enumerate() {
        assert_eq!(c, r, "{what}: line {} differs (C vs Rust)", n + 1);
    }
    assert_eq!(
        c_out.lines().count(),
        expected.lines().count(),
        "{what}: line counts differ"
    );
}

/// The 8-thruster planar air-bearing craft, the 16-thruster 3-D free-flyer and SPHERES
/// through `massid_craft` / `massid_*_craft_mix*`: the C program's firing times equal the
/// Rust `CraftMixer`'s bit for bit, in Q8.24 and f32, for every command, errors included.
#[test]
fn c_craft_mixer_matches_the_rust_craft_mixer() {
    let exe = build_c_program();
    let selftest = run(Command::new(&exe).arg("--selftest"), "capi_run --selftest");
    assert!(String::from_utf8_lossy(&selftest.stdout).contains("all checks passed"));
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("capi");
    for (k, (name, expect_pairs)) in [("airbearing-mpc", 0), ("freeflyer16", 0), ("sph2", 1)]
        .into_iter()
        .enumerate()
    {
        let sat = example_satellite(name);
        let thrusters = massid_kernel_host::craft::thrusters(&sat).expect("1-16 thrusters");
        let c = sat.com_m();
        let com = [q24(c.x), q24(c.y), q24(c.z)];
        let cmds = craft_commands(&sat, 2300 + k as u64);
        let mut file = craft_lines(&sat, &thrusters);
        let _ = writeln!(file, "com {} {} {}", com[0], com[1], com[2]);
        for c in &cmds {
            let _ = writeln!(
                file,
                "cmd {} {} {} {} {} {}",
                c[0], c[1], c[2], c[3], c[4], c[5]
            );
        }
        let path = dir.join(format!("{name}.craft"));
        std::fs::write(&path, file).expect("write craft file");
        let c_out =
            String::from_utf8(run(Command::new(&exe).arg("--craft").arg(&path), name).stdout)
                .expect("utf-8");
        let expected = rust_craft_run(
            &thrusters,
            sat.planar,
            sat.pressure_drop_n_per_extra as f32,
            com,
            &cmds,
        );
        compare_lines(name, &c_out, &expected);
        // What the run exercised.
        assert!(
            expected.contains(&format!("fixed init status=0 pairs={expect_pairs}")),
            "{name}: {}",
            expected.lines().next().unwrap_or("")
        );
        let ok = expected
            .lines()
            .filter(|l| l.contains(" status=0 on"))
            .count();
        let firing = expected
            .lines()
            .filter(|l| {
                l.contains(" status=0 on")
                    && l.split(" off ")
                        .nth(1)
                        .is_some_and(|o| o.split(' ').any(|v| v != "0"))
            })
            .count();
        let out_of_reach = expected
            .lines()
            .filter(|l| l.contains(" status=8 "))
            .count();
        println!(
            "{name}: {} commands x 2 formats, {ok} mixed ({firing} firing), {out_of_reach} out of reach (status 8)",
            cmds.len()
        );
        assert!(firing >= 2 * (cmds.len() - 2), "{name}: too few firings");
        if sat.planar {
            assert_eq!(
                out_of_reach, 2,
                "{name}: the off-plane command is status 8 in both formats"
            );
        }
    }
}

/// Hex of an f32's bits.
fn hx(v: f32) -> String {
    format!("{:08x}", v.to_bits())
}

/// What `capi_run --flight-id` prints of its settings: scale, max_window, turn_window, skip,
/// turn limit, turn weights, gyroscopic, noise order, free terms, axes.
type Settings = (
    [f32; 9],
    u32,
    u32,
    u32,
    f32,
    [f32; 3],
    bool,
    u8,
    [bool; 9],
    [bool; 3],
);

/// Parses the hex floats of `capi_run --flight-id`'s settings line.
fn settings_from_line(line: &str) -> Settings {
    let f: Vec<&str> = line.split_whitespace().collect();
    let hexf = |s: &str| f32::from_bits(u32::from_str_radix(s, 16).expect("hex"));
    let after = |key: &str| -> &str {
        f.iter()
            .find_map(|t| t.strip_prefix(key))
            .unwrap_or_else(|| panic!("{key} in {line}"))
    };
    let scale: [f32; 9] = std::array::from_fn(|i| hexf(f[2 + i]));
    let flags = |key: &str| -> Vec<bool> {
        let i = f.iter().position(|t| *t == key).expect(key);
        f[i + 1].chars().map(|c| c == '1').collect()
    };
    let turn = hexf(f[f.iter().position(|t| *t == "turn").expect("turn") + 1]);
    let w = f.iter().position(|t| *t == "weight").expect("weight");
    let weight: [f32; 3] = std::array::from_fn(|i| hexf(f[w + 1 + i]));
    let free = flags("free");
    let axes = flags("axes");
    (
        scale,
        after("window=").parse().expect("window"),
        after("turn_window=").parse().expect("turn_window"),
        after("skip=").parse().expect("skip"),
        turn,
        weight,
        after("gyro=") == "1",
        after("order=").parse().expect("order"),
        std::array::from_fn(|i| free[i]),
        std::array::from_fn(|i| axes[i]),
    )
}

/// The onboard identification through `massid_f32_flight_id_*` on a simulated SPHERES flight
/// (3-D, gyroscopic term), a planar air-bearing one and a cubesat's: the C result (estimate, covariance,
/// noise model, held terms, timing statistic) equals the Rust `FlightId`'s bit for bit, and
/// `massid_flight_id_settings_default` gives the ground tool's settings.
#[test]
fn c_flight_id_matches_the_rust_flight_id() {
    use massid_kernel::flight_id::solve::MAX_ORDER;
    use massid_tests::identification_mc::{fly, Condition};
    use reference_f64::flight_id::flight::Command as Cmd;

    let exe = build_c_program();
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("capi");
    let conditions = [
        (
            // 1 kHz: below it the ground tool treats v1 words as coarse (windows cut at
            // every change, no noise model), which the defaults do not choose.
            "sph2-combo-1khz",
            Condition::Spheres {
                maneuver: massid_sim::Maneuver::Combo,
                rate_hz: 1000.0,
                noise: 1.0,
            },
        ),
        (
            "airbearing-planar-25hz",
            Condition::PlanarMocap {
                step_ms: 40,
                control_ms: 80,
                closed_loop: false,
            },
        ),
        (
            // A craft whose inertia couples the axes 3.56x more than SPHERES': its windows
            // end sooner (`flight_id::window`).
            "cubesat8-combo-100hz",
            Condition::Craft {
                model: "cubesat8",
                maneuver: massid_sim::Maneuver::Combo,
                rate_hz: 100.0,
            },
        ),
    ];
    for (name, cond) in conditions {
        let sim = fly(&cond, 2323);
        let (sat, flight) = (&sim.model, &sim.flight);
        let thrusters = massid_kernel_host::craft::thrusters(sat).expect("thrusters");
        let c = sat.com_m();
        let com = [c.x as f32, c.y as f32, c.z as f32];
        let inertia = sat.inertia_kgm2.map(|v| v as f32);
        let period = flight.period_s as f32;
        let mut file = craft_lines(sat, &thrusters);
        file.push_str("id");
        for v in inertia.iter().chain(com.iter()).chain([period].iter()) {
            let _ = write!(file, " {}", hx(*v));
        }
        file.push('\n');
        // The samples as the ground tool pushes them (kernel-host/src/flight_id.rs).
        let mut samples: Vec<(f32, [f32; 3], bool, u16)> = Vec::new();
        let mut prev: Option<f64> = None;
        for ((t, rate), cmd) in flight
            .time_s
            .iter()
            .zip(flight.rate.iter())
            .zip(&flight.commands)
        {
            let dt = prev.map_or(0.0, |p| t - p) as f32;
            prev = Some(*t);
            let axes = if sat.planar {
                [false, false, true]
            } else {
                flight.axes
            };
            let valid = (0..3).all(|a| !axes[a] || rate[a].is_finite());
            let r = rate.map(|v| if v.is_finite() { v as f32 } else { 0.0 });
            let Cmd::Word(w) = cmd else {
                panic!("{name}: the test flights command thruster words")
            };
            samples.push((dt, r, valid, *w));
            let _ = writeln!(
                file,
                "s {} {} {} {} {} {}",
                hx(dt),
                hx(r[0]),
                hx(r[1]),
                hx(r[2]),
                u8::from(valid),
                w
            );
        }
        let path = dir.join(format!("{name}.flight"));
        std::fs::write(&path, file).expect("write flight file");
        let c_out =
            String::from_utf8(run(Command::new(&exe).arg("--flight-id").arg(&path), name).stdout)
                .expect("utf-8");
        let mut lines = c_out.lines();
        let settings_line = lines.next().expect("settings line");
        assert!(
            settings_line.starts_with("settings status=0 "),
            "{name}: {settings_line}"
        );
        assert_eq!(lines.next(), Some("init status=0"), "{name}");
        let (scale, max_window, turn_window, skip, turn, turn_weight, gyro, order, free, axes) =
            settings_from_line(settings_line);

        // The defaults are the ground tool's choices (kernel-host/src/flight_id.rs; its scale
        // is computed in f64, so compared to f32 rounding).
        let j_nom = sat.inertia_matrix().try_inverse().expect("inertia");
        let duration = flight.time_s.last().unwrap() - flight.time_s[0];
        for (m, s) in scale.iter().enumerate() {
            let term = if m < 6 {
                reference_f64::flight_id::rigid::Term::InvInertia(m)
            } else {
                reference_f64::flight_id::rigid::Term::Com(m - 6)
            };
            let host = reference_f64::flight_id::term_scale(sat, &j_nom, term, duration);
            assert!(
                (f64::from(*s) - host).abs() <= 1e-5 * host,
                "{name}: scale {m}: C default {s} vs ground {host}"
            );
        }
        assert_eq!(
            max_window,
            (60.0 / flight.period_s).round() as u32,
            "{name}"
        );
        // The window rule follows the craft's gyroscopic coupling (`flight_id::window`): SPHERES
        // and the planar craft keep the 8 s floor, the cubesat counts its turns 3.56x.
        let weights = massid_kernel::flight_id::window::turn_weights(&inertia).expect("inertia");
        assert_eq!(turn_weight, weights, "{name}");
        assert_eq!(
            weights.iter().all(|w| *w > 3.5),
            name.starts_with("cubesat8"),
            "{name}: {weights:?}"
        );
        let floor_s = 8.0 / weights.iter().fold(1.0f32, |m, w| m.max(*w));
        assert_eq!(
            turn_window,
            (f64::from(floor_s) / flight.period_s).round() as u32,
            "{name}"
        );
        assert_eq!((skip, order), (MAX_ORDER as u32, MAX_ORDER as u8), "{name}");
        assert_eq!(gyro, !sat.planar, "{name}");
        assert_eq!(turn, if sat.planar { f32::INFINITY } else { 4.0 }, "{name}");
        let host_free: [bool; 9] = std::array::from_fn(|m| !sat.planar || matches!(m, 2 | 6 | 7));
        assert_eq!(free, host_free, "{name}");
        assert_eq!(
            axes,
            if sat.planar {
                [false, false, true]
            } else {
                [true; 3]
            },
            "{name}"
        );

        // The same run through the Rust API, in f32 and in the integer float (the C ABI's
        // settings are f32; each reaches the format by its exact conversion).
        let cfg = FlightIdConfig {
            period_s: period,
            sensor: SensorResponse::Point,
            rate_noise_ma_root: 0.0,
            rate_noise_ma_lag: 1,
            delay_periods: 0.0,
            cut_at_changes: false,
            max_window,
            max_window_turn_rad: turn,
            turn_weight,
            turn_window,
            // The C ABI's: the settings do not carry it.
            max_window_walk: massid_kernel::flight_id::window::MAX_WINDOW_WALK,
            skip,
            solve: SolveConfig {
                j_nominal: [0.0; 6],
                free,
                axes,
                gyroscopic: gyro,
                max_noise_order: order,
                scale,
            },
            // Replaced by the craft's own in `rust_flight_id_line`, as the C ABI's init does.
            envelope: Envelope::of_craft([0.0; 6]),
            // The settings' default: no stated thrust uncertainty.
            thrust: ThrustUncertainty::none(),
        };
        let drop = sat.pressure_drop_n_per_extra as f32;
        let expected =
            rust_flight_id_line::<f32>(name, &cfg, &inertia, &thrusters, com, drop, &samples);
        compare_lines(name, &lines.collect::<Vec<_>>().join("\n"), &expected);
        let c_fixed = String::from_utf8(
            run(Command::new(&exe).arg("--fixed-flight-id").arg(&path), name).stdout,
        )
        .expect("utf-8");
        let mut fixed_lines = c_fixed.lines();
        assert_eq!(
            fixed_lines.next(),
            Some(settings_line),
            "{name}: fixed settings"
        );
        assert_eq!(
            fixed_lines.next(),
            Some("init status=0"),
            "{name}: fixed init"
        );
        let expected =
            rust_flight_id_line::<IntFloat>(name, &cfg, &inertia, &thrusters, com, drop, &samples);
        compare_lines(
            &format!("{name} (integer float)"),
            &fixed_lines.collect::<Vec<_>>().join("\n"),
            &expected,
        );
    }
}

/// What `capi_run --flight-id` (f32) or `--fixed-flight-id` (the integer float) prints after
/// its settings and init lines, made through the Rust API in format `S`: `cfg` is the f32
/// settings (its nominal inverse inertia is recomputed in `S` from `inertia`, as the C ABI
/// does).
fn rust_flight_id_line<S: SumScalar>(
    name: &str,
    cfg: &FlightIdConfig<f32>,
    inertia: &[f32; 6],
    thrusters: &[Thruster],
    com: [f32; 3],
    drop: f32,
    samples: &[(f32, [f32; 3], bool, u16)],
) -> String {
    let c = S::from_f32;
    let cfg = FlightIdConfig {
        period_s: c(cfg.period_s),
        sensor: cfg.sensor,
        rate_noise_ma_root: c(cfg.rate_noise_ma_root),
        rate_noise_ma_lag: cfg.rate_noise_ma_lag,
        delay_periods: cfg.delay_periods,
        cut_at_changes: cfg.cut_at_changes,
        max_window: cfg.max_window,
        max_window_turn_rad: c(cfg.max_window_turn_rad),
        turn_weight: cfg.turn_weight.map(c),
        turn_window: cfg.turn_window,
        max_window_walk: c(cfg.max_window_walk),
        skip: cfg.skip,
        solve: SolveConfig {
            j_nominal: inverse_inertia(&inertia.map(c)).expect("inertia"),
            free: cfg.solve.free,
            axes: cfg.solve.axes,
            gyroscopic: cfg.solve.gyroscopic,
            max_noise_order: cfg.solve.max_noise_order,
            scale: cfg.solve.scale.map(c),
        },
        envelope: Envelope::of_craft([S::ZERO; 6]),
        thrust: ThrustUncertainty::none(),
    };
    let table = Craft::<S>::new(thrusters, com, drop).expect("craft");
    let cfg = FlightIdConfig {
        envelope: Envelope::of_craft(table.wrench_bound()),
        ..cfg
    };
    let mut id = FlightId::new(cfg).expect("flight id");
    for (dt, r, valid, w) in samples {
        id.push(c(*dt), r.map(c), *valid, table.command(*w));
    }
    id.finish();
    let h = |v: S| hx(v.to_f32());
    let mut expected = String::new();
    match id.solve() {
        Ok(s) => {
            let _ = write!(
                expected,
                "solve status=0 samples={} steps={} pd={} timing={} {}",
                samples.len(),
                s.steps,
                u8::from(s.positive_definite),
                u8::from(s.timing_statistic.is_some()),
                s.timing_statistic.map_or(hx(0.0), h)
            );
            expected.push_str(" symmetry ");
            for v in s.symmetry_statistic {
                expected.push(if v.is_some() { '1' } else { '0' });
            }
            for v in s.symmetry_statistic {
                let _ = write!(expected, " {}", v.map_or(hx(0.0), h));
            }
            let _ = write!(
                expected,
                " inconsistent={}",
                u8::from(massid_kernel::flight_id::consistency::rejects(
                    s.timing_statistic,
                    &s.symmetry_statistic
                ))
            );
            expected.push_str(" theta");
            for v in s.theta {
                let _ = write!(expected, " {}", h(v));
            }
            expected.push_str(" held ");
            for held in s.held {
                expected.push(if held { '1' } else { '0' });
            }
            expected.push_str(" noise");
            for n in s.noise {
                let _ = write!(expected, " {}", n.order);
                for p in n.phi {
                    let _ = write!(expected, " {}", h(p));
                }
                let _ = write!(expected, " {}", h(n.sigma2));
            }
            expected.push_str(" cov");
            for row in s.covariance {
                for v in row {
                    let _ = write!(expected, " {}", h(v));
                }
            }
            println!(
                "{name} ({}): {} samples, theta {:?}, held {:?}",
                core::any::type_name::<S>(),
                samples.len(),
                s.theta.map(S::to_f32),
                s.held
            );
        }
        Err(e) => panic!("{name}: the Rust FlightId gives {e:?}"),
    }
    expected
}

use massid_kernel::capi::craft::{
    massid_f32_flight_id_finish, massid_f32_flight_id_init, massid_f32_flight_id_push,
    massid_f32_flight_id_reanchor, massid_f32_flight_id_solve, massid_flight_id_settings_default,
    MassidCraft, MassidFlightId, MassidFlightIdResult, MassidFlightIdSettings,
};
use massid_kernel::capi::MassidStatus;
use std::mem::MaybeUninit;

/// A planar craft through the C ABI: one thruster turns it each way, a third pushes it along
/// y; Izz 0.25, sampled at 100 Hz. Its default settings.
fn three_thruster_craft() -> (MassidCraft, MassidFlightIdSettings) {
    let mut craft = MassidCraft {
        count: 3,
        planar: 1,
        thruster_pos_m: [[0.0; 3]; 16],
        thrust_dir: [[0.0; 3]; 16],
        thrust_n: [0.0; 16],
        pressure_drop_n_per_extra: 0.0,
    };
    craft.thruster_pos_m[..3].copy_from_slice(&[
        [0.2, 0.2, 0.0],
        [0.2, -0.2, 0.0],
        [-0.2, 0.0, 0.0],
    ]);
    craft.thrust_dir[..3].copy_from_slice(&[[1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
    craft.thrust_n[..3].copy_from_slice(&[0.5, 0.5, 0.5]);
    let inertia = [0.2f32, 0.2, 0.25, 0.0, 0.0, 0.0];
    let com = [0.0f32; 3];
    let mut settings = MaybeUninit::<MassidFlightIdSettings>::uninit();
    // SAFETY: valid pointers to a craft, six and three floats and a settings slot.
    let status = unsafe {
        massid_flight_id_settings_default(
            &craft,
            inertia.as_ptr(),
            com.as_ptr(),
            0.01,
            settings.as_mut_ptr(),
        )
    };
    assert_eq!(status, MassidStatus::Ok);
    // SAFETY: written by the call above.
    (craft, unsafe { settings.assume_init() })
}

/// Flies [`three_thruster_craft`] (true Izz `izz`) through the C ABI with `settings`: pulses
/// each way and along y, the yaw rate following Izz (torque 0.1 N m), with a small
/// deterministic noise; `between(block, k)` runs before sample `k` is pushed. The final solve.
fn fly_three_thruster_craft(
    settings: &MassidFlightIdSettings,
    izz: f32,
    mut between: impl FnMut(*mut MassidFlightId, u32),
) -> Result<MassidFlightIdResult, MassidStatus> {
    let (craft, _) = three_thruster_craft();
    let mut block: Box<MaybeUninit<MassidFlightId>> = Box::new(MaybeUninit::uninit());
    let b = block.as_mut_ptr();
    // SAFETY: an 8-aligned block of the type, a craft and settings.
    let st = unsafe { massid_f32_flight_id_init(b, &craft, settings) };
    if st != MassidStatus::Ok {
        return Err(st);
    }
    let mut rate = 0.0f32;
    let mut x = 7u32;
    for k in 0..6000u32 {
        between(b, k);
        let word: u16 = match (k / 50) % 6 {
            0 => 1,
            2 => 2,
            4 => 4,
            _ => 0,
        };
        x = x.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        let noise = 1e-3 * ((x >> 8) as f32 / (1u32 << 24) as f32 - 0.5);
        let r = [0.0, 0.0, rate + noise];
        // SAFETY: an initialised block and three floats.
        let st = unsafe { massid_f32_flight_id_push(b, 0.01, r.as_ptr(), 1, word) };
        assert_eq!(st, MassidStatus::Ok);
        // (lever x force about z: -0.1, +0.1 and -0.1 N m)
        let torque = match word {
            1 | 4 => -0.1,
            2 => 0.1,
            _ => 0.0,
        };
        rate += torque / izz * 0.01;
    }
    let mut out = MaybeUninit::<MassidFlightIdResult>::uninit();
    // SAFETY: an initialised block and a result slot.
    unsafe {
        assert_eq!(massid_f32_flight_id_finish(b), MassidStatus::Ok);
        let st = massid_f32_flight_id_solve(b, out.as_mut_ptr());
        if st != MassidStatus::Ok {
            return Err(st);
        }
        Ok(out.assume_init())
    }
}

/// The C ABI's settings carry each thruster's thrust uncertainty to the fit: the estimate is
/// unchanged, Izz's variance grows by about what a common thrust error of that size does to it
/// (a uniform thrust error is an inertia error), and a non-finite entry is refused.
#[test]
fn the_c_abi_carries_the_thrust_uncertainty() {
    let (_, defaults) = three_thruster_craft();
    assert_eq!(defaults.thrust_sigma_rel, [0.0; 16]);
    let run = |sigma: [f32; 16]| {
        // (Field assignment: struct-update syntax here made rustc 1.95 panic, "broken MIR".)
        let mut s = defaults;
        s.thrust_sigma_rel = sigma;
        fly_three_thruster_craft(&s, 0.25, |_, _| {})
    };
    let plain = run([0.0; 16]).expect("no uncertainty");
    let mut sigma = [0.0f32; 16];
    sigma[..3].copy_from_slice(&[0.05; 3]);
    let stated = run(sigma).expect("stated uncertainty");
    assert_eq!(plain.theta, stated.theta, "considering changes no estimate");
    // The y thruster's torque error looks like a CoM x shift (its lever is along x), so Jzz
    // rests on the two x thrusters, whose independent 5 % errors average over turns half
    // each way: Var(Jzz) grows by (0.05 Jzz)^2 / 2.
    let jzz = plain.theta[2];
    let grown = stated.covariance[2][2] - plain.covariance[2][2];
    let common = (0.05 * jzz).powi(2);
    assert!(
        grown > 0.4 * common && grown < 0.6 * common,
        "Var(Jzz) grew by {grown:e}; a common 5 % error gives {common:e}"
    );
    sigma[1] = f32::NAN;
    assert_eq!(run(sigma).err(), Some(MassidStatus::BadParameters));
}

/// A C caller re-anchors the f32 sums at its solve mid-flight (`massid_f32_flight_id_reanchor`):
/// on a craft 30 % heavier in yaw than its model, the final estimate is the one without
/// re-anchoring to within a hundredth of its sigma (the move is exact); a NULL theta and a
/// NaN one are refused and change nothing (the final solve bit for bit the plain one).
#[test]
fn the_c_abi_re_anchors_the_f32_sums() {
    let (_, settings) = three_thruster_craft();
    let izz = 0.325;
    let plain = fly_three_thruster_craft(&settings, izz, |_, _| {}).expect("plain");
    let moved = fly_three_thruster_craft(&settings, izz, |b, k| {
        if k == 1024 || k == 2048 || k == 4096 {
            let mut fit = MaybeUninit::<MassidFlightIdResult>::uninit();
            // SAFETY: an initialised block, a result slot, then nine floats.
            unsafe {
                assert_eq!(
                    massid_f32_flight_id_solve(b, fit.as_mut_ptr()),
                    MassidStatus::Ok
                );
                let theta = fit.assume_init().theta;
                assert_eq!(
                    massid_f32_flight_id_reanchor(b, theta.as_ptr()),
                    MassidStatus::Ok
                );
            }
        }
    })
    .expect("re-anchored");
    for m in [2, 6, 7] {
        let gap = (moved.theta[m] - plain.theta[m]) / plain.covariance[m][m].sqrt();
        assert!(gap.abs() < 0.01, "term {m}: {gap}");
    }
    assert!(
        (1.0 / plain.theta[2] - izz).abs() < 0.01 * izz,
        "{}",
        1.0 / plain.theta[2]
    );
    let refused = fly_three_thruster_craft(&settings, izz, |b, k| {
        if k == 3000 {
            // SAFETY: an initialised block; NULL, then nine floats.
            unsafe {
                assert_eq!(
                    massid_f32_flight_id_reanchor(b, std::ptr::null()),
                    MassidStatus::NullPointer
                );
                assert_eq!(
                    massid_f32_flight_id_reanchor(b, [f32::NAN; 9].as_ptr()),
                    MassidStatus::Overflow
                );
            }
        }
    })
    .expect("refused");
    assert_eq!(refused.theta, plain.theta);
    assert_eq!(refused.covariance, plain.covariance);
}

/// The ABI's layout is the one recorded for its version: every struct's size is checked
/// against `ABI_LAYOUTS`' row for `ABI_VERSION`, so a struct that changes size without a new
/// version (as `turn_weight` and `thrust_sigma_rel` once did) fails here; the C program
/// checks the version against its header's `MASSID_ABI_VERSION`
/// (`c_program_matches_the_rust_api_on_open_recordings`).
#[test]
fn the_abi_layout_is_the_one_recorded_for_its_version() {
    use massid_kernel::capi::{
        abi_layout_check, abi_sizes, massid_abi_version, AbiMismatch, ABI_LAYOUTS, ABI_VERSION,
    };
    let sizes = abi_sizes();
    assert_eq!(massid_abi_version(), ABI_VERSION);
    assert!(
        sizes.iter().all(|s| *s > 0),
        "every ABI type has a size: {sizes:?}"
    );
    assert_eq!(
        abi_layout_check(ABI_VERSION, &sizes),
        Ok(()),
        "an ABI struct changed size: raise ABI_VERSION (kernel/src/capi.rs and \
         MASSID_ABI_VERSION in massid_kernel.h) and add its row to ABI_LAYOUTS"
    );
    // Versions are distinct rows, the newest is this one.
    let versions: Vec<u32> = ABI_LAYOUTS.iter().map(|(v, _)| *v).collect();
    assert_eq!(versions.iter().max(), Some(&ABI_VERSION));
    // Planted: the settings struct (craft type 4, entry 12) one field longer, as
    // `thrust_sigma_rel` made it, is caught and named; so is a version with no row.
    let mut grown = sizes;
    grown[12] += 64;
    assert_eq!(
        abi_layout_check(ABI_VERSION, &grown),
        Err(AbiMismatch::Size {
            index: 12,
            recorded: sizes[12],
            now: sizes[12] + 64
        })
    );
    assert_eq!(
        abi_layout_check(ABI_VERSION + 1, &sizes),
        Err(AbiMismatch::UnknownVersion(ABI_VERSION + 1))
    );
}
