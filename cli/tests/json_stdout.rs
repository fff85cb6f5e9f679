//! One output convention (issue 26 item 5): when a subcommand's JSON goes to stdout, stdout
//! holds the JSON alone and parses; the human text goes to stderr. `estimate --json -` used
//! to print its text result on stdout before the JSON.
mod common;
use common::{massid, ok, repo, s, tmp};

fn json(stdout: &str, what: &str) -> serde_json::Value {
    serde_json::from_str(stdout)
        .unwrap_or_else(|e| panic!("{what}: stdout is not JSON ({e}):\n{stdout}"))
}

#[test]
fn estimate_and_diagnose_print_only_json_on_stdout_with_json_dash() {
    let d = tmp("json_stdout", "estimate");
    let v1 = d.join("sph2.csv");
    ok(&[
        "simulate",
        "--maneuver",
        "single",
        "--rate",
        "50",
        "--out",
        &s(&v1),
    ]);
    let open3 = repo().join("../shared/data/open3");
    let v2 = s(&open3.join("r01_pl6_nominal.csv"));
    let v2_model = s(&open3.join("r01_pl6_nominal.model.toml"));
    let v1 = s(&v1);
    for args in [
        vec!["estimate", &v1, "--json", "-"],
        vec!["estimate", &v1, "--kernel", "all", "--json", "-"],
        vec![
            "estimate", &v1, "--method", "seed", "--kernel", "all", "--json", "-",
        ],
        vec![
            "estimate", &v2, "--model", &v2_model, "--kernel", "all", "--json", "-",
        ],
        vec!["diagnose", &v1, "--json", "-"],
    ] {
        let o = massid(&args);
        assert!(
            o.status.success(),
            "{args:?}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        let v = json(&String::from_utf8_lossy(&o.stdout), &format!("{args:?}"));
        assert!(v["format"].as_str().is_some(), "{args:?}: {v}");
        // the text result is not lost: it is on stderr
        assert!(!o.stderr.is_empty(), "{args:?}: no text on stderr");
    }
    // with the JSON in a file, the text stays on stdout
    let out = d.join("e.json");
    let text = ok(&["estimate", &v1, "--json", &s(&out)]);
    assert!(text.contains("[f64] output-error"), "{text}");
    json(&std::fs::read_to_string(&out).unwrap(), "e.json");
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn mix_and_characterize_json_is_json_alone() {
    for args in [
        vec![
            "mix",
            "--satellite",
            "sph2",
            "--force",
            "0.1,0,0",
            "--torque",
            "0,0,-0.001",
            "--json",
        ],
        vec![
            "mix",
            "--satellite",
            "sph2",
            "--force",
            "0.1,0,0",
            "--torque",
            "0,0,0.001",
            "--trace",
            "--json",
        ],
        vec![
            "characterize",
            "--json",
            "parallel-axis",
            "--mass",
            "4",
            "--offset",
            "0.003",
        ],
    ] {
        json(&ok(&args), &format!("{args:?}"));
    }
}
