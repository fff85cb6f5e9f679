//! Converts a window of a `massid-recording/1` CSV into a compact binary blob embedded in the
//! firmware (6 bytes per sample: gyro x, y, z counts and the thruster word, four 12-bit values
//! packed little endian into 48 bits), so that the window fits the micro:bit's 256 KB flash.
//!
//! Inputs (environment, all optional):
//! - `MASSID_QEMU_RECORDING`: the CSV (default: `shared/data/open/o01_nominal_rga12.csv`
//!   beside the repository).
//! - `MASSID_QEMU_WINDOW_MS`: `START..END` in the recording's `time_ms` (default `900..10200`:
//!   five 1 s firings: the batch pair and three RLS firings, small enough for the micro:bit's 256 KB flash).
//!
//! - `MASSID_QEMU_COUNT`: `1` for the instruction-count image of `scripts/kernel-report.sh`
//!   (`sequence::COUNT_RUN`): it leaves out work that is not measured and would only make the
//!   trace long (the integer float's fit).
//!
//! The window must be gap-free (one sample per millisecond): the kernel is called once per
//! sample as by a 1 kHz interrupt, so a gap would silently change the sequence.
use std::env;
use std::fmt::Write as _;
use std::fs;
use std::path::PathBuf;

fn main() {
    println!("cargo:rerun-if-env-changed=MASSID_QEMU_RECORDING");
    println!("cargo:rerun-if-env-changed=MASSID_QEMU_WINDOW_MS");
    println!("cargo:rerun-if-env-changed=MASSID_QEMU_COUNT");
    let count_run = env::var("MASSID_QEMU_COUNT").is_ok_and(|v| v == "1");
    let manifest = PathBuf::from(env::var("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR"));
    let csv_path = env::var("MASSID_QEMU_RECORDING").map(PathBuf::from).unwrap_or_else(|_| {
        manifest.join("../../../../shared/data/open/o01_nominal_rga12.csv")
    });
    println!("cargo:rerun-if-changed={}", csv_path.display());
    let window = env::var("MASSID_QEMU_WINDOW_MS").unwrap_or_else(|_| "900..10200".to_string());
    let (start, end) = parse_window(&window).unwrap_or_else(|e| fail(&format!("MASSID_QEMU_WINDOW_MS={window:?}: {e}")));

    let text = fs::read_to_string(&csv_path)
        .unwrap_or_else(|e| fail(&format!("{}: cannot read: {e}", csv_path.display())));
    let mut blob = Vec::new();
    let mut satellite = String::from("sph2");
    let mut header_seen = false;
    let mut expected_time = start;
    for (index, line) in text.lines().enumerate() {
        let line_no = index + 1;
        let where_ = || format!("{}:{line_no}", csv_path.display());
        if let Some(meta) = line.strip_prefix('#') {
            if let Some((k, v)) = meta.split_once('=') {
                if k.trim() == "satellite" {
                    satellite = v.trim().to_string();
                }
            }
            continue;
        }
        if !header_seen {
            if line.trim() != "time_ms,gyro_x,gyro_y,gyro_z,accel_x,accel_y,accel_z,thrusters" {
                fail(&format!("{}: unexpected header {line:?}", where_()));
            }
            header_seen = true;
            continue;
        }
        let fields: Vec<&str> = line.trim().split(',').collect();
        if fields.len() != 8 {
            fail(&format!("{}: expected 8 fields, found {}", where_(), fields.len()));
        }
        let num = |i: usize| -> u32 {
            fields[i].parse::<u32>().unwrap_or_else(|_| fail(&format!("{}: field {} is not an integer: {:?}", where_(), i + 1, fields[i])))
        };
        let time = num(0);
        if time < start {
            continue;
        }
        if time >= end {
            break;
        }
        if time != expected_time {
            fail(&format!("{}: time_ms {time} but the window needs {expected_time} (gap or duplicate)", where_()));
        }
        expected_time += 1;
        let mut packed = 0u64;
        for (slot, i) in [1, 2, 3, 7].into_iter().enumerate() {
            let v = num(i);
            if v > 4095 {
                fail(&format!("{}: field {} = {v} is out of 0..4095", where_(), i + 1));
            }
            packed |= u64::from(v) << (12 * slot);
        }
        blob.extend_from_slice(&packed.to_le_bytes()[..6]);
    }
    if expected_time != end {
        fail(&format!("{}: the recording ends at {expected_time} ms, before the window end {end} ms", csv_path.display()));
    }
    let out = PathBuf::from(env::var("OUT_DIR").expect("cargo sets OUT_DIR"));
    fs::write(out.join("sequence.bin"), &blob).unwrap_or_else(|e| fail(&format!("writing sequence.bin: {e}")));
    let mut rs = String::new();
    let _ = writeln!(rs, "/// Recording the sequence was cut from.");
    let _ = writeln!(rs, "pub const SOURCE: &str = {:?};", csv_path.file_name().map(|f| f.to_string_lossy().into_owned()).unwrap_or_default());
    let _ = writeln!(rs, "/// Satellite named in the recording's metadata.");
    let _ = writeln!(rs, "pub const SATELLITE: &str = {satellite:?};");
    let _ = writeln!(rs, "/// `time_ms` of the first embedded sample.");
    let _ = writeln!(rs, "pub const START_MS: u32 = {start};");
    let _ = writeln!(rs, "/// Number of embedded samples (one per millisecond).");
    let _ = writeln!(rs, "pub const LEN: usize = {};", (end - start) as usize);
    let _ = writeln!(rs, "/// Built for the instruction-count trace (`MASSID_QEMU_COUNT=1`).");
    let _ = writeln!(rs, "pub const COUNT_RUN: bool = {count_run};");
    fs::write(out.join("sequence_meta.rs"), rs).unwrap_or_else(|e| fail(&format!("writing sequence_meta.rs: {e}")));
}

fn parse_window(s: &str) -> Result<(u32, u32), String> {
    let (a, b) = s.split_once("..").ok_or("expected START..END")?;
    let a: u32 = a.trim().parse().map_err(|_| "START is not an integer")?;
    let b: u32 = b.trim().parse().map_err(|_| "END is not an integer")?;
    if b <= a {
        return Err("END must be greater than START".into());
    }
    Ok((a, b))
}

fn fail(msg: &str) -> ! {
    eprintln!("massid-qemu-runner build: {msg}");
    std::process::exit(1)
}
