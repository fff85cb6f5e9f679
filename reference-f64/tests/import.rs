//! `reference_f64::import`: the real air-bearing log through the shipped mapping (checked
//! against the raw CSV parsed independently here), unit conversions on small synthetic logs,
//! and every mapping and data error naming its file and line.
use reference_f64::import::{import, import_reader, Mapping};
use reference_f64::rate_recording::{Commands, RateRecording};
use std::path::PathBuf;

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn real_log() -> PathBuf {
    repo().join("../shared/data/real/airbearing-mpc/real_test_data.csv")
}

fn mapping(text: &str) -> Mapping {
    Mapping::parse(text, "map.toml").unwrap_or_else(|e| panic!("{e}"))
}

fn run(map: &str, log: &str) -> RateRecording {
    import_reader(&mapping(map), log.as_bytes(), "log.csv").unwrap_or_else(|e| panic!("{e}"))
}

/// The raw file's column by header name, parsed here without the csv crate: every row has
/// exactly one quoted field (Command_Vector), so splitting on '"' isolates it.
struct Raw {
    header: Vec<String>,
    rows: Vec<(Vec<String>, String)>,
}

fn raw_real() -> Raw {
    let text = std::fs::read_to_string(real_log()).expect("the real log");
    let mut lines = text.lines();
    let header: Vec<String> = lines
        .next()
        .unwrap()
        .split(',')
        .map(str::to_string)
        .collect();
    let rows = lines
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let parts: Vec<&str> = l.split('"').collect();
            assert_eq!(parts.len(), 3, "one quoted field per row: {l}");
            let before: Vec<String> = parts[0].split(',').map(str::to_string).collect();
            (before, parts[1].to_string())
        })
        .collect();
    Raw { header, rows }
}

#[test]
fn the_real_airbearing_log_imports_with_the_shipped_mapping() {
    let m = Mapping::read(&repo().join("examples/import/airbearing-mpc.toml"))
        .unwrap_or_else(|e| panic!("{e}"));
    let r = import(&m, &real_log()).unwrap_or_else(|e| panic!("{e}"));
    let raw = raw_real();
    // 3270 rows, no repeated Control_Time: every row is a sample.
    assert_eq!(raw.rows.len(), 3270);
    assert_eq!(r.time_ms.len(), 3270);
    assert_eq!(r.issues.duplicates, 0);
    assert_eq!(r.axes, [false, false, true]);
    assert_eq!(r.satellite(), Some("airbearing-mpc"));
    assert_eq!(r.meta("imported_from"), Some("real_test_data.csv"));
    let Commands::Thrusters { n, words } = &r.commands else {
        panic!("thruster words expected")
    };
    assert_eq!(*n, 8);
    // ~60 ms per control step.
    assert!((r.sample_rate_hz() - 1000.0 / 60.0).abs() < 1e-9);
    assert_eq!(r.issues.gaps, 0, "{:?}", r.issues);

    let col = |name: &str| raw.header.iter().position(|h| h == name).unwrap();
    let (t_col, w_col) = (col("Control_Time"), col("Current_Angular_Vel"));
    assert!(w_col < col("Command_Vector") && t_col < w_col);
    for k in [0, 1, 2, 100, 1234, 2000, 3269] {
        let (before, vector) = &raw.rows[k];
        let t: f64 = before[t_col].parse().unwrap();
        assert_eq!(r.time_ms[k], (t * 1000.0).round() as u64, "row {k}");
        let w: f64 = before[w_col].parse().unwrap();
        assert_eq!(r.rate[k][2].to_bits(), w.to_bits(), "row {k}");
        assert!(r.rate[k][0].is_nan() && r.rate[k][1].is_nan());
        let states: Vec<u16> = vector
            .trim_matches(|c| c == '[' || c == ']')
            .split(", ")
            .map(|s| s.parse().unwrap())
            .collect();
        assert_eq!(states.len(), 8);
        let word = states
            .iter()
            .enumerate()
            .fold(0u16, |w, (i, s)| w | (s << i));
        assert_eq!(words[k], word, "row {k}: {vector}");
    }
    // The first row of the spec example: [1, 0, 1, 0, 1, 0, 1, 0] is thrusters 1, 3, 5, 7.
    assert_eq!(words[0], 0b0101_0101);

    // Written and read back, the recording is the same.
    let mut text = Vec::new();
    r.write_to(&mut text).unwrap();
    let back = RateRecording::from_reader(&text[..], "back.csv").unwrap();
    assert_eq!(back.time_ms, r.time_ms);
    assert_eq!(back.commands, r.commands);
    assert_eq!(back.metadata, r.metadata);
    let bits = |r: &RateRecording| {
        r.rate
            .iter()
            .map(|v| v.map(f64::to_bits))
            .collect::<Vec<_>>()
    };
    assert_eq!(bits(&back), bits(&r));
}

const THRUSTERS_2: &str = "[thrusters]\ncount = 2\ncolumns = [\"A\", \"B\"]\n";

#[test]
fn deg_per_s_counts_sign_and_time_units_convert() {
    let map = format!(
        "satellite = \"t\"\n[time]\ncolumn = \"t\"\nunit = \"us\"\nstart = \"zero\"\n[rates]\nx = {{ column = \"gx\", unit = \"deg/s\" }}\ny = {{ column = \"gy\", unit = \"counts\", counts_per_rad_s = 1000, bias_counts = 2048 }}\nz = {{ column = \"gz\", unit = \"rad/s\", sign = -1 }}\n{THRUSTERS_2}"
    );
    let log = "t,gx,gy,gz,A,B\n5000000,180,3048,0.5,1,0\n5010400,-90,1048,,true,TRUE\n5020600,,2048.5,-1,0,false\n";
    let r = run(&map, log);
    assert_eq!(r.time_ms, vec![0, 10, 21], "us, rounded to the nearest ms");
    assert_eq!(r.axes, [true, true, true]);
    let pi = std::f64::consts::PI;
    assert!((r.rate[0][0] - pi).abs() < 1e-15);
    assert!((r.rate[1][0] + pi / 2.0).abs() < 1e-15);
    assert!(r.rate[2][0].is_nan(), "empty field: a missing sample");
    assert_eq!(r.rate[0][1], 1.0);
    assert_eq!(r.rate[1][1], -1.0);
    assert_eq!(r.rate[2][1], 0.0005);
    assert_eq!(r.rate[0][2], -0.5);
    assert!(r.rate[1][2].is_nan());
    assert_eq!(r.rate[2][2], 1.0);
    assert_eq!(
        r.commands,
        Commands::Thrusters {
            n: 2,
            words: vec![1, 3, 0]
        }
    );
}

#[test]
fn bitmask_and_vector_sources_and_duplicates() {
    let base = "satellite = \"t\"\nsample_rate_hz = 100\n[time]\ncolumn = \"time\"\nunit = \"ms\"\n[rates]\nz = { column = \"w\", unit = \"rad/s\" }\n";
    let hex =
        format!("{base}[thrusters]\ncount = 12\nbitmask = {{ column = \"word\", base = 16 }}\n");
    let r = run(
        &hex,
        "time,w,word\n0,0.1,0x0FFF\n10,0.2,a\n10,0.9,1\n50,0.3,0\n",
    );
    assert_eq!(r.time_ms, vec![0, 10, 50]);
    assert_eq!(r.rate[1][2], 0.2, "the first of a repeated time wins");
    assert_eq!(r.issues.duplicates, 1);
    assert_eq!((r.issues.gaps, r.issues.missing_samples), (1, 3));
    assert_eq!(r.meta("sample_rate_hz"), Some("100"));
    assert_eq!(
        r.commands,
        Commands::Thrusters {
            n: 12,
            words: vec![4095, 10, 0]
        }
    );
    let bin =
        format!("{base}[thrusters]\ncount = 3\nbitmask = {{ column = \"word\", base = 2 }}\n");
    let r = run(&bin, "time,w,word\n0,0.1,0b110\n1,0.1,011\n");
    assert_eq!(
        r.commands,
        Commands::Thrusters {
            n: 3,
            words: vec![6, 3]
        }
    );
    let vec = format!("{base}[thrusters]\ncount = 4\nvector = \"v\"\n");
    let r = run(&vec, "time,w,v\n0,0.1,\"[0, 1, 1, 0]\"\n1,0.1,1 0 0 1\n");
    assert_eq!(
        r.commands,
        Commands::Thrusters {
            n: 4,
            words: vec![6, 9]
        }
    );
}

#[test]
fn a_wrench_mapping_imports_forces_and_torques() {
    let map = "satellite = \"t\"\n[time]\ncolumn = \"t\"\nunit = \"s\"\n[rates]\nz = { column = \"w\", unit = \"rad/s\" }\n[wrench]\nforce_x = { column = \"Fx\", unit = \"N\" }\ntorque_z = { column = \"Tz\", unit = \"N m\" }\n";
    let r = run(map, "t,Fx,Tz,w\n0,0.5,-0.01,0\n0.1,0,0,0\n");
    let Commands::Wrench { present, values } = &r.commands else {
        panic!("wrench expected")
    };
    assert_eq!(present, &[true, false, false, false, false, true]);
    assert_eq!((values[0][0], values[0][5]), (0.5, -0.01));
    assert_eq!(r.meta("thrusters"), None);
    let mut text = Vec::new();
    r.write_to(&mut text).unwrap();
    assert!(String::from_utf8(text)
        .unwrap()
        .contains("time_ms,rate_z,force_x,torque_z\n0,0,0.5,-0.01\n100,0,0,0\n"));
}

#[test]
fn every_mapping_error_names_the_file_and_line() {
    let head = "satellite = \"t\"\n[time]\ncolumn = \"t\"\nunit = \"s\"\n[rates]\nz = { column = \"w\", unit = \"rad/s\" }\n";
    let thr = "[thrusters]\ncount = 2\nvector = \"v\"\n";
    let cases: Vec<(String, usize, &str)> = vec![
        (
            format!("{head}{thr}speed = 3\n"),
            10,
            "unknown field `speed`",
        ),
        (
            format!("satelite = \"t\"\n{head}{thr}"),
            1,
            "unknown field `satelite`",
        ),
        (
            head.replace("unit = \"s\"", "unit = \"min\""),
            4,
            "unknown variant `min`",
        ),
        (
            format!(
                "{}{thr}",
                head.replace("unit = \"s\"", "unit = \"s\"\nstart = \"first\"")
            ),
            5,
            "unknown variant `first`",
        ),
        (
            format!("{}{thr}", head.replace("rad/s\"", "rad/s\", offset = 1")),
            6,
            "unknown field `offset`",
        ),
        (
            format!("{}{thr}", head.replace("rad/s", "rpm")),
            6,
            "unknown variant `rpm`",
        ),
        (
            format!("{}{thr}", head.replace("rad/s\"", "counts\"")),
            6,
            "needs counts_per_rad_s and bias_counts",
        ),
        (
            format!(
                "{}{thr}",
                head.replace("rad/s\"", "rad/s\", counts_per_rad_s = 2")
            ),
            6,
            "for unit = \"counts\" only",
        ),
        (
            format!("{}{thr}", head.replace("rad/s\"", "rad/s\", sign = 2")),
            6,
            "sign 2",
        ),
        (
            format!("{head}[thrusters]\ncount = 17\nvector = \"v\"\n"),
            8,
            "count 17",
        ),
        (
            format!("{head}[thrusters]\ncount = 0\nvector = \"v\"\n"),
            8,
            "count 0",
        ),
        (
            format!("{head}[thrusters]\ncount = 2\ncolumns = [\"a\"]\n"),
            9,
            "columns lists 1 names",
        ),
        (
            format!("{head}[thrusters]\ncount = 2\n"),
            7,
            "exactly one of columns, vector, bitmask",
        ),
        (
            format!("{head}[thrusters]\ncount = 2\nvector = \"v\"\ncolumns = [\"a\", \"b\"]\n"),
            7,
            "exactly one of",
        ),
        (
            format!("{head}[thrusters]\ncount = 2\nbitmask = {{ column = \"b\", base = 8 }}\n"),
            9,
            "base 8",
        ),
        (
            format!("{head}[thrusters]\ncount = 2\nbitmask = {{ column = \"b\", bse = 16 }}\n"),
            9,
            "unknown field `bse`",
        ),
        (
            format!(
                "{}{thr}",
                head.replace("z = { column = \"w\", unit = \"rad/s\" }\n", "")
            ),
            5,
            "at least one of x, y, z",
        ),
        (
            format!("{}{thr}", head.replace("z = {", "w = {")),
            6,
            "unknown field `w`",
        ),
        (head.to_string(), 1, "needs a [thrusters] or a [wrench]"),
        (
            format!("{head}{thr}[wrench]\nforce_x = {{ column = \"f\", unit = \"N\" }}\n"),
            10,
            "not both",
        ),
        (
            format!("{head}[wrench]\n"),
            7,
            "[wrench] needs at least one of",
        ),
        (
            format!("{head}[wrench]\ntorque_z = {{ column = \"f\", unit = \"N\" }}\n"),
            8,
            "unknown variant `N`",
        ),
        (
            format!("{head}[wrench]\nforce_x = {{ column = \"f\", unit = \"kN\" }}\n"),
            8,
            "unknown variant `kN`",
        ),
        (
            format!(
                "{}{thr}",
                head.replace("satellite = \"t\"", "satellite = \"\"")
            ),
            1,
            "non-empty name",
        ),
        (
            format!(
                "{}{thr}",
                head.replace(
                    "satellite = \"t\"",
                    "satellite = \"t\"\nsample_rate_hz = -5"
                )
            ),
            2,
            "sample_rate_hz -5",
        ),
        (
            format!(
                "{}{thr}",
                head.replace("[time]\ncolumn = \"t\"\n", "[time]\n")
            ),
            2,
            "missing field `column`",
        ),
        (
            format!("{}{thr}", head.replace("satellite = \"t\"\n", "")),
            1,
            "missing field `satellite`",
        ),
        (format!("{head}{thr}count = [\n"), 11, "column"),
    ];
    for (text, line, reason) in cases {
        let e = Mapping::parse(&text, "map.toml").expect_err(&text);
        assert_eq!(e.file, "map.toml");
        assert_eq!(e.line, line, "{text}\n-> {e}");
        assert!(e.reason.contains(reason), "{text}\n-> {e}");
        assert!(
            e.to_string().starts_with(&format!("map.toml:{line}: ")),
            "{e}"
        );
    }
}

#[test]
fn every_data_error_names_the_log_and_line() {
    let map = "satellite = \"t\"\n[time]\ncolumn = \"t\"\nunit = \"ms\"\n[rates]\nz = { column = \"w\", unit = \"rad/s\" }\n[thrusters]\ncount = 3\nvector = \"v\"\n";
    let h = "t,w,v";
    let cases: Vec<(String, usize, &str)> = vec![
        (String::new(), 1, "empty file"),
        (format!("{h}\n"), 1, "a header but no data rows"),
        (
            "t,v\n0,1\n".to_string(),
            1,
            "column w ([rates].z) is not in the header",
        ),
        (
            "t,w,v,w\n".to_string(),
            1,
            "column w ([rates].z) appears twice",
        ),
        (
            format!("{h}\n0,0,1 0 0\n10,abc,1 0 0\n"),
            3,
            "column w: \"abc\" is not a number",
        ),
        (
            format!("{h}\n0,inf,1 0 0\n"),
            2,
            "column w: \"inf\" is not finite",
        ),
        (format!("{h}\n,0,1 0 0\n"), 2, "column t: the time is empty"),
        (
            format!("{h}\n-5,0,1 0 0\n"),
            2,
            "column t: time -5 is negative",
        ),
        (
            format!("{h}\n5,0,1 0 0\n4,0,1 0 0\n"),
            3,
            "column t: time_ms goes backwards (4 after 5)",
        ),
        (
            format!("{h}\n0,0,1 0\n"),
            2,
            "column v: \"1 0\" has 2 entries, expected 3",
        ),
        (format!("{h}\n0,0,\"[1, 0, x]\"\n"), 2, "entry 3 \"x\""),
        (
            format!("{h}\n0,0,1 0 0\n1,0\n"),
            3,
            "row has 2 fields, the header has 3",
        ),
        (format!("{h}\n0,0,1 0 0,7\n"), 2, "row has 4 fields"),
    ];
    for (log, line, reason) in cases {
        let e = import_reader(&mapping(map), log.as_bytes(), "log.csv").expect_err(&log);
        assert_eq!(e.file, "log.csv");
        assert_eq!(e.line, line, "{log:?} -> {e}");
        assert!(e.reason.contains(reason), "{log:?} -> {e}");
        assert!(e.to_string().starts_with(&format!("log.csv:{line}: ")));
    }
    // Quoted fields spanning lines: the line is where the row starts.
    let e = import_reader(
        &mapping(map),
        "t,w,v\n0,0,\"1\n0\n0\"\n1,zz,1 0 0\n".as_bytes(),
        "log.csv",
    )
    .unwrap_err();
    assert_eq!(e.line, 5, "{e}");
}
