//! The safe state of the outputs, written once: stepper driver disabled,
//! STEP low, relief valve de-energised (the normally-open valve vents the
//! line) and advance drive off.
//!
//! [`safe_outputs`] is the one routine that puts the pins there. It is
//! called at boot (before anything else touches a pin), by the control task
//! on every step in the Fault state, and by the board's panic and HardFault
//! handlers before they log and reset; the virtual board calls it on its
//! simulated pins the same way. The levels it writes are the ones the
//! wiring's resistors hold while the MCU is in reset (`board` module's
//! wiring table): pull-up on ENABLE, pull-downs on STEP, the valve's
//! MOSFET gate and the advance drive.
//!
//! A panic must not stop half-way, so every pin is written even when an
//! earlier write failed; the failures are counted, not returned early.

use embedded_hal::digital::{OutputPin, PinState};

/// ENABLE level that turns the stepper driver's outputs off (the
/// A4988/DRV8825 ENABLE is active low).
pub const DRIVER_OFF: PinState = PinState::High;

/// STEP level at rest (the driver steps on the rising edge).
pub const STEP_IDLE: PinState = PinState::Low;

/// Relief-valve gate level that de-energises the normally-open valve: open,
/// line vented.
pub const VALVE_VENTED: PinState = PinState::Low;

/// Advance-drive level for "off".
pub const ADVANCE_OFF: PinState = PinState::Low;

/// The pins the safe state sets, by role.
#[derive(Debug)]
pub struct SafePins<'a, Enable, Step, Valve, Advance> {
    /// Stepper driver ENABLE (active low).
    pub driver_enable: &'a mut Enable,
    /// Stepper driver STEP.
    pub step: &'a mut Step,
    /// Relief valve MOSFET gate (high = energised = closed).
    pub relief_valve: &'a mut Valve,
    /// Advance drive (high = on).
    pub advance_drive: &'a mut Advance,
}

/// How many of the four pin writes failed (0 = all outputs safe).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SafeOutputsFailed(pub u8);

/// Drives every output to its safe level, driver first (it moves the
/// plunger), then STEP, the valve (vents) and the advance drive. Every pin
/// is written even after a failure; `Err` counts the failed writes.
pub fn safe_outputs<Enable, Step, Valve, Advance>(
    pins: SafePins<'_, Enable, Step, Valve, Advance>,
) -> Result<(), SafeOutputsFailed>
where
    Enable: OutputPin,
    Step: OutputPin,
    Valve: OutputPin,
    Advance: OutputPin,
{
    let results = [
        pins.driver_enable.set_state(DRIVER_OFF).is_ok(),
        pins.step.set_state(STEP_IDLE).is_ok(),
        pins.relief_valve.set_state(VALVE_VENTED).is_ok(),
        pins.advance_drive.set_state(ADVANCE_OFF).is_ok(),
    ];
    let failed = results.iter().filter(|ok| !**ok).count() as u8;
    if failed == 0 {
        Ok(())
    } else {
        Err(SafeOutputsFailed(failed))
    }
}

/// The relief valve's gate level for `open` (normally open valve:
/// energised = closed).
pub fn valve_level(open: bool) -> PinState {
    if open {
        VALVE_VENTED
    } else {
        PinState::High
    }
}

/// The advance drive's level for `on`.
pub fn advance_level(on: bool) -> PinState {
    if on {
        PinState::High
    } else {
        ADVANCE_OFF
    }
}
