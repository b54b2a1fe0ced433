//! Cycle parameters with validated ranges. A set with any field out of range
//! is rejected whole: the controller never runs half of a new set.

use serde::{Deserialize, Serialize};

/// Tunable parameters of the burrowing cycle and its safety limits.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Params {
    /// Sand cover above the actuator axis (mm), selects the table row.
    pub depth_mm: f32,
    /// Expansion stops when the estimated outer diameter reaches this (mm).
    pub target_diameter_mm: f32,
    /// Injection rate while expanding (mL/s).
    pub expand_rate_ml_per_s: f32,
    /// Withdrawal rate while shrinking (mL/s, positive number).
    pub shrink_rate_ml_per_s: f32,
    /// Time at constant volume after expanding (ms).
    pub hold_ms: u32,
    /// Time the advance drive runs after shrinking (ms).
    pub advance_ms: u32,
    /// Number of cycles to run after `Start`; 0 = until `Stop`.
    pub cycles: u16,
    /// Over-pressure limit (kPa), enforced independently of the table.
    pub max_pressure_kpa: f32,
    /// Largest net volume the pump may inject (mL); beyond it is a fault.
    pub max_volume_ml: f32,
    /// Sand collapse: expansion stops early once the sand's pressure–volume
    /// slope falls below this fraction of its initial slope.
    pub plateau_slope_fraction: f32,
    /// Leak: largest pressure drop at constant volume during a hold (kPa).
    pub leak_max_drop_kpa: f32,
    /// Stall: volume stepped with no pressure response before a fault (mL).
    pub stall_volume_ml: f32,
    /// Stall: pressure rise that counts as a response over that volume (kPa).
    pub stall_min_rise_kpa: f32,
    /// Largest tolerated gap between volume- and table-based diameters (mm).
    pub diameter_mismatch_mm: f32,
}

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
    StallVolumeMl,
    StallMinRiseKpa,
    DiameterMismatchMm,
}

/// A rejected parameter set: the first field out of its range.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ParamError {
    /// The offending field.
    pub field: ParamField,
}
