//! `libmassid_kernel_capi.a`: the kernel's C ABI (`massid_kernel::capi`, header
//! `kernel/include/massid_kernel.h`) as a static library for C flight software. Built and
//! exercised with gcc by `tests/tests/capi.rs` (program `kernel/capi-test/capi_run.c`).
pub use massid_kernel::capi;
