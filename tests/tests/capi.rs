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

/// Builds the static library and the C program; returns the program's path.
fn build_c_program() -> PathBuf {
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
