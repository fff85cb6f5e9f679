//! `massid estimate` identifies any craft (issue 22 item 2): a 3-D ten-thruster craft's v2
//! recording and a planar craft's motion-capture recording (`../shared/data/open3/`) are
//! estimated, not refused, and the JSON says how (method, sensor response, noise model,
//! consistency tests); a planar craft's unidentifiable terms are null. The onboard kernel's
//! output-error form (f32) identifies them too; the seed's design refuses v2 with a clear error.
mod common;
use common::massid;
use std::path::PathBuf;

fn open3(name: &str) -> (String, String) {
    let d = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/open3");
    (
        d.join(format!("{name}.csv")).display().to_string(),
        d.join(format!("{name}.model.toml")).display().to_string(),
    )
}

/// `massid estimate` of an open3 recording with `extra` arguments: stdout and the JSON.
fn estimate_with(name: &str, extra: &[&str]) -> (String, serde_json::Value) {
    let (rec, model) = open3(name);
    // One directory per call: tests run in parallel on the same recordings.
    static CALLS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let call = CALLS.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
    let dir = std::env::temp_dir().join(format!("massid-any-{}-{call}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("e.json");
    let mut args = vec![
        "estimate",
        &rec,
        "--model",
        &model,
        "--json",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    let o = massid(&args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    std::fs::remove_dir_all(&dir).ok();
    (String::from_utf8_lossy(&o.stdout).into_owned(), v)
}

fn estimate_json(name: &str) -> serde_json::Value {
    estimate_with(name, &[]).1
}

#[test]
fn a_3d_v2_recording_of_another_craft_is_identified() {
    let v = estimate_json("r04_ft10_nominal");
    let r = &v["results"]["f64"];
    assert_eq!(r["status"], "ok", "{r}");
    assert_eq!(r["method"], "output_error");
    assert_eq!(r["sensor_response"], "point");
    assert_eq!(r["noise_model"].as_array().unwrap().len(), 3);
    assert!(r["consistency"]
        .as_array()
        .unwrap()
        .iter()
        .any(|t| t["test"] == "thrust"));
    let ixx = r["inertia_kgm2"][0].as_f64().unwrap();
    let se = r["inertia_stderr_kgm2"][0].as_f64().unwrap();
    assert!(
        (ixx - 0.045).abs() < 3.0 * se && se < 1e-3,
        "Ixx {ixx} +- {se}"
    );
}

#[test]
fn a_planar_motion_capture_recording_reports_only_what_it_can_know() {
    let v = estimate_json("r01_pl6_nominal");
    let r = &v["results"]["f64"];
    assert_eq!(r["status"], "ok", "{r}");
    assert!(r["inertia_kgm2"][2].as_f64().is_some());
    for i in [0, 1, 3, 4, 5] {
        assert!(r["inertia_kgm2"][i].is_null(), "{r}");
    }
    assert!(r["com_offset_mm"][2].is_null());
    assert!(r["unobservable"]
        .as_array()
        .unwrap()
        .iter()
        .any(|t| t == "Ixx"));
}

#[test]
fn the_onboard_kernels_identify_v2_craft_and_the_seed_method_refuses_them() {
    for (name, term, truth, status) in [
        ("r04_ft10_nominal", 0, 0.045, "ok"),
        // Motion-capture rates (central differences): the moving average taken out, tested.
        ("r01_pl6_nominal", 2, 0.085, "ok"),
    ] {
        let (stdout, v) = estimate_with(name, &["--kernel", "all"]);
        // both kernels answer (the fixed one in its integer float) next to f64
        assert!(stdout.contains("[f32] vs f64"), "{stdout}");
        assert!(stdout.contains("[fixed] vs f64"), "{stdout}");
        for kernel in ["f32", "fixed"] {
            let r = &v["results"][kernel];
            assert_eq!(r["status"], status, "{name} {kernel}: {r}");
            if status == "ok" {
                assert_eq!(r["consistency"][0]["test"], "valve_timing", "{r}");
            }
            // The motion-capture noise's moving average (lag 2 for a central mean) is found
            // and reported, a gyro's is none.
            let ma = r["noise_model"][0]["ma_coefficient"].as_f64().unwrap();
            if name.contains("pl6") {
                assert!(ma < -0.2 && r["noise_model"][0]["ma_lag"] == 2, "{r}");
            } else {
                assert_eq!(ma, 0.0, "{r}");
            }
            let value = r["inertia_kgm2"][term].as_f64().unwrap();
            let se = r["inertia_stderr_kgm2"][term].as_f64().unwrap();
            assert!(
                (value - truth).abs() < 3.0 * se && se < 0.01 * truth,
                "{name} {kernel}: {value} +- {se}"
            );
        }
    }
    let (rec, model) = open3("r04_ft10_nominal");
    let o = massid(&["estimate", &rec, "--model", &model, "--method", "seed"]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("format v2") && err.contains("output-error"),
        "{err}"
    );
}
