#!/usr/bin/env bash
# Installs what the tests need on a fresh machine: rustup targets, nightly rust-src for the
# Hexagon DSP build, QEMU for the emulated Cortex-M runs, gcc for the C ABI test, Z3 for the
# solver proofs, Python's venv for the Ray recipe check.
# Idempotent: skips what is already there.
set -euo pipefail

need_apt=()
command -v gcc >/dev/null || need_apt+=(gcc)
command -v qemu-system-arm >/dev/null || need_apt+=(qemu-system-arm)
# llvm-size / llvm-objdump for scripts/kernel-report.sh.
{ command -v llvm-size >/dev/null && command -v llvm-objdump >/dev/null; } || need_apt+=(llvm)
# plotters' font rendering (font-kit) links fontconfig and freetype.
{ command -v pkg-config >/dev/null && pkg-config --exists fontconfig freetype2; } || need_apt+=(pkg-config libfontconfig1-dev libfreetype-dev)
# Z3 for proofs-solver (the z3 crate links Debian's libz3; its bindgen needs libclang 14).
{ [ -e /usr/include/z3.h ] && ls /usr/lib/llvm-14/lib/libclang*.so* >/dev/null 2>&1 && [ -d /usr/lib/llvm-14/lib/clang ]; } || \
  need_apt+=(libz3-dev libclang1-14 libclang-common-14-dev)
# Python with venv for scripts/batch-engine-check.sh (Ray from PyPI into a venv).
{ command -v python3 >/dev/null && python3 -c 'import venv, ensurepip' 2>/dev/null; } || need_apt+=(python3 python3-venv)
if [ ${#need_apt[@]} -gt 0 ]; then
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq "${need_apt[@]}" >/dev/null
fi

# Formatting, lints and docs are part of the test command.
rustup component add rustfmt clippy >/dev/null 2>&1 || rustup component add rustfmt clippy
rustup target add thumbv6m-none-eabi thumbv7em-none-eabihf riscv32imc-unknown-none-elf >/dev/null 2>&1 || \
  rustup target add thumbv6m-none-eabi thumbv7em-none-eabihf riscv32imc-unknown-none-elf
if rustup toolchain list | grep -q nightly; then :; else rustup toolchain install nightly --profile minimal; fi
rustup component add rust-src --toolchain nightly >/dev/null 2>&1 || rustup component add rust-src --toolchain nightly
# Nightly Cortex-M std for the -Zemit-stack-sizes builds of scripts/kernel-report.sh.
rustup target add --toolchain nightly thumbv6m-none-eabi thumbv7em-none-eabihf >/dev/null 2>&1 || \
  rustup target add --toolchain nightly thumbv6m-none-eabi thumbv7em-none-eabihf
