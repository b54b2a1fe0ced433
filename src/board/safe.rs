//! The safe state by register, for the paths that own no pin driver: boot
//! (before the HAL has made any pin), the Fault state (the pump task owns
//! ENABLE and STEP) and the panic and HardFault handlers (the executor may
//! be anywhere). All of them call [`crate::safety::safe_outputs`] through
//! [`drive_outputs_safe`]; a GPIO set/reset register write is atomic, so it
//! cannot tear a write of the task that owns the pin.
//!
//! The handlers then record why they reset ([`crate::reset_cause`], in RAM
//! the startup code leaves alone), log with defmt and reset the MCU; the
//! next boot reads the record with [`take_reset_record`].

use core::convert::Infallible;
use core::mem::MaybeUninit;
use core::sync::atomic::{AtomicBool, Ordering};

use cortex_m_rt::{exception, ExceptionFrame};
use embassy_stm32::pac;
use embassy_stm32::pac::gpio::Gpio;
use embedded_hal::digital::{ErrorType, OutputPin};

use crate::reset_cause::{PanicKind, ResetRecord};
use crate::safety::{safe_outputs, SafeOutputsFailed, SafePins};

/// A GPIO output written through its port's registers.
struct RawPin {
    port: Gpio,
    /// Pin number within the port, 0–15.
    pin: u8,
}

impl RawPin {
    /// Raw register values, not the PAC's indexed field setters: those
    /// bounds-check the pin number, a panic branch this code (run by the
    /// panic handler) must not have. The pin is masked to 0–15.
    fn set(&mut self, high: bool) {
        let pin = u32::from(self.pin & 0x0f);
        // Level first, then output mode: an input pin becomes an output
        // already at the safe level, with no glitch. BSRR: bits 0–15 set,
        // 16–31 reset.
        let bit = if high { 1 << pin } else { 1 << (pin + 16) };
        self.port.bsrr().write_value(pac::gpio::regs::Bsrr(bit));
        // MODER: two bits a pin, 0b01 = general-purpose output.
        self.port.moder().modify(|w| {
            w.0 = (w.0 & !(0b11 << (2 * pin))) | (0b01 << (2 * pin));
        });
    }
}

impl ErrorType for RawPin {
    type Error = Infallible;
}

impl OutputPin for RawPin {
    fn set_low(&mut self) -> Result<(), Infallible> {
        self.set(false);
        Ok(())
    }

    fn set_high(&mut self) -> Result<(), Infallible> {
        self.set(true);
        Ok(())
    }
}

/// STEP: TIM1 stopped with CH3 forced low, then PA10 a plain output,
/// low, so no edge can follow whatever the timer was doing.
struct StepPin(RawPin);

impl ErrorType for StepPin {
    type Error = Infallible;
}

impl OutputPin for StepPin {
    fn set_low(&mut self) -> Result<(), Infallible> {
        super::step_timer::stop_by_register();
        self.0.set(false);
        Ok(())
    }

    fn set_high(&mut self) -> Result<(), Infallible> {
        self.0.set(true);
        Ok(())
    }
}

/// Drives ENABLE (PB5), STEP (PA10, its timer stopped), the relief valve
/// (PA8) and the advance drive (PA9) to their safe levels with
/// [`safe_outputs`], turning the GPIO ports' clocks on first (boot may
/// call it before the HAL has).
pub fn drive_outputs_safe() -> Result<(), SafeOutputsFailed> {
    pac::RCC.ahb1enr().modify(|w| {
        w.set_gpioaen(true);
        w.set_gpioben(true);
    });
    safe_outputs(SafePins {
        driver_enable: &mut RawPin {
            port: pac::GPIOB,
            pin: 5,
        },
        step: &mut StepPin(RawPin {
            port: pac::GPIOA,
            pin: 10,
        }),
        relief_valve: &mut RawPin {
            port: pac::GPIOA,
            pin: 8,
        },
        advance_drive: &mut RawPin {
            port: pac::GPIOA,
            pin: 9,
        },
    })
}

/// The record a handler leaves for the next boot; `.uninit` is not
/// zeroed by the startup code.
#[link_section = ".uninit.urechis_reset_record"]
static mut RESET_RECORD: MaybeUninit<[u32; 4]> = MaybeUninit::uninit();

/// Reads the last run's record (a panic or HardFault, and where) and clears
/// it; `None` after a power-on (noise), a pin or watchdog reset.
pub fn take_reset_record() -> Option<(PanicKind, u32)> {
    let slot = core::ptr::addr_of_mut!(RESET_RECORD).cast::<[u32; 4]>();
    // SAFETY: a static of four words that only this function and the
    // handlers touch, never both at once (single core; boot runs before
    // any task); volatile so the write before reset is not elided.
    let words = unsafe { core::ptr::read_volatile(slot) };
    unsafe { core::ptr::write_volatile(slot, ResetRecord::EMPTY.to_words()) };
    ResetRecord::from_words(words).decode()
}

fn write_reset_record(kind: PanicKind, pc: u32) {
    let slot = core::ptr::addr_of_mut!(RESET_RECORD).cast::<[u32; 4]>();
    // SAFETY: as in `take_reset_record`; interrupts are off here.
    unsafe { core::ptr::write_volatile(slot, ResetRecord::new(kind, pc).to_words()) };
}

/// Set by the first handler to run: a panic inside the handler's own
/// logging goes straight to the reset.
static HANDLING: AtomicBool = AtomicBool::new(false);

/// Time left for a debug probe to read the log before the reset (core
/// cycles at 84 MHz): 20 ms, well inside the independent watchdog's
/// shortest timeout (68 ms).
const LOG_DRAIN_CYCLES: u32 = 84_000 * 20;

fn safe_then_reset(kind: PanicKind, pc: u32, log: impl FnOnce()) -> ! {
    cortex_m::interrupt::disable();
    let _ = drive_outputs_safe();
    write_reset_record(kind, pc);
    if !HANDLING.swap(true, Ordering::Relaxed) {
        log();
        cortex_m::asm::delay(LOG_DRAIN_CYCLES);
    }
    cortex_m::peripheral::SCB::sys_reset()
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    safe_then_reset(PanicKind::Panic, 0, || {
        defmt::error!(
            "panic: {}: outputs safe, resetting",
            defmt::Display2Format(info)
        )
    })
}

#[exception]
unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
    let pc = frame.pc();
    safe_then_reset(PanicKind::HardFault, pc, || {
        defmt::error!("HardFault at pc {=u32:#010x}: outputs safe, resetting", pc)
    })
}
