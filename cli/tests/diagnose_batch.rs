//! `massid diagnose --out DIR` over many recordings (issue 25 item 3): the same JSON bytes
//! as one `massid diagnose FILE --json` per recording whatever --jobs, a summary row per
//! recording sorted by file, resumable, a bad recording an error row that stops nothing.
//! Each check is a function returning what differs, and one test plants a fault for each
//! to show it is caught.
mod common;
use common::{massid, ok, repo, s, tmp};
use std::path::{Path, PathBuf};

/// Three short recordings (100 Hz, a few seconds) in `dir/recs`: nominal, with latency, and
/// another maneuver; returns the folder.
fn recordings(dir: &Path) -> PathBuf {
    let recs = dir.join("recs");
    let latency = repo().join("examples/models/sph2_latency.toml");
    let runs: [(&str, &[&str]); 3] = [
        (
            "a_nominal",
            &["--maneuver", "single", "--seconds", "3", "--seed", "1"],
        ),
        (
            "b_latency",
            &[
                "--maneuver",
                "single",
                "--seconds",
                "3",
                "--seed",
                "2",
                "--model",
                &s(&latency),
            ],
        ),
        (
            "c_combo",
            &["--maneuver", "combo", "--seconds", "3", "--seed", "3"],
        ),
    ];
    for (name, extra) in runs {
        let out = recs.join(format!("{name}.csv"));
        let mut args = vec!["simulate", "--rate", "100", "--out"];
        let o = s(&out);
        args.push(&o);
        args.extend_from_slice(extra);
        ok(&args);
    }
    recs
}

/// The summary rows without their `seconds` (the one field that differs between runs).
fn rows(dir: &Path) -> Vec<serde_json::Value> {
    let text = std::fs::read_to_string(dir.join("summary.jsonl")).expect("summary.jsonl");
    text.lines()
        .map(|l| {
            let mut v: serde_json::Value = serde_json::from_str(l).expect("a JSON row");
            v.as_object_mut().unwrap().remove("seconds");
            v
        })
        .collect()
}

/// What differs between two output folders: the set of JSONs, any JSON's bytes, the
/// summary rows (but for seconds).
fn differences(a: &Path, b: &Path) -> Vec<String> {
    let jsons = |d: &Path| -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.ends_with(".json"))
            .collect();
        v.sort();
        v
    };
    let mut diffs = Vec::new();
    if jsons(a) != jsons(b) {
        diffs.push(format!("JSON files {:?} vs {:?}", jsons(a), jsons(b)));
    }
    for n in jsons(a) {
        if std::fs::read(a.join(&n)).ok() != std::fs::read(b.join(&n)).ok() {
            diffs.push(format!("{n} differs"));
        }
    }
    if rows(a) != rows(b) {
        diffs.push("summary rows differ".into());
    }
    diffs
}

fn batch(args: &[&str]) -> std::process::Output {
    let mut all = vec!["diagnose"];
    all.extend_from_slice(args);
    massid(&all)
}

fn stderr(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn jobs_1_and_2_write_the_single_run_bytes_and_the_same_summary() {
    let dir = tmp("diagnose_batch", "jobs");
    let recs = recordings(&dir);
    let (d1, d2) = (dir.join("j1"), dir.join("j2"));
    for (d, jobs) in [(&d1, "1"), (&d2, "2")] {
        let o = batch(&[&s(&recs), "--out", &s(d), "--jobs", jobs]);
        assert!(o.status.success(), "{}", stderr(&o));
        assert!(stderr(&o).contains("3 to do"), "{}", stderr(&o));
    }
    assert_eq!(differences(&d1, &d2), Vec::<String>::new());
    let rows1 = rows(&d1);
    assert_eq!(rows1.len(), 3);
    let files: Vec<&str> = rows1.iter().map(|r| r["file"].as_str().unwrap()).collect();
    let mut sorted = files.clone();
    sorted.sort();
    assert_eq!(files, sorted, "rows sorted by file");
    assert!(rows1.iter().all(|r| r["status"] == "ok"), "{rows1:?}");
    // the latency recording names an effect (at 100 Hz over 3 s: a thrust rise or the
    // latency), with its parameters, in its row
    let b = &rows1[1];
    assert!(b["effects"][0].is_string(), "{b}");
    assert!(b["params"][0].is_object(), "{b}");
    // CSV: header plus a line per recording
    let csv = std::fs::read_to_string(d1.join("summary.csv")).unwrap();
    assert_eq!(csv.lines().count(), 4, "{csv}");
    assert!(csv.starts_with("file,status,"));
    // each JSON is the single run's bytes, and each row the single run's --summary-row
    // (one run each: `--json FILE --summary-row` writes both)
    for (i, f) in files.iter().enumerate() {
        let name = Path::new(f)
            .file_stem()
            .unwrap()
            .to_string_lossy()
            .into_owned();
        let single_json = dir.join(format!("single-{name}.json"));
        let row = ok(&["diagnose", f, "--json", &s(&single_json), "--summary-row"]);
        let batch_json = std::fs::read_to_string(d2.join(format!("{name}.json"))).unwrap();
        assert_eq!(
            std::fs::read_to_string(&single_json).unwrap(),
            batch_json,
            "{f}: batch JSON = single run's"
        );
        let mut row: serde_json::Value = serde_json::from_str(row.trim()).unwrap();
        assert!(row["seconds"].as_f64().unwrap() > 0.0);
        row.as_object_mut().unwrap().remove("seconds");
        assert_eq!(row, rows1[i], "{f}: --summary-row = the batch's row");
    }

    // The check catches a planted fault: one changed byte in a JSON, one changed row.
    let planted = dir.join("planted");
    std::fs::create_dir_all(&planted).unwrap();
    for e in std::fs::read_dir(&d1).unwrap() {
        let e = e.unwrap();
        std::fs::copy(e.path(), planted.join(e.file_name())).unwrap();
    }
    let a = planted.join("a_nominal.json");
    let text = std::fs::read_to_string(&a).unwrap();
    std::fs::write(&a, text.replacen("\"samples\": 3", "\"samples\": 4", 1)).unwrap();
    assert_eq!(
        differences(&d1, &planted),
        vec!["a_nominal.json differs".to_string()]
    );
    let summary = planted.join("summary.jsonl");
    let text = std::fs::read_to_string(&summary).unwrap();
    std::fs::write(
        &summary,
        text.replacen("\"status\":\"ok\"", "\"status\":\"okay\"", 1),
    )
    .unwrap();
    assert_eq!(differences(&d1, &planted).len(), 2);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn an_interrupted_batch_resumes_and_its_summary_is_complete() {
    let dir = tmp("diagnose_batch", "resume");
    let recs = recordings(&dir);
    let full = dir.join("full");
    ok(&["diagnose", &s(&recs), "--out", &s(&full), "--jobs", "2"]);
    // An interrupted run: two JSONs written (one by a single run, without its seconds), a
    // stray temporary file, no summary. The JSON of a_nominal is planted with another
    // residual so that a recomputation would show.
    let part = dir.join("part");
    std::fs::create_dir_all(&part).unwrap();
    let a = std::fs::read_to_string(full.join("a_nominal.json")).unwrap();
    let planted = a.replacen(
        "\"residual_rms_before\": [",
        "\"residual_rms_before\": [\n    7.0,\n    7.0,\n    7.0\n  ],\n  \"was\": [",
        1,
    );
    assert_ne!(planted, a);
    std::fs::write(part.join("a_nominal.json"), &planted).unwrap();
    std::fs::copy(
        full.join("a_nominal.seconds"),
        part.join("a_nominal.seconds"),
    )
    .unwrap();
    ok(&[
        "diagnose",
        &s(&recs.join("b_latency.csv")),
        "--json",
        &s(&part.join("b_latency.json")),
    ]);
    std::fs::write(part.join(".c_combo.json.tmp99999"), "{ half").unwrap();
    let o = batch(&[&s(&recs), "--out", &s(&part), "--jobs", "2"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains("1 to do") && err.contains("2 already diagnosed"),
        "{err}"
    );
    // skipped, not recomputed: the planted JSON is still there and its row shows it
    assert_eq!(
        std::fs::read_to_string(part.join("a_nominal.json")).unwrap(),
        planted
    );
    let r = rows(&part);
    assert_eq!(r.len(), 3, "one row per recording");
    assert_eq!(r[0]["residual_rms_before"][0], 7.0);
    // the JSON without its seconds file: row with seconds null
    let raw = std::fs::read_to_string(part.join("summary.jsonl")).unwrap();
    assert!(
        raw.lines().nth(1).unwrap().contains("\"seconds\":null"),
        "{raw}"
    );
    // and the whole folder differs from an uninterrupted run only by the planted JSON
    assert_eq!(
        differences(&full, &part),
        vec![
            "a_nominal.json differs".to_string(),
            "summary rows differ".to_string()
        ]
    );
    // --force diagnoses everything again: then identical
    let o = batch(&[&s(&recs), "--out", &s(&part), "--force"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("3 to do"), "{}", stderr(&o));
    assert_eq!(differences(&full, &part), Vec::<String>::new());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_bad_recording_gets_an_error_row_and_the_others_succeed() {
    let dir = tmp("diagnose_batch", "bad");
    let recs = recordings(&dir);
    std::fs::write(
        recs.join("b_bad.csv"),
        "# format = massid-recording/1\nnot,a,recording\n",
    )
    .unwrap();
    let out = dir.join("out");
    // a list as well as a folder: the list names the folder's bad file again (one row)
    let list = dir.join("list.txt");
    std::fs::write(
        &list,
        format!("# the bad one\n\n{}\n", s(&recs.join("b_bad.csv"))),
    )
    .unwrap();
    let o = batch(&[
        &s(&recs),
        "--list",
        &s(&list),
        "--out",
        &s(&out),
        "--jobs",
        "2",
    ]);
    assert!(
        !o.status.success(),
        "a failed recording makes the exit status non-zero"
    );
    let err = stderr(&o);
    assert!(
        err.contains("1 of 4 recordings could not be diagnosed"),
        "{err}"
    );
    let r = rows(&out);
    assert_eq!(r.len(), 4, "{r:?}");
    let bad = &r[1];
    assert_eq!(bad["file"], s(&recs.join("b_bad.csv")));
    assert_eq!(bad["status"], "error");
    let msg = bad["error"].as_str().unwrap();
    assert!(msg.contains("b_bad.csv:"), "file:line: reason: {msg}");
    assert!(!out.join("b_bad.json").exists());
    for (i, name) in [(0, "a_nominal"), (2, "b_latency"), (3, "c_combo")] {
        assert_eq!(r[i]["status"], "ok", "{:?}", r[i]);
        assert!(out.join(format!("{name}.json")).exists());
    }
    // the same row from the per-recording command, with a non-zero status
    let single = massid(&["diagnose", &s(&recs.join("b_bad.csv")), "--summary-row"]);
    assert!(!single.status.success());
    let mut row: serde_json::Value =
        serde_json::from_str(String::from_utf8_lossy(&single.stdout).trim()).unwrap();
    row.as_object_mut().unwrap().remove("seconds");
    assert_eq!(&row, bad);
    // The check catches a planted fault: a batch that dropped the bad row.
    let text = std::fs::read_to_string(out.join("summary.jsonl")).unwrap();
    let dropped: String = text
        .lines()
        .filter(|l| !l.contains("b_bad"))
        .map(|l| format!("{l}\n"))
        .collect();
    std::fs::write(out.join("summary.jsonl"), dropped).unwrap();
    assert_eq!(rows(&out).len(), 3, "a dropped row shows");

    // A forced rerun where a recording now fails leaves no stale JSON behind, so the run
    // after it does not skip the recording as diagnosed (its row stays an error).
    let nominal = recs.join("a_nominal.csv");
    let good = std::fs::read(&nominal).unwrap();
    std::fs::write(&nominal, "# format = massid-recording/1\nbroken\n").unwrap();
    let forced = [s(&recs), "--out".into(), s(&out), "--force".into()];
    let forced: Vec<&str> = forced.iter().map(String::as_str).collect();
    assert!(!batch(&forced).status.success());
    assert!(!out.join("a_nominal.json").exists(), "a stale JSON stays");
    assert!(!out.join("a_nominal.seconds").exists());
    assert!(!batch(&[&s(&recs), "--out", &s(&out)]).status.success());
    let row = rows(&out)
        .into_iter()
        .find(|r| {
            r["file"]
                .as_str()
                .is_some_and(|f| f.ends_with("a_nominal.csv"))
        })
        .expect("a row for the broken recording");
    assert_eq!(row["status"], "error", "{row}");
    std::fs::write(&nominal, good).unwrap();

    // --out may be the recordings' own folder: its summary.csv is not taken for a
    // recording, so a rerun there resumes instead of refusing to overwrite an input.
    for _ in 0..2 {
        let o = batch(&[&s(&recs), "--out", &s(&recs)]);
        assert!(!stderr(&o).contains("input"), "{}", stderr(&o));
        assert_eq!(rows(&recs).len(), 4, "three recordings and the bad one");
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn batch_inputs_and_outputs_are_checked_before_any_work() {
    let dir = tmp("diagnose_batch", "checks");
    let rec = dir.join("r.csv");
    ok(&[
        "simulate",
        "--maneuver",
        "single",
        "--seconds",
        "2",
        "--rate",
        "100",
        "--out",
        &s(&rec),
    ]);
    let refuse = |args: &[&str], says: &str| {
        let o = batch(args);
        assert!(!o.status.success(), "{args:?} refused");
        assert!(stderr(&o).contains(says), "{args:?}: {}", stderr(&o));
    };
    let out = dir.join("out");
    refuse(&[&s(&rec), "--out", "-"], "--out -");
    refuse(&[&s(&rec), &s(&rec), "--json", "x.json"], "--out DIR");
    refuse(&[&s(&dir)], "--out DIR");
    refuse(&[&s(&rec), "--jobs", "2"], "--out");
    refuse(&[&s(&rec), "--out", &s(&out), "--jobs", "0"], "--jobs 0");
    let list = dir.join("list.txt");
    std::fs::write(&list, format!("{}\n\nmissing.csv\n", s(&rec))).unwrap();
    refuse(
        &["--list", &s(&list), "--out", &s(&out)],
        "list.txt:3: missing.csv: no such file",
    );
    // two recordings that differ only by their extension would write one JSON: refused,
    // nothing written (alike names in different folders are not: see
    // same_file_names_in_different_folders_keep_their_own_json_and_resume_apart)
    let txt = dir.join("r.txt");
    std::fs::copy(&rec, &txt).unwrap();
    refuse(
        &[&s(&rec), &s(&txt), "--out", &s(&out)],
        "both would be diagnosed into",
    );
    assert!(!out.exists(), "nothing written");
    // a JSON that would replace an input (the recording r.json in its own folder as output)
    let json_rec = dir.join("in.json");
    std::fs::copy(&rec, &json_rec).unwrap();
    refuse(
        &[&s(&json_rec), "--out", &s(&dir)],
        "refusing to overwrite an input",
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// Runs `massid diagnose ARGS` in `cwd`.
fn batch_in(cwd: &Path, args: &[&str]) -> std::process::Output {
    std::process::Command::new(common::bin())
        .current_dir(cwd)
        .arg("diagnose")
        .args(args)
        .output()
        .expect("massid runs")
}

#[test]
fn same_file_names_in_different_folders_keep_their_own_json_and_resume_apart() {
    // a/flight.csv and b/flight.csv: two different recordings with one file name. Each gets
    // its own JSON (its path below the recordings' common folder: a/flight.json and
    // b/flight.json), its own row, and a resumed batch redoes exactly the missing one.
    let dir = tmp("diagnose_batch", "same_names");
    let latency = repo().join("examples/models/sph2_latency.toml");
    let (a, b) = (dir.join("a/flight.csv"), dir.join("b/flight.csv"));
    for (rec, extra) in [
        (&a, vec!["--seed", "1"]),
        (&b, vec!["--seed", "2", "--model", &s(&latency)]),
    ] {
        let mut args = vec!["simulate", "--rate", "100", "--maneuver", "single"];
        args.extend(["--seconds", "3", "--out"]);
        let o = s(rec);
        args.push(&o);
        args.extend(extra);
        ok(&args);
    }
    // the single runs: each recording's JSON bytes and row
    let single = |rec: &Path, name: &str| {
        let json = dir.join(format!("single-{name}.json"));
        let row = ok(&["diagnose", &s(rec), "--json", &s(&json), "--summary-row"]);
        let mut row: serde_json::Value = serde_json::from_str(row.trim()).unwrap();
        row.as_object_mut().unwrap().remove("seconds");
        (std::fs::read_to_string(&json).unwrap(), row)
    };
    let (json_a, row_a) = single(&a, "a");
    let (json_b, row_b) = single(&b, "b");
    assert_ne!(json_a, json_b, "two different recordings");
    let out = dir.join("out");
    let (out_a, out_b) = (out.join("a/flight.json"), out.join("b/flight.json"));
    // What differs from the single runs: the JSON bytes at each key and the rows.
    let check = || -> Vec<String> {
        let mut diffs = Vec::new();
        for (path, want) in [(&out_a, &json_a), (&out_b, &json_b)] {
            if std::fs::read_to_string(path).ok().as_ref() != Some(want) {
                diffs.push(format!("{}: not the single run's JSON", s(path)));
            }
        }
        if rows(&out) != vec![row_a.clone(), row_b.clone()] {
            diffs.push(format!("rows {:?}", rows(&out)));
        }
        diffs
    };

    let o = batch(&[&s(&a), &s(&b), "--out", &s(&out), "--jobs", "2"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("2 to do"), "{}", stderr(&o));
    assert_eq!(check(), Vec::<String>::new());
    assert!(!out.join("flight.json").exists(), "no shared name");

    // Interrupted after a/flight.json: b's JSON, its seconds and the summary missing. The
    // rerun redoes b alone (a's JSON, planted with a marker, is kept as it is), from another
    // directory and with other spellings of the same paths: the keys do not depend on them.
    std::fs::remove_file(&out_b).unwrap();
    std::fs::remove_file(out.join("b/flight.seconds")).unwrap();
    std::fs::remove_file(out.join("summary.jsonl")).unwrap();
    let marked = json_a.replacen("\"samples\"", "\"marker\": 1,\n  \"samples\"", 1);
    assert_ne!(marked, json_a);
    std::fs::write(&out_a, &marked).unwrap();
    let o = batch_in(&dir, &["./b", "a/../a/flight.csv", "--out", &s(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains("1 to do") && err.contains("1 already diagnosed"),
        "{err}"
    );
    assert_eq!(
        std::fs::read_to_string(&out_a).unwrap(),
        marked,
        "a not redone"
    );
    assert_eq!(std::fs::read_to_string(&out_b).unwrap(), json_b, "b redone");
    assert!(out.join("b/flight.seconds").exists());
    // both present: neither redone, whatever the order and the spelling
    let o = batch_in(&dir.join("a"), &["../b/flight.csv", ".", "--out", &s(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("0 to do"), "{}", stderr(&o));
    // --force redoes both, each into its own JSON: the single runs again
    let o = batch(&[&s(&a), &s(&b), "--out", &s(&out), "--force"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("2 to do"), "{}", stderr(&o));
    assert_eq!(check(), Vec::<String>::new());

    // The check catches a planted fault: b's diagnosis in a's JSON (what a shared name
    // would leave).
    std::fs::write(&out_a, &json_b).unwrap();
    assert_eq!(check().len(), 1, "{:?}", check());
    std::fs::remove_dir_all(&dir).ok();
}

/// The rows' fields in their order, named by where each row came from, against the columns
/// of `summary.csv`: what differs.
fn field_differences(
    columns: &[String],
    rows: &std::collections::BTreeMap<String, Vec<String>>,
) -> Vec<String> {
    rows.iter()
        .filter(|(_, fields)| fields.as_slice() != columns)
        .map(|(from, fields)| format!("{from}: {fields:?}"))
        .collect()
}

/// Imports `scripts/batch_ray.py` (or `MASSID_BATCH_RAY`, to run this test against another
/// version of it) without Ray, runs its per-recording task on each (name, recording, extra
/// options) and prints, as JSON, each row's keys in order; also those of the rows given on
/// stdin (name -> line). Python's dicts keep the order of a JSON object's keys.
const ROW_KEYS_PY: &str = r#"
import importlib.util, json, sys, types
sys.dont_write_bytecode = True  # no __pycache__ left in scripts/
script, massid = sys.argv[1], sys.argv[2]
# an older script imported Ray at the top: a stand-in lets it load (the task is then the
# plain function); the current one imports Ray only in main()
sys.modules["ray"] = types.SimpleNamespace(remote=lambda f: f)
spec = importlib.util.spec_from_file_location("batch_ray", script)
m = importlib.util.module_from_spec(spec)
spec.loader.exec_module(m)
given = json.load(sys.stdin)
keys = {name: list(json.loads(line).keys()) for name, line in given["rust"].items()}
for name, rec, extra in given["python"]:
    _, _, line = m.diagnose(massid, rec, extra)
    row = json.loads(line)
    keys[name] = list(row.keys())
    keys[name + " status"] = [row["status"]]
print(json.dumps(keys))
"#;

#[test]
fn every_row_rust_or_python_ok_or_error_has_the_same_fields_in_the_same_order() {
    let dir = tmp("diagnose_batch", "row_fields");
    let recs = dir.join("recs");
    let good = recs.join("good.csv");
    ok(&[
        "simulate",
        "--maneuver",
        "single",
        "--seconds",
        "2",
        "--rate",
        "100",
        "--out",
        &s(&good),
    ]);
    let bad = recs.join("bad.csv");
    std::fs::write(&bad, "# format = massid-recording/1\nnot,a,recording\n").unwrap();
    // Rust: the batch's summary (an ok and an error row) and header, the per-recording
    // command's rows
    let out = dir.join("out");
    assert!(!batch(&[&s(&recs), "--out", &s(&out)]).status.success());
    let csv = std::fs::read_to_string(out.join("summary.csv")).unwrap();
    let columns: Vec<String> = csv
        .lines()
        .next()
        .unwrap()
        .split(',')
        .map(str::to_string)
        .collect();
    let summary = std::fs::read_to_string(out.join("summary.jsonl")).unwrap();
    let mut rust = serde_json::Map::new();
    for line in summary.lines() {
        let status = if line.contains("\"status\":\"ok\"") {
            "ok"
        } else {
            "error"
        };
        rust.insert(format!("rust batch {status} row"), line.into());
    }
    assert_eq!(rust.len(), 2, "{summary}");
    let single = |rec: &Path| {
        let o = massid(&["diagnose", &s(rec), "--summary-row"]);
        String::from_utf8_lossy(&o.stdout).trim().to_string()
    };
    rust.insert("rust --summary-row ok row".into(), single(&good).into());
    rust.insert("rust --summary-row error row".into(), single(&bad).into());
    // a refused option still gets its error row, naming the recording and the reason
    let refused = massid(&["diagnose", &s(&good), "--horizon", "-1", "--summary-row"]);
    assert!(!refused.status.success());
    let refused_row = String::from_utf8_lossy(&refused.stdout).trim().to_string();
    let parsed: serde_json::Value = serde_json::from_str(&refused_row).expect("one JSON row");
    assert_eq!(parsed["status"], "error", "{refused_row}");
    assert_eq!(parsed["file"], s(&good).as_str(), "{refused_row}");
    assert!(
        parsed["error"].as_str().unwrap().contains("--horizon -1"),
        "{refused_row}"
    );
    rust.insert("rust --summary-row refused row".into(), refused_row.into());
    // Python (scripts/batch_ray.py's task, without Ray): massid's rows passed on, and its
    // own error row when massid prints none (an option the argument parser rejects)
    let python = serde_json::json!([
        ["python ok row", s(&good), []],
        ["python error row", s(&bad), []],
        ["python fallback row", s(&good), ["--no-such-option"]],
    ]);
    let script = std::env::var("MASSID_BATCH_RAY")
        .unwrap_or_else(|_| s(&repo().join("scripts/batch_ray.py")));
    let mut child = std::process::Command::new("python3")
        .args(["-c", ROW_KEYS_PY, &script, &common::bin()])
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("python3 runs (the Ray recipe's rows are checked with it)");
    let given = serde_json::json!({"rust": rust, "python": python}).to_string();
    use std::io::Write;
    child
        .stdin
        .take()
        .unwrap()
        .write_all(given.as_bytes())
        .unwrap();
    let o = child.wait_with_output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let mut keys: std::collections::BTreeMap<String, Vec<String>> =
        serde_json::from_slice(&o.stdout).expect("the keys as JSON");
    // the fallback row really is the script's own (the argument parser refused: no row)
    assert_eq!(
        keys.remove("python fallback row status").unwrap(),
        ["error"]
    );
    assert_eq!(keys.remove("python error row status").unwrap(), ["error"]);
    assert_eq!(keys.remove("python ok row status").unwrap(), ["ok"]);
    assert_eq!(keys.len(), 8, "{keys:?}");
    assert_eq!(
        columns,
        [
            "file",
            "status",
            "model",
            "samples",
            "effects",
            "params",
            "residual_rms_before",
            "residual_rms_after",
            "unexplained",
            "error",
            "seconds"
        ]
    );
    assert_eq!(field_differences(&columns, &keys), Vec::<String>::new());

    // The check catches a planted fault: the error row the script wrote before (three
    // fields), and a row with its fields out of order.
    let mut planted = keys.clone();
    planted.insert(
        "old python fallback row".into(),
        vec!["file".into(), "status".into(), "error".into()],
    );
    let mut swapped = columns.clone();
    swapped.swap(0, 1);
    planted.insert("swapped".into(), swapped);
    assert_eq!(field_differences(&columns, &planted).len(), 2);
    std::fs::remove_dir_all(&dir).ok();
}
