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

    #[entry]
    fn main() -> ! {
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
