//! The control period and the firmware's stated fault-detection bounds.
//!
//! A bound is the longest time from the last control step whose inputs were
//! healthy to the first step whose outputs are the safe state (pump
//! disabled, relief valve open). Parameter-dependent bounds are given by
//! [`detection_bound_ms`]; the `*_DETECT_MS` constants are their values for
//! [`Params::DEFAULT`]. The self-test scenarios check every one of them.

use super::params::Params;
use super::types::Fault;

/// Control period (ms): the board calls `Controller::step` at 100 Hz.
pub const CONTROL_PERIOD_MS: u32 = 10;

/// A step arriving more than this after the previous one is an overrun
/// (three periods).
pub const CONTROL_OVERRUN_LIMIT_MS: u32 = 3 * CONTROL_PERIOD_MS;

/// Stated detection bound (ms) of `fault` under `params`:
///
/// - immediate faults (over-pressure, out-of-range reading, end-stop, leak,
///   volume limit): one period;
/// - sensor bus: `sensor_bus_error_steps` periods;
/// - stale: `sensor_stale_ms` + one period; frozen: `sensor_frozen_ms` + one
///   period (counted from the last change of the value);
/// - pump stall: two blocks of `stall_volume_ml` at the expand rate, each
///   rounded up to whole periods plus one period for the float sum;
/// - diameter mismatch: `diameter_mismatch_ms` + one period (from the last
///   step within the tolerance);
/// - control overrun: 0, it latches in the late step itself; a loop that
///   never steps again is the hardware watchdog's job, which is not fed;
/// - link loss: `link_timeout_ms` + one period, counted from the last step
///   that received a host frame (with the watch off, 0: it never latches).
pub const fn detection_bound_ms(fault: Fault, params: &Params) -> u32 {
    let t = CONTROL_PERIOD_MS;
    match fault {
        Fault::OverPressure
        | Fault::SensorOutOfRange
        | Fault::EndStop
        | Fault::Leak
        | Fault::VolumeLimit => t,
        Fault::SensorBus => params.sensor_bus_error_steps as u32 * t,
        Fault::SensorStale => params.sensor_stale_ms.saturating_add(t),
        Fault::SensorFrozen => params.sensor_frozen_ms.saturating_add(t),
        Fault::PumpStall => {
            let block_ms = params.stall_volume_ml / params.expand_rate_ml_per_s * 1000.0;
            // Ceiling to whole periods without std float methods.
            let periods = (block_ms / t as f32) as u32;
            let periods = if (periods as f32) * (t as f32) < block_ms {
                periods + 1
            } else {
                periods
            };
            2 * (periods + 1) * t
        }
        Fault::DiameterMismatch => params.diameter_mismatch_ms.saturating_add(t),
        // Latched at boot from the handler's record, no detection time.
        Fault::ControlOverrun | Fault::Panic => 0,
        Fault::LinkLoss => {
            if params.link_timeout_ms == 0 {
                0
            } else {
                params.link_timeout_ms.saturating_add(t)
            }
        }
    }
}

/// Over-pressure: the step that sees the reading.
pub const OVER_PRESSURE_DETECT_MS: u32 = detection_bound_ms(Fault::OverPressure, &Params::DEFAULT);
/// Sensor bus: three failed steps by default.
pub const SENSOR_BUS_DETECT_MS: u32 = detection_bound_ms(Fault::SensorBus, &Params::DEFAULT);
/// Implausible reading (NaN, ±∞ below the range): the step that sees it.
pub const SENSOR_OUT_OF_RANGE_DETECT_MS: u32 =
    detection_bound_ms(Fault::SensorOutOfRange, &Params::DEFAULT);
/// Frozen sensor while pumping (default 300 ms + one period).
pub const SENSOR_FROZEN_DETECT_MS: u32 = detection_bound_ms(Fault::SensorFrozen, &Params::DEFAULT);
/// Stale reading (default 50 ms + one period).
pub const SENSOR_STALE_DETECT_MS: u32 = detection_bound_ms(Fault::SensorStale, &Params::DEFAULT);
/// End-stop closed while active: the step that sees it.
pub const END_STOP_DETECT_MS: u32 = detection_bound_ms(Fault::EndStop, &Params::DEFAULT);
/// Pump stall (default 2 × (500 + 10) ms).
pub const PUMP_STALL_DETECT_MS: u32 = detection_bound_ms(Fault::PumpStall, &Params::DEFAULT);
/// Leak during a hold: the step where the drop exceeds the limit.
pub const LEAK_DETECT_MS: u32 = detection_bound_ms(Fault::Leak, &Params::DEFAULT);
/// Volume out of its limits: the step that sees it.
pub const VOLUME_LIMIT_DETECT_MS: u32 = detection_bound_ms(Fault::VolumeLimit, &Params::DEFAULT);
/// Diameter mismatch (default 500 ms + one period).
pub const DIAMETER_MISMATCH_DETECT_MS: u32 =
    detection_bound_ms(Fault::DiameterMismatch, &Params::DEFAULT);
/// Control overrun: latched in the late step itself.
pub const CONTROL_OVERRUN_DETECT_MS: u32 =
    detection_bound_ms(Fault::ControlOverrun, &Params::DEFAULT);

/// Link loss (default 2 s + one period).
pub const LINK_LOSS_DETECT_MS: u32 = detection_bound_ms(Fault::LinkLoss, &Params::DEFAULT);

/// Accepted range of the sensor's gauge zero, absolute (kPa): the
/// atmosphere from about 3,000 m above sea level (70 kPa) to a deep
/// low-lying lab on a high-pressure day with a few decimetres of water
/// over the sensor (115 kPa; sea level is 101.3). A zero outside it means
/// the tare was taken with the head pressurised, buried or on a broken
/// part: `Start` is refused ([`CommandError::NoPressureZero`]).
///
/// [`CommandError::NoPressureZero`]: super::CommandError::NoPressureZero
pub const PRESSURE_ZERO_RANGE_KPA: (f32, f32) = (70.0, 115.0);

/// True when `zero_kpa` (absolute) is a gauge zero the controller accepts:
/// finite and inside [`PRESSURE_ZERO_RANGE_KPA`].
pub fn pressure_zero_in_range(zero_kpa: f32) -> bool {
    zero_kpa >= PRESSURE_ZERO_RANGE_KPA.0 && zero_kpa <= PRESSURE_ZERO_RANGE_KPA.1
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_bounds() {
        assert_eq!(OVER_PRESSURE_DETECT_MS, 10);
        assert_eq!(SENSOR_BUS_DETECT_MS, 30);
        assert_eq!(SENSOR_FROZEN_DETECT_MS, 310);
        assert_eq!(SENSOR_STALE_DETECT_MS, 60);
        // 1 mL at 2 mL/s = 500 ms = 50 periods; 2 × (50 + 1) × 10 ms.
        assert_eq!(PUMP_STALL_DETECT_MS, 1020);
        assert_eq!(DIAMETER_MISMATCH_DETECT_MS, 510);
        assert_eq!(LINK_LOSS_DETECT_MS, 2010);
    }

    #[test]
    fn zero_range() {
        assert!(pressure_zero_in_range(101.325));
        assert!(!pressure_zero_in_range(f32::NAN));
        assert!(!pressure_zero_in_range(60.0));
        assert!(!pressure_zero_in_range(130.0));
    }

    #[test]
    fn stall_bound_rounds_up() {
        let p = Params {
            stall_volume_ml: 1.0,
            expand_rate_ml_per_s: 3.0,
            ..Params::DEFAULT
        };
        // 333.3 ms → 34 periods; 2 × 35 × 10.
        assert_eq!(detection_bound_ms(Fault::PumpStall, &p), 700);
    }
}
