#!/usr/bin/env bash
# Runs every test of the workspace, installing what they need first.
# This is the README's test command; .ci/run calls it on a clean checkout.
set -euo pipefail
cd "$(dirname "$0")/.."

step() { printf '\n==== %s ====\n' "$*"; }

# A clean checkout builds once: incremental caches only cost disk here (4 GB).
export CARGO_INCREMENTAL=0

step "toolchain and system packages"
scripts/setup.sh

step "formatting, lints and docs (every crate, every target; warnings are errors)"
cargo fmt --all --check
cargo clippy --workspace --all-targets --locked -- -D warnings
RUSTDOCFLAGS="-D warnings" cargo doc --workspace --no-deps --locked

step "workspace tests (host)"
cargo test --workspace --locked

step "diagnose over many recordings through Ray, local mode (issue 25 item 4: Ray into a venv from PyPI, ~35 s the first time)"
MASSID=${CARGO_TARGET_DIR:-target}/debug/massid scripts/batch-engine-check.sh

step "the cfg(kani) side of the proof harnesses type-checks (Kani itself cannot be installed here)"
proofs/kani-stub/check.sh

step "benchmarks compile (run them with cargo bench; ratios: scripts/bench-report.sh)"
cargo bench --workspace --locked --no-run

if [ -x scripts/cross-check.sh ]; then
  step "embedded targets"
  scripts/cross-check.sh
fi

step "disk used by the build"
du -sh "${CARGO_TARGET_DIR:-target}" 2>/dev/null || true

step "all tests passed"
