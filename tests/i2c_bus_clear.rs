//! The I²C bus clear (NXP UM10204 §3.1.16) against a simulated pair of
//! open-drain lines with a device that holds SDA low until it has seen a
//! number of SCL rising edges.

use std::cell::{Cell, RefCell};
use std::convert::Infallible;

use embedded_hal::delay::DelayNs;
use embedded_hal::digital::{ErrorType, InputPin, OutputPin};
use urechis::drivers::i2c_bus_clear::{clear_bus, BusClearError, MAX_CLOCKS};

/// The two lines, a stuck device and what happened on them.
#[derive(Default)]
struct Lines {
    held_for: Cell<u8>,
    scl_high: Cell<bool>,
    sda_low: Cell<bool>,
    rising_scl: Cell<u8>,
    /// (SCL high, SDA level) at each SDA edge the master made.
    sda_edges: RefCell<Vec<(bool, bool)>>,
}

struct Scl<'a>(&'a Lines);
struct Sda<'a>(&'a Lines);

impl ErrorType for Scl<'_> {
    type Error = Infallible;
}
impl OutputPin for Scl<'_> {
    fn set_low(&mut self) -> Result<(), Infallible> {
        self.0.scl_high.set(false);
        Ok(())
    }
    fn set_high(&mut self) -> Result<(), Infallible> {
        if !self.0.scl_high.get() {
            self.0.rising_scl.set(self.0.rising_scl.get() + 1);
            self.0.held_for.set(self.0.held_for.get().saturating_sub(1));
        }
        self.0.scl_high.set(true);
        Ok(())
    }
}
impl ErrorType for Sda<'_> {
    type Error = Infallible;
}
impl OutputPin for Sda<'_> {
    fn set_low(&mut self) -> Result<(), Infallible> {
        self.0.sda_low.set(true);
        self.0
            .sda_edges
            .borrow_mut()
            .push((self.0.scl_high.get(), false));
        Ok(())
    }
    fn set_high(&mut self) -> Result<(), Infallible> {
        self.0.sda_low.set(false);
        self.0
            .sda_edges
            .borrow_mut()
            .push((self.0.scl_high.get(), true));
        Ok(())
    }
}
impl InputPin for Sda<'_> {
    fn is_high(&mut self) -> Result<bool, Infallible> {
        Ok(!self.is_low()?)
    }
    fn is_low(&mut self) -> Result<bool, Infallible> {
        Ok(self.0.sda_low.get() || self.0.held_for.get() > 0)
    }
}

struct NoDelay;
impl DelayNs for NoDelay {
    fn delay_ns(&mut self, _: u32) {}
}

fn clear(held_for: u8) -> (Result<u8, BusClearError>, Lines) {
    let lines = Lines {
        held_for: Cell::new(held_for),
        scl_high: Cell::new(true),
        ..Lines::default()
    };
    let r = clear_bus(&mut Scl(&lines), &mut Sda(&lines), &mut NoDelay);
    (r, lines)
}

/// The last SDA edge is a STOP: SDA rising while SCL is high, after SDA
/// went low while SCL was low.
fn ends_with_stop(lines: &Lines) -> bool {
    let edges = lines.sda_edges.borrow();
    matches!(edges.as_slice(), [.., (false, false), (true, true)])
        && lines.scl_high.get()
        && !lines.sda_low.get()
}

#[test]
fn a_free_bus_gets_a_stop_and_no_clocks() {
    let (r, lines) = clear(0);
    assert_eq!(r, Ok(0));
    assert!(ends_with_stop(&lines));
    // Only the STOP's own rising SCL edge.
    assert_eq!(lines.rising_scl.get(), 1);
}

#[test]
fn a_held_sda_is_clocked_free_then_stopped() {
    for held in 1..=MAX_CLOCKS {
        let (r, lines) = clear(held);
        assert_eq!(r, Ok(held), "held for {held}");
        assert_eq!(lines.held_for.get(), 0);
        assert!(ends_with_stop(&lines));
    }
}

#[test]
fn a_device_stuck_for_good_is_reported_after_nine_clocks() {
    let (r, lines) = clear(MAX_CLOCKS + 1);
    assert_eq!(r, Err(BusClearError::SdaStuckLow));
    assert_eq!(lines.rising_scl.get(), MAX_CLOCKS);
}
