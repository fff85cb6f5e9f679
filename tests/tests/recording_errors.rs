//! Bad recordings: every error class of `contracts/recording-format.md` gives an error
//! naming the file, the line and the reason, never a panic (a proptest fuzz backs it);
//! round trips of recordings and satellite model files.
use massid_tests::open_data_dir;
use proptest::prelude::*;
use reference_f64::recording::{Recording, RecordingReader};
use reference_f64::satellite::Satellite;
use std::path::PathBuf;

const HEADER: &str = "time_ms,gyro_x,gyro_y,gyro_z,accel_x,accel_y,accel_z,thrusters";
const FORMAT: &str = "# format = massid-recording/1";

fn scratch_dir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("massid-recerr-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn each_error_class_names_file_line_and_reason() {
    let dir = scratch_dir("classes");
    // (contract error class, file content, line, words the reason must contain)
    let cases: Vec<(&str, String, usize, &str)> = vec![
        ("empty file", String::new(), 1, "empty file"),
        (
            "missing format key",
            format!("# satellite = sph2\n{HEADER}\n0,1,2,3,4,5,6,0\n"),
            2,
            "missing 'format'",
        ),
        (
            "unknown format version",
            format!("# format = massid-recording/7\n{HEADER}\n"),
            1,
            "unknown format version",
        ),
        (
            "missing header column",
            format!("{FORMAT}\ntime_ms,gyro_x,gyro_y,gyro_z,accel_x,accel_y,thrusters\n"),
            2,
            "missing header column(s): accel_z",
        ),
        (
            "unknown header column",
            format!("{FORMAT}\n{HEADER},temp\n"),
            2,
            "unknown header column 'temp'",
        ),
        (
            "non-integer field",
            format!("{FORMAT}\n{HEADER}\n0,1,2,3,4,5,6,0\n1,1,2.5,3,4,5,6,0\n"),
            4,
            "gyro_y '2.5' is not an integer",
        ),
        (
            "out-of-range field",
            format!("{FORMAT}\n{HEADER}\n0,1,2,3,4,5,6,4096\n"),
            3,
            "thrusters 4096 is out of range",
        ),
        (
            "time going backwards",
            format!("{FORMAT}\n{HEADER}\n10,1,2,3,4,5,6,0\n9,1,2,3,4,5,6,0\n"),
            4,
            "time_ms goes backwards",
        ),
        (
            "wrong number of fields",
            format!("{FORMAT}\n{HEADER}\n0,1,2,3,4,5,6,0\n1,1,2,3\n"),
            4,
            "row has 4 fields",
        ),
    ];
    for (class, text, line, reason) in cases {
        let path = dir.join(format!("{}.csv", class.replace(' ', "_")));
        std::fs::write(&path, &text).unwrap();
        let before = std::fs::read(&path).unwrap();
        let e = Recording::read(&path).expect_err(class);
        let shown = e.to_string();
        assert_eq!(e.file, path.display().to_string(), "{class}");
        assert_eq!(e.line, line, "{class}: {shown}");
        assert!(e.reason.contains(reason), "{class}: {shown}");
        assert!(
            shown.starts_with(&format!("{}:{line}: ", path.display())),
            "{shown}"
        );
        assert_eq!(
            std::fs::read(&path).unwrap(),
            before,
            "the input is never modified"
        );
    }
    let missing = dir.join("does-not-exist.csv");
    let e = Recording::read(&missing).unwrap_err();
    assert!(e.to_string().contains("does-not-exist.csv") && e.reason.contains("cannot open"));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn artefacts_are_survived_and_counted() {
    // o09: 8 gaps of 1-20 samples and 5 duplicate rows (its README)
    let rec = Recording::read(&open_data_dir().join("o09_nominal_artefacts_combo.csv")).unwrap();
    assert_eq!(rec.issues.gaps, 8);
    assert_eq!(rec.issues.duplicates, 5);
    assert!(rec.issues.missing_samples >= 8 && rec.issues.missing_samples <= 160);
    // the streaming reader counts the same without holding the samples
    let f = std::io::BufReader::new(
        std::fs::File::open(open_data_dir().join("o09_nominal_artefacts_combo.csv")).unwrap(),
    );
    let mut rd = RecordingReader::new(f, "o09").unwrap();
    let n = rd.by_ref().inspect(|s| assert!(s.is_ok(), "{s:?}")).count();
    assert_eq!(n, rec.samples.len());
    assert_eq!(rd.issues(), rec.issues);
}

#[test]
fn recordings_and_model_files_round_trip() {
    let dir = scratch_dir("roundtrip");
    let mut rec =
        Recording::read(&open_data_dir().join("o09_nominal_artefacts_combo.csv")).unwrap();
    rec.samples.truncate(5000);
    let p = dir.join("copy.csv");
    rec.write(&p).unwrap();
    let back = Recording::read(&p).unwrap();
    assert_eq!(back.samples, rec.samples);
    assert_eq!(
        back.metadata, rec.metadata,
        "unknown keys pass through in order"
    );
    for name in Satellite::BUILTIN_NAMES {
        let s = Satellite::builtin(name).unwrap();
        let mp = dir.join(format!("{name}.toml"));
        std::fs::write(&mp, s.to_toml_string()).unwrap();
        assert_eq!(Satellite::from_toml_file(&mp).unwrap(), s);
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

fn valid_text() -> String {
    let mut t = format!("{FORMAT}\n# satellite = sph2\n# sample_rate_hz = 1000\n{HEADER}\n");
    for k in 0..20u32 {
        t.push_str(&format!(
            "{k},{},{},2058,2048,2049,2047,{}\n",
            2077 + k % 3,
            2070 + k % 5,
            (k / 5) * 3
        ));
    }
    t
}

/// Reads bytes; Ok or an error whose line is within the text and whose file is the name.
fn read_never_panics(bytes: &[u8]) {
    let lines = bytes.iter().filter(|&&b| b == b'\n').count() + 1;
    match Recording::from_reader(bytes, "fuzz.csv") {
        Ok(r) => {
            assert!(r.samples.windows(2).all(|w| w[0].time_ms < w[1].time_ms));
        }
        Err(e) => {
            assert_eq!(e.file, "fuzz.csv");
            assert!(e.line >= 1 && e.line <= lines, "line {} of {lines}", e.line);
            assert!(!e.reason.is_empty());
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 400, ..ProptestConfig::default() })]

    #[test]
    fn random_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
        read_never_panics(&bytes);
        let mut with_header = format!("{FORMAT}\n{HEADER}\n").into_bytes();
        with_header.extend_from_slice(&bytes);
        read_never_panics(&with_header);
    }

    #[test]
    fn mutated_valid_files_never_panic(
        edits in proptest::collection::vec((0usize..2000, any::<u8>(), 0u8..3), 1..8)
    ) {
        let mut b = valid_text().into_bytes();
        for (pos, byte, kind) in edits {
            if b.is_empty() { break; }
            let i = pos % b.len();
            match kind {
                0 => b[i] = byte,
                1 => { b.remove(i); }
                _ => b.insert(i, byte),
            }
        }
        read_never_panics(&b);
    }

    #[test]
    fn written_recordings_read_back(rows in proptest::collection::vec((0u64..5, [0u16..4096, 0u16..4096, 0u16..4096], [0u16..4096, 0u16..4096, 0u16..4096], 0u16..4096), 0..50)) {
        let mut t = 0;
        let samples: Vec<_> = rows.into_iter().map(|(step, gyro, accel, thrusters)| {
            t += step + 1;
            reference_f64::recording::Sample { time_ms: t, gyro, accel, thrusters }
        }).collect();
        let rec = Recording::new("p.csv", Some("sph3"), None, samples);
        let mut out = Vec::new();
        rec.write_to(&mut out).unwrap();
        let back = Recording::from_reader(out.as_slice(), "p.csv").unwrap();
        prop_assert_eq!(back.samples, rec.samples);
        prop_assert_eq!(back.issues, rec.issues);
    }
}
