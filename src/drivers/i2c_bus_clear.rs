//! Freeing an I²C bus that a device holds low (NXP UM10204 §3.1.16, "bus
//! clear"): a device that lost clocks mid-byte (a reset of the master, a
//! glitch on SCL) keeps driving SDA low while it waits for the rest of its
//! byte. Up to nine clock pulses on SCL let it finish and release SDA; a
//! STOP then returns every device to idle.
//!
//! Generic over embedded-hal pins: the board drives PB8/PB9 as open-drain
//! GPIOs with the I²C peripheral off, the virtual board its simulated
//! lines; both call [`clear_bus`].

use embedded_hal::delay::DelayNs;
use embedded_hal::digital::{InputPin, OutputPin};

/// Most SCL pulses a stuck device can need: the eight bits of its byte and
/// the acknowledge.
pub const MAX_CLOCKS: u8 = 9;

/// Half a clock period (µs): 100 kHz, the bus's own speed.
pub const HALF_PERIOD_US: u32 = 5;

/// The bus could not be freed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum BusClearError {
    /// SDA still low after [`MAX_CLOCKS`] pulses: a device is stuck for
    /// good (or SDA is shorted to ground).
    SdaStuckLow,
    /// A pin could not be read or written.
    Pin,
}

fn pin<E>(_: E) -> BusClearError {
    BusClearError::Pin
}

/// Clocks SCL until SDA is released (at most [`MAX_CLOCKS`] pulses), then
/// sends a STOP (SDA rising while SCL is high). Returns the pulses it took
/// (0: the bus was free; a STOP is still sent). `scl` and `sda` are
/// open-drain lines with pull-ups: high = released.
pub fn clear_bus<Scl, Sda, D>(
    scl: &mut Scl,
    sda: &mut Sda,
    delay: &mut D,
) -> Result<u8, BusClearError>
where
    Scl: OutputPin,
    Sda: OutputPin + InputPin,
    D: DelayNs,
{
    sda.set_high().map_err(pin)?;
    scl.set_high().map_err(pin)?;
    delay.delay_us(HALF_PERIOD_US);
    let mut pulses = 0;
    while sda.is_low().map_err(pin)? {
        if pulses == MAX_CLOCKS {
            return Err(BusClearError::SdaStuckLow);
        }
        scl.set_low().map_err(pin)?;
        delay.delay_us(HALF_PERIOD_US);
        scl.set_high().map_err(pin)?;
        delay.delay_us(HALF_PERIOD_US);
        pulses += 1;
    }
    // STOP: SDA low while SCL is low, SCL high, then SDA high.
    scl.set_low().map_err(pin)?;
    delay.delay_us(HALF_PERIOD_US);
    sda.set_low().map_err(pin)?;
    delay.delay_us(HALF_PERIOD_US);
    scl.set_high().map_err(pin)?;
    delay.delay_us(HALF_PERIOD_US);
    sda.set_high().map_err(pin)?;
    delay.delay_us(HALF_PERIOD_US);
    Ok(pulses)
}
