//! The one model format (issue 14 item 1): one model file drives `simulate`, then
//! `estimate`, `diagnose` and `mix` against the same file; every example model file in the
//! repository passes `massid model check`; a typo is an error with line and column.
mod common;
use common::{massid, ok, repo};
use std::path::PathBuf;

fn tmp(name: &str) -> PathBuf {
    common::tmp("model", name)
}

#[test]
fn every_example_model_passes_check() {
    let dir = repo().join("examples/models");
    let mut n = 0;
    for e in std::fs::read_dir(&dir).expect("examples/models") {
        let p = e.unwrap().path();
        if p.extension().is_some_and(|x| x == "toml") {
            let out = ok(&["model", "check", p.to_str().unwrap()]);
            assert!(out.contains(": ok: satellite"), "{out}");
            n += 1;
        }
    }
    assert!(n >= 2, "{n} example models");
}

#[test]
fn one_model_file_drives_simulate_estimate_diagnose_and_mix() {
    let d = tmp("drive");
    for model in ["sph2.toml", "sph2_latency.toml"] {
        let m = repo().join("examples/models").join(model);
        let m = m.to_str().unwrap();
        let rec = d.join(format!("{model}.csv"));
        let rec = rec.to_str().unwrap();
        ok(&[
            "simulate",
            "--model",
            m,
            "--maneuver",
            "rga12",
            "--seconds",
            "12",
            "--out",
            rec,
        ]);
        let est = d.join(format!("{model}.estimate.json"));
        ok(&[
            "estimate",
            rec,
            "--model",
            m,
            "--kernel",
            "f64",
            "--json",
            est.to_str().unwrap(),
        ]);
        assert!(std::fs::read_to_string(&est)
            .unwrap()
            .contains("\"status\""));
        let diag = d.join(format!("{model}.diagnosis.json"));
        ok(&[
            "diagnose",
            rec,
            "--model",
            m,
            "--json",
            diag.to_str().unwrap(),
        ]);
        assert!(std::fs::read_to_string(&diag)
            .unwrap()
            .contains("\"effects\""));
        assert!(ok(&["mix", "--model", m, "--torque", "0,0,0.01"]).contains("delivered"));
    }
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn a_typo_is_an_error_with_line_and_column() {
    let d = tmp("typo");
    let bad = d.join("bad.toml");
    let text = std::fs::read_to_string(repo().join("examples/models/sph2.toml"))
        .unwrap()
        .replacen("mass_kg", "mass_kgg", 1);
    std::fs::write(&bad, text).unwrap();
    for cmd in [
        vec!["model", "check"],
        vec!["mix", "--torque", "0,0,0.01", "--model"],
    ] {
        let mut args = cmd.clone();
        args.push(bad.to_str().unwrap());
        let out = massid(&args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?} accepted a typo");
        assert!(
            err.contains("bad.toml:") && err.contains("column") && err.contains("mass_kgg"),
            "{err}"
        );
    }
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn simulate_says_when_the_recording_is_longer_than_asked() {
    // combo --seconds 20 writes 22.5 s (its last command and coast): said, not silent.
    let d = tmp("seconds");
    let rec = d.join("combo.csv");
    let out = massid(&[
        "simulate",
        "--maneuver",
        "combo",
        "--seconds",
        "20",
        "--out",
        rec.to_str().unwrap(),
    ]);
    assert!(out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("note: --seconds 20") && err.contains("22.4"),
        "{err}"
    );
    std::fs::remove_dir_all(&d).ok();
}
