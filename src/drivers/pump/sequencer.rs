//! Keeps the step timer supplied from the [`StepPlanner`]: the pump task's
//! logic, free of any executor so that the host tests drive it against
//! [`super::SimStepTimer`] at whatever instants they choose.
//!
//! The timer holds the pulse in progress and one queued period; after
//! each completed pulse [`StepSequencer::service`] plans the one after
//! that. Between runs (from rest, after a stop or a reversal, which the
//! planner ends at rate 0) it writes DIR and starts the timer again.

use embedded_hal::digital::{InputPin, OutputPin};

use super::{Direction, Plan, PumpError, StepPlanner, StepPulses, SyringePump};

/// What the sequencer drives: a pump whose steps come from a timer
/// ([`SyringePump`] on the board and the virtual board; the emulator's
/// plant pump, on the same timer model).
pub trait StepDrive {
    /// Counts the pulses completed in this run into the position and
    /// returns their number ([`SyringePump::sync`]).
    fn sync(&mut self) -> u32;
    /// True while the timer runs.
    fn running(&self) -> bool;
    /// `Err` when the end-stop ahead reads triggered or cannot be read
    /// ([`SyringePump::check_ahead`]).
    fn check_ahead(&mut self, direction: Direction) -> Result<(), PumpError>;
    /// Starts a run ([`SyringePump::start`]).
    fn start(
        &mut self,
        direction: Direction,
        first_us: u32,
        second_us: u32,
    ) -> Result<(), PumpError>;
    /// Queues the next period ([`StepPulses::queue_period`]).
    fn queue_period(&mut self, period_us: u32);
    /// Ends the run after the pulse in progress ([`StepPulses::finish`]).
    fn finish(&mut self);
    /// Stops at once ([`StepPulses::stop`]).
    fn stop(&mut self);
}

impl<S, D, E, Ee, Ef> StepDrive for SyringePump<S, D, E, Ee, Ef>
where
    S: StepPulses,
    D: OutputPin,
    E: OutputPin,
    Ee: InputPin,
    Ef: InputPin,
{
    fn sync(&mut self) -> u32 {
        SyringePump::sync(self)
    }
    fn running(&self) -> bool {
        SyringePump::running(self)
    }
    fn check_ahead(&mut self, direction: Direction) -> Result<(), PumpError> {
        SyringePump::check_ahead(self, direction)
    }
    fn start(
        &mut self,
        direction: Direction,
        first_us: u32,
        second_us: u32,
    ) -> Result<(), PumpError> {
        SyringePump::start(self, direction, first_us, second_us)
    }
    fn queue_period(&mut self, period_us: u32) {
        SyringePump::queue_period(self, period_us);
    }
    fn finish(&mut self) {
        SyringePump::finish(self);
    }
    fn stop(&mut self) {
        SyringePump::stop(self);
    }
}

/// The pump's step plan, fed to its timer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepSequencer {
    planner: StepPlanner,
    target_ml_per_s: f32,
    /// Direction of the run on the timer.
    direction: Direction,
    /// Pulses of that run whose period the timer was given.
    planned: u32,
    /// The run ends with this pulse (the planner reached rest, or turns).
    last: Option<u32>,
    /// The first step of the next run, planned but not yet started:
    /// direction and wait after the previous step (µs).
    pending: Option<(Direction, u32)>,
}

impl StepSequencer {
    /// At rest, for a pump moving `ml_per_step` (mL) per microstep.
    pub fn new(ml_per_step: f32) -> Self {
        Self {
            planner: StepPlanner::new(ml_per_step),
            target_ml_per_s: 0.0,
            direction: Direction::Inject,
            planned: 0,
            last: None,
            pending: None,
        }
    }

    /// The rate to head for (mL/s, signed; see [`StepPlanner::next`]); it
    /// applies from the next planned step on.
    pub fn set_target(&mut self, rate_ml_per_s: f32) {
        self.target_ml_per_s = rate_ml_per_s;
    }

    /// The signed rate of the last planned step (mL/s).
    pub fn rate_ml_per_s(&self) -> f32 {
        self.planner.rate_ml_per_s()
    }

    /// Forgets the motion (the timer was stopped at once: a disable, an
    /// end-stop): the next run starts from standstill.
    pub fn stop_now(&mut self) {
        self.planner.stop_now();
        self.pending = None;
        self.last = None;
    }

    fn plan(&mut self) -> Option<(Direction, u32)> {
        match self.planner.next(self.target_ml_per_s) {
            Plan::Step { direction, wait_us } => Some((direction, wait_us)),
            Plan::Idle => None,
        }
    }

    /// Brings the timer up to date; call it after every completed pulse,
    /// on every new target, and now and then at rest.
    ///
    /// While running: stops at once if the end-stop ahead reads triggered
    /// (raw) and returns the refusal; otherwise plans up to the pulse
    /// after the one in progress, and ends the run with its last pulse.
    /// Stopped: starts the next run if the plan has one (refusals as
    /// [`SyringePump::start`]; the plan then restarts from standstill).
    pub fn service<P: StepDrive>(&mut self, pump: &mut P) -> Result<(), PumpError> {
        let done = pump.sync();
        if pump.running() {
            if let Err(e) = pump.check_ahead(self.direction) {
                pump.stop();
                self.stop_now();
                return Err(e);
            }
            // Pulse `done + 1` is in progress: if it is the last, no edge
            // after it.
            if self.last.is_some_and(|last| last <= done + 1) {
                pump.finish();
                return Ok(());
            }
            // A late service: the timer repeated the last period for
            // pulses nobody planned; count them into the plan.
            while self.last.is_none() && self.planned < done + 1 {
                self.plan_one(pump, false);
            }
            while self.last.is_none() && self.planned < done + 2 {
                self.plan_one(pump, true);
            }
            if self.last.is_some_and(|last| last <= done + 1) {
                pump.finish();
            }
            return Ok(());
        }
        // Stopped: a run ended (or none ran).
        self.last = None;
        let next = match self.pending.take() {
            Some(step) => Some(step),
            None => self.plan(),
        };
        let Some((direction, first_us)) = next else {
            return Ok(());
        };
        // After a first step from standstill the rate is not 0: the
        // second step goes the same way.
        let second_us = match self.plan() {
            Some((d, wait_us)) if d == direction => wait_us,
            _ => first_us,
        };
        if let Err(e) = pump.start(direction, first_us, second_us) {
            self.stop_now();
            return Err(e);
        }
        self.direction = direction;
        self.planned = 2;
        Ok(())
    }

    /// Plans pulse `planned + 1`; queues its period when `queue`. A rest
    /// or a turn makes pulse `planned` the run's last.
    fn plan_one<P: StepDrive>(&mut self, pump: &mut P, queue: bool) {
        match self.plan() {
            Some((direction, wait_us)) if direction == self.direction => {
                if queue {
                    pump.queue_period(wait_us);
                }
                self.planned += 1;
            }
            turn => {
                self.pending = turn;
                self.last = Some(self.planned);
            }
        }
    }
}
