//! Stepper-driven syringe pump on an A4988/DRV8825-class STEP/DIR driver,
//! with an end-stop switch at each end of the plunger travel.
//!
//! Driver timing (datasheet minimums): STEP high ≥ 1 µs (A4988) / 1.9 µs
//! (DRV8825), STEP low the same, DIR setup before the STEP rising edge
//! ≥ 200 ns (A4988) / 650 ns (DRV8825) and held as long after it. STEP
//! comes from a hardware timer ([`pulses`]): [`STEP_HIGH_US`] high (margin
//! for the HSI clock's tolerance), at least [`STEP_LOW_US`] low, and DIR is
//! written only while the timer is stopped, at least the first step's
//! period (≥ [`pulses::MIN_STEP_PERIOD_US`]) before its edge. The driver
//! steps on STEP's rising edge. ENABLE is active-low on both parts: low =
//! outputs on.
//!
//! Sign convention: positive position and volume = injected. Injecting pushes
//! the plunger towards the `empty` end-stop; withdrawing towards `full`.

pub mod config;
pub mod debounce;
pub mod pulses;
pub mod ramp;
pub mod sequencer;

use embedded_hal::digital::{InputPin, OutputPin};

use crate::controller::EndStops;
pub use config::{
    PumpConfig, PumpConfigError, PumpConfigField, SwitchPolarity, MAX_RATE_ML_PER_S,
    MIN_RATE_ML_PER_S,
};
pub use debounce::{EndStopDebounce, END_STOP_DEBOUNCE_US};
pub use pulses::{SimStepTimer, StepPulses, MAX_STEP_PERIOD_US, MIN_STEP_PERIOD_US};
pub use ramp::{Plan, StepPlanner, ACCEL_ML_PER_S2};
pub use sequencer::{StepDrive, StepSequencer};

/// STEP high time (µs): the timer's pulse width, 3 µs so that the
/// DRV8825's 1.9 µs holds even with the HSI clock several per cent slow.
pub const STEP_HIGH_US: u32 = 3;
/// Shortest STEP low time between pulses (µs).
pub const STEP_LOW_US: u32 = 2;

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

    /// Microsteps one step in this direction adds to the position: +1
    /// injecting, −1 withdrawing (the sign convention above).
    pub const fn steps(self) -> i32 {
        match self {
            Direction::Inject => 1,
            Direction::Withdraw => -1,
        }
    }
}

/// The pins, by role (named so STEP and DIR cannot be swapped silently).
#[derive(Debug)]
pub struct PumpPins<Step, Dir, Enable, EndEmpty, EndFull> {
    /// STEP: the timer that pulses it ([`StepPulses`]), one microstep per
    /// rising edge.
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
    /// The step timer is still running: DIR changes only while stopped.
    Running,
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
/// plunger position counted in signed microsteps: the pulses the step
/// timer completed.
pub struct SyringePump<Step, Dir, Enable, EndEmpty, EndFull> {
    pins: PumpPins<Step, Dir, Enable, EndEmpty, EndFull>,
    config: PumpConfig,
    enabled: bool,
    /// Position when the timer was last started (microsteps).
    run_base_steps: i32,
    /// +1 injecting, −1 withdrawing, in the last run.
    run_sign: i32,
    position_steps: i32,
}

impl<Step, Dir, Enable, EndEmpty, EndFull> SyringePump<Step, Dir, Enable, EndEmpty, EndFull>
where
    Step: StepPulses,
    Dir: OutputPin,
    Enable: OutputPin,
    EndEmpty: InputPin,
    EndFull: InputPin,
{
    /// A pump over these pins, after [`PumpConfig::validate`]. Touches no pin:
    /// the board must create ENABLE high (disabled) and the timer stopped
    /// with STEP low. The pump starts disabled at position 0.
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
            run_base_steps: 0,
            run_sign: 1,
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

    /// Stops the step timer at once, then turns the motor outputs off
    /// (ENABLE high). The pump refuses to start from now on even if the
    /// pin write fails.
    pub fn disable(&mut self) -> Result<(), PumpError> {
        self.stop();
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

    /// Checks the end-stop ahead of `direction` (`empty` for inject,
    /// `full` for withdraw), raw: `Err(EndStop)` when triggered, the pin's
    /// error when unreadable.
    pub fn check_ahead(&mut self, direction: Direction) -> Result<(), PumpError> {
        let polarity = self.config.end_stop_polarity;
        let blocked = match direction {
            Direction::Inject => {
                Self::triggered(&mut self.pins.end_empty, polarity, PinRole::EndEmpty)?
            }
            Direction::Withdraw => {
                Self::triggered(&mut self.pins.end_full, polarity, PinRole::EndFull)?
            }
        };
        if blocked {
            Err(PumpError::EndStop)
        } else {
            Ok(())
        }
    }

    /// Starts the step timer in `direction`: the first step `first_us`
    /// from now, the second `second_us` after it (µs; see
    /// [`StepPulses::start`]).
    ///
    /// Refuses, starting nothing, when disabled ([`PumpError::Disabled`]),
    /// when the timer still runs ([`PumpError::Running`]: DIR changes only
    /// while stopped), when the end-stop ahead is triggered or unreadable
    /// ([`SyringePump::check_ahead`]), or when DIR cannot be written.
    pub fn start(
        &mut self,
        direction: Direction,
        first_us: u32,
        second_us: u32,
    ) -> Result<(), PumpError> {
        if !self.enabled {
            return Err(PumpError::Disabled);
        }
        self.sync();
        if self.pins.step.running() {
            return Err(PumpError::Running);
        }
        self.check_ahead(direction)?;
        let dir_high = (direction == Direction::Inject) == self.config.inject_dir_high;
        self.pins
            .dir
            .set_state(dir_high.into())
            .map_err(|_| PumpError::Pin(PinRole::Dir))?;
        self.run_base_steps = self.position_steps;
        self.run_sign = direction.steps();
        self.pins.step.start(first_us, second_us);
        Ok(())
    }

    /// Queues the next period (µs; [`StepPulses::queue_period`]).
    pub fn queue_period(&mut self, period_us: u32) {
        self.pins.step.queue_period(period_us);
    }

    /// Ends the run after the pulse in progress ([`StepPulses::finish`]).
    pub fn finish(&mut self) {
        self.pins.step.finish();
    }

    /// Stops the step timer at once ([`StepPulses::stop`]) and counts what
    /// it emitted.
    pub fn stop(&mut self) {
        self.pins.step.stop();
        self.sync();
    }

    /// True while the step timer runs.
    pub fn running(&self) -> bool {
        self.pins.step.running()
    }

    /// Brings the position up to the pulses the timer completed in this
    /// run and returns their number.
    pub fn sync(&mut self) -> u32 {
        let pulses = self.pins.step.pulses();
        // The stroke is far below i32::MAX / 2 steps (validated): a run
        // cannot overflow; saturate rather than wrap if it ever did.
        let moved = i32::try_from(pulses).unwrap_or(i32::MAX);
        self.position_steps = self
            .run_base_steps
            .saturating_add(self.run_sign.saturating_mul(moved));
        pulses
    }

    /// Waits until the timer completes a pulse after the `seen`-th of
    /// this run, or stops ([`StepPulses::wait_pulse`]).
    pub async fn wait_pulse(&mut self, seen: u32) {
        self.pins.step.wait_pulse(seen).await;
    }

    /// Plunger position (microsteps, positive = injected) since power-up or
    /// the last [`SyringePump::zero_position`], as of the last
    /// [`SyringePump::sync`].
    pub fn position_steps(&self) -> i32 {
        self.position_steps
    }

    /// Net volume pushed (mL, positive = injected), from the step count.
    pub fn volume_ml(&self) -> f32 {
        self.config.ml_from_steps(self.position_steps)
    }

    /// Declares the current plunger position the zero of volume (stopped
    /// only; refused while the timer runs).
    pub fn zero_position(&mut self) -> Result<(), PumpError> {
        if self.running() {
            return Err(PumpError::Running);
        }
        let moved = i32::try_from(self.sync()).unwrap_or(i32::MAX);
        // The finished run's pulses still count in `sync`: offset them.
        self.run_base_steps = self.run_sign.saturating_mul(moved).saturating_neg();
        self.position_steps = 0;
        Ok(())
    }
}
