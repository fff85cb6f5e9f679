//! The batch diagnosis (`cli/src/cmd/batch.rs`) and the single one (`cli/src/cmd/diagnose.rs`)
//! depend on each other one way only: the per-recording job (diagnosis, JSON, summary row)
//! lives in `diagnose`, which the batch uses; `diagnose` never names the batch, and the
//! choice between one recording and many is the command dispatch's (`cmd::run_diagnose`).
//! Read from the sources: an import cycle compiles in Rust, so only the text shows it.
use std::collections::BTreeSet;
use std::path::PathBuf;

fn source(name: &str) -> String {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("src")
        .join(name);
    std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// The sibling modules `text` names in code (`super::NAME` or `use super::{NAME, ..}`),
/// comments left out (a doc link is no dependency).
fn siblings(text: &str) -> BTreeSet<String> {
    let mut found = BTreeSet::new();
    let code: String = text
        .lines()
        .map(|l| match l.find("//") {
            Some(i) => &l[..i],
            None => l,
        })
        .collect::<Vec<_>>()
        .join("\n");
    let ident = |s: &str| -> String {
        s.chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect()
    };
    let mut rest = code.as_str();
    while let Some(i) = rest.find("super::") {
        rest = &rest[i + "super::".len()..];
        let after = rest.trim_start();
        if let Some(group) = after.strip_prefix('{') {
            // `use super::{a, b::c}`: each item's first segment
            let end = group.find('}').unwrap_or(group.len());
            for item in group[..end].split(',') {
                let name = ident(item.trim());
                if !name.is_empty() {
                    found.insert(name);
                }
            }
        } else {
            let name = ident(after);
            // `super::NAME::...` is a module; `super::f(` an item of `cmd` itself
            if after[name.len()..].starts_with("::") {
                found.insert(name);
            }
        }
    }
    found
}

/// What is wrong with the layout, given the three sources.
fn layout_faults(batch: &str, diagnose: &str, dispatch: &str) -> Vec<String> {
    let mut faults = Vec::new();
    let (b, d) = (siblings(batch), siblings(diagnose));
    if d.contains("batch") {
        faults.push("diagnose.rs names the batch module (the dependency must run one way: batch -> diagnose)".to_string());
    }
    if !b.contains("diagnose") {
        faults.push("batch.rs does not use the per-recording job of diagnose.rs".to_string());
    }
    if !(dispatch.contains("batch::run(") && dispatch.contains("diagnose::run(")) {
        faults.push("cmd/mod.rs does not choose between diagnose::run and batch::run".to_string());
    }
    faults
}

#[test]
fn the_batch_uses_the_per_recording_job_and_not_the_other_way_round() {
    let batch = source("cmd/batch.rs");
    let diagnose = source("cmd/diagnose.rs");
    let dispatch = source("cmd/mod.rs");
    assert_eq!(
        layout_faults(&batch, &diagnose, &dispatch),
        Vec::<String>::new()
    );
    // the main dispatch goes through cmd::run_diagnose
    assert!(
        source("main.rs").contains("cmd::run_diagnose(a)"),
        "main.rs dispatches `diagnose` through cmd::run_diagnose"
    );

    // The check catches the cycle this layout replaced (diagnose.rs calling the batch, as it
    // did before: `super::batch::run(..)` and `super::batch::Row::error(..)`), in either
    // spelling, and a doc link is not taken for one.
    let old = format!("{diagnose}\nfn f() {{ return super::batch::run(b); }}\n");
    assert_eq!(layout_faults(&batch, &old, &dispatch).len(), 1);
    let old = format!("{diagnose}\nuse super::{{batch::Row, mix}};\n");
    assert_eq!(layout_faults(&batch, &old, &dispatch).len(), 1);
    let doc = format!("{diagnose}\n/// see [`super::batch::run`]\n");
    assert_eq!(layout_faults(&batch, &doc, &dispatch), Vec::<String>::new());
    assert_eq!(
        siblings("use super::diagnose::{diagnose_file, Row};\nsuper::check_output(x);"),
        BTreeSet::from(["diagnose".to_string()])
    );
}
