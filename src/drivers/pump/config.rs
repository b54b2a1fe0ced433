//! Syringe pump geometry and motion limits, and the step ↔ volume
//! conversions derived from them. Pure arithmetic, no pins.

use core::f32::consts::PI;

use super::pulses::{MAX_STEP_PERIOD_US, MIN_STEP_PERIOD_US};

/// Highest volume rate the pump steps at (mL/s), for every build: the
/// controller's rate parameters are refused above it
/// ([`crate::controller::RANGES`]) and the pump clamps any faster command
/// to it, so the two cannot disagree. 4 mL/s is ≈ 9,550 microsteps/s with
/// the default mechanics, 3 rev/s = 180 rpm, well inside a NEMA 17's range
/// on a 12–24 V driver.
pub const MAX_RATE_ML_PER_S: f32 = 4.0;

/// Lowest volume rate the pump steps at (mL/s), for every build: the
/// controller's rate parameters are refused below it and the step planner
/// takes a slower target as 0 (no motion), so the slowest step period
/// stays within the step timer's ([`PumpConfig::validate`]).
pub const MIN_RATE_ML_PER_S: f32 = 0.05;

/// Microsteps per full step the A4988/DRV8825 family can select.
const MAX_MICROSTEPS: u16 = 256;

/// Electrical level of an end-stop input when the switch is triggered
/// (the plunger at that end).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SwitchPolarity {
    /// Triggered reads low: a normally-open switch to ground with a
    /// pull-up. Not fail-safe: a broken wire reads as "not at the end".
    ActiveLow,
    /// Triggered reads high: a normally-closed switch to ground with a
    /// pull-up, the board's wiring (the default). Fail-safe: a broken wire
    /// or a lost connector reads high, as triggered, and stops the cycle.
    #[default]
    ActiveHigh,
}

/// Mechanics of the pump and its motion limits.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PumpConfig {
    /// Plunger travel per motor revolution (mm/rev): the lead screw's lead.
    /// Default 2.0, a single-start T8×2 trapezoidal screw.
    pub lead_pitch_mm: f32,
    /// Full steps per motor revolution. Default 200 (1.8° NEMA 17).
    pub full_steps_per_rev: u16,
    /// Microsteps per full step set on the driver's MS pins (a power of two,
    /// 1..=256). Default 16 (A4988 maximum).
    pub microsteps: u16,
    /// Inner diameter of the syringe barrel (mm). Default 29.21, the paper's
    /// 50 mL syringe.
    pub syringe_bore_mm: f32,
    /// Usable syringe volume (mL). Default 50.0.
    pub stroke_ml: f32,
    /// DIR level that moves the plunger in (injects). Default high; flip it
    /// instead of rewiring when the motor turns the wrong way.
    pub inject_dir_high: bool,
    /// Electrical polarity of both end-stop switches. Default
    /// [`SwitchPolarity::ActiveHigh`]: normally-closed switches.
    pub end_stop_polarity: SwitchPolarity,
}

impl Default for PumpConfig {
    fn default() -> Self {
        Self {
            lead_pitch_mm: 2.0,
            full_steps_per_rev: 200,
            microsteps: 16,
            syringe_bore_mm: 29.21,
            stroke_ml: 50.0,
            inject_dir_high: true,
            end_stop_polarity: SwitchPolarity::ActiveHigh,
        }
    }
}

/// A [`PumpConfig`] field, named in errors.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[allow(missing_docs)] // one variant per field of [`PumpConfig`], same meaning
pub enum PumpConfigField {
    LeadPitchMm,
    FullStepsPerRev,
    Microsteps,
    SyringeBoreMm,
    StrokeMl,
}

/// A rejected pump configuration: the first field out of its range.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PumpConfigError {
    /// The offending field.
    pub field: PumpConfigField,
}

fn positive_finite(x: f32) -> bool {
    x.is_finite() && x > 0.0
}

impl PumpConfig {
    /// Checks every field; the first one out of range is named.
    ///
    /// Ranges: lead, bore and stroke finite and > 0; full steps per
    /// revolution > 0; microsteps a power of two in 1..=256, and few enough
    /// that [`MAX_RATE_ML_PER_S`] needs no faster than one microstep per
    /// [`MIN_STEP_PERIOD_US`], and coarse enough that the slowest planned
    /// step (ending or starting at [`MIN_RATE_ML_PER_S`]: twice the
    /// volume of a step over that rate) fits the timer's
    /// [`MAX_STEP_PERIOD_US`] (both reported as `Microsteps`); the stroke no
    /// more than `i32::MAX / 2` microsteps (the position can never overflow
    /// within travel).
    pub fn validate(&self) -> Result<(), PumpConfigError> {
        let err = |field| Err(PumpConfigError { field });
        if !positive_finite(self.lead_pitch_mm) {
            return err(PumpConfigField::LeadPitchMm);
        }
        if self.full_steps_per_rev == 0 {
            return err(PumpConfigField::FullStepsPerRev);
        }
        if !self.microsteps.is_power_of_two() || self.microsteps > MAX_MICROSTEPS {
            return err(PumpConfigField::Microsteps);
        }
        if !positive_finite(self.syringe_bore_mm) || !positive_finite(self.ml_per_step()) {
            return err(PumpConfigField::SyringeBoreMm);
        }
        // From here on ml_per_step is finite and > 0, so the quotients below
        // are > 0 (possibly +inf) and never NaN.
        if 1.0e6 * self.ml_per_step() / MAX_RATE_ML_PER_S < MIN_STEP_PERIOD_US as f32 {
            // Too fine a step for MAX_RATE_ML_PER_S at the driver's
            // fastest STEP: fewer microsteps fix it.
            return err(PumpConfigField::Microsteps);
        }
        if 2.0e6 * self.ml_per_step() / MIN_RATE_ML_PER_S > MAX_STEP_PERIOD_US as f32 {
            // Too coarse a step for the timer at the slowest rate: more
            // microsteps fix it.
            return err(PumpConfigField::Microsteps);
        }
        if !positive_finite(self.stroke_ml)
            || self.stroke_ml / self.ml_per_step() > (i32::MAX / 2) as f32
        {
            return err(PumpConfigField::StrokeMl);
        }
        Ok(())
    }

    /// Volume moved by one microstep (mL):
    /// π/4 · bore² · lead / (full steps per rev · microsteps), mm³ → mL.
    pub fn ml_per_step(&self) -> f32 {
        let area_mm2 = PI / 4.0 * self.syringe_bore_mm * self.syringe_bore_mm;
        let steps_per_rev = f32::from(self.full_steps_per_rev) * f32::from(self.microsteps);
        area_mm2 * self.lead_pitch_mm / steps_per_rev / 1000.0
    }

    /// Microsteps per mL of volume (1/mL).
    pub fn steps_per_ml(&self) -> f32 {
        1.0 / self.ml_per_step()
    }

    /// Volume (mL) of a signed microstep count (positive = injected).
    pub fn ml_from_steps(&self, steps: i32) -> f32 {
        // Exact in f64 for every i32; one rounding to f32.
        (f64::from(steps) * f64::from(self.ml_per_step())) as f32
    }

    /// Microsteps (nearest, positive = inject) for a volume (mL). Saturates
    /// at the `i32` range; NaN gives 0.
    pub fn steps_from_ml(&self, ml: f32) -> i32 {
        // `as` from float saturates and maps NaN to 0: no panic on any input.
        libm::round(f64::from(ml) * f64::from(self.steps_per_ml())) as i32
    }

    /// Time between microsteps (µs) for a volume rate (mL/s, either sign),
    /// clamped to [`MAX_RATE_ML_PER_S`] and rounded up so the
    /// pump never runs faster than asked. `None` means no motion: a zero or
    /// non-finite rate, or one so slow the interval exceeds `u32::MAX` µs.
    pub fn step_interval_us(&self, rate_ml_per_s: f32) -> Option<u32> {
        let rate = libm::fabsf(rate_ml_per_s);
        if !positive_finite(rate) {
            return None;
        }
        let rate = rate.min(MAX_RATE_ML_PER_S);
        let interval_us = libm::ceil(1.0e6 * f64::from(self.ml_per_step()) / f64::from(rate));
        if interval_us.is_finite() && interval_us >= 1.0 && interval_us <= f64::from(u32::MAX) {
            Some(interval_us as u32)
        } else {
            None
        }
    }
}
