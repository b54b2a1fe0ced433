//! The control period and the firmware's stated fault-detection bounds.
//!
//! A bound is the longest time from the last control step whose inputs were
//! healthy to the first step whose outputs are the safe state (pump
//! disabled, relief valve open). Parameter-dependent bounds are given by
//! [`detection_bound_ms`]; the `*_DETECT_MS` constants are their values for
//! [`Params::DEFAULT`]. The self-test scenarios check every one of them.

use super::params::{ParamField, Params};
use super::types::Fault;
use crate::drivers::ms5837::Model;
use crate::drivers::pump::ACCEL_ML_PER_S2;

/// `ms` rounded up to whole control periods, without std float methods.
const fn ceil_periods(ms: f32) -> u32 {
    let t = CONTROL_PERIOD_MS as f32;
    let periods = (ms / t) as u32;
    if (periods as f32) * t < ms {
        periods + 1
    } else {
        periods
    }
}

/// The pressure sensor this build is for: one model per build, as fitted.
/// The MS5837-02BA by default (the wiring's part: 300–1200 mbar absolute
/// specified, 1 Pa resolution); the cargo feature `sensor-30ba` builds
/// for the MS5837-30BA (0–30 bar) instead, for rigs that need more than
/// the 02BA's ≈ 18 kPa gauge at sea level.
pub const SENSOR_MODEL: Model = if cfg!(feature = "sensor-30ba") {
    Model::Bar30
} else {
    Model::Bar02
};

/// Absolute pressures the fitted sensor is specified over (kPa): every
/// pressure limit must lie inside them ([`sensor_sees_limits`], the ranges
/// of `max_pressure_kpa`, `sensor_min_kpa` and `sensor_max_kpa`).
pub const SENSOR_SPECIFIED_KPA: (f32, f32) = SENSOR_MODEL.specified_kpa();

/// Largest gauge pressure (kPa) the fitted sensor can see with the lowest
/// accepted zero: the ceiling of `max_pressure_kpa` and `sensor_max_kpa`
/// (02BA: 120 − 70 = 50 kPa). The zero in force lowers it further; `Start`
/// and a tare check that ([`sensor_sees_limits`]).
pub const SENSOR_MAX_GAUGE_KPA: f32 = SENSOR_SPECIFIED_KPA.1 - PRESSURE_ZERO_RANGE_KPA.0;

/// Lowest gauge pressure (kPa) the fitted sensor can see with the highest
/// accepted zero, but no lower than −100 kPa (a vacuum at sea level): the
/// floor of `sensor_min_kpa` (02BA: 30 − 115 = −85 kPa).
pub const SENSOR_MIN_GAUGE_KPA: f32 = {
    let floor = SENSOR_SPECIFIED_KPA.0 - PRESSURE_ZERO_RANGE_KPA.1;
    if floor > -100.0 {
        floor
    } else {
        -100.0
    }
};

/// Checks that with the gauge zero `zero_kpa` (absolute) the fitted sensor
/// can see both pressure limits of `params`: `zero + max_pressure_kpa` no
/// higher than the top of [`SENSOR_SPECIFIED_KPA`] (else the trip could
/// sit where the reading is not to be trusted) and `zero + sensor_min_kpa`
/// no lower than its bottom. `Start` and a new tare are refused otherwise,
/// naming the field. A NaN anywhere fails.
pub fn sensor_sees_limits(zero_kpa: f32, params: &Params) -> Result<(), ParamField> {
    let (lo, hi) = SENSOR_SPECIFIED_KPA;
    // Written so that NaN fails.
    let trip_visible = zero_kpa + params.max_pressure_kpa <= hi;
    if !trip_visible {
        return Err(ParamField::MaxPressureKpa);
    }
    let floor_visible = zero_kpa + params.sensor_min_kpa >= lo;
    if !floor_visible {
        return Err(ParamField::SensorMinKpa);
    }
    Ok(())
}

/// Control period (ms): the board calls `Controller::step` at 100 Hz.
pub const CONTROL_PERIOD_MS: u32 = 10;

/// A step arriving more than this after the previous one is an overrun
/// (three periods).
pub const CONTROL_OVERRUN_LIMIT_MS: u32 = 3 * CONTROL_PERIOD_MS;

/// Stated detection bound (ms) of `fault` under `params`:
///
/// - immediate faults (over-pressure, out-of-range reading, end-stop, leak,
///   volume limit): one period;
/// - sensor bus: from the first failed read, the sensor task's
///   [`FAILED_PERIODS_BEFORE_BUS_ERROR`](crate::sensing::FAILED_PERIODS_BEFORE_BUS_ERROR)
///   failed periods (each retried, with a bus recovery between them) before
///   it publishes `BusError`, then `sensor_bus_error_steps` steps;
/// - stale: `sensor_stale_ms` + one period; frozen: `sensor_frozen_ms` + one
///   period (counted from the last change of the value);
/// - pump stall: two blocks of `stall_volume_ml` at the rate in use (the
///   expand rate in Expand, the shrink rate in Shrink; the bound takes the
///   slower), each
///   rounded up to whole periods plus one period for the float sum, plus
///   the pump's ramp to that rate (`rate / ACCEL_ML_PER_S2`, whole
///   periods);
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
        Fault::SensorBus => {
            (crate::sensing::FAILED_PERIODS_BEFORE_BUS_ERROR as u32
                + params.sensor_bus_error_steps as u32)
                * t
        }
        Fault::SensorStale => params.sensor_stale_ms.saturating_add(t),
        Fault::SensorFrozen => params.sensor_frozen_ms.saturating_add(t),
        Fault::PumpStall => {
            // The slower of the two pumping rates: Expand's blocks at the
            // expand rate, Shrink's at the shrink rate.
            let rate = if params.expand_rate_ml_per_s < params.shrink_rate_ml_per_s {
                params.expand_rate_ml_per_s
            } else {
                params.shrink_rate_ml_per_s
            };
            let block_ms = params.stall_volume_ml / rate * 1000.0;
            // The pump reaches the rate after its ramp; the first block is
            // late by at most the ramp's time.
            let ramp_ms = rate / ACCEL_ML_PER_S2 * 1000.0;
            2 * (ceil_periods(block_ms) + 1) * t + ceil_periods(ramp_ms) * t
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

/// The board's timing around the controller, for the end-to-end bounds
/// ([`end_to_end_bound_ms`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BoardTiming {
    /// Time between sensor reads (ms): one per control period.
    pub sensor_period_ms: u32,
    /// Longest from the start of a read (the pressure's sampling, D1
    /// first) to its publication (ms): two conversions and the bus
    /// traffic, rounded up.
    pub sensor_read_ms: u32,
    /// Longest from an end-stop switch opening to the pump task publishing
    /// it (ms): the debounce and the pump task's idle poll.
    pub end_stop_delay_ms: u32,
    /// The relief valve's response (ms): from its gate going low to the
    /// line vented. A property of the fitted valve (small solenoid valves:
    /// 10–50 ms). The emulator's plant delays its valve by this figure
    /// (host-sim's `PlantConfig::valve_response_ms`, 50 ms by default)
    /// and checks every fault scenario's venting against
    /// [`end_to_end_bound_ms`]; a slower valve fails those checks.
    pub valve_response_ms: u32,
}

/// The board's timing: sensor read every period, a read within 7 ms
/// (OSR 1024: 2 × 2.28 ms + 1.6 ms of bus, `tasks::sensor::READ_MAX_US`),
/// end-stops within 4 ms (2 ms debounce + 2 ms idle poll), and a 50 ms
/// valve.
pub const BOARD_TIMING: BoardTiming = BoardTiming {
    sensor_period_ms: CONTROL_PERIOD_MS,
    sensor_read_ms: 7,
    end_stop_delay_ms: 4,
    valve_response_ms: 50,
};

/// Longest time (ms) from the physical event to the line vented, under
/// `params` and `timing`: [`detection_bound_ms`] (from the first step whose
/// inputs show the fault) plus what lies before and after it.
///
/// - Faults seen through the pressure (over-pressure, out of range, leak,
///   stall, diameter mismatch): the sensor's period and read time before
///   a reading shows the event; or, if the readings stop meanwhile, the
///   oldest reading accepted (`sensor_stale_ms`, the stale fault's bound),
///   whichever is longer.
/// - Sensor faults (bus, stale, frozen) are timed from the sensor's
///   failure: their own bound.
/// - End-stop: the switch's debounce and poll before the step.
/// - Volume limit, overrun, link loss, panic: the pump task publishes the
///   count at every step; the others need no input.
///
/// Every fault then adds the valve's response. The control loop's phase
/// is inside each bound's period.
pub const fn end_to_end_bound_ms(fault: Fault, params: &Params, timing: &BoardTiming) -> u32 {
    let bound = detection_bound_ms(fault, params);
    let sensed = timing.sensor_period_ms + timing.sensor_read_ms + bound;
    let stale = detection_bound_ms(Fault::SensorStale, params);
    let before = match fault {
        Fault::OverPressure
        | Fault::SensorOutOfRange
        | Fault::Leak
        | Fault::PumpStall
        | Fault::DiameterMismatch => {
            if sensed > stale {
                sensed
            } else {
                stale
            }
        }
        Fault::EndStop => timing.end_stop_delay_ms + bound,
        Fault::SensorBus
        | Fault::SensorFrozen
        | Fault::SensorStale
        | Fault::VolumeLimit
        | Fault::ControlOverrun
        | Fault::LinkLoss
        | Fault::Panic => bound,
    };
    before.saturating_add(timing.valve_response_ms)
}

/// Over-pressure: the step that sees the reading.
pub const OVER_PRESSURE_DETECT_MS: u32 = detection_bound_ms(Fault::OverPressure, &Params::DEFAULT);
/// Sensor bus: two failed sensor periods, then three steps, by default.
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
/// Pump stall (default 2 × (500 + 10) ms + 10 ms of ramp).
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
        // (2 failed sensor periods + 3 steps) × 10 ms.
        assert_eq!(SENSOR_BUS_DETECT_MS, 50);
        assert_eq!(SENSOR_FROZEN_DETECT_MS, 310);
        assert_eq!(SENSOR_STALE_DETECT_MS, 60);
        // 1 mL at 2 mL/s = 500 ms = 50 periods; 2 × (50 + 1) × 10 ms,
        // plus the 10 ms ramp to 2 mL/s at 200 mL/s².
        assert_eq!(PUMP_STALL_DETECT_MS, 1030);
        assert_eq!(DIAMETER_MISMATCH_DETECT_MS, 510);
        assert_eq!(LINK_LOSS_DETECT_MS, 2010);
    }

    #[test]
    fn limits_the_02ba_can_see() {
        if SENSOR_MODEL != Model::Bar02 {
            return;
        }
        assert_eq!(SENSOR_MAX_GAUGE_KPA, 50.0);
        assert_eq!(SENSOR_MIN_GAUGE_KPA, -85.0);
        let p = Params::DEFAULT;
        // Sea level: 101.3 + 15 = 116.3 kPa ≤ 120.
        assert_eq!(sensor_sees_limits(101.325, &p), Ok(()));
        // The default trip is visible for every zero up to 105 kPa.
        assert_eq!(sensor_sees_limits(105.0, &p), Ok(()));
        assert_eq!(
            sensor_sees_limits(105.1, &p),
            Err(ParamField::MaxPressureKpa)
        );
        let low = Params {
            sensor_min_kpa: -70.0,
            ..p
        };
        // 101.3 − 70 = 31.3 kPa ≥ 30; 99 − 70 = 29 kPa is below the 02BA.
        assert_eq!(sensor_sees_limits(101.325, &low), Ok(()));
        assert_eq!(
            sensor_sees_limits(99.0, &low),
            Err(ParamField::SensorMinKpa)
        );
        assert_eq!(
            sensor_sees_limits(f32::NAN, &p),
            Err(ParamField::MaxPressureKpa)
        );
    }

    #[test]
    fn end_to_end_bounds_of_the_defaults() {
        let p = Params::DEFAULT;
        let b = |f| end_to_end_bound_ms(f, &p, &BOARD_TIMING);
        // A pressure event: max(10 + 7 + 10, 60) + 50 ms of valve.
        assert_eq!(b(Fault::OverPressure), 110);
        assert_eq!(b(Fault::Leak), 110);
        // The sensor's own faults: their bound + the valve.
        assert_eq!(b(Fault::SensorBus), 100);
        assert_eq!(b(Fault::SensorStale), 110);
        assert_eq!(b(Fault::SensorFrozen), 360);
        // 4 ms of debounce and poll, the step, the valve.
        assert_eq!(b(Fault::EndStop), 64);
        assert_eq!(b(Fault::PumpStall), 10 + 7 + 1030 + 50);
        assert_eq!(b(Fault::DiameterMismatch), 10 + 7 + 510 + 50);
        assert_eq!(b(Fault::LinkLoss), 2060);
        assert_eq!(b(Fault::Panic), 50);
        for f in Fault::ALL {
            assert!(b(f) >= detection_bound_ms(f, &p) + BOARD_TIMING.valve_response_ms);
        }
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
        // 333.3 ms → 34 periods; 2 × 35 × 10, plus a 15 ms ramp → 2
        // periods.
        assert_eq!(detection_bound_ms(Fault::PumpStall, &p), 720);
    }
}
