//! Picks the memory map for the QEMU machine of the target and links with cortex-m-rt's
//! `link.x`: `thumbv6m-none-eabi` runs on `-machine microbit` (nRF51822: 256 KB flash at 0,
//! 16 KB RAM), `thumbv7em-none-eabihf` on `-machine mps2-an386` (Cortex-M4F; 4 MB SSRAM1 at
//! 0 used as flash, SSRAM2 at 0x2000_0000, of which 256 KB are used as RAM: the integer-float
//! identification's state (29 kB) plus its fit's stack overflowed 64 KB; 256 KB is what an
//! STM32F4-class part has, 192-256 KB).
use std::env;
use std::fs;
use std::path::PathBuf;

fn main() {
    let target = env::var("TARGET").unwrap_or_default();
    // The `capi` build only serves the stack analysis and is never run: it keeps every C-ABI
    // entry point of both instantiations, which does not fit the micro:bit's flash.
    let analysis_only = env::var_os("CARGO_FEATURE_CAPI").is_some();
    let memory = if target.starts_with("thumbv6m") && !analysis_only {
        "MEMORY\n{\n  FLASH : ORIGIN = 0x00000000, LENGTH = 256K\n  RAM : ORIGIN = 0x20000000, LENGTH = 16K\n}\n"
    } else {
        "MEMORY\n{\n  FLASH : ORIGIN = 0x00000000, LENGTH = 4M\n  RAM : ORIGIN = 0x20000000, LENGTH = 256K\n}\n"
    };
    let out = PathBuf::from(env::var("OUT_DIR").unwrap_or_default());
    // Keep the per-function stack sizes that `-Z emit-stack-sizes` produces (non-allocated).
    let extra = "SECTIONS\n{\n  .stack_sizes (INFO) :\n  {\n    KEEP(*(.stack_sizes));\n  }\n}\nINSERT AFTER .got;\n";
    if let Err(e) = fs::write(out.join("memory.x"), memory).and_then(|()| fs::write(out.join("stack_sizes.x"), extra)) {
        eprintln!("massid-qemu-firmware build: writing the linker scripts to {}: {e}", out.display());
        std::process::exit(1);
    }
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed=build.rs");
    if target.starts_with("thumb") {
        println!("cargo:rustc-link-arg-bins=-Tlink.x");
        println!("cargo:rustc-link-arg-bins=-Tstack_sizes.x");
    }
}
