//! The stepper syringe pump as the board drives it: the firmware's own
//! step sequencing ([`StepSequencer`]: the trapezoidal ramp, reversals
//! through rest, a stop at a triggered end-stop) on the firmware's model
//! of the board's step timer ([`SimStepTimer`]), serviced the moment each
//! pulse completes and at each command, as the board's pump task is; the
//! firmware's [`PumpConfig`] turns microsteps into millilitres. The
//! plunger moves on each rising edge; the count (what the firmware reports
//! as its volume) is the pulses the timer completed.
//!
//! Two fault modes sit in the mechanics, below what the firmware can see:
//! - **stall**: the motor loses its steps (skipped steps, a sheared
//!   coupling): the driver still counts every step, the plunger does not
//!   move;
//! - the end-stops close at the two ends of the barrel's travel
//!   (`empty` with the plunger fully in, `full` fully out); the plunger
//!   cannot move past them.

use urechis::controller::{EndStops, PumpCommand};
use urechis::drivers::pump::{
    Direction, PumpConfig, PumpError, SimStepTimer, StepDrive, StepSequencer,
};

/// Microseconds per millisecond.
const US_PER_MS: u64 = 1000;

/// A syringe pump on a STEP/DIR driver with its two end-stops.
#[derive(Clone, Debug)]
pub struct StepperPump {
    config: PumpConfig,
    /// Microsteps the driver counted since power-up (positive = injected):
    /// what the firmware reports as its volume.
    counted_steps: i32,
    /// Water left in the barrel (mL): the plunger's true position.
    barrel_ml: f64,
    /// Net volume the plunger really pushed out since power-up (mL).
    displaced_ml: f64,
    /// The command in force.
    command: PumpCommand,
    /// The motor loses every step (they are still counted).
    stalled: bool,
    /// The board's step timer and the pump task's sequencing of it.
    timer: SimStepTimer,
    sequencer: StepSequencer,
    /// The count when the timer last started, and the run's direction.
    run_base_steps: i32,
    direction: Direction,
}

impl StepperPump {
    /// A pump at power-up (driver disabled, count 0) with `fill_ml` of
    /// water in the barrel (clamped to the stroke).
    pub fn new(config: PumpConfig, fill_ml: f64) -> Self {
        Self {
            config,
            counted_steps: 0,
            barrel_ml: fill_ml.clamp(0.0, f64::from(config.stroke_ml)),
            displaced_ml: 0.0,
            command: PumpCommand::Disable,
            stalled: false,
            timer: SimStepTimer::new(),
            sequencer: StepSequencer::new(config.ml_per_step()),
            run_base_steps: 0,
            direction: Direction::Inject,
        }
    }

    /// The pump's configuration.
    pub fn config(&self) -> &PumpConfig {
        &self.config
    }

    /// Volume the firmware reads (mL): the driver's step count through
    /// [`PumpConfig::ml_from_steps`], exactly as the board reports it.
    pub fn reported_volume_ml(&self) -> f32 {
        self.config.ml_from_steps(self.counted_steps)
    }

    /// Microsteps the driver took since power-up: one per rising edge,
    /// so a pulse still high counts here before the firmware's count
    /// (pulses completed, [`StepperPump::reported_volume_ml`]) has it.
    pub fn counted_steps(&self) -> i32 {
        let high = i32::from(self.timer.step_high());
        self.counted_steps
            .saturating_add(self.direction.steps() * high)
    }

    /// Water in the barrel (mL), 0 (empty) to the stroke (full).
    pub fn barrel_ml(&self) -> f64 {
        self.barrel_ml
    }

    /// Net volume the plunger pushed out since power-up (mL).
    pub fn displaced_ml(&self) -> f64 {
        self.displaced_ml
    }

    /// The end-stop switches: `empty` closes with the plunger fully in,
    /// `full` fully out.
    pub fn end_stops(&self) -> EndStops {
        EndStops {
            empty: self.barrel_ml <= 0.0,
            full: self.barrel_ml >= f64::from(self.config.stroke_ml),
        }
    }

    /// Makes the motor lose (or stop losing) its steps.
    pub fn set_stalled(&mut self, stalled: bool) {
        self.stalled = stalled;
    }

    /// True while the motor loses its steps.
    pub fn stalled(&self) -> bool {
        self.stalled
    }

    /// The command in force.
    pub fn command(&self) -> PumpCommand {
        self.command
    }

    /// The signed rate of the last planned step (mL/s).
    pub fn planned_rate_ml_per_s(&self) -> f32 {
        self.sequencer.rate_ml_per_s()
    }

    /// Applies a new command at time `now_us` (not before the last
    /// [`StepperPump::advance`]), as the board's pump task does: `Disable`
    /// stops the timer at once; `Hold` and `Run` set the plan's target and
    /// start a run from rest.
    pub fn apply(&mut self, command: PumpCommand, now_us: u64) {
        self.run_timer(now_us);
        self.command = command;
        let mut sequencer = self.sequencer;
        match command {
            PumpCommand::Disable => {
                StepDrive::stop(self);
                sequencer.stop_now();
                sequencer.set_target(0.0);
            }
            PumpCommand::Hold => sequencer.set_target(0.0),
            PumpCommand::Run { rate_ml_per_s } => sequencer.set_target(rate_ml_per_s),
        }
        if command != PumpCommand::Disable {
            // A refusal (an end-stop ahead) leaves the pump at rest; the
            // controller sees the switch.
            let _ = sequencer.service(self);
        }
        self.sequencer = sequencer;
    }

    /// Runs the motor over `[from_us, to_us)`: every edge the timer makes,
    /// the plan serviced as each pulse completes. Returns the microsteps
    /// counted (signed).
    pub fn advance(&mut self, from_us: u64, to_us: u64) -> i32 {
        let before = self.counted_steps;
        self.run_timer(from_us);
        while let Some(done_us) = self.timer.next_completion_us().filter(|t| *t <= to_us) {
            self.run_timer(done_us);
            let mut sequencer = self.sequencer;
            let _ = sequencer.service(self);
            self.sequencer = sequencer;
        }
        self.run_timer(to_us);
        self.sync_count();
        self.counted_steps - before
    }

    /// The timer up to `t_us`, the plunger moved by its edges.
    fn run_timer(&mut self, t_us: u64) {
        let mut edges = 0u32;
        self.timer.advance(t_us, |_| edges += 1);
        for _ in 0..edges {
            self.move_plunger(self.direction);
        }
    }

    /// The count from the pulses the timer completed in this run.
    fn sync_count(&mut self) -> u32 {
        let pulses = self.timer.pulses();
        let moved = i32::try_from(pulses).unwrap_or(i32::MAX);
        self.counted_steps = self
            .run_base_steps
            .saturating_add(self.direction.steps() * moved);
        pulses
    }

    /// One microstep driven from outside (a STEP pulse with DIR set for
    /// `direction`), as the virtual board's pins deliver it; false when
    /// refused (end-stop ahead closed).
    pub fn pulse(&mut self, direction: Direction) -> bool {
        if !self.move_plunger(direction) {
            return false;
        }
        self.counted_steps = self.counted_steps.saturating_add(direction.steps());
        true
    }

    /// Whether the end-stop that `direction` moves towards is closed.
    fn blocked_ahead(&self, direction: Direction) -> bool {
        let stops = self.end_stops();
        match direction {
            Direction::Inject => stops.empty,
            Direction::Withdraw => stops.full,
        }
    }

    /// The plunger one microstep in `direction`, unless the end-stop ahead
    /// is closed (false) or the motor is stalled (true, no motion).
    fn move_plunger(&mut self, direction: Direction) -> bool {
        if self.blocked_ahead(direction) {
            return false;
        }
        if !self.stalled {
            let ml = f64::from(direction.steps()) * f64::from(self.config.ml_per_step());
            self.displaced_ml += ml;
            self.barrel_ml = (self.barrel_ml - ml).clamp(0.0, f64::from(self.config.stroke_ml));
        }
        true
    }
}

impl StepDrive for StepperPump {
    fn sync(&mut self) -> u32 {
        self.sync_count()
    }

    fn running(&self) -> bool {
        self.timer.running()
    }

    fn check_ahead(&mut self, direction: Direction) -> Result<(), PumpError> {
        if self.blocked_ahead(direction) {
            Err(PumpError::EndStop)
        } else {
            Ok(())
        }
    }

    fn start(
        &mut self,
        direction: Direction,
        first_us: u32,
        second_us: u32,
    ) -> Result<(), PumpError> {
        if self.command == PumpCommand::Disable {
            return Err(PumpError::Disabled);
        }
        self.sync_count();
        if self.timer.running() {
            return Err(PumpError::Running);
        }
        self.check_ahead(direction)?;
        self.run_base_steps = self.counted_steps;
        self.direction = direction;
        self.timer.start(first_us, second_us);
        Ok(())
    }

    fn queue_period(&mut self, period_us: u32) {
        self.timer.queue_period(period_us);
    }

    fn finish(&mut self) {
        self.timer.finish();
    }

    fn stop(&mut self) {
        self.timer.stop();
        self.sync_count();
    }
}

/// Milliseconds to microseconds.
pub fn us_from_ms(ms: u32) -> u64 {
    u64::from(ms) * US_PER_MS
}

#[cfg(test)]
mod tests {
    use super::*;
    use urechis::drivers::pump::{Plan, StepPlanner, STEP_HIGH_US};

    fn run(rate: f32) -> PumpCommand {
        PumpCommand::Run {
            rate_ml_per_s: rate,
        }
    }

    /// Pulses the firmware's planner completes toward `target` from rest
    /// at 0 by `to_us`.
    fn planned_pulses(config: &PumpConfig, target: f32, to_us: u64) -> i32 {
        let mut p = StepPlanner::new(config.ml_per_step());
        let (mut t, mut n) = (0u64, 0);
        while let Plan::Step { wait_us, .. } = p.next(target) {
            t += u64::from(wait_us);
            if t + u64::from(STEP_HIGH_US) > to_us {
                break;
            }
            n += 1;
        }
        n
    }

    #[test]
    fn steps_follow_the_firmware_plan() {
        let config = PumpConfig::default();
        let mut pump = StepperPump::new(config, 25.0);
        pump.apply(run(1.0), 0);
        // Advanced in 1 ms windows, as the plant does: the same pulses as
        // the planner's schedule from 0.
        let mut steps = 0;
        for ms in 0..1000 {
            steps += pump.advance(ms * 1000, (ms + 1) * 1000);
        }
        assert_eq!(steps, planned_pulses(&config, 1.0, 1_000_000));
        // One second at 1 mL/s less the 5 ms ramp's 2.5 µL: 1 mL within
        // a step or two.
        let ml = f64::from(pump.reported_volume_ml());
        assert!(
            (ml - 0.9975).abs() < 2.0 * f64::from(config.ml_per_step()),
            "{ml}"
        );
        assert_eq!(ml, f64::from(config.ml_from_steps(steps)));
        // f32 count vs f64 sum of the same steps.
        assert!((pump.displaced_ml() - ml).abs() < 1e-6);
    }

    #[test]
    fn rate_is_clamped_to_the_pump_maximum() {
        let config = PumpConfig::default();
        let mut fast = StepperPump::new(config, 25.0);
        fast.apply(run(-10.0), 0);
        let steps = fast.advance(0, 1_000_000);
        assert_eq!(-steps, planned_pulses(&config, -4.0, 1_000_000));
        assert_eq!(fast.planned_rate_ml_per_s(), -4.0);
        assert!(fast.displaced_ml() < 0.0);
    }

    #[test]
    fn end_stop_refuses_and_stall_counts_without_moving() {
        let config = PumpConfig::default();
        let mut pump = StepperPump::new(config, 0.5);
        pump.apply(run(2.0), 0);
        pump.advance(0, 1_000_000);
        assert!(pump.end_stops().empty);
        assert!((pump.displaced_ml() - 0.5).abs() <= f64::from(config.ml_per_step()));
        let counted = pump.counted_steps();
        pump.advance(1_000_000, 2_000_000);
        assert_eq!(pump.counted_steps(), counted, "a closed end-stop refuses");

        let mut pump = StepperPump::new(config, 25.0);
        pump.set_stalled(true);
        pump.apply(run(2.0), 0);
        pump.advance(0, 500_000);
        assert!(pump.counted_steps() > 0);
        assert_eq!(pump.displaced_ml(), 0.0);
        assert_eq!(pump.barrel_ml(), 25.0);
    }

    #[test]
    fn hold_and_disable_do_not_step() {
        let mut pump = StepperPump::new(PumpConfig::default(), 25.0);
        for c in [PumpCommand::Hold, PumpCommand::Disable, run(0.0)] {
            pump.apply(c, 0);
            assert_eq!(pump.advance(0, 1_000_000), 0);
        }
    }
}
