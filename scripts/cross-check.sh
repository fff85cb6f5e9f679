#!/usr/bin/env bash
# Embedded-target checks of the kernel (called by scripts/test-all.sh; needs scripts/setup.sh):
#  1. release builds of massid-kernel for thumbv6m-none-eabi, thumbv7em-none-eabihf,
#     riscv32imc-unknown-none-elf (stable) and hexagon-unknown-none-elf (nightly,
#     -Zbuild-std=core); msp430-none-elf is tried too and only reported;
#  2. clippy on the kernel (its panic-forbidding lints are in kernel/src/lib.rs) with -D warnings;
#  3. QEMU: the firmware of kernel/qemu runs the kernel (fixed and f32) over a recorded sequence
#     on an emulated Cortex-M0 (micro:bit) and Cortex-M4F (MPS2-AN386); its semihosted output
#     must equal the host build's (fixed bit for bit, f32 within MASSID_F32_MAX_ULP, default 0);
#  4. scripts/kernel-report.sh (code size, state size, stack, instructions per tick), unless
#     MASSID_SKIP_REPORT=1; informative (a failure there is printed, not fatal).
# Artefacts go to out/kernel/. Exits non-zero on the first failure.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD
BASE=${CARGO_TARGET_DIR:-$ROOT/target}
OUT=$ROOT/out/kernel
mkdir -p "$OUT"
step() { printf '\n---- %s ----\n' "$*"; }

STABLE_TARGETS=(thumbv6m-none-eabi thumbv7em-none-eabihf riscv32imc-unknown-none-elf)

step "massid-kernel --release for ${STABLE_TARGETS[*]}"
for t in "${STABLE_TARGETS[@]}"; do
  CARGO_TARGET_DIR=$BASE cargo build --locked --release -p massid-kernel --target "$t"
  CARGO_TARGET_DIR=$BASE cargo build --locked --release -p massid-kernel --features capi --target "$t"
done

step "massid-kernel --release for hexagon-unknown-none-elf (nightly, -Zbuild-std=core)"
CARGO_TARGET_DIR=$BASE/nightly cargo +nightly build --locked --release -p massid-kernel --features capi \
  --target hexagon-unknown-none-elf -Zbuild-std=core

step "massid-kernel --release for msp430-none-elf (nightly; informative only)"
if CARGO_TARGET_DIR=$BASE/nightly cargo +nightly build --locked --release -p massid-kernel --features capi \
     --target msp430-none-elf -Zbuild-std=core >"$OUT/msp430-build.log" 2>&1; then
  echo "msp430-none-elf: builds"
else
  echo "msp430-none-elf: does not build (see $OUT/msp430-build.log); not required"
fi

step "clippy (kernel, -D warnings)"
CARGO_TARGET_DIR=$BASE cargo clippy --locked -p massid-kernel -- -D warnings
CARGO_TARGET_DIR=$BASE cargo clippy --locked -p massid-kernel --features capi -- -D warnings
CARGO_TARGET_DIR=$BASE cargo clippy --locked -p massid-kernel --features capi --target thumbv6m-none-eabi -- -D warnings

step "QEMU: kernel on Cortex-M0 and Cortex-M4F vs host build"
# The micro:bit image is size-optimised (opt-level s, as a 256 KB-flash flight image would be);
# the M4F image uses the release profile as is (opt-level 3, the build the report counts).
QBASE=$BASE/qemu
M0BASE=$BASE/qemu-s
(
  cd kernel/qemu
  CARGO_TARGET_DIR=$QBASE cargo build --locked --release -p massid-qemu-host
  CARGO_TARGET_DIR=$QBASE cargo test --locked --release -p massid-qemu-host
  CARGO_PROFILE_RELEASE_OPT_LEVEL=s CARGO_TARGET_DIR=$M0BASE \
    cargo build --locked --release -p massid-qemu-firmware --target thumbv6m-none-eabi
  CARGO_TARGET_DIR=$QBASE cargo build --locked --release -p massid-qemu-firmware --target thumbv7em-none-eabihf
)
HOST_TOOL=$QBASE/release/massid-qemu-host
"$HOST_TOOL" run >"$OUT/host.txt"
# the M0's suite leaves out the identification (its state does not fit the micro:bit's 16 kB)
"$HOST_TOOL" run --no-identification >"$OUT/host-m0.txt"
run_qemu() { # image machine-args...
  local image=$1; shift
  timeout 600 qemu-system-arm "$@" -semihosting-config enable=on,target=native -nographic \
    -monitor none -serial none -kernel "$image"
}
run_qemu "$M0BASE/thumbv6m-none-eabi/release/massid-qemu-firmware" -machine microbit >"$OUT/qemu-m0.txt"
run_qemu "$QBASE/thumbv7em-none-eabihf/release/massid-qemu-firmware" -machine mps2-an386 -cpu cortex-m4 >"$OUT/qemu-m4f.txt"
"$HOST_TOOL" compare "$OUT/host-m0.txt" "$OUT/qemu-m0.txt" "${MASSID_F32_MAX_ULP:-0}"
"$HOST_TOOL" compare "$OUT/host.txt" "$OUT/qemu-m4f.txt" "${MASSID_F32_MAX_ULP:-0}"

if [ "${MASSID_SKIP_REPORT:-0}" != 1 ]; then
  step "kernel report (informative: goals are reported, not enforced)"
  scripts/kernel-report.sh || echo "cross-check: WARNING: scripts/kernel-report.sh failed; the checks above passed"
fi
echo "cross-check: all embedded checks passed"
