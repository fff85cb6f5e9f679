#!/usr/bin/env bash
# Type-checks the cfg(kani) side of massid-proofs (every harness as Kani compiles it, the
# library and its test targets) against a stand-in `kani` crate, where the real Kani cannot
# be installed. Proves nothing by itself.
# Usage: proofs/kani-stub/check.sh   (builds into $CARGO_TARGET_DIR or target/, ~2 min)
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
out="${CARGO_TARGET_DIR:-$here/../../target}/kani-stub"
mkdir -p "$out"
rustc --edition 2021 --crate-type proc-macro --crate-name kani_macros -o "$out/libkani_macros.so" "$here/kani_macros.rs"
rustc --edition 2021 --crate-type rlib --crate-name kani --extern kani_macros="$out/libkani_macros.so" -o "$out/libkani.rlib" "$here/kani.rs"
cd "$here/../.."
# The wrapper gives cfg(kani) to massid-proofs' own crates (library and every test target)
# and to nothing else. A separate target directory keeps the normal build's cache.
KANI_STUB_DIR="$out" RUSTC_WRAPPER="$here/rustc-wrapper.sh" \
  CARGO_TARGET_DIR="$out/target" cargo check -p massid-proofs --all-targets --quiet
echo "cfg(kani) side of massid-proofs (library and test targets) type-checks"
