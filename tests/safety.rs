//! The safe-outputs routine shared by boot, the Fault state and the panic
//! and HardFault handlers, against embedded-hal-mock pins: every output
//! goes to its safe electrical level, and a failing pin does not stop the
//! others from being written.

use embedded_hal_mock::eh1::digital::{Mock as PinMock, State, Transaction as Pin};
use embedded_hal_mock::eh1::MockError;
use urechis::safety::{advance_level, safe_outputs, valve_level, SafeOutputsFailed, SafePins};

/// The safe levels written out again from the wiring: ENABLE high (the
/// A4988/DRV8825 enable is active low), STEP low, valve gate low
/// (normally-open valve de-energised = vented), advance drive low.
#[test]
fn every_output_goes_to_its_safe_level() {
    let mut enable = PinMock::new(&[Pin::set(State::High)]);
    let mut step = PinMock::new(&[Pin::set(State::Low)]);
    let mut valve = PinMock::new(&[Pin::set(State::Low)]);
    let mut advance = PinMock::new(&[Pin::set(State::Low)]);
    let result = safe_outputs(SafePins {
        driver_enable: &mut enable,
        step: &mut step,
        relief_valve: &mut valve,
        advance_drive: &mut advance,
    });
    assert_eq!(result, Ok(()));
    for pin in [&mut enable, &mut step, &mut valve, &mut advance] {
        pin.done();
    }
}

#[test]
fn a_failing_pin_does_not_stop_the_others() {
    let err = || MockError::Io(std::io::ErrorKind::Other);
    let mut enable = PinMock::new(&[Pin::set(State::High).with_error(err())]);
    let mut step = PinMock::new(&[Pin::set(State::Low)]);
    let mut valve = PinMock::new(&[Pin::set(State::Low).with_error(err())]);
    let mut advance = PinMock::new(&[Pin::set(State::Low)]);
    let result = safe_outputs(SafePins {
        driver_enable: &mut enable,
        step: &mut step,
        relief_valve: &mut valve,
        advance_drive: &mut advance,
    });
    assert_eq!(result, Err(SafeOutputsFailed(2)));
    for pin in [&mut enable, &mut step, &mut valve, &mut advance] {
        pin.done();
    }
}

#[test]
fn valve_and_advance_levels() {
    use embedded_hal::digital::PinState;
    assert_eq!(valve_level(true), PinState::Low);
    assert_eq!(valve_level(false), PinState::High);
    assert_eq!(advance_level(true), PinState::High);
    assert_eq!(advance_level(false), PinState::Low);
}
