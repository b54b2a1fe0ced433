//! Runs every controller self-test scenario ([`urechis::selftest::SCENARIOS`])
//! on a Cortex-M4 under `qemu-system-arm -machine netduinoplus2`, then
//! replays every recorded emulator run
//! ([`urechis_qemu_tests::replay_data::RECORDINGS`]) through the same
//! controller and checks each step's decision against the host's
//! ([`urechis::replay::check`]). Prints one `name ... ok` /
//! `name ... FAILED: why` line per scenario and recording and a closing
//! `N passed, N failed` line through semihosting, and exits with the
//! semihosting exit code (0 only when everything passed).
//!
//! On any other target this is a stub, so host builds of the whole workspace
//! (`cargo clippy --workspace --target host-tuple`) stay green.
#![cfg_attr(target_os = "none", no_std)]
#![cfg_attr(target_os = "none", no_main)]

#[cfg(target_os = "none")]
mod qemu {
    use core::sync::atomic::{AtomicU32, Ordering};

    use cortex_m_rt::entry;
    use cortex_m_semihosting::{debug, hprint, hprintln};
    use urechis::replay;
    use urechis::selftest::SCENARIOS;
    use urechis::table::generated::TABLE;
    use urechis_qemu_tests::replay_data::RECORDINGS;

    /// Scenarios finished so far, kept where the panic handler can read them.
    static PASSED: AtomicU32 = AtomicU32::new(0);
    static FAILED: AtomicU32 = AtomicU32::new(0);

    /// The pattern the free stack is painted with.
    const PAINT: u32 = 0xC0FF_EE55;

    extern "C" {
        /// End of the static RAM (cortex-m-rt): the stack may grow down to
        /// here.
        static __sheap: u32;
        /// Top of the stack (cortex-m-rt).
        static _stack_start: u32;
    }

    /// Paints the free stack below the current stack pointer (less a
    /// margin for this function's own frame).
    fn paint_stack() {
        let bottom = core::ptr::addr_of!(__sheap) as usize;
        let sp = cortex_m::register::msp::read() as usize - 64;
        let mut p = bottom;
        while p < sp {
            // SAFETY: between the end of the statics and the live stack:
            // memory nothing uses yet.
            unsafe { core::ptr::write_volatile(p as *mut u32, PAINT) };
            p += 4;
        }
    }

    /// Deepest the stack reached (bytes from its top): the first word from
    /// the bottom that is no longer paint.
    fn stack_high_water_bytes() -> usize {
        let bottom = core::ptr::addr_of!(__sheap) as usize;
        let top = core::ptr::addr_of!(_stack_start) as usize;
        let mut p = bottom;
        // SAFETY: reads of the same free region.
        while p < top && unsafe { core::ptr::read_volatile(p as *const u32) } == PAINT {
            p += 4;
        }
        top - p
    }

    #[entry]
    fn main() -> ! {
        paint_stack();
        for scenario in SCENARIOS {
            // Printed first so a panicking scenario is named on its line.
            hprint!("{} ... ", scenario.name);
            match (scenario.run)() {
                Ok(()) => {
                    PASSED.fetch_add(1, Ordering::Relaxed);
                    hprintln!("ok");
                }
                Err(why) => {
                    FAILED.fetch_add(1, Ordering::Relaxed);
                    hprintln!("FAILED: {}", why);
                }
            }
        }
        // The self-tests build their tables on the stack; the replays run
        // only the controller and the decoder: measured apart.
        let scenarios_bytes = stack_high_water_bytes();
        paint_stack();
        for recording in RECORDINGS {
            hprint!("replay {} ... ", recording.name);
            match replay::check(recording.bytes, TABLE) {
                Ok(summary) => {
                    PASSED.fetch_add(1, Ordering::Relaxed);
                    hprintln!(
                        "ok ({} steps, telemetry digest {:#010x})",
                        summary.steps,
                        summary.digest
                    );
                }
                Err(why) => {
                    FAILED.fetch_add(1, Ordering::Relaxed);
                    hprintln!("FAILED: {}", why);
                }
            }
        }
        hprintln!(
            "stack high-water mark (painted stack, read back): self-tests {} bytes, replays {} bytes",
            scenarios_bytes,
            stack_high_water_bytes()
        );
        finish()
    }

    /// Prints the closing count line and exits: code 0 only if none failed.
    fn finish() -> ! {
        let (passed, failed) = (
            PASSED.load(Ordering::Relaxed),
            FAILED.load(Ordering::Relaxed),
        );
        hprintln!("{} passed, {} failed", passed, failed);
        debug::exit(if failed == 0 {
            debug::EXIT_SUCCESS
        } else {
            debug::EXIT_FAILURE
        });
        // Only reached when no debugger/QEMU honours the exit request.
        loop {
            cortex_m::asm::bkpt();
        }
    }

    /// A panic fails the scenario that raised it and ends the run (there is
    /// no unwinding to go on with): say where, print the count line, exit
    /// non-zero. panic-probe would spin in a fault loop under QEMU instead.
    #[panic_handler]
    fn panic(info: &core::panic::PanicInfo) -> ! {
        hprintln!("FAILED: {}", info);
        FAILED.fetch_add(1, Ordering::Relaxed);
        finish()
    }
}

#[cfg(not(target_os = "none"))]
fn main() {
    eprintln!(
        "urechis-qemu-tests runs on a Cortex-M4 under QEMU: use `bash scripts/qemu-test.sh`."
    );
}
