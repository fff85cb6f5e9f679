#!/usr/bin/env bash
# RUSTC_WRAPPER for check.sh: adds `--cfg kani` and the stand-in `kani` crate to the crates
# of massid-proofs only (its library and test targets); every dependency builds as usual
# (some, like zerocopy, carry Kani contracts of their own that the stand-in does not model).
rustc="$1"; shift
for a in "$@"; do
  case "$a" in
    proofs/src/lib.rs|proofs/tests/*.rs|*/proofs/src/lib.rs|*/proofs/tests/*.rs)
      exec "$rustc" "$@" --cfg kani --extern kani="$KANI_STUB_DIR/libkani.rlib" -L "$KANI_STUB_DIR" ;;
  esac
done
exec "$rustc" "$@"
