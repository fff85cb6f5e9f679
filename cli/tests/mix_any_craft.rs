//! `massid mix --model` and `massid model check` for craft without SPHERES' opposing pairs:
//! the firing delivers the command (the table's commanded and delivered columns agree), the
//! check names the mixing rule and the reach, an unreachable direction is a clear error.
mod common;
use common::{massid, ok, repo, s};

fn model(name: &str) -> String {
    s(&repo().join("examples/models").join(format!("{name}.toml")))
}

/// The two three-number columns of the table row starting with `label`.
fn row(out: &str, label: &str) -> (Vec<f64>, Vec<f64>) {
    let line = out
        .lines()
        .find(|l| l.starts_with(label))
        .unwrap_or_else(|| panic!("no {label} row in\n{out}"));
    let nums: Vec<f64> = line
        .split(|c: char| c == '[' || c == ']' || c == ',' || c.is_whitespace())
        .filter_map(|t| t.parse().ok())
        .collect();
    assert_eq!(nums.len(), 6, "{line}");
    (nums[..3].to_vec(), nums[3..].to_vec())
}

#[test]
fn every_example_craft_is_mixed_and_delivers_the_command() {
    for (name, force, torque) in [
        ("airbearing-mpc", "0.2,-0.1,0", "0,0,0.03"),
        ("cubesat8", "0,0,0.05", "0.002,0,0.001"),
        ("freeflyer16", "0.4,0.4,0", "0,0,0.03"),
    ] {
        let out = ok(&[
            "mix",
            "--model",
            &model(name),
            "--force",
            force,
            "--torque",
            torque,
        ]);
        assert!(!out.contains("warning"), "{name}:\n{out}");
        for label in ["force N", "torque Nm"] {
            let (cmd, got) = row(&out, label);
            let size = cmd.iter().map(|v| v * v).sum::<f64>().sqrt();
            for (c, g) in cmd.iter().zip(&got) {
                assert!(
                    (c - g).abs() <= 0.05 * size,
                    "{name} {label}: {cmd:?} vs {got:?}"
                );
            }
        }
        let check = ok(&["model", "check", &model(name)]);
        assert!(
            check.contains("non-negative allocation, reaches every axis both ways"),
            "{check}"
        );
    }
    assert!(ok(&["model", "check", "sph2"]).contains("opposing-pair rules"));
}

#[test]
fn unreachable_and_off_plane_commands_are_refused_clearly() {
    let out = massid(&[
        "mix",
        "--model",
        &model("airbearing-mpc"),
        "--force",
        "0,0,0.1",
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("planar craft has no Fz"),
        "{err}"
    );
    // A craft of two thrusters that both push -x cannot push +x.
    let dir = common::tmp("two", "mix_any_craft").join("two.toml");
    let text = std::fs::read_to_string(model("airbearing-mpc")).unwrap();
    let mut lines: Vec<String> = Vec::new();
    let mut skip = 0;
    for l in text.lines() {
        if skip > 0 {
            skip -= 1;
            continue;
        }
        if l.starts_with("thruster_pos_m") {
            lines.push("thruster_pos_m = [[0.145, 0.06, 0.0], [0.145, -0.06, 0.0]]".into());
            skip = 9;
        } else if l.starts_with("thrust_dir") {
            lines.push("thrust_dir = [[-1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]]".into());
            skip = 9;
        } else if l.starts_with("thrust_n") {
            lines.push("thrust_n = [0.44, 0.43]".into());
        } else {
            lines.push(l.to_string());
        }
    }
    std::fs::write(&dir, lines.join("\n")).unwrap();
    let check = ok(&["model", "check", &s(&dir)]);
    assert!(check.contains("cannot produce +Fx"), "{check}");
    let out = massid(&["mix", "--model", &s(&dir), "--force", "0.1,0,0"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("out of reach"),
        "{err}"
    );
}

/// The air-bearing model with its `thrust_n` line replaced by `thrusts`, written to a
/// temporary file named after `what`.
fn airbearing_with_thrusts(what: &str, thrusts: &str) -> std::path::PathBuf {
    let text = std::fs::read_to_string(model("airbearing-mpc")).unwrap();
    let edited: String = text
        .lines()
        .map(|l| {
            if l.starts_with("thrust_n") {
                format!("thrust_n = {thrusts}")
            } else {
                l.to_string()
            }
        })
        .collect::<Vec<_>>()
        .join("\n");
    let path = common::tmp(what, "mix_any_craft").join(format!("{what}.toml"));
    std::fs::write(&path, edited).unwrap();
    path
}

#[test]
fn model_check_says_whether_the_kernel_flies_the_craft() {
    for name in ["airbearing-mpc", "cubesat8", "freeflyer16", "sph2"] {
        let out = ok(&["model", "check", &model(name)]);
        assert!(
            out.contains("onboard kernel: Q8.24 envelope fits")
                && out.contains("mixer vs f64 reference")
                && !out.contains("CANNOT"),
            "{out}"
        );
    }
    // Thrusters of 100 N: the craft's wrench leaves Q8.24's range, and the check names it.
    let path = airbearing_with_thrusts("strong", "[100, 100, 100, 100, 100, 100, 100, 100]");
    let out = ok(&["model", "check", &s(&path), "--ranges"]);
    assert!(
        out.contains("Q8.24 CANNOT fly this craft: wrench T"),
        "{out}"
    );
    // --ranges prints the envelope's table, the quantity past the limit marked.
    assert!(
        out.contains("DOES NOT FIT") && out.contains("OVERFLOW") && out.contains("wrench Tz"),
        "{out}"
    );
    // Two thrusters 1e-5 as strong as the others: the kernel cannot balance them in its
    // formats and says which command it refuses.
    let path = airbearing_with_thrusts(
        "weak",
        "[0.441450, 0.430659, 0.427716, 0.438017, 0.00000469, 0.00000447, 0.466956, 0.484124]",
    );
    let out = ok(&["model", "check", &s(&path)]);
    assert!(
        out.contains("Q8.24 CANNOT") && out.contains("refuses force"),
        "{out}"
    );
}
