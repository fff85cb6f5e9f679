//! Issue 26 item 4: a proptest fuzz of every parser a user's file goes through: the
//! recording readers (format v1 and v2), the model file (`massid_sim::model_file`, with the
//! plausibility checks of issue 26) and the import mapping plus the log it drives. Each case
//! is a valid file with a few random edits (tokens inserted or substituted: extreme numbers,
//! separators, TOML syntax, metadata keys, lines deleted, duplicated or cut); the parser must
//! not panic, and an error must read `file:line: reason` (line >= 1 and within the file) or
//! `file: reason` (never `file:0:`).
//!
//! Size: [`CASES`] per parser, 5 parsers, 10^5 cases in all (measured in README.md).
use massid_sim::model_file::ModelFile;
use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};
use reference_f64::import::{import_reader, Mapping};
use reference_f64::rate_recording::RateRecording;
use reference_f64::recording::Recording;

/// Cases per parser (5 parsers): 10^5 in all.
const CASES: u32 = 20_000;

const TOKENS: &[&str] = &[
    "",
    "0",
    "-1",
    "1e308",
    "-1e308",
    "1e-320",
    "NaN",
    "inf",
    "4095",
    "4096",
    "65536",
    "18446744073709551616",
    "99999999999999999999999",
    "-0",
    "0x1F",
    "0b101",
    ",",
    ",,",
    "\n",
    "\r\n",
    "\r",
    "#",
    "# ",
    "=",
    " = ",
    "[",
    "]",
    "[[",
    "\"",
    "'",
    "{",
    "}",
    "é",
    "\u{feff}",
    "\u{0}",
    "\t",
    " ",
    "true",
    "false",
    "[1, 2]",
    "[]",
    "# format = massid-recording/1",
    "# format = massid-recording/2",
    "# format = massid-recording/3",
    "# sample_rate_hz = 1",
    "# sample_rate_hz = 1e308",
    "# sample_rate_hz = -5",
    "# axes = x,y,z",
    "# axes = q",
    "# thrusters = 17",
    "# thrusters = 0",
    "time_ms",
    "rate_z",
    "thrusters",
    "force_x",
    "satellite = \"sph2\"",
    "planar = true",
    "[[effects]]",
    "effect = \"thrust_scale\"",
    "params = { scale = [1e9] }",
    "params = { open_ms = 1e9, close_ms = 0 }",
    "effect = \"thruster_latency\"",
    "thrust_n = [0.0]",
    "inertia_kgm2 = [1e308, 1, 1, 0, 0, 0]",
    "sample_rate_hz = 1000",
    "sample_rate_hz = 0",
    "count = 17",
    "count = -1",
    "bitmask = \"x\"",
    "vector = \"Command_Vector\"",
    "unit = \"furlongs\"",
    "unit = \"deg/s\"",
    "[wrench]",
    "[thrusters]",
];

#[derive(Clone, Debug)]
enum Edit {
    Insert(u32, usize),
    Replace(u32, u8, usize),
    DeleteLine(u32),
    DuplicateLine(u32),
    Truncate(u32),
}

fn edit_strategy() -> impl Strategy<Value = Edit> {
    prop_oneof![
        4 => (any::<u32>(), 0..TOKENS.len()).prop_map(|(p, t)| Edit::Insert(p, t)),
        4 => (any::<u32>(), 1u8..12, 0..TOKENS.len()).prop_map(|(p, l, t)| Edit::Replace(p, l, t)),
        1 => any::<u32>().prop_map(Edit::DeleteLine),
        1 => any::<u32>().prop_map(Edit::DuplicateLine),
        1 => any::<u32>().prop_map(Edit::Truncate),
    ]
}

fn floor_boundary(s: &str, mut i: usize) -> usize {
    i = i.min(s.len());
    while !s.is_char_boundary(i) {
        i -= 1;
    }
    i
}

fn apply(text: &str, edits: &[Edit]) -> String {
    let mut s = text.to_string();
    for e in edits {
        let n = s.len().max(1) as u32;
        match *e {
            Edit::Insert(p, t) => {
                let i = floor_boundary(&s, (p % n) as usize);
                s.insert_str(i, TOKENS[t]);
            }
            Edit::Replace(p, l, t) => {
                let a = floor_boundary(&s, (p % n) as usize);
                let b = floor_boundary(&s, a + l as usize);
                s.replace_range(a..b, TOKENS[t]);
            }
            Edit::DeleteLine(p) | Edit::DuplicateLine(p) => {
                let mut lines: Vec<&str> = s.split_inclusive('\n').collect();
                if lines.is_empty() {
                    continue;
                }
                let k = (p as usize) % lines.len();
                if matches!(e, Edit::DeleteLine(_)) {
                    lines.remove(k);
                } else {
                    lines.insert(k, lines[k]);
                }
                s = lines.concat();
            }
            Edit::Truncate(p) => {
                let i = floor_boundary(&s, (p % n) as usize);
                s.truncate(i);
            }
        }
    }
    s
}

/// The error reads `file:line: reason` with 1 <= line <= lines + 1, or `file: reason`.
fn check_error(msg: &str, file: &str, lines: usize) -> Result<(), TestCaseError> {
    let rest = msg
        .strip_prefix(file)
        .ok_or_else(|| TestCaseError::fail(format!("error does not start with {file}: {msg}")))?;
    if let Some(r) = rest.strip_prefix(": ") {
        prop_assert!(!r.trim().is_empty(), "empty reason: {msg}");
        return Ok(());
    }
    let r = rest
        .strip_prefix(':')
        .ok_or_else(|| TestCaseError::fail(format!("no ':' after the file: {msg}")))?;
    let digits: String = r.chars().take_while(char::is_ascii_digit).collect();
    let line: usize = digits
        .parse()
        .map_err(|_| TestCaseError::fail(format!("no line number: {msg}")))?;
    prop_assert!(
        line >= 1 && line <= lines + 1,
        "line {line} outside 1..={}: {msg}",
        lines + 1
    );
    prop_assert!(
        r[digits.len()..].starts_with(": "),
        "no ': ' after the line: {msg}"
    );
    Ok(())
}

fn lines_of(s: &str) -> usize {
    // every line-ending convention a reader might count
    s.split(['\n', '\r']).count()
}

fn v1_text() -> String {
    let mut s = String::from(
        "# format = massid-recording/1\n# satellite = sph2\n# sample_rate_hz = 1000\ntime_ms,gyro_x,gyro_y,gyro_z,accel_x,accel_y,accel_z,thrusters\n",
    );
    for t in 0..30 {
        let w = if (10..20).contains(&t) { 2064 } else { 0 };
        s.push_str(&format!(
            "{t},{},2070,2058,2048,2049,2047,{w}\n",
            2077 + t % 3
        ));
    }
    s
}

fn v2_text() -> String {
    let mut s = String::from(
        "# format = massid-recording/2\n# satellite = airbearing-mpc\n# axes = z\n# thrusters = 8\n# sample_rate_hz = 16.667\ntime_ms,rate_z,thrusters\n",
    );
    for k in 0..30 {
        s.push_str(&format!(
            "{},{},{}\n",
            k * 60,
            0.26 + 0.001 * k as f64,
            (k * 37) % 256
        ));
    }
    s
}

fn repo_file(rel: &str) -> String {
    let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join(rel);
    std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

fn runner() -> TestRunner {
    let config = Config {
        cases: CASES,
        failure_persistence: None,
        ..Config::default()
    };
    // A fixed seed: the same cases every run (a failure names its input).
    TestRunner::new_with_rng(config, TestRng::from_seed(RngAlgorithm::ChaCha, &[26; 32]))
}

fn edits() -> impl Strategy<Value = Vec<Edit>> {
    prop::collection::vec(edit_strategy(), 1..6)
}

#[test]
fn recording_v1_reader() {
    let base = v1_text();
    runner()
        .run(&edits(), |e| {
            let text = apply(&base, &e);
            if let Err(err) = Recording::from_reader(text.as_bytes(), "fuzz.csv") {
                check_error(&err.to_string(), "fuzz.csv", lines_of(&text))?;
            }
            Ok(())
        })
        .unwrap();
}

#[test]
fn recording_v2_reader() {
    let base = v2_text();
    runner()
        .run(&edits(), |e| {
            let text = apply(&base, &e);
            if let Err(err) = RateRecording::from_reader(text.as_bytes(), "fuzz.csv") {
                check_error(&err.to_string(), "fuzz.csv", lines_of(&text))?;
            }
            Ok(())
        })
        .unwrap();
}

#[test]
fn model_file_reader() {
    let bases = [
        repo_file("examples/models/airbearing-mpc.toml"),
        repo_file("examples/models/sph2_latency.toml"),
        "satellite = \"sph2\"\n\n[[effects]]\neffect = \"thrust_scale\"\nparams = { scale = [1, 1, 1, 1, 1, 0.7, 1, 1, 1, 1, 1, 0] }\n\n[[effects]]\neffect = \"inertia\"\nparams = { inertia_kgm2 = [0.025, 0.022, 0.02, 0.0, 0.0, 0.0] }\n".to_string(),
    ];
    for b in &bases {
        ModelFile::parse(b, "fuzz.toml").expect("the seeds are valid");
    }
    runner()
        .run(&(0..bases.len(), edits()), |(b, e)| {
            let text = apply(&bases[b], &e);
            match ModelFile::parse(&text, "fuzz.toml") {
                Err(err) => check_error(&err.to_string(), "fuzz.toml", lines_of(&text))?,
                Ok(m) => {
                    // what was accepted is plausible, effects included
                    prop_assert!(m.satellite.check_plausible().is_ok());
                    for eff in &m.effects {
                        prop_assert!(eff.check_plausible(&m.satellite).is_ok());
                    }
                }
            }
            Ok(())
        })
        .unwrap();
}

#[test]
fn import_mapping_reader() {
    let base = repo_file("examples/import/airbearing-mpc.toml");
    let wrench = "satellite = \"t\"\nsample_rate_hz = 10\n[time]\ncolumn = \"t\"\nunit = \"s\"\n[rates]\nz = { column = \"w\", unit = \"deg/s\" }\n[wrench]\nforce_x = { column = \"Fx\", unit = \"N\" }\ntorque_z = { column = \"Tz\", unit = \"N m\" }\n".to_string();
    let bases = [base, wrench];
    for b in &bases {
        Mapping::parse(b, "fuzz.toml").expect("the seeds are valid");
    }
    runner()
        .run(&(0..bases.len(), edits()), |(b, e)| {
            let text = apply(&bases[b], &e);
            if let Err(err) = Mapping::parse(&text, "fuzz.toml") {
                check_error(&err.to_string(), "fuzz.toml", lines_of(&text))?;
            }
            Ok(())
        })
        .unwrap();
}

#[test]
fn import_log_reader() {
    let mapping = Mapping::parse(
        &repo_file("examples/import/airbearing-mpc.toml"),
        "map.toml",
    )
    .expect("the example mapping");
    let mut log = String::from("Control_Time,Current_Angular_Vel,Command_Vector\n");
    for k in 0..30 {
        log.push_str(&format!(
            "{:.2},{},\"[{}, 0, 1, 0, 0, 0, 0, {}]\"\n",
            k as f64 * 0.06,
            0.26 - 0.002 * k as f64,
            k % 2,
            (k / 3) % 2
        ));
    }
    import_reader(&mapping, log.as_bytes(), "log.csv").expect("the seed log imports");
    runner()
        .run(&edits(), |e| {
            let text = apply(&log, &e);
            if let Err(err) = import_reader(&mapping, text.as_bytes(), "log.csv") {
                let msg = err.to_string();
                // a contradiction with the mapping names the mapping, else the log
                if msg.starts_with("map.toml") {
                    check_error(&msg, "map.toml", 100)?;
                } else {
                    check_error(&msg, "log.csv", lines_of(&text))?;
                }
            }
            Ok(())
        })
        .unwrap();
}
