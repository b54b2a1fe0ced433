//! The stepper syringe pump as the board drives it: the firmware's own
//! [`PumpConfig`] turns a commanded rate into a microstep interval and
//! microsteps into millilitres; the schedule follows the board's pump task
//! (a start or a reversal steps at once, then every interval; a rate change
//! in the same direction keeps the schedule), and a step towards a closed
//! end-stop is refused and not counted, as the driver does.
//!
//! Two fault modes sit in the mechanics, below what the firmware can see:
//! - **stall**: the motor loses its steps (skipped steps, a sheared
//!   coupling): the driver still counts every step, the plunger does not
//!   move;
//! - the end-stops close at the two ends of the barrel's travel
//!   (`empty` with the plunger fully in, `full` fully out).

use urechis::controller::{EndStops, PumpCommand};
use urechis::drivers::pump::{Direction, PumpConfig};

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
    /// The command in force and the time (µs) of the next step under it.
    command: PumpCommand,
    next_step_us: u64,
    /// The motor loses every step (they are still counted).
    stalled: bool,
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
            next_step_us: 0,
            stalled: false,
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

    /// Microsteps counted since power-up.
    pub fn counted_steps(&self) -> i32 {
        self.counted_steps
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

    /// Applies a new command at time `now_us`, like the board's pump task:
    /// a start or a reversal steps at once, a rate change in the same
    /// direction keeps the running schedule.
    pub fn apply(&mut self, command: PumpCommand, now_us: u64) {
        if !same_motion(self.command, command) {
            self.next_step_us = now_us;
        }
        self.command = command;
    }

    /// Runs the motor over `[from_us, to_us)`: every step due in that
    /// window, each refused when the end-stop ahead is closed. Returns the
    /// microsteps counted (signed).
    pub fn advance(&mut self, from_us: u64, to_us: u64) -> i32 {
        let PumpCommand::Run { rate_ml_per_s } = self.command else {
            return 0;
        };
        let (Some(direction), Some(interval_us)) = (
            Direction::from_rate(rate_ml_per_s),
            self.config.step_interval_us(rate_ml_per_s),
        ) else {
            return 0;
        };
        // After a pause (the board's "no burst to catch up") the schedule
        // restarts at the window.
        if self.next_step_us < from_us {
            self.next_step_us = from_us;
        }
        let mut counted = 0;
        while self.next_step_us < to_us {
            if self.step(direction) {
                counted += match direction {
                    Direction::Inject => 1,
                    Direction::Withdraw => -1,
                };
            }
            self.next_step_us += u64::from(interval_us);
        }
        counted
    }

    /// One microstep driven from outside (a STEP pulse with DIR set for
    /// `direction`), as the virtual board's pins deliver it; false when
    /// refused (end-stop ahead closed).
    pub fn pulse(&mut self, direction: Direction) -> bool {
        self.step(direction)
    }

    /// One microstep; false when refused (end-stop ahead closed).
    fn step(&mut self, direction: Direction) -> bool {
        let stops = self.end_stops();
        let (blocked, sign) = match direction {
            Direction::Inject => (stops.empty, 1.0),
            Direction::Withdraw => (stops.full, -1.0),
        };
        if blocked {
            return false;
        }
        let Some(next) = self.counted_steps.checked_add(sign as i32) else {
            return false;
        };
        self.counted_steps = next;
        if !self.stalled {
            let ml = sign * f64::from(self.config.ml_per_step());
            self.displaced_ml += ml;
            self.barrel_ml = (self.barrel_ml - ml).clamp(0.0, f64::from(self.config.stroke_ml));
        }
        true
    }
}

/// Milliseconds to microseconds.
pub fn us_from_ms(ms: u32) -> u64 {
    u64::from(ms) * US_PER_MS
}

/// True when `new` keeps stepping the same way as `old` (the board's rule).
fn same_motion(old: PumpCommand, new: PumpCommand) -> bool {
    match (old, new) {
        (PumpCommand::Run { rate_ml_per_s: a }, PumpCommand::Run { rate_ml_per_s: b }) => {
            Direction::from_rate(a).is_some() && Direction::from_rate(a) == Direction::from_rate(b)
        }
        _ => false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(rate: f32) -> PumpCommand {
        PumpCommand::Run {
            rate_ml_per_s: rate,
        }
    }

    #[test]
    fn steps_at_the_config_interval() {
        let config = PumpConfig::default();
        let mut pump = StepperPump::new(config, 25.0);
        pump.apply(run(1.0), 0);
        let steps = pump.advance(0, 1_000_000);
        // One second at 1 mL/s: a step at 0 and every
        // ceil(1e6 · ml_per_step) µs after.
        let interval = config.step_interval_us(1.0).unwrap();
        assert_eq!(steps as u64, 1_000_000_u64.div_ceil(u64::from(interval)));
        let ml = f64::from(pump.reported_volume_ml());
        assert_eq!(ml, f64::from(config.ml_from_steps(steps)));
        // The interval rounds up: never faster than asked, slower by at
        // most one µs per interval.
        let slowest = f64::from(interval - 1) / f64::from(interval);
        assert!(
            ml <= 1.0 + f64::from(config.ml_per_step()) && ml >= slowest - 1e-3,
            "{ml}"
        );
        // f32 count vs f64 sum of the same steps.
        assert!((pump.displaced_ml() - ml).abs() < 1e-6);
    }

    #[test]
    fn rate_is_clamped_to_the_pump_maximum() {
        let config = PumpConfig::default();
        let mut pump = StepperPump::new(config, 25.0);
        pump.apply(run(-4.0), 0);
        let steps = pump.advance(0, 1_000_000);
        let interval = config
            .step_interval_us(urechis::drivers::pump::MAX_RATE_ML_PER_S)
            .unwrap();
        assert_eq!(config.step_interval_us(-4.0), Some(interval));
        assert_eq!(
            -i64::from(steps),
            1_000_000_u64.div_ceil(u64::from(interval)) as i64
        );
        assert!(pump.displaced_ml() < 0.0);
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
