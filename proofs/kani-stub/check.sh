#!/usr/bin/env bash
# Type-checks the cfg(kani) side of massid-proofs (every harness as Kani compiles it) against a
# stand-in `kani` crate, where the real Kani cannot be installed. Proves nothing by itself.
# Usage: proofs/kani-stub/check.sh   (builds into $CARGO_TARGET_DIR or target/, ~2 min)
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
out="${CARGO_TARGET_DIR:-$here/../../target}/kani-stub"
mkdir -p "$out"
rustc --edition 2021 --crate-type proc-macro --crate-name kani_macros -o "$out/libkani_macros.so" "$here/kani_macros.rs"
rustc --edition 2021 --crate-type rlib --crate-name kani --extern kani_macros="$out/libkani_macros.so" -o "$out/libkani.rlib" "$here/kani.rs"
cd "$here/../.."
# `cargo rustc` passes the flags to massid-proofs only (its dependencies build as usual).
CARGO_TARGET_DIR="$out/target" cargo rustc -p massid-proofs --lib --profile check --quiet -- \
  --cfg kani --extern kani="$out/libkani.rlib" -L "$out"
echo "cfg(kani) side of massid-proofs type-checks"
