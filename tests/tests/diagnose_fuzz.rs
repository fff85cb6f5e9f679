//! Robustness fuzz of the mismatch diagnosis: `massid_diagnose::diagnose_recording` fed
//! random *valid* recordings (`contracts/recording-format.md`) must never panic, never
//! return an error for a non-empty recording, and must cost about the same whatever the
//! time stamps say (a telemetry gap is not work).
//!
//! Recordings are generated as `massid-recording/1` CSV text in memory (with the builders
//! of `massid_diagnose::rows`, shared with `diagnose/tests/no_panic_fuzz.rs`) and parsed with
//! `reference_f64::recording::Recording::from_reader`, the path `massid diagnose` takes
//! (so duplicate rows reach the reader as they would in a file). Each case runs under
//! `catch_unwind` on its own thread with a time limit; failures are collected with their
//! family and seed and reported together at the end.
//!
//! Tests:
//! - `diagnosis_never_panics_on_valid_recordings`: the case families below, in process.
//! - `huge_time_gaps_do_not_panic_or_allocate`: forward jumps of 1e9 and 1e11 ms (and a
//!   first sample that late). Each case runs in a child process (this test binary run
//!   again on that one case) under an address-space limit, so an allocation proportional
//!   to the gap is reported as a failure instead of aborting the whole binary or
//!   exhausting the machine.
//! - `gaps_cost_like_no_gaps`: one 10 s recording as is, with a 1e11 ms jump in the middle,
//!   with a 1-hour gap in the middle; the gapped ones may take at most 3x + 1 s of the
//!   plain one (child processes too).
//!
//! Environment:
//! - `MASSID_FUZZ_CASES`: number of in-process cases (default [`DEFAULT_CASES`]);
//! - `MASSID_FUZZ_SEED`: base seed (case i uses seed base + i);
//! - `MASSID_FUZZ_REPLAY=family:seed[,family:seed...]`: run only those cases
//!   (family names as printed in a failure, e.g. `rail-axis-part:1234`);
//! - `MASSID_FUZZ_CASE_TIMEOUT_S`: per-case wall-time limit (default 60 s);
//! - `MASSID_FUZZ_CHILD_MEM_MB`: address-space limit of the child processes (default 1024).

use massid_diagnose::rows::{
    csv_text, has_usable_gyro, jump_forward, parse_recording, quiet_samples, random_pulses,
    regular_times, set_gyro, set_word, simulated_samples, with_duplicates,
};
use massid_diagnose::{diagnose_recording, report, Settings};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use reference_f64::recording::{Sample, MAX_COUNT};
use reference_f64::satellite::Satellite;
use std::cell::RefCell;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::io::Read;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::process::{Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// In-process cases when `MASSID_FUZZ_CASES` is not set: three of each family, chosen so
/// the test stays under about a minute in the test profile (opt-level 2) on the shared
/// 2-core machine, run beside this file's two other tests (52 cases took 40 s alone and
/// 60 s beside them, at load average 3).
const DEFAULT_CASES: usize = 39;
const DEFAULT_SEED: u64 = 0x00d1_a9f0_5eed;
const SATELLITES: [&str; 5] = ["sph1", "sph2", "sph3", "sph4", "sph5"];
/// Sample rates of the small recordings (1000 Hz twice as likely).
const RATES: [u32; 5] = [1000, 1000, 500, 100, 50];
const ONE_HOUR_MS: u64 = 3_600_000;
const CHILD_ENV: &str = "MASSID_FUZZ_CHILD";
const RESULT_TAG: &str = "MASSID_FUZZ_CHILD_RESULT";

// ------------------------------------------------------------------------------------
// Case families.
// ------------------------------------------------------------------------------------

/// The in-process case families (the huge gaps have their own test).
const FAMILIES: &[&str] = &[
    "rail-axis-all",
    "rail-axis-part",
    "all-saturated",
    "stuck-axis",
    "declared-100hz-steps-1ms",
    "declared-1000hz-steps-10ms",
    "no-firings",
    "all-thrusters-on",
    "random-pulses",
    "very-short",
    "one-hour-gap",
    "duplicates",
    "mixed",
];

/// One generated recording: CSV text plus what it is, for the failure list.
pub struct Built {
    pub family: String,
    pub seed: u64,
    pub satellite: String,
    pub text: String,
    pub desc: String,
}

fn pick<T: Copy>(rng: &mut ChaCha8Rng, xs: &[T]) -> T {
    xs[rng.gen_range(0..xs.len())]
}

/// A base recording of `n` samples every `step_ms`: quiet or simulated content, some
/// with random pulses.
fn base(
    sat_name: &str,
    sat: &Satellite,
    rate: u32,
    n: usize,
    step_ms: u64,
    rng: &mut ChaCha8Rng,
    d: &mut String,
) -> Vec<Sample> {
    let t0 = if rng.gen_bool(0.7) {
        0
    } else {
        rng.gen_range(1..5000)
    };
    let simulated = step_ms == (1000 / rate) as u64 && t0 == 0 && rng.gen_bool(0.3);
    let mut v = if simulated {
        write!(d, " simulated").unwrap();
        simulated_samples(sat_name, rate, n, rng.gen())
    } else {
        write!(d, " quiet t0={t0}").unwrap();
        let mut v = quiet_samples(sat, &regular_times(n, step_ms, t0), rng);
        if rng.gen_bool(0.6) {
            let p = pick(rng, &[0.005, 0.02, 0.1, 0.5]);
            write!(d, " pulses(p={p})").unwrap();
            random_pulses(&mut v, p, rng);
        }
        v
    };
    v.truncate(n);
    v
}

fn random_range(n: usize, rng: &mut ChaCha8Rng) -> std::ops::Range<usize> {
    let a = rng.gen_range(0..n);
    let b = rng.gen_range(a + 1..=n);
    a..b
}

/// Builds case `family` from `seed` (deterministic: the pair reproduces the case).
pub fn build_case(family: &str, seed: u64) -> Built {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let rng = &mut rng;
    let sat_name = pick(rng, &SATELLITES);
    let sat = Satellite::builtin(sat_name).unwrap();
    let mut rate = pick(rng, &RATES);
    // 50..2000 samples, log-uniform (most cases small, so each diagnosis is fast)
    let mut n = (50.0f64 * 40f64.powf(rng.gen::<f64>())).round() as usize;
    let mut step = (1000 / rate) as u64;
    let mut declared = if rng.gen_bool(0.8) {
        Some(rate as f64)
    } else {
        None
    };
    match family {
        "declared-100hz-steps-1ms" => {
            rate = 1000;
            step = 1;
            declared = Some(100.0);
        }
        "declared-1000hz-steps-10ms" => {
            rate = 100;
            step = 10;
            declared = Some(1000.0);
        }
        "very-short" => n = pick(rng, &[1, 2, 5]),
        _ => {}
    }
    let mut d = format!("{sat_name} n={n} step={step}ms declared={declared:?}");
    let mut v = base(sat_name, &sat, rate, n, step, rng, &mut d);
    let fam = if family == "mixed" {
        let k = rng.gen_range(2..=3);
        let parts: Vec<&str> = (0..k)
            .map(|_| pick(rng, &FAMILIES[..FAMILIES.len() - 1]))
            .collect();
        write!(d, " mixed{parts:?}").unwrap();
        parts
    } else {
        vec![family]
    };
    let mut dup_rows = 0;
    for f in fam {
        let n = v.len();
        match f {
            "rail-axis-all" | "rail-axis-part" => {
                let axis = rng.gen_range(0..3);
                let count = pick(rng, &[0, MAX_COUNT]);
                let r = if f == "rail-axis-all" {
                    0..n
                } else {
                    random_range(n, rng)
                };
                write!(d, " gyro[{axis}]={count} on {r:?}").unwrap();
                set_gyro(&mut v, axis, r, count);
            }
            "all-saturated" => {
                let how = rng.gen_range(0..4);
                write!(d, " saturated(kind {how})").unwrap();
                for s in &mut v {
                    match how {
                        0 => s.gyro = std::array::from_fn(|_| pick(rng, &[0, MAX_COUNT])),
                        1 => s.gyro = [MAX_COUNT; 3],
                        2 => s.gyro = [0; 3],
                        _ => s.accel[rng.gen_range(0..3)] = pick(rng, &[0, MAX_COUNT]),
                    }
                }
            }
            "stuck-axis" => {
                let axis = rng.gen_range(0..3);
                let count = if rng.gen_bool(0.5) {
                    sat.gyro_bias_counts[axis].round() as u16
                } else {
                    rng.gen_range(1..MAX_COUNT)
                };
                let r = if rng.gen_bool(0.5) {
                    0..n
                } else {
                    random_range(n, rng)
                };
                write!(d, " gyro[{axis}] stuck at {count} on {r:?}").unwrap();
                set_gyro(&mut v, axis, r, count);
            }
            "no-firings" => {
                d.push_str(" no firings");
                set_word(&mut v, 0..n, 0);
            }
            "all-thrusters-on" => {
                d.push_str(" all 12 on");
                set_word(&mut v, 0..n, 0x0fff);
            }
            "random-pulses" | "declared-100hz-steps-1ms" | "declared-1000hz-steps-10ms" => {
                let p = pick(rng, &[0.01, 0.05, 0.2, 1.0]);
                write!(d, " random pulses p={p}").unwrap();
                random_pulses(&mut v, p, rng);
            }
            "very-short" => {
                if rng.gen_bool(0.5) {
                    random_pulses(&mut v, 0.5, rng);
                }
                if rng.gen_bool(0.3) {
                    set_gyro(
                        &mut v,
                        rng.gen_range(0..3),
                        0..n,
                        pick(rng, &[0, MAX_COUNT]),
                    );
                }
            }
            "one-hour-gap" => {
                let at = if n > 1 { rng.gen_range(1..n) } else { 0 };
                write!(d, " +1h jump before sample {at}").unwrap();
                jump_forward(&mut v, at, ONE_HOUR_MS);
            }
            "duplicates" => dup_rows += rng.gen_range(1..=20),
            other => panic!("unknown family {other}"),
        }
    }
    if dup_rows > 0 {
        write!(d, " {dup_rows} duplicate rows").unwrap();
        v = with_duplicates(&v, dup_rows, rng);
    }
    let text = csv_text(Some(sat_name), declared, &v);
    Built {
        family: family.to_string(),
        seed,
        satellite: sat_name.to_string(),
        text,
        desc: d,
    }
}

/// A case of the huge-gap family: `kind` is `jump-1e9`, `jump-1e11` (one forward jump in
/// the middle) or `late-start-1e9`, `late-start-1e11` (the first sample already that late);
/// `jump-none` / `late-start-none` is the same recording without the gap (for comparing
/// costs by hand: `MASSID_FUZZ_CHILD=late-start-none:SEED <test binary>
/// huge_time_gaps_do_not_panic_or_allocate --exact --nocapture`).
pub fn build_huge_gap_case(kind: &str, seed: u64) -> Built {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let rng = &mut rng;
    let sat_name = pick(rng, &SATELLITES);
    let sat = Satellite::builtin(sat_name).unwrap();
    let rate = pick(rng, &RATES);
    let n = rng.gen_range(50..=1000);
    let step = (1000 / rate) as u64;
    let gap: u64 = match kind.rsplit_once('-').map(|(_, g)| g) {
        Some("1e11") => 100_000_000_000,
        Some("1e9") => 1_000_000_000,
        Some("none") => 0,
        _ => panic!("huge-gap kind {kind}: expected jump-|late-start- then 1e9|1e11|none"),
    };
    let mut v = quiet_samples(&sat, &regular_times(n, step, 0), rng);
    random_pulses(&mut v, 0.05, rng);
    let at = if kind.starts_with("jump") {
        rng.gen_range(1..n)
    } else {
        0
    };
    jump_forward(&mut v, at, gap);
    let desc = format!("{sat_name} n={n} step={step}ms, +{gap} ms before sample {at}");
    let text = csv_text(Some(sat_name), Some(rate as f64), &v);
    Built {
        family: kind.to_string(),
        seed,
        satellite: sat_name.to_string(),
        text,
        desc,
    }
}

// ------------------------------------------------------------------------------------
// Running a case: catch_unwind on a worker thread, the panic message and location
// captured by a panic hook (and not printed), a wall-time limit.
// ------------------------------------------------------------------------------------

thread_local! {
    static CAPTURED: RefCell<Option<Vec<String>>> = const { RefCell::new(None) };
}

fn install_capturing_hook() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            let capturing = CAPTURED.with(|c| c.borrow().is_some());
            if !capturing {
                return previous(info);
            }
            let msg = info
                .payload()
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| info.payload().downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "<non-string panic payload>".to_string());
            let loc = info
                .location()
                .map(|l| format!("{}:{}", l.file(), l.line()))
                .unwrap_or_default();
            // the innermost frame in the workspace (the location of a panic inside std or
            // a dependency is not where the bug is)
            let bt = std::backtrace::Backtrace::force_capture().to_string();
            let frame = workspace_frame(&bt.lines().map(str::trim).collect::<Vec<_>>());
            let mut s = format!("panicked at {loc}: {msg}");
            if let Some(f) = frame.filter(|f| !f.ends_with(&loc)) {
                write!(s, " (innermost workspace frame {f})").unwrap();
            }
            CAPTURED.with(|c| c.borrow_mut().as_mut().unwrap().push(s));
        }));
    });
}

/// The innermost frame of a printed backtrace that is workspace code (not std, not a
/// dependency, not this file), as `path:line`.
fn workspace_frame(lines: &[&str]) -> Option<String> {
    lines
        .iter()
        .filter_map(|l| l.strip_prefix("at "))
        .find(|l| {
            !l.contains("/rustc/") && !l.contains("/.cargo/") && !l.contains("diagnose_fuzz.rs")
        })
        .map(|l| {
            l.rsplit_once(':')
                .map(|(f, _col)| f)
                .unwrap_or(l)
                .to_string()
        })
}

/// What a case came to.
#[derive(Clone, Debug)]
pub enum Outcome {
    Ok { seconds: f64, refused: bool },
    Failed { what: String, seconds: f64 },
}

/// How a diagnosis that did not panic ended.
enum Ended {
    Diagnosed,
    /// An error for a recording without usable gyro data: allowed, counted.
    Refused,
}

/// Parses and diagnoses `b` (what `massid diagnose --json --report` does, short of the
/// files): the reader, `diagnose_recording`, the summary and the JSON. Err: a failure
/// other than a panic (an error where usable data exist, an inconsistent output).
fn diagnose_text(b: &Built) -> Result<Ended, String> {
    let rec = parse_recording(&b.text, &format!("{}-{}.csv", b.family, b.seed));
    let sat = Satellite::builtin(&b.satellite).unwrap();
    match diagnose_recording(&rec, &sat, &Settings::default()) {
        Ok(a) => {
            let _ = report::summary(&a);
            serde_json::to_string_pretty(&a.output).map_err(|e| format!("JSON: {e}"))?;
            if a.output.samples != rec.samples.len() as u64 {
                return Err(format!(
                    "output.samples {} != {} samples",
                    a.output.samples,
                    rec.samples.len()
                ));
            }
            Ok(Ended::Diagnosed)
        }
        Err(e)
            if !has_usable_gyro(&rec.samples)
                && !rec.samples.is_empty()
                && !e.to_string().contains("no samples") =>
        {
            Ok(Ended::Refused)
        }
        Err(e) => Err(format!(
            "returned Err on a valid recording of {} samples with usable gyro data: {e}",
            rec.samples.len()
        )),
    }
}

/// Runs `diagnose_text(b)` under `catch_unwind` on its own thread; a case still running
/// after `timeout` is reported and its thread left behind.
fn run_in_thread(b: Built, timeout: Duration) -> Outcome {
    install_capturing_hook();
    let (tx, rx) = mpsc::channel();
    let start = Instant::now();
    std::thread::Builder::new()
        .name(format!("fuzz-{}-{}", b.family, b.seed))
        .stack_size(16 << 20)
        .spawn(move || {
            CAPTURED.with(|c| *c.borrow_mut() = Some(Vec::new()));
            let r = catch_unwind(AssertUnwindSafe(|| diagnose_text(&b)));
            let panics = CAPTURED.with(|c| c.borrow_mut().take().unwrap_or_default());
            let _ = tx.send(match r {
                Ok(Ok(ended)) => Ok(ended),
                Ok(Err(e)) => Err(e),
                Err(_) => Err(panics
                    .last()
                    .cloned()
                    .unwrap_or_else(|| "panicked (no message captured)".into())),
            });
        })
        .expect("spawn case thread");
    match rx.recv_timeout(timeout) {
        Ok(Ok(ended)) => Outcome::Ok {
            seconds: start.elapsed().as_secs_f64(),
            refused: matches!(ended, Ended::Refused),
        },
        Ok(Err(what)) => Outcome::Failed {
            what,
            seconds: start.elapsed().as_secs_f64(),
        },
        Err(_) => Outcome::Failed {
            what: format!(
                "still running after {} s (timeout; thread left running)",
                timeout.as_secs()
            ),
            seconds: timeout.as_secs_f64(),
        },
    }
}

fn env_u64(key: &str) -> Option<u64> {
    let v = std::env::var(key).ok()?;
    let v = v.trim();
    let parsed = match v.strip_prefix("0x") {
        Some(h) => u64::from_str_radix(h, 16),
        None => v.parse(),
    };
    Some(parsed.unwrap_or_else(|_| panic!("{key}={v} is not an integer")))
}

fn case_timeout() -> Duration {
    Duration::from_secs(env_u64("MASSID_FUZZ_CASE_TIMEOUT_S").unwrap_or(60))
}

/// A failed case, for the report.
struct Failure {
    family: String,
    seed: u64,
    desc: String,
    what: String,
}

/// `s` with every run of 6 or more digits replaced by `N`.
fn long_numbers_elided(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    let mut digits = String::new();
    for c in s.chars().chain(std::iter::once(' ')) {
        if c.is_ascii_digit() {
            digits.push(c);
            continue;
        }
        out.push_str(if digits.len() >= 6 { "N" } else { &digits });
        digits.clear();
        out.push(c);
    }
    out.pop();
    out
}

/// One line per distinct (family, failure) with how many cases and the first seed, then
/// every failing case.
fn failure_report(fails: &[Failure], ran: usize) -> String {
    let mut groups: BTreeMap<(String, String), (usize, u64)> = BTreeMap::new();
    for f in fails {
        // sizes and times differ between cases of one failure; line numbers (< 6 digits) stay
        let key = (f.family.clone(), long_numbers_elided(&f.what));
        let e = groups.entry(key).or_insert((0, f.seed));
        e.0 += 1;
    }
    let mut s = format!(
        "{} of {ran} cases failed; {} distinct (family, failure):\n",
        fails.len(),
        groups.len()
    );
    for ((fam, what), (count, seed)) in &groups {
        writeln!(
            s,
            "  [{fam}] x{count} (e.g. MASSID_FUZZ_REPLAY={fam}:{seed}): {what}"
        )
        .unwrap();
    }
    s.push_str("cases:\n");
    for f in fails {
        writeln!(s, "  {}:{} {} -> {}", f.family, f.seed, f.desc, f.what).unwrap();
    }
    s
}

#[test]
fn diagnosis_never_panics_on_valid_recordings() {
    let timeout = case_timeout();
    let cases: Vec<(String, u64)> = match std::env::var("MASSID_FUZZ_REPLAY") {
        Ok(list) => list
            .split(',')
            .map(|c| {
                let (f, s) = c
                    .trim()
                    .rsplit_once(':')
                    .expect("MASSID_FUZZ_REPLAY=family:seed");
                (f.to_string(), s.parse().expect("seed"))
            })
            .collect(),
        Err(_) => {
            let n = env_u64("MASSID_FUZZ_CASES")
                .map(|n| n as usize)
                .unwrap_or(DEFAULT_CASES);
            let base = env_u64("MASSID_FUZZ_SEED").unwrap_or(DEFAULT_SEED);
            (0..n)
                .map(|i| {
                    (
                        FAMILIES[i % FAMILIES.len()].to_string(),
                        base.wrapping_add(i as u64),
                    )
                })
                .collect()
        }
    };
    let start = Instant::now();
    let mut fails = Vec::new();
    let mut timed_out: Vec<String> = Vec::new();
    // family -> (cases, seconds, max seconds, refused, failed)
    let mut per_family: BTreeMap<String, (usize, f64, f64, usize, usize)> = BTreeMap::new();
    let mut ran = 0;
    let mut skipped = 0;
    for (family, seed) in cases {
        if timed_out.contains(&family) {
            // its timed-out case is still running; more of the same would pile up
            skipped += 1;
            continue;
        }
        if family.starts_with("jump-") || family.starts_with("late-start-") {
            panic!("{family} is a huge-gap case: replay it with the huge_time_gaps test");
        }
        let b = build_case(&family, seed);
        let desc = b.desc.clone();
        let outcome = run_in_thread(b, timeout);
        ran += 1;
        let (seconds, refused, failed) = match &outcome {
            Outcome::Ok { seconds, refused } => (*seconds, *refused, false),
            Outcome::Failed { what, seconds } => {
                eprintln!("FAIL {family}:{seed} {desc}\n     {what}");
                if what.contains("timeout") {
                    timed_out.push(family.clone());
                }
                fails.push(Failure {
                    family: family.clone(),
                    seed,
                    desc,
                    what: what.clone(),
                });
                (*seconds, false, true)
            }
        };
        let e = per_family.entry(family).or_insert((0, 0.0, 0.0, 0, 0));
        e.0 += 1;
        e.1 += seconds;
        e.2 = e.2.max(seconds);
        e.3 += refused as usize;
        e.4 += failed as usize;
    }
    let total = start.elapsed().as_secs_f64();
    println!("diagnose fuzz: {ran} cases run ({skipped} skipped after a timeout) in {total:.1} s");
    for (f, (n, sum, max, refused, failed)) in &per_family {
        println!(
            "  {f:<28} {n:>4} cases, {failed:>3} failed, {refused:>3} refused (no usable gyro data), mean {:.2} s, max {max:.2} s",
            sum / *n as f64
        );
    }
    assert!(fails.is_empty(), "{}", failure_report(&fails, ran));
}

// ------------------------------------------------------------------------------------
// Child processes: the cases that may abort the process (an allocation proportional to
// a huge gap aborts, it does not panic) run in this test binary started again on one
// case, under an address-space limit.
// ------------------------------------------------------------------------------------

/// In a child: which case to run (`None` in the parent).
fn child_case() -> Option<String> {
    std::env::var(CHILD_ENV).ok()
}

/// Reports a child's result on stdout for the parent.
fn child_report(r: &Result<f64, String>) {
    match r {
        Ok(s) => println!("{RESULT_TAG}\tok\t{s}\t"),
        Err(e) => println!("{RESULT_TAG}\tfail\t0\t{}", e.replace(['\n', '\t'], " ")),
    }
}

/// Runs `diagnose_text(b)` in the child under catch_unwind; the seconds of the diagnosis.
fn child_run(b: Built) -> Result<f64, String> {
    install_capturing_hook();
    CAPTURED.with(|c| *c.borrow_mut() = Some(Vec::new()));
    let start = Instant::now();
    let r = catch_unwind(AssertUnwindSafe(|| diagnose_text(&b)));
    let seconds = start.elapsed().as_secs_f64();
    let panics = CAPTURED.with(|c| c.borrow_mut().take().unwrap_or_default());
    match r {
        Ok(Ok(_)) => Ok(seconds),
        Ok(Err(e)) => Err(e),
        Err(_) => Err(panics
            .last()
            .cloned()
            .unwrap_or_else(|| "panicked (no message captured)".into())),
    }
}

/// Starts this test binary on test `test_name`, case `case`, with the address space
/// limited to `MASSID_FUZZ_CHILD_MEM_MB` (default 1024 MB) and killed after `timeout`.
/// Ok(seconds the child measured) or Err(why, including an abort's stderr).
fn run_child(test_name: &str, case: &str, timeout: Duration) -> Result<f64, String> {
    let exe = std::env::current_exe().expect("current exe");
    let mem_kb = env_u64("MASSID_FUZZ_CHILD_MEM_MB").unwrap_or(1024) * 1024;
    let mut child = Command::new("sh")
        .arg("-c")
        .arg(format!("ulimit -v {mem_kb} && exec \"$0\" \"$@\""))
        .arg(&exe)
        .args([
            test_name,
            "--exact",
            "--nocapture",
            "--test-threads=1",
            "-q",
        ])
        .env(CHILD_ENV, case)
        .env("RUST_BACKTRACE", "1")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start child test process");
    // drain the pipes on threads so a chatty child cannot block
    let mut out_pipe = child.stdout.take().unwrap();
    let mut err_pipe = child.stderr.take().unwrap();
    let out_t = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = out_pipe.read_to_string(&mut s);
        s
    });
    let err_t = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = err_pipe.read_to_string(&mut s);
        s
    });
    let start = Instant::now();
    let status = loop {
        if let Some(st) = child.try_wait().expect("wait child") {
            break Some(st);
        }
        if start.elapsed() > timeout {
            let _ = child.kill();
            let _ = child.wait();
            break None;
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let out = out_t.join().unwrap_or_default();
    let err = err_t.join().unwrap_or_default();
    if let Some(line) = out.lines().find(|l| l.starts_with(RESULT_TAG)) {
        let f: Vec<&str> = line.splitn(4, '\t').collect();
        return match f.get(1) {
            Some(&"ok") => Ok(f.get(2).and_then(|s| s.parse().ok()).unwrap_or(0.0)),
            _ => Err(f.get(3).unwrap_or(&"").to_string()),
        };
    }
    // the abort message, and where it came from (the child runs with RUST_BACKTRACE=1)
    let lines: Vec<&str> = err
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .collect();
    let mut tail = lines
        .iter()
        .filter(|l| {
            !l.starts_with("note:")
                && !l.starts_with("at ")
                && !l.starts_with("stack backtrace")
                && !l.chars().next().is_some_and(|c| c.is_ascii_digit())
        })
        .take(3)
        .copied()
        .collect::<Vec<_>>()
        .join(" | ");
    if let Some(frame) = workspace_frame(&lines) {
        write!(tail, " (innermost workspace frame {frame})").unwrap();
    }
    match status {
        None => Err(format!(
            "still running after {:.0} s (child killed); stderr: {tail}",
            timeout.as_secs_f64()
        )),
        Some(st) => {
            use std::os::unix::process::ExitStatusExt;
            let how = match st.signal() {
                Some(6) => "process aborted (SIGABRT)".to_string(),
                Some(9) => "process killed (SIGKILL, out of memory?)".to_string(),
                Some(sig) => format!("process killed by signal {sig}"),
                None => format!("process exited with {st} and no result"),
            };
            Err(format!(
                "{how} [address space limited to {} MB]; stderr: {tail}",
                mem_kb / 1024
            ))
        }
    }
}

const HUGE_GAP_KINDS: [&str; 4] = ["jump-1e9", "jump-1e11", "late-start-1e9", "late-start-1e11"];

#[test]
fn huge_time_gaps_do_not_panic_or_allocate() {
    const NAME: &str = "huge_time_gaps_do_not_panic_or_allocate";
    if let Some(case) = child_case() {
        let (kind, seed) = case.rsplit_once(':').expect("kind:seed");
        child_report(&child_run(build_huge_gap_case(kind, seed.parse().unwrap())));
        return;
    }
    let base = env_u64("MASSID_FUZZ_SEED").unwrap_or(DEFAULT_SEED);
    let timeout = case_timeout();
    let start = Instant::now();
    let mut fails = Vec::new();
    let mut ran = 0;
    for rep in 0..2u64 {
        for (i, kind) in HUGE_GAP_KINDS.iter().enumerate() {
            let seed = base.wrapping_add(1000 + 10 * rep + i as u64);
            let desc = build_huge_gap_case(kind, seed).desc;
            ran += 1;
            match run_child(NAME, &format!("{kind}:{seed}"), timeout) {
                Ok(s) => println!("  {kind}:{seed} {desc}: ok in {s:.2} s"),
                Err(what) => {
                    eprintln!("FAIL {kind}:{seed} {desc}\n     {what}");
                    fails.push(Failure {
                        family: kind.to_string(),
                        seed,
                        desc,
                        what,
                    });
                }
            }
        }
    }
    println!(
        "huge gaps: {ran} cases run (one child process each) in {:.1} s",
        start.elapsed().as_secs_f64()
    );
    assert!(fails.is_empty(), "{}", failure_report(&fails, ran));
}

/// The 10 s recording of `gaps_cost_like_no_gaps`: sph2 flying random PWM at 1 kHz, as
/// is (`plain`), with a 1e11 ms jump (`jump-1e11`) or a 1-hour gap (`gap-1h`) in the middle.
fn gap_cost_case(variant: &str) -> Built {
    let mut v = simulated_samples("sph2", 1000, 10_000, 77);
    let mid = v.len() / 2;
    match variant {
        "plain" => {}
        "jump-1e11" => jump_forward(&mut v, mid, 100_000_000_000),
        "gap-1h" => jump_forward(&mut v, mid, ONE_HOUR_MS),
        other => panic!("unknown variant {other}"),
    }
    let text = csv_text(Some("sph2"), Some(1000.0), &v);
    Built {
        family: variant.to_string(),
        seed: 77,
        satellite: "sph2".into(),
        text,
        desc: format!("sph2 10 s 1 kHz {variant}"),
    }
}

#[test]
fn gaps_cost_like_no_gaps() {
    const NAME: &str = "gaps_cost_like_no_gaps";
    if let Some(variant) = child_case() {
        child_report(&child_run(gap_cost_case(&variant)));
        return;
    }
    let plain = run_child(NAME, "plain", Duration::from_secs(300))
        .unwrap_or_else(|e| panic!("plain recording: {e}"));
    let limit = 3.0 * plain + 1.0;
    println!("gaps cost: plain 10 s recording diagnosed in {plain:.2} s; limit for the gapped ones {limit:.2} s");
    let mut problems = Vec::new();
    for variant in ["jump-1e11", "gap-1h"] {
        // let it run past the limit (to say how slow) but not forever
        let kill_after = Duration::from_secs_f64(2.0 * limit + 10.0);
        match run_child(NAME, variant, kill_after) {
            Ok(s) if s <= limit => println!("  {variant}: {s:.2} s"),
            Ok(s) => problems.push(format!(
                "{variant}: {s:.2} s > {limit:.2} s (3 x plain + 1 s)"
            )),
            Err(e) => problems.push(format!("{variant}: {e}")),
        }
    }
    assert!(
        problems.is_empty(),
        "gapped recordings (plain took {plain:.2} s):\n  {}",
        problems.join("\n  ")
    );
}
