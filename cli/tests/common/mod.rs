//! What every CLI test needs: the binary, run and checked; the repository; a fresh temporary
//! directory. One copy, included by each test file (`mod common;`).
#![allow(dead_code)] // each test file uses its own subset
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The binary under test; `MASSID_BIN` runs the tests against another build (e.g. the one
/// before a fix, to see each test fail).
pub fn bin() -> String {
    std::env::var("MASSID_BIN").unwrap_or_else(|_| env!("CARGO_BIN_EXE_massid").to_string())
}

/// Runs `massid` with `args`.
pub fn massid(args: &[&str]) -> Output {
    Command::new(bin())
        .args(args)
        .output()
        .expect("massid runs")
}

/// Runs `massid`, expects success, returns stdout.
pub fn ok(args: &[&str]) -> String {
    let out = massid(args);
    assert!(
        out.status.success(),
        "massid {args:?} failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// The workspace root.
pub fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// An empty directory for one test: `file` names the test file, `name` the test.
pub fn tmp(file: &str, name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("massid-{file}-{}-{name}", std::process::id()));
    std::fs::remove_dir_all(&d).ok();
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A path as an argument.
pub fn s(p: &Path) -> String {
    p.display().to_string()
}
