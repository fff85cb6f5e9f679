//! `massid import`: the real air-bearing log through the shipped mapping, the summary line,
//! errors as `file:line: reason`, and never overwriting a file.
mod common;
use common::{massid, repo, s};
use std::path::PathBuf;

fn tmp(name: &str) -> PathBuf {
    common::tmp("import", name)
}

#[test]
fn imports_the_real_log_and_refuses_to_overwrite() {
    let d = tmp("real");
    let log = repo().join("../shared/data/real/airbearing-mpc/real_test_data.csv");
    let map = repo().join("examples/import/airbearing-mpc.toml");
    let out = d.join("air.csv");
    let args = ["import", &s(&log), "--mapping", &s(&map), "--out", &s(&out)];
    let o = massid(&args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        stdout.contains("3270 rows")
            && stdout.contains("196.160 s")
            && stdout.contains("axes z")
            && stdout.contains("8 thrusters")
            && stdout.contains("0 gaps"),
        "{stdout}"
    );
    assert_eq!(stdout.lines().count(), 1, "one summary line: {stdout}");
    let written = std::fs::read_to_string(&out).unwrap();
    assert!(written.starts_with("# format = massid-recording/2\n# satellite = airbearing-mpc\n# axes = z\n# thrusters = 8\n"));
    assert!(written.contains("time_ms,rate_z,thrusters\n0,0.261371637295856,85\n60,"));
    assert_eq!(
        reference_f64::rate_recording::format_version(&out).unwrap(),
        2
    );

    // A second run must not replace the file, nor may --out name an input.
    let before = std::fs::read(&out).unwrap();
    let o = massid(&args);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("refusing to overwrite"), "{err}");
    assert_eq!(std::fs::read(&out).unwrap(), before);
    let copy = d.join("log.csv");
    std::fs::copy(&log, &copy).unwrap();
    let o = massid(&[
        "import",
        &s(&copy),
        "--mapping",
        &s(&map),
        "--out",
        &s(&copy),
    ]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("refusing to overwrite an input file"));
    let o = massid(&[
        "import",
        &s(&copy),
        "--mapping",
        &s(&map),
        "--out",
        &s(&map),
    ]);
    assert!(!o.status.success(), "the mapping is an input too");
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn errors_name_the_file_and_line() {
    let d = tmp("errors");
    let map = d.join("map.toml");
    std::fs::write(
        &map,
        "satellite = \"t\"\n[time]\ncolumn = \"t\"\nunit = \"s\"\n[rates]\nz = { column = \"w\", unit = \"deg/s\" }\n[thrusters]\ncount = 2\ncolumns = [\"A\", \"B\"]\n",
    )
    .unwrap();
    let log = d.join("log.csv");
    std::fs::write(&log, "t,w,A,B\n0,1,0,1\n0.1,abc,1,0\n").unwrap();
    let out = d.join("rec.csv");
    let o = massid(&["import", &s(&log), "--mapping", &s(&map), "--out", &s(&out)]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains(&format!(
            "{}:3: column w: \"abc\" is not a number",
            log.display()
        )),
        "{err}"
    );
    assert!(!out.exists(), "nothing written on error");

    std::fs::write(&log, "t,w,A,B\n0,1,0,1\n0.1,-90,1,0\n").unwrap();
    let o = massid(&["import", &s(&log), "--mapping", &s(&map), "--out", &s(&out)]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let written = std::fs::read_to_string(&out).unwrap();
    assert!(
        written.contains(
            "time_ms,rate_z,thrusters\n0,0.017453292519943295,2\n100,-1.5707963267948966,1\n"
        ),
        "{written}"
    );

    std::fs::write(
        &map,
        "satellite = \"t\"\n[time]\ncolumn = \"t\"\nunit = \"hours\"\n",
    )
    .unwrap();
    let o = massid(&[
        "import",
        &s(&log),
        "--mapping",
        &s(&map),
        "--out",
        &s(&d.join("r2.csv")),
    ]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains(&format!(
            "{}:4: column 8: unknown variant `hours`",
            map.display()
        )),
        "{err}"
    );
    std::fs::remove_dir_all(&d).ok();
}
