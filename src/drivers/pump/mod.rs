//! Stepper-driven syringe pump on an A4988/DRV8825-class STEP/DIR driver,
//! with an end-stop switch at each end of the plunger travel.
//!
//! Driver timing (datasheet minimums): STEP high ≥ 1 µs (A4988) / 1.9 µs
//! (DRV8825), STEP low the same, DIR setup before the STEP rising edge
//! ≥ 200 ns (A4988) / 650 ns (DRV8825) and held as long after it. This
//! driver uses 2 µs high, 2 µs low and 1 µs DIR setup, so it meets both
//! parts however fast [`SyringePump::step`] is called. The driver steps on
//! STEP's rising edge. ENABLE is active-low on both parts: low = outputs on.
//!
//! Sign convention: positive position and volume = injected. Injecting pushes
//! the plunger towards the `empty` end-stop; withdrawing towards `full`.

pub mod config;
pub mod debounce;
pub mod ramp;

use embedded_hal::digital::{InputPin, OutputPin};
use embedded_hal_async::delay::DelayNs;

use crate::controller::EndStops;
pub use config::{
    PumpConfig, PumpConfigError, PumpConfigField, SwitchPolarity, MAX_RATE_ML_PER_S,
    MIN_STEP_PERIOD_US,
};
pub use debounce::{EndStopDebounce, END_STOP_DEBOUNCE_US};
pub use ramp::{Plan, StepPlanner, ACCEL_ML_PER_S2};

/// STEP high time (µs).
pub const STEP_HIGH_US: u32 = 2;
/// STEP low time after each pulse (µs), so back-to-back steps stay legal.
pub const STEP_LOW_US: u32 = 2;
/// Wait between a DIR change and the next STEP rising edge (µs).
pub const DIR_SETUP_US: u32 = 1;

/// Which way the plunger moves.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Direction {
    /// Plunger in, towards the `empty` end-stop: volume rises.
    Inject,
    /// Plunger out, towards the `full` end-stop: volume falls.
    Withdraw,
}

impl Direction {
    /// The direction of a volume rate (mL/s): positive injects, negative
    /// withdraws; zero or NaN is no motion.
    pub fn from_rate(rate_ml_per_s: f32) -> Option<Self> {
        if rate_ml_per_s > 0.0 {
            Some(Direction::Inject)
        } else if rate_ml_per_s < 0.0 {
            Some(Direction::Withdraw)
        } else {
            None
        }
    }
}

/// The pins, by role (named so STEP and DIR cannot be swapped silently).
#[derive(Debug)]
pub struct PumpPins<Step, Dir, Enable, EndEmpty, EndFull> {
    /// STEP output: one microstep per rising edge.
    pub step: Step,
    /// DIR output: level per [`PumpConfig::inject_dir_high`].
    pub dir: Dir,
    /// ENABLE output, active-low (high = motor outputs off).
    pub enable: Enable,
    /// End-stop switch, triggered when the plunger is fully in.
    pub end_empty: EndEmpty,
    /// End-stop switch, triggered when the plunger is fully out.
    pub end_full: EndFull,
}

/// Which pin an I/O error came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PinRole {
    /// STEP output.
    Step,
    /// DIR output.
    Dir,
    /// ENABLE output.
    Enable,
    /// `empty` end-stop input.
    EndEmpty,
    /// `full` end-stop input.
    EndFull,
}

/// A refused or failed pump operation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PumpError {
    /// The end-stop in the requested direction is triggered: no step was
    /// made.
    EndStop,
    /// The driver is disabled: no step was made.
    Disabled,
    /// A GPIO operation failed on this pin.
    Pin(PinRole),
    /// The position counter would overflow `i32`: no step was made.
    PositionOverflow,
}

/// [`SyringePump::new`] refused the configuration; the pins come back.
#[derive(Debug)]
pub struct ConfigRejected<P> {
    /// Why.
    pub error: PumpConfigError,
    /// The pins, untouched.
    pub pins: P,
}

/// A syringe pump: a STEP/DIR stepper driver plus two end-stops, with the
/// plunger position counted in signed microsteps.
pub struct SyringePump<Step, Dir, Enable, EndEmpty, EndFull> {
    pins: PumpPins<Step, Dir, Enable, EndEmpty, EndFull>,
    config: PumpConfig,
    enabled: bool,
    /// Last DIR level written; `None` until the first step.
    dir_high: Option<bool>,
    position_steps: i32,
}

impl<Step, Dir, Enable, EndEmpty, EndFull> SyringePump<Step, Dir, Enable, EndEmpty, EndFull>
where
    Step: OutputPin,
    Dir: OutputPin,
    Enable: OutputPin,
    EndEmpty: InputPin,
    EndFull: InputPin,
{
    /// A pump over these pins, after [`PumpConfig::validate`]. Touches no pin:
    /// the board must create ENABLE high (disabled) and STEP low. The pump
    /// starts disabled at position 0.
    #[allow(clippy::type_complexity)] // the error hands every pin back
    pub fn new(
        pins: PumpPins<Step, Dir, Enable, EndEmpty, EndFull>,
        config: PumpConfig,
    ) -> Result<Self, ConfigRejected<PumpPins<Step, Dir, Enable, EndEmpty, EndFull>>> {
        if let Err(error) = config.validate() {
            return Err(ConfigRejected { error, pins });
        }
        Ok(Self {
            pins,
            config,
            enabled: false,
            dir_high: None,
            position_steps: 0,
        })
    }

    /// Gives the pins back.
    pub fn destroy(self) -> PumpPins<Step, Dir, Enable, EndEmpty, EndFull> {
        self.pins
    }

    /// The (validated) configuration.
    pub fn config(&self) -> &PumpConfig {
        &self.config
    }

    /// Turns the motor outputs on (ENABLE low). The pump counts as enabled
    /// only if the pin write succeeded.
    pub fn enable(&mut self) -> Result<(), PumpError> {
        self.pins
            .enable
            .set_low()
            .map_err(|_| PumpError::Pin(PinRole::Enable))?;
        self.enabled = true;
        Ok(())
    }

    /// Turns the motor outputs off (ENABLE high). The pump refuses to step
    /// from now on even if the pin write fails.
    pub fn disable(&mut self) -> Result<(), PumpError> {
        self.enabled = false;
        self.pins
            .enable
            .set_high()
            .map_err(|_| PumpError::Pin(PinRole::Enable))
    }

    /// True after a successful [`SyringePump::enable`] and until
    /// [`SyringePump::disable`].
    pub fn is_enabled(&self) -> bool {
        self.enabled
    }

    fn triggered<P: InputPin>(
        pin: &mut P,
        polarity: SwitchPolarity,
        role: PinRole,
    ) -> Result<bool, PumpError> {
        let read = match polarity {
            SwitchPolarity::ActiveLow => pin.is_low(),
            SwitchPolarity::ActiveHigh => pin.is_high(),
        };
        read.map_err(|_| PumpError::Pin(role))
    }

    /// Reads both end-stop switches (`empty` first), true = triggered (per
    /// [`PumpConfig::end_stop_polarity`]), raw: the pump task debounces
    /// what it reports ([`EndStopDebounce`]).
    pub fn end_stops(&mut self) -> Result<EndStops, PumpError> {
        let polarity = self.config.end_stop_polarity;
        let empty = Self::triggered(&mut self.pins.end_empty, polarity, PinRole::EndEmpty)?;
        let full = Self::triggered(&mut self.pins.end_full, polarity, PinRole::EndFull)?;
        Ok(EndStops { empty, full })
    }

    /// One microstep in `direction`.
    ///
    /// Refuses, touching no output, when disabled ([`PumpError::Disabled`]),
    /// when the end-stop ahead (`empty` for inject, `full` for withdraw) is
    /// triggered or unreadable ([`PumpError::EndStop`] / [`PumpError::Pin`]),
    /// or when the count would overflow. Otherwise writes DIR (waiting
    /// [`DIR_SETUP_US`] if its level changed), raises STEP for
    /// [`STEP_HIGH_US`], lowers it and waits [`STEP_LOW_US`]. The step counts
    /// once STEP went high, even if lowering it then fails.
    pub async fn step<D: DelayNs>(
        &mut self,
        direction: Direction,
        delay: &mut D,
    ) -> Result<(), PumpError> {
        if !self.enabled {
            return Err(PumpError::Disabled);
        }
        let polarity = self.config.end_stop_polarity;
        let (blocked, delta) = match direction {
            Direction::Inject => (
                Self::triggered(&mut self.pins.end_empty, polarity, PinRole::EndEmpty)?,
                1,
            ),
            Direction::Withdraw => (
                Self::triggered(&mut self.pins.end_full, polarity, PinRole::EndFull)?,
                -1,
            ),
        };
        if blocked {
            return Err(PumpError::EndStop);
        }
        let next = self
            .position_steps
            .checked_add(delta)
            .ok_or(PumpError::PositionOverflow)?;

        let dir_high = (direction == Direction::Inject) == self.config.inject_dir_high;
        let dir_write = if dir_high {
            self.pins.dir.set_high()
        } else {
            self.pins.dir.set_low()
        };
        if dir_write.is_err() {
            // Level unknown now: force a setup wait next time.
            self.dir_high = None;
            return Err(PumpError::Pin(PinRole::Dir));
        }
        if self.dir_high != Some(dir_high) {
            delay.delay_us(DIR_SETUP_US).await;
            self.dir_high = Some(dir_high);
        }

        self.pins
            .step
            .set_high()
            .map_err(|_| PumpError::Pin(PinRole::Step))?;
        // The driver moved on the rising edge.
        self.position_steps = next;
        delay.delay_us(STEP_HIGH_US).await;
        self.pins
            .step
            .set_low()
            .map_err(|_| PumpError::Pin(PinRole::Step))?;
        delay.delay_us(STEP_LOW_US).await;
        Ok(())
    }

    /// Plunger position (microsteps, positive = injected) since power-up or
    /// the last [`SyringePump::zero_position`].
    pub fn position_steps(&self) -> i32 {
        self.position_steps
    }

    /// Net volume pushed (mL, positive = injected), from the step count.
    pub fn volume_ml(&self) -> f32 {
        self.config.ml_from_steps(self.position_steps)
    }

    /// Declares the current plunger position the zero of volume.
    pub fn zero_position(&mut self) {
        self.position_steps = 0;
    }
}
