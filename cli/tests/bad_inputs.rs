//! Issue 26: every input gets a right answer or a clear error. One test per case of the
//! issue's "Why" list: panics, hangs, confidently wrong answers, models accepted without a
//! check, and the conventions the subcommands now share.
mod common;
use common::{bin, massid, ok, repo, s};
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

/// Runs massid, expects a failure, returns stderr (which must hold no panic).
fn fails(args: &[&str]) -> String {
    let out = massid(args);
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(
        !out.status.success(),
        "massid {args:?} should fail; stdout:\n{}",
        String::from_utf8_lossy(&out.stdout)
    );
    assert!(
        !err.contains("panicked"),
        "massid {args:?} panicked:\n{err}"
    );
    assert!(
        !err.contains(":0:"),
        "an error not tied to a line says file:0: ({args:?}):\n{err}"
    );
    err
}

fn data(rel: &str) -> String {
    repo()
        .join("../shared/data")
        .join(rel)
        .display()
        .to_string()
}

fn tmp(name: &str) -> PathBuf {
    common::tmp("bad", name)
}

const O01: &str = "open/o01_nominal_rga12.csv";

fn planar_model() -> String {
    s(&repo().join("examples/models/airbearing-mpc.toml"))
}

// ---- Panics ----------------------------------------------------------------------------

#[test]
fn a_12_thruster_recording_with_an_8_thruster_model_is_refused_not_a_panic() {
    for extra in [
        &["--method", "seed"][..],
        &["--kernel", "all"][..],
        &["--kernel", "fixed"][..],
        &[][..],
    ] {
        let rec = data(O01);
        let model = planar_model();
        let mut args = vec!["estimate", rec.as_str(), "--model", model.as_str()];
        args.extend_from_slice(extra);
        let e = fails(&args);
        assert!(
            e.contains("12-thruster 3-D SPHERES craft") || e.contains("does not have"),
            "{e}"
        );
    }
    // diagnose: the thruster bits the model lacks, before any analysis
    let e = fails(&["diagnose", &data(O01), "--model", &planar_model()]);
    assert!(
        e.contains("thruster(s) 5, 12") || e.contains("does not have"),
        "{e}"
    );
}

/// Runs massid with its stdout a pipe closed before it writes.
fn closed_stdout(args: &[&str]) -> Output {
    let mut child = Command::new(bin())
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("massid runs");
    drop(child.stdout.take());
    child.wait_with_output().expect("massid ends")
}

#[test]
fn a_closed_pipe_ends_every_subcommand_quietly() {
    let rec = data(O01);
    let cases: Vec<Vec<&str>> = vec![
        vec!["estimate", &rec, "--kernel", "all"],
        vec!["diagnose", &rec],
        vec!["mix", "--satellite", "sph2", "--force", "0.1,0,0"],
        vec!["model", "show", "sph2"],
        vec!["characterize", "slosh"],
        vec!["--help"],
    ];
    for args in cases {
        let out = closed_stdout(&args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            !err.contains("panicked") && !err.contains("Broken pipe"),
            "massid {args:?} with a closed stdout:\n{err}"
        );
    }
}

// ---- Hangs -----------------------------------------------------------------------------

#[test]
fn a_tiny_integration_step_is_refused_with_the_bound() {
    let d = tmp("step");
    let out = s(&d.join("x.csv"));
    let t = std::time::Instant::now();
    let e = fails(&[
        "simulate",
        "--step-ms",
        "1e-9",
        "--seconds",
        "1",
        "--out",
        &out,
    ]);
    assert!(t.elapsed().as_secs() < 10, "took {:?}", t.elapsed());
    assert!(
        e.contains("--step-ms 1e-9") && e.contains("at most 1e8"),
        "{e}"
    );
    assert!(!d.join("x.csv").exists());
}

#[test]
fn a_recording_too_long_for_diagnose_is_refused_before_the_analysis() {
    // 1 000 001 rows of a coasting craft: refused after reading, in seconds, not after an
    // analysis that never ends.
    let d = tmp("long");
    let p = d.join("long.csv");
    let mut text = String::from("# format = massid-recording/1\n# satellite = sph2\ntime_ms,gyro_x,gyro_y,gyro_z,accel_x,accel_y,accel_z,thrusters\n");
    for t in 0..1_000_001u64 {
        text.push_str(&format!("{t},2077,2070,2058,2048,2048,2048,0\n"));
    }
    std::fs::write(&p, text).unwrap();
    let t = std::time::Instant::now();
    let e = fails(&["diagnose", &s(&p)]);
    assert!(t.elapsed().as_secs() < 30, "took {:?}", t.elapsed());
    assert!(e.contains("takes at most 1000000"), "{e}");
    std::fs::remove_dir_all(&d).ok();
}

// ---- Confidently wrong -----------------------------------------------------------------

fn first_rows(n: usize, d: &Path) -> String {
    let text = std::fs::read_to_string(data(O01)).unwrap();
    let mut out = String::new();
    let mut rows = 0;
    for line in text.lines() {
        let header = line.starts_with('#') || line.starts_with("time_ms");
        if !header {
            if rows == n {
                break;
            }
            rows += 1;
        }
        out.push_str(line);
        out.push('\n');
    }
    let p = d.join(format!("rows{n}.csv"));
    std::fs::write(&p, out).unwrap();
    s(&p)
}

#[test]
fn diagnose_refuses_a_recording_of_one_to_three_rows() {
    let d = tmp("short");
    for n in 1..=3 {
        let e = fails(&["diagnose", &first_rows(n, &d)]);
        assert!(
            e.contains(&format!("{n} sample(s)")) && e.contains("at least 100"),
            "{e}"
        );
    }
}

#[test]
fn a_gyro_stuck_at_its_bias_is_called_unresponsive_not_a_thrust_scale() {
    let d = tmp("stuck");
    let text = std::fs::read_to_string(data(O01)).unwrap();
    let mut out = String::new();
    for line in text.lines() {
        if line.starts_with('#') || line.starts_with("time_ms") {
            out.push_str(line);
        } else {
            let f: Vec<&str> = line.split(',').collect();
            out.push_str(&format!(
                "{},2077,2070,2058,{},{},{},{}",
                f[0], f[4], f[5], f[6], f[7]
            ));
        }
        out.push('\n');
    }
    let p = s(&d.join("stuck.csv"));
    std::fs::write(&p, out).unwrap();
    let e = fails(&["diagnose", &p]);
    assert!(
        e.contains("does not respond to the thrusters") && e.contains("no_gyro_response"),
        "{e}"
    );
    assert!(!e.contains("thrust_scale"), "{e}");
    // estimate agrees (its status)
    assert!(ok(&["estimate", &p]).contains("no_gyro_response"));
}

#[test]
fn simulate_of_an_8_thruster_planar_model_refuses_rga12_and_writes_v2_for_its_own_maneuvers() {
    let d = tmp("planar-sim");
    let out = s(&d.join("pl.csv"));
    // rga12 (the default) flies the SPHERES layout: refused, naming what works
    let e = fails(&["simulate", "--model", &planar_model(), "--out", &out]);
    assert!(
        e.contains("planar craft with 8 thrusters")
            && e.contains("rga12")
            && e.contains("single, combo, random-pwm"),
        "{e}"
    );
    assert!(!d.join("pl.csv").exists(), "no file of zero gyro counts");
    // a maneuver built from its thrusters: rates in rad/s (v2), not zero counts
    ok(&[
        "simulate",
        "--model",
        &planar_model(),
        "--maneuver",
        "single",
        "--rate",
        "50",
        "--out",
        &out,
    ]);
    let text = std::fs::read_to_string(d.join("pl.csv")).unwrap();
    assert!(
        text.starts_with("# format = massid-recording/2\n"),
        "{text:.200}"
    );
}

#[test]
fn mix_refuses_a_command_out_of_reach() {
    let e = fails(&["mix", "--satellite", "sph2", "--force", "1e308,0,0"]);
    assert!(e.contains("out of reach"), "{e}");
    // within 1000x of the reach it still scales with a warning, as the seed's mixer
    assert!(ok(&["mix", "--satellite", "sph2", "--force", "10,0,0"]).contains("scaled to"));
}

#[test]
fn characterize_slosh_refuses_a_step_that_cannot_represent_the_mode() {
    let e = fails(&["characterize", "slosh", "--dt", "1e308"]);
    assert!(e.contains("--dt 1e308") && e.contains("(0, 1.2825]"), "{e}");
    let e = fails(&["characterize", "slosh", "--dt", "-1"]);
    assert!(e.contains("--dt -1"), "{e}");
    assert!(!ok(&["characterize", "slosh", "--dt", "0.01"]).contains("null"));
}

fn airbearing_log() -> String {
    data("real/airbearing-mpc/real_test_data.csv")
}

#[test]
fn an_import_mapping_whose_rate_contradicts_the_time_steps_is_an_error() {
    let d = tmp("import-rate");
    let map = d.join("map.toml");
    let base = std::fs::read_to_string(repo().join("examples/import/airbearing-mpc.toml")).unwrap();
    std::fs::write(&map, format!("sample_rate_hz = 1000\n{base}")).unwrap();
    let e = fails(&[
        "import",
        &airbearing_log(),
        "--mapping",
        &s(&map),
        "--out",
        &s(&d.join("o.csv")),
    ]);
    assert!(
        e.contains("map.toml:1:") && e.contains("1 ms period") && e.contains("60 ms"),
        "{e}"
    );
}

#[test]
fn a_declared_rate_that_contradicts_the_time_steps_is_an_error_in_diagnose_too() {
    let d = tmp("rate");
    let text = std::fs::read_to_string(data(O01))
        .unwrap()
        .replace("# sample_rate_hz = 1000", "# sample_rate_hz = 100");
    let p = d.join("mislabelled.csv");
    std::fs::write(&p, text).unwrap();
    for cmd in ["diagnose", "estimate"] {
        let e = fails(&[cmd, &s(&p)]);
        assert!(
            e.contains("mislabelled.csv:3:") && e.contains("10 ms period"),
            "{cmd}: {e}"
        );
    }
}

// ---- Models accepted without a check ---------------------------------------------------

/// The flat sph2 model with `from` replaced by `to` (once).
fn sph2_with(d: &Path, name: &str, from: &str, to: &str) -> String {
    let text = std::fs::read_to_string(repo().join("examples/models/sph2.toml")).unwrap();
    assert!(text.contains(from), "{from}");
    let p = d.join(name);
    std::fs::write(&p, text.replacen(from, to, 1)).unwrap();
    s(&p)
}

#[test]
fn implausible_models_are_refused_with_file_line_and_reason() {
    let d = tmp("models");
    let cases = [
        (
            "zero_thrust.toml",
            "thrust_n = [\n    0.1085,",
            "thrust_n = [\n    0.0,",
            "thrust_n[0] = 0 N",
        ),
        (
            "huge_inertia.toml",
            "inertia_kgm2 = [\n    0.0242,",
            "inertia_kgm2 = [\n    1e308,",
            "inertia_kgm2",
        ),
        (
            "long_dir.toml",
            "thrust_dir = [\n    [\n    0.9988,",
            "thrust_dir = [\n    [\n    100.0,",
            "thrust_dir[0] has norm",
        ),
    ];
    for (name, from, to, says) in cases {
        let p = sph2_with(&d, name, from, to);
        for cmd in [
            vec!["model", "check", p.as_str()],
            vec!["mix", "--model", p.as_str(), "--force", "0.1,0,0"],
        ] {
            let e = fails(&cmd);
            assert!(
                e.contains(&format!("{name}:")) && e.contains(says),
                "{cmd:?}: {e}"
            );
            // the line of the key
            let line = std::fs::read_to_string(&p)
                .unwrap()
                .lines()
                .position(|l| l.starts_with(says.split(['[', ' ']).next().unwrap()))
                .unwrap()
                + 1;
            assert!(e.contains(&format!("{name}:{line}:")), "{e}");
        }
    }
    // effects: a latency of 1e9 ms, a thrust_scale list of 2 entries on a 12-thruster craft
    let lat = d.join("latency.toml");
    std::fs::write(
        &lat,
        "satellite = \"sph2\"\n\n[[effects]]\neffect = \"thruster_latency\"\nparams = { open_ms = 1e9, close_ms = 6.0 }\n",
    )
    .unwrap();
    let e = fails(&["model", "check", &s(&lat)]);
    assert!(
        e.contains("latency.toml:3:") && e.contains("open_ms"),
        "{e}"
    );
    let sc = d.join("scale.toml");
    std::fs::write(
        &sc,
        "satellite = \"sph2\"\n\n[[effects]]\neffect = \"thrust_scale\"\nparams = { scale = [0.5, 0.5] }\n",
    )
    .unwrap();
    let out = s(&d.join("sim.csv"));
    let e = fails(&["simulate", "--model", &s(&sc), "--out", &out]);
    assert!(
        e.contains("scale.toml:3:") && e.contains("2 entries") && e.contains("12 thrusters"),
        "{e}"
    );
    assert!(
        !d.join("sim.truth.json").exists(),
        "nothing copied into a truth file"
    );
    // every example model still passes
    for m in ["sph2.toml", "sph2_latency.toml", "airbearing-mpc.toml"] {
        ok(&[
            "model",
            "check",
            &s(&repo().join("examples/models").join(m)),
        ]);
    }
}

// ---- Inconsistent ----------------------------------------------------------------------

#[test]
fn outputs_are_never_overwritten_without_force_in_simulate_and_import_alike() {
    let d = tmp("force");
    let out = s(&d.join("r.csv"));
    let sim = [
        "simulate",
        "--maneuver",
        "single",
        "--seconds",
        "2",
        "--out",
        &out,
    ];
    ok(&sim);
    let e = fails(&sim);
    assert!(e.contains("exists") && e.contains("--force"), "{e}");
    let mut forced = sim.to_vec();
    forced.push("--force");
    ok(&forced);

    let map = s(&repo().join("examples/import/airbearing-mpc.toml"));
    let imp = [
        "import",
        &airbearing_log(),
        "--mapping",
        &map,
        "--out",
        &out,
    ];
    let e = fails(&imp);
    assert!(e.contains("exists") && e.contains("--force"), "{e}");
    let mut forced = imp.to_vec();
    forced.push("--force");
    ok(&forced);
}

#[test]
fn dash_means_stdout_and_no_file_named_dash_is_written() {
    let d = tmp("dash");
    let rec = data(O01);
    let out = Command::new(bin())
        .args(["diagnose", &rec, "--json", "-"])
        .current_dir(&d)
        .output()
        .unwrap();
    assert!(out.status.success());
    let v: serde_json::Value =
        serde_json::from_slice(&out.stdout).expect("stdout is the JSON alone");
    assert_eq!(v["format"], "massid-diagnosis/1");
    assert!(!d.join("-").exists());
    let out = Command::new(bin())
        .args(["estimate", &rec, "--json", "-"])
        .current_dir(&d)
        .output()
        .unwrap();
    assert!(out.status.success());
    assert!(String::from_utf8_lossy(&out.stdout).contains("\"massid-estimate/1\""));
    assert!(!d.join("-").exists());
    let map = s(&repo().join("examples/import/airbearing-mpc.toml"));
    let out = Command::new(bin())
        .args(["import", &airbearing_log(), "--mapping", &map, "--out", "-"])
        .current_dir(&d)
        .output()
        .unwrap();
    assert!(out.status.success());
    assert!(String::from_utf8_lossy(&out.stdout).starts_with("# format = massid-recording/2"));
    assert!(!d.join("-").exists());
}

#[test]
fn built_in_names_are_models_everywhere() {
    assert!(ok(&["model", "show", "sph2"]).contains("name = \"sph2\""));
    assert!(ok(&["model", "check", "sph3"]).contains("ok: satellite sph3"));
    ok(&["mix", "--model", "sph2", "--force", "0.1,0,0"]);
    ok(&["estimate", &data(O01), "--model", "sph2"]);
}

#[test]
fn negative_numbers_need_no_equals_sign() {
    ok(&["mix", "--satellite", "sph2", "--torque", "-0.001,0,0"]);
    let e = fails(&["estimate", &data(O01), "--latency-ms", "-5"]);
    assert!(e.contains("--latency-ms -5"), "{e}");
    let e = fails(&["diagnose", &data(O01), "--horizon", "-1"]);
    assert!(e.contains("--horizon -1"), "{e}");
}

#[test]
fn errors_not_tied_to_a_line_do_not_say_line_0() {
    let e = fails(&["model", "check", "/nonexistent/m.toml"]);
    assert!(e.contains("/nonexistent/m.toml: cannot read"), "{e}");
    let e = fails(&["diagnose", "/nonexistent/r.csv"]);
    assert!(e.contains("/nonexistent/r.csv: "), "{e}");
    let e = fails(&[
        "import",
        &airbearing_log(),
        "--mapping",
        "/nonexistent/map.toml",
        "--out",
        "/tmp/never.csv",
    ]);
    assert!(e.contains("/nonexistent/map.toml: "), "{e}");
}

#[test]
fn a_mapping_error_names_no_internal_type() {
    let d = tmp("mapping-type");
    let map = d.join("map.toml");
    std::fs::write(
        &map,
        "satellite = \"x\"\n[time]\ncolumn = \"Control_Time\"\nunit = \"s\"\n[rates]\nz = { column = \"Current_Angular_Vel\", unit = \"rad/s\" }\n[thrusters]\ncount = 8\nbitmask = \"Command_Vector\"\n",
    )
    .unwrap();
    let e = fails(&[
        "import",
        &airbearing_log(),
        "--mapping",
        &s(&map),
        "--out",
        &s(&d.join("o.csv")),
    ]);
    assert!(e.contains("map.toml:9:") && !e.contains("Raw"), "{e}");
}

#[test]
fn a_report_path_that_is_a_file_fails_before_the_analysis() {
    let d = tmp("report");
    let file = d.join("report");
    std::fs::write(&file, "x").unwrap();
    let t = std::time::Instant::now();
    let e = fails(&["diagnose", &data(O01), "--report", &s(&file)]);
    assert!(e.contains("not a directory"), "{e}");
    assert!(t.elapsed().as_secs_f64() < 1.0, "took {:?}", t.elapsed());
    // an existing JSON output too, before the analysis
    let json = d.join("out.json");
    std::fs::write(&json, "{}").unwrap();
    let t = std::time::Instant::now();
    let e = fails(&["diagnose", &data(O01), "--json", &s(&json)]);
    assert!(e.contains("--force"), "{e}");
    assert!(t.elapsed().as_secs_f64() < 1.0, "took {:?}", t.elapsed());
}
