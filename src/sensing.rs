//! What the sensor task does when a read fails: written once, for the
//! board's sensor task ([`crate::tasks::sensor`]) and for host-sim's
//! emulated sensor, which follows the same rules.
//!
//! Each control period the task reads the part; a read that fails (NAK,
//! CRC, timeout) is tried again at once, within the same period
//! ([`RETRIES_PER_PERIOD`]). A single bus glitch therefore costs nothing:
//! the period still publishes a fresh reading. A period whose read and
//! retry both failed is a *failed period* ([`SensorHealth::period_failed`]):
//! the task then clears the bus (nine SCL pulses and a STOP if a device
//! holds SDA low, then a reset of the I²C peripheral; see
//! [`crate::drivers::i2c_bus_clear`]) and re-initialises the part, which
//! frees a bus held by a part that lost its place in a transfer. It keeps
//! the last good reading published meanwhile (its age grows, which the
//! controller's stale monitor bounds), and publishes
//! [`PressureSample::BusError`](crate::controller::PressureSample::BusError)
//! only once [`FAILED_PERIODS_BEFORE_BUS_ERROR`] periods in a row failed:
//! a bus the recovery cured never shows as an error, one it did not cure
//! latches `SensorBus` ([`crate::controller::detection_bound_ms`]).

/// Extra read attempts within one control period after a failed one.
pub const RETRIES_PER_PERIOD: u8 = 1;

/// Consecutive failed periods (each with its retry and a bus recovery in
/// between) before the task publishes `BusError`.
pub const FAILED_PERIODS_BEFORE_BUS_ERROR: u8 = 2;

/// What the task does after a failed period.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AfterFailure {
    /// Publish `BusError` (the failure persisted).
    pub publish_bus_error: bool,
    /// Clear the bus and re-initialise the part before the next period.
    pub recover: bool,
}

/// The count of consecutive failed periods.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SensorHealth {
    failed_periods: u8,
}

impl SensorHealth {
    /// A healthy sensor.
    pub const fn new() -> Self {
        Self { failed_periods: 0 }
    }

    /// A period delivered a reading: the count starts again.
    pub fn read_ok(&mut self) {
        self.failed_periods = 0;
    }

    /// A period's read and its retries all failed.
    pub fn period_failed(&mut self) -> AfterFailure {
        self.failed_periods = self.failed_periods.saturating_add(1);
        AfterFailure {
            publish_bus_error: self.failed_periods >= FAILED_PERIODS_BEFORE_BUS_ERROR,
            recover: true,
        }
    }

    /// Consecutive failed periods so far.
    pub fn failed_periods(&self) -> u8 {
        self.failed_periods
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bus_error_only_once_the_failure_persists() {
        let mut h = SensorHealth::new();
        let first = h.period_failed();
        assert!(first.recover && !first.publish_bus_error);
        h.read_ok();
        assert!(!h.period_failed().publish_bus_error);
        let second = h.period_failed();
        assert!(second.recover && second.publish_bus_error);
        for _ in 0..300 {
            assert!(h.period_failed().publish_bus_error);
        }
        assert_eq!(h.failed_periods(), u8::MAX);
    }
}
