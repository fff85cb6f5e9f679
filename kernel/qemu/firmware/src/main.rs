//! Runs the kernel over the embedded sequence and prints its outputs over semihosting, then
//! exits QEMU (status 0, or 1 on a write error or a panic).
#![no_std]
#![no_main]

use core::fmt::{self, Write};
use cortex_m_rt::entry;
use cortex_m_semihosting::debug::{self, EXIT_FAILURE, EXIT_SUCCESS};
use cortex_m_semihosting::hio;

/// Line-buffered semihosting stdout (one host call per line, not per `write_str`).
struct Semihosted {
    stream: hio::HostStream,
    line: [u8; 256],
    len: usize,
}

impl Semihosted {
    fn flush(&mut self) -> fmt::Result {
        let n = self.len;
        self.len = 0;
        self.stream.write_all(self.line.get(..n).unwrap_or(&[])).map_err(|()| fmt::Error)
    }
}

impl Write for Semihosted {
    fn write_str(&mut self, s: &str) -> fmt::Result {
        for &b in s.as_bytes() {
            if self.len == self.line.len() {
                self.flush()?;
            }
            if let Some(slot) = self.line.get_mut(self.len) {
                *slot = b;
                self.len += 1;
            }
            if b == b'\n' {
                self.flush()?;
            }
        }
        Ok(())
    }
}

/// The C ABI entry points, kept in the image (never called here) for the stack analysis.
#[cfg(feature = "capi")]
mod keep_capi {
    use massid_kernel::capi as c;

    /// Addresses of functions (only stored, never dereferenced).
    #[allow(dead_code)]
    pub struct Keep(pub [*const (); 31]);
    // SAFETY: the array is immutable and only holds code addresses.
    unsafe impl Sync for Keep {}

    #[used]
    pub static KEEP: Keep = Keep([
        c::massid_fixed_init as *const (),
        c::massid_fixed_tick as *const (),
        c::massid_fixed_tick_gap as *const (),
        c::massid_fixed_finish as *const (),
        c::massid_fixed_estimates as *const (),
        c::massid_fixed_mixer_init as *const (),
        c::massid_fixed_mixer_from_pipeline as *const (),
        c::massid_fixed_mix as *const (),
        c::massid_f32_init as *const (),
        c::massid_f32_tick as *const (),
        c::massid_f32_tick_gap as *const (),
        c::massid_f32_finish as *const (),
        c::massid_f32_estimates as *const (),
        c::massid_f32_mixer_init as *const (),
        c::massid_f32_mixer_from_pipeline as *const (),
        c::massid_f32_mix as *const (),
        c::craft::massid_fixed_craft_mixer_init as *const (),
        c::craft::massid_fixed_craft_mix as *const (),
        c::craft::massid_f32_craft_mixer_init as *const (),
        c::craft::massid_f32_craft_mix as *const (),
        c::craft::massid_f32_flight_id_init as *const (),
        c::craft::massid_f32_flight_id_push as *const (),
        c::craft::massid_f32_flight_id_push_wrench as *const (),
        c::craft::massid_f32_flight_id_finish as *const (),
        c::craft::massid_f32_flight_id_solve as *const (),
        c::craft::massid_f32_flight_id_reanchor as *const (),
        c::craft::massid_fixed_flight_id_init as *const (),
        c::craft::massid_fixed_flight_id_push as *const (),
        c::craft::massid_fixed_flight_id_push_wrench as *const (),
        c::craft::massid_fixed_flight_id_finish as *const (),
        c::craft::massid_fixed_flight_id_solve as *const (),
    ]);
}

#[entry]
fn main() -> ! {
    let status = match hio::hstdout() {
        Ok(stream) => {
            let mut out = Semihosted { stream, line: [0; 256], len: 0 };
            match massid_qemu_runner::run_all(&mut out).and_then(|()| out.flush()) {
                Ok(()) => EXIT_SUCCESS,
                Err(_) => EXIT_FAILURE,
            }
        }
        Err(()) => EXIT_FAILURE,
    };
    debug::exit(status);
    loop {
        cortex_m::asm::nop();
    }
}

#[panic_handler]
fn panic(_info: &core::panic::PanicInfo) -> ! {
    if let Ok(mut err) = hio::hstderr() {
        let _ = err.write_all(b"PANIC in firmware\n");
    }
    debug::exit(EXIT_FAILURE);
    loop {
        cortex_m::asm::nop();
    }
}
