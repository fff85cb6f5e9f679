//! `libmassid_kernel_capi.a`: the kernel's C ABI (`massid_kernel::capi`, header
//! `kernel/include/massid_kernel.h`) as a static library for C flight software. Built and
//! exercised with gcc by `tests/tests/capi.rs` (program `kernel/capi-test/capi_run.c`); built
//! for the embedded targets by `scripts/kernel-report.sh` for the code-size table.
#![cfg_attr(target_os = "none", no_std)]

pub use massid_kernel::capi;

/// Bare-metal builds: the kernel never panics (clippy denies every panicking construct), so
/// this handler is unreachable; it parks the core rather than returning into C.
#[cfg(target_os = "none")]
#[panic_handler]
fn panic(_info: &core::panic::PanicInfo) -> ! {
    loop {
        core::hint::spin_loop();
    }
}
