//! Cycle parameters with validated ranges. A set with any field out of range
//! is rejected whole: the controller never runs half of a new set.
//!
//! Every field has a closed range in [`RANGES`] (also given in each field's
//! doc). The ranges of the pressure limits come from the fitted sensor
//! model ([`SENSOR_MODEL`](super::SENSOR_MODEL)) and those of the rates
//! from the pump ([`MAX_RATE_ML_PER_S`]): no host can set a limit the
//! hardware cannot honour. [`Params::validate`] checks every field against it (NaN fails every
//! range) plus one cross-field rule: `max_pressure_kpa < sensor_max_kpa`, so
//! the limit is always inside what the sensor can measure (reported as
//! [`ParamField::MaxPressureKpa`]), and one on the host link: a cycle
//! without a limit (`cycles` = 0) needs the link watch
//! (`link_timeout_ms` > 0, reported as [`ParamField::LinkTimeoutMs`]).

use serde::{Deserialize, Serialize};

use super::bounds::{SENSOR_MAX_GAUGE_KPA, SENSOR_MIN_GAUGE_KPA};
use crate::drivers::pump::{MAX_RATE_ML_PER_S, MIN_RATE_ML_PER_S};

/// Tunable parameters of the burrowing cycle and its safety limits.
///
/// [`Params::DEFAULT`] suits the paper's actuator (D0 = 18.7 mm, 20 mm
/// expansion zone, expanded to 25 mm at 40 mm depth): expand at 2 mL/s
/// (about 4.3 mL, 2.2 s), hold 0.5 s, shrink at 4 mL/s (1.1 s), advance 1 s,
/// so one cycle takes about 5 s as in the paper.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Params {
    /// Sand cover above the actuator axis (mm), selects the table row.
    /// Range 0–200 (the paper's box holds 200 mm of sand).
    pub depth_mm: f32,
    /// Expansion stops when the estimated outer diameter reaches this (mm).
    /// Range 10–50.
    pub target_diameter_mm: f32,
    /// Injection rate while expanding (mL/s). Range the pump's
    /// [`MIN_RATE_ML_PER_S`] (0.05) to its
    /// [`MAX_RATE_ML_PER_S`] (4).
    pub expand_rate_ml_per_s: f32,
    /// Withdrawal rate while shrinking (mL/s, positive number). Range
    /// [`MIN_RATE_ML_PER_S`] (0.05)
    /// to the pump's [`MAX_RATE_ML_PER_S`] (4).
    pub shrink_rate_ml_per_s: f32,
    /// Time at constant volume after expanding (ms). Range 0–60 000.
    pub hold_ms: u32,
    /// Time the advance drive runs after shrinking (ms). Range 0–60 000.
    pub advance_ms: u32,
    /// Number of cycles to run after `Start`; 0 = until `Stop`. Any value.
    pub cycles: u16,
    /// Over-pressure limit (kPa gauge), enforced independently of the
    /// table, in every state. Range 1 to what the fitted sensor can see
    /// ([`SENSOR_MAX_GAUGE_KPA`], 50 for the
    /// 02BA), and below `sensor_max_kpa`; `Start` and a tare also refuse a
    /// zero with which `zero + max_pressure_kpa` passes the sensor's
    /// specified maximum ([`sensor_sees_limits`](super::sensor_sees_limits)).
    /// Default 15: sea level's 101.3 kPa plus 15 is 116.3 kPa, inside the
    /// 02BA's 120, and the deepest emulated cycles (100 mm of sand) peak
    /// near 6 kPa.
    pub max_pressure_kpa: f32,
    /// Largest net volume the pump may have injected since power-up (mL);
    /// beyond it is a fault. Range 0.5–50 (a 50 mL syringe).
    pub max_volume_ml: f32,
    /// Sand collapse: expansion stops early once the sand's pressure–volume
    /// slope falls below this fraction of its initial (largest) slope.
    /// Range 0–0.9; 0 disables the early stop.
    pub plateau_slope_fraction: f32,
    /// Leak: the smallest pressure drop below the hold's peak at constant
    /// volume that counts as a leak (kPa), whatever the pressure: a floor
    /// well above the sensor's noise. Range 0.05–50. The limit is the larger
    /// of this and `leak_max_drop_fraction` of the peak
    /// ([`Params::leak_limit_kpa`]).
    pub leak_max_drop_kpa: f32,
    /// Leak: largest drop below the hold's peak as a fraction of that peak
    /// (−). A pin-hole leak empties the head at a rate ∝ its pressure, so it
    /// takes the same fraction of the pressure in a hold at any depth: an
    /// absolute limit alone misses it wherever the working pressure is low.
    /// Range 0.02–1.
    pub leak_max_drop_fraction: f32,
    /// Stall: volume stepped with no pressure response before a fault (mL).
    /// Range 0.05–20.
    pub stall_volume_ml: f32,
    /// Stall: pressure rise that counts as a response over that volume (kPa).
    /// Range 0–20 (0 only trips on a falling pressure). The ratio
    /// `stall_min_rise_kpa / stall_volume_ml` must stay below the head's
    /// slowest healthy slope: in sand that is far above the default
    /// 0.05 kPa/mL, but in free water (depth 0) the skin alone gives only
    /// about 0.02–0.1 kPa/mL, so lower it for free-water runs.
    pub stall_min_rise_kpa: f32,
    /// Largest tolerated gap between volume- and table-based diameters (mm).
    /// Range 0.1–20.
    pub diameter_mismatch_mm: f32,
    /// How long the diameter gap may exceed `diameter_mismatch_mm` before a
    /// fault (ms). Range 10–10 000.
    pub diameter_mismatch_ms: u32,
    /// The plateau early stop is only considered once the volume-based
    /// diameter has grown this much past D0 (mm). Range 0–20.
    pub plateau_min_expansion_mm: f32,
    /// The plateau early stop is armed only once the sand's slope has
    /// reached this (kPa/mL): in free water there is no sand curve to watch.
    /// Range 0.01–100.
    pub plateau_min_slope_kpa_per_ml: f32,
    /// Shrinking ends when the volume is within this of the rest volume
    /// captured at `Start` (mL). Range 0.001–1.
    pub rest_tolerance_ml: f32,
    /// Smallest net volume since power-up (mL): withdrawing more than was
    /// injected sucks on the skin. Range −10–0.
    pub min_volume_ml: f32,
    /// Lowest plausible sensor reading (kPa gauge); below it (or NaN, or −∞)
    /// is a sensor fault. Range from what the fitted sensor can see
    /// ([`SENSOR_MIN_GAUGE_KPA`], −85 for the
    /// 02BA) to 0; `Start` and a tare also check it against the zero.
    pub sensor_min_kpa: f32,
    /// Sensor full scale (kPa gauge): `max_pressure_kpa` must lie below it.
    /// Readings above `max_pressure_kpa` are always treated as
    /// over-pressure, saturated or not. Range 1 to
    /// [`SENSOR_MAX_GAUGE_KPA`] (50 for the
    /// 02BA). Default 18: the 02BA's 120 kPa less sea level's 101.3.
    pub sensor_max_kpa: f32,
    /// A reading older than this when the step sees it is stale (ms).
    /// Range 10–1000.
    pub sensor_stale_ms: u32,
    /// A bit-identical reading for this long while the pump runs is a frozen
    /// sensor (ms). Range 20–10 000.
    pub sensor_frozen_ms: u32,
    /// This many consecutive steps with a bus error (or no sample) is a bus
    /// fault. Range 1–100.
    pub sensor_bus_error_steps: u8,
    /// Host link watchdog: while a cycle runs, no host frame (a command or
    /// a `Heartbeat`) for longer than this stops it into the safe state
    /// with [`Fault::LinkLoss`](super::Fault::LinkLoss) (ms). Range
    /// 0–60 000; 0 turns the watch off and is accepted only with a cycle
    /// limit (`cycles` > 0): a cycle without a limit always needs the
    /// heartbeat. A value below [`LINK_TIMEOUT_MIN_MS`] other than 0 is
    /// refused.
    pub link_timeout_ms: u32,
}

/// Shortest link timeout accepted other than 0 (ms): ten control periods,
/// so that one late frame on a busy link does not stop a cycle.
pub const LINK_TIMEOUT_MIN_MS: u32 = 100;

/// A parameter field, named in errors.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[allow(missing_docs)] // one variant per field of [`Params`], same meaning
pub enum ParamField {
    DepthMm,
    TargetDiameterMm,
    ExpandRateMlPerS,
    ShrinkRateMlPerS,
    HoldMs,
    AdvanceMs,
    Cycles,
    MaxPressureKpa,
    MaxVolumeMl,
    PlateauSlopeFraction,
    LeakMaxDropKpa,
    LeakMaxDropFraction,
    StallVolumeMl,
    StallMinRiseKpa,
    DiameterMismatchMm,
    DiameterMismatchMs,
    PlateauMinExpansionMm,
    PlateauMinSlopeKpaPerMl,
    RestToleranceMl,
    MinVolumeMl,
    SensorMinKpa,
    SensorMaxKpa,
    SensorStaleMs,
    SensorFrozenMs,
    SensorBusErrorSteps,
    LinkTimeoutMs,
}

/// A rejected parameter set: the first field out of its range.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ParamError {
    /// The offending field.
    pub field: ParamField,
}

/// The closed range `[min, max]` one field must lie in, in the field's unit
/// (integer fields compare exactly: every bound is below 2^24).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FieldRange {
    /// The field.
    pub field: ParamField,
    /// Smallest accepted value (field unit).
    pub min: f32,
    /// Largest accepted value (field unit).
    pub max: f32,
}

const fn range(field: ParamField, min: f32, max: f32) -> FieldRange {
    FieldRange { field, min, max }
}

/// Every field's accepted range, in declaration order; [`Params::validate`]
/// walks this table.
pub const RANGES: [FieldRange; 26] = [
    range(ParamField::DepthMm, 0.0, 200.0),
    range(ParamField::TargetDiameterMm, 10.0, 50.0),
    range(
        ParamField::ExpandRateMlPerS,
        MIN_RATE_ML_PER_S,
        MAX_RATE_ML_PER_S,
    ),
    range(
        ParamField::ShrinkRateMlPerS,
        MIN_RATE_ML_PER_S,
        MAX_RATE_ML_PER_S,
    ),
    range(ParamField::HoldMs, 0.0, 60_000.0),
    range(ParamField::AdvanceMs, 0.0, 60_000.0),
    range(ParamField::Cycles, 0.0, u16::MAX as f32),
    range(ParamField::MaxPressureKpa, 1.0, SENSOR_MAX_GAUGE_KPA),
    range(ParamField::MaxVolumeMl, 0.5, 50.0),
    range(ParamField::PlateauSlopeFraction, 0.0, 0.9),
    range(ParamField::LeakMaxDropKpa, 0.05, 50.0),
    range(ParamField::LeakMaxDropFraction, 0.02, 1.0),
    range(ParamField::StallVolumeMl, 0.05, 20.0),
    range(ParamField::StallMinRiseKpa, 0.0, 20.0),
    range(ParamField::DiameterMismatchMm, 0.1, 20.0),
    range(ParamField::DiameterMismatchMs, 10.0, 10_000.0),
    range(ParamField::PlateauMinExpansionMm, 0.0, 20.0),
    range(ParamField::PlateauMinSlopeKpaPerMl, 0.01, 100.0),
    range(ParamField::RestToleranceMl, 0.001, 1.0),
    range(ParamField::MinVolumeMl, -10.0, 0.0),
    range(ParamField::SensorMinKpa, SENSOR_MIN_GAUGE_KPA, 0.0),
    range(ParamField::SensorMaxKpa, 1.0, SENSOR_MAX_GAUGE_KPA),
    range(ParamField::SensorStaleMs, 10.0, 1000.0),
    range(ParamField::SensorFrozenMs, 20.0, 10_000.0),
    range(ParamField::SensorBusErrorSteps, 1.0, 100.0),
    range(ParamField::LinkTimeoutMs, 0.0, 60_000.0),
];

impl ParamField {
    /// This field's accepted range.
    pub fn range(self) -> FieldRange {
        // RANGES lists every variant once (checked by a unit test); the
        // NaN fallback would reject every value, never accept one.
        RANGES
            .iter()
            .find(|r| r.field == self)
            .copied()
            .unwrap_or(range(self, f32::NAN, f32::NAN))
    }
}

impl Params {
    /// Defaults for the paper's actuator; see the type's docs.
    pub const DEFAULT: Params = Params {
        depth_mm: 40.0,
        target_diameter_mm: 25.0,
        expand_rate_ml_per_s: 2.0,
        shrink_rate_ml_per_s: 4.0,
        hold_ms: 500,
        advance_ms: 1000,
        cycles: 0,
        max_pressure_kpa: 15.0,
        max_volume_ml: 10.0,
        plateau_slope_fraction: 0.1,
        leak_max_drop_kpa: 0.3,
        leak_max_drop_fraction: 0.25,
        stall_volume_ml: 1.0,
        stall_min_rise_kpa: 0.05,
        diameter_mismatch_mm: 2.5,
        diameter_mismatch_ms: 500,
        plateau_min_expansion_mm: 1.0,
        plateau_min_slope_kpa_per_ml: 0.5,
        rest_tolerance_ml: 0.05,
        min_volume_ml: -0.5,
        sensor_min_kpa: -20.0,
        sensor_max_kpa: 18.0,
        sensor_stale_ms: 50,
        sensor_frozen_ms: 300,
        sensor_bus_error_steps: 3,
        link_timeout_ms: 2_000,
    };

    /// Largest pressure drop below a hold's peak `peak_kpa` that is not a
    /// leak (kPa): `leak_max_drop_fraction` of the peak, at least
    /// `leak_max_drop_kpa`.
    pub fn leak_limit_kpa(&self, peak_kpa: f32) -> f32 {
        let relative = self.leak_max_drop_fraction * peak_kpa;
        if relative > self.leak_max_drop_kpa {
            relative
        } else {
            self.leak_max_drop_kpa
        }
    }

    /// The value of `field` as f32 (integer fields convert exactly).
    pub fn get(&self, field: ParamField) -> f32 {
        match field {
            ParamField::DepthMm => self.depth_mm,
            ParamField::TargetDiameterMm => self.target_diameter_mm,
            ParamField::ExpandRateMlPerS => self.expand_rate_ml_per_s,
            ParamField::ShrinkRateMlPerS => self.shrink_rate_ml_per_s,
            // Values above 2^24 lose bits but stay above every bound.
            ParamField::HoldMs => self.hold_ms as f32,
            ParamField::AdvanceMs => self.advance_ms as f32,
            ParamField::Cycles => f32::from(self.cycles),
            ParamField::MaxPressureKpa => self.max_pressure_kpa,
            ParamField::MaxVolumeMl => self.max_volume_ml,
            ParamField::PlateauSlopeFraction => self.plateau_slope_fraction,
            ParamField::LeakMaxDropKpa => self.leak_max_drop_kpa,
            ParamField::LeakMaxDropFraction => self.leak_max_drop_fraction,
            ParamField::StallVolumeMl => self.stall_volume_ml,
            ParamField::StallMinRiseKpa => self.stall_min_rise_kpa,
            ParamField::DiameterMismatchMm => self.diameter_mismatch_mm,
            ParamField::DiameterMismatchMs => self.diameter_mismatch_ms as f32,
            ParamField::PlateauMinExpansionMm => self.plateau_min_expansion_mm,
            ParamField::PlateauMinSlopeKpaPerMl => self.plateau_min_slope_kpa_per_ml,
            ParamField::RestToleranceMl => self.rest_tolerance_ml,
            ParamField::MinVolumeMl => self.min_volume_ml,
            ParamField::SensorMinKpa => self.sensor_min_kpa,
            ParamField::SensorMaxKpa => self.sensor_max_kpa,
            ParamField::SensorStaleMs => self.sensor_stale_ms as f32,
            ParamField::SensorFrozenMs => self.sensor_frozen_ms as f32,
            ParamField::SensorBusErrorSteps => f32::from(self.sensor_bus_error_steps),
            ParamField::LinkTimeoutMs => self.link_timeout_ms as f32,
        }
    }

    /// Sets `field` to `value`, for tools and tests that walk [`RANGES`].
    /// Integer fields take the value rounded toward zero and saturated to
    /// their type (NaN gives 0), like Rust's `as` conversion.
    pub fn set(&mut self, field: ParamField, value: f32) {
        match field {
            ParamField::DepthMm => self.depth_mm = value,
            ParamField::TargetDiameterMm => self.target_diameter_mm = value,
            ParamField::ExpandRateMlPerS => self.expand_rate_ml_per_s = value,
            ParamField::ShrinkRateMlPerS => self.shrink_rate_ml_per_s = value,
            ParamField::HoldMs => self.hold_ms = value as u32,
            ParamField::AdvanceMs => self.advance_ms = value as u32,
            ParamField::Cycles => self.cycles = value as u16,
            ParamField::MaxPressureKpa => self.max_pressure_kpa = value,
            ParamField::MaxVolumeMl => self.max_volume_ml = value,
            ParamField::PlateauSlopeFraction => self.plateau_slope_fraction = value,
            ParamField::LeakMaxDropKpa => self.leak_max_drop_kpa = value,
            ParamField::LeakMaxDropFraction => self.leak_max_drop_fraction = value,
            ParamField::StallVolumeMl => self.stall_volume_ml = value,
            ParamField::StallMinRiseKpa => self.stall_min_rise_kpa = value,
            ParamField::DiameterMismatchMm => self.diameter_mismatch_mm = value,
            ParamField::DiameterMismatchMs => self.diameter_mismatch_ms = value as u32,
            ParamField::PlateauMinExpansionMm => self.plateau_min_expansion_mm = value,
            ParamField::PlateauMinSlopeKpaPerMl => self.plateau_min_slope_kpa_per_ml = value,
            ParamField::RestToleranceMl => self.rest_tolerance_ml = value,
            ParamField::MinVolumeMl => self.min_volume_ml = value,
            ParamField::SensorMinKpa => self.sensor_min_kpa = value,
            ParamField::SensorMaxKpa => self.sensor_max_kpa = value,
            ParamField::SensorStaleMs => self.sensor_stale_ms = value as u32,
            ParamField::SensorFrozenMs => self.sensor_frozen_ms = value as u32,
            ParamField::SensorBusErrorSteps => self.sensor_bus_error_steps = value as u8,
            ParamField::LinkTimeoutMs => self.link_timeout_ms = value as u32,
        }
    }

    /// Checks every field against [`RANGES`] (NaN is out of every range),
    /// then `max_pressure_kpa < sensor_max_kpa`, then the link timeout
    /// (0 only with `cycles` > 0, else at least [`LINK_TIMEOUT_MIN_MS`]).
    /// Returns the first offending field in declaration order.
    pub fn validate(&self) -> Result<(), ParamError> {
        for r in RANGES {
            let v = self.get(r.field);
            // Written so that NaN fails: every comparison with NaN is false.
            if !(v >= r.min && v <= r.max) {
                return Err(ParamError { field: r.field });
            }
        }
        let measurable = self.max_pressure_kpa < self.sensor_max_kpa;
        if !measurable {
            return Err(ParamError {
                field: ParamField::MaxPressureKpa,
            });
        }
        let link = self.link_timeout_ms;
        if (link == 0 && self.cycles == 0) || (link != 0 && link < LINK_TIMEOUT_MIN_MS) {
            return Err(ParamError {
                field: ParamField::LinkTimeoutMs,
            });
        }
        Ok(())
    }
}

impl Default for Params {
    fn default() -> Self {
        Self::DEFAULT
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_is_valid() {
        assert_eq!(Params::DEFAULT.validate(), Ok(()));
    }

    #[test]
    fn ranges_list_every_field_once_in_order() {
        for (i, r) in RANGES.iter().enumerate() {
            assert!(r.min <= r.max, "{:?}", r.field);
            assert_eq!(r.field.range(), *r);
            for other in &RANGES[i + 1..] {
                assert_ne!(r.field, other.field);
            }
        }
    }
}
