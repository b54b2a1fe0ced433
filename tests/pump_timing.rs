//! The pump task's step sequencing ([`StepSequencer`]) against the exact
//! host model of the board's step timer ([`SimStepTimer`]), on a virtual
//! µs clock: every rising edge is compared with the times the step planner
//! gives, whenever the sequencer is serviced; reversals, Disable and the
//! end-stops are checked on the edges themselves.

use std::cell::RefCell;
use std::convert::Infallible;
use std::rc::Rc;

use embedded_hal::digital::{ErrorType, InputPin, OutputPin};
use urechis::drivers::pump::{
    Plan, PumpConfig, PumpError, PumpPins, SimStepTimer, StepPlanner, StepPulses, StepSequencer,
    SyringePump, STEP_HIGH_US,
};

/// The rig on the test's clock: the timer, the driver's pins and a plunger
/// whose `empty` switch opens (triggers) at a given step count.
#[derive(Default)]
struct World {
    timer: SimStepTimer,
    dir_high: bool,
    enabled: bool,
    /// Rising edges: time (µs) and DIR level.
    edges: Vec<(u64, bool)>,
    /// Microsteps the motor made (edges with the driver on), + = inject.
    motor_steps: i64,
    /// The `empty` switch triggers once the motor is this far in.
    empty_at_steps: Option<i64>,
}

type W = Rc<RefCell<World>>;

impl World {
    fn advance(w: &W, to_us: u64) {
        let mut guard = w.borrow_mut();
        let World {
            timer,
            dir_high,
            enabled,
            edges,
            motor_steps,
            ..
        } = &mut *guard;
        timer.advance(to_us, |t| {
            edges.push((t, *dir_high));
            if *enabled {
                // DIR high injects (the default configuration).
                *motor_steps += if *dir_high { 1 } else { -1 };
            }
        });
    }
}

struct Step(W);
struct Dir(W);
struct Enable(W);
struct EndStop(W, bool);

impl StepPulses for Step {
    fn start(&mut self, first_us: u32, second_us: u32) {
        self.0.borrow_mut().timer.start(first_us, second_us);
    }
    fn queue_period(&mut self, period_us: u32) {
        self.0.borrow_mut().timer.queue_period(period_us);
    }
    fn finish(&mut self) {
        self.0.borrow_mut().timer.finish();
    }
    fn stop(&mut self) {
        self.0.borrow_mut().timer.stop();
    }
    fn pulses(&self) -> u32 {
        self.0.borrow().timer.pulses()
    }
    fn running(&self) -> bool {
        self.0.borrow().timer.running()
    }
    async fn wait_pulse(&mut self, _seen: u32) {}
}

impl ErrorType for Dir {
    type Error = Infallible;
}
impl OutputPin for Dir {
    fn set_low(&mut self) -> Result<(), Infallible> {
        let mut w = self.0.borrow_mut();
        assert!(!w.timer.running(), "DIR written while the timer runs");
        w.dir_high = false;
        Ok(())
    }
    fn set_high(&mut self) -> Result<(), Infallible> {
        let mut w = self.0.borrow_mut();
        assert!(!w.timer.running(), "DIR written while the timer runs");
        w.dir_high = true;
        Ok(())
    }
}

impl ErrorType for Enable {
    type Error = Infallible;
}
impl OutputPin for Enable {
    fn set_low(&mut self) -> Result<(), Infallible> {
        self.0.borrow_mut().enabled = true;
        Ok(())
    }
    fn set_high(&mut self) -> Result<(), Infallible> {
        self.0.borrow_mut().enabled = false;
        Ok(())
    }
}

impl ErrorType for EndStop {
    type Error = Infallible;
}
impl InputPin for EndStop {
    /// Normally-closed switch (the default polarity): high = triggered.
    fn is_high(&mut self) -> Result<bool, Infallible> {
        let w = self.0.borrow();
        let empty = w.empty_at_steps.is_some_and(|at| w.motor_steps >= at);
        Ok(self.1 && empty)
    }
    fn is_low(&mut self) -> Result<bool, Infallible> {
        Ok(!self.is_high()?)
    }
}

type Pump = SyringePump<Step, Dir, Enable, EndStop, EndStop>;

fn rig() -> (W, Pump, StepSequencer) {
    let w = W::default();
    let pins = PumpPins {
        step: Step(Rc::clone(&w)),
        dir: Dir(Rc::clone(&w)),
        enable: Enable(Rc::clone(&w)),
        end_empty: EndStop(Rc::clone(&w), true),
        end_full: EndStop(Rc::clone(&w), false),
    };
    let config = PumpConfig::default();
    let pump = SyringePump::new(pins, config).unwrap_or_else(|r| panic!("{:?}", r.error));
    let seq = StepSequencer::new(config.ml_per_step());
    (w, pump, seq)
}

/// When the sequencer is serviced.
#[derive(Clone, Copy)]
enum Polls {
    /// `late_us` after every completed pulse (and every ms at rest).
    AfterPulse { late_us: u64 },
    /// On a fixed grid, blind to the pulses.
    Grid { every_us: u64 },
}

/// Services the pump from `from_us` to `to_us` at the times `polls`
/// gives; returns the last service time.
fn run(w: &W, pump: &mut Pump, seq: &mut StepSequencer, from_us: u64, to_us: u64, polls: Polls) {
    let mut t = from_us;
    while t < to_us {
        World::advance(w, t);
        // Refusals are checked by the tests that expect them.
        let _ = seq.service(pump);
        let next = match polls {
            Polls::AfterPulse { late_us } => match w.borrow().timer.next_completion_us() {
                Some(done) => done + late_us,
                None => t + 1_000,
            },
            Polls::Grid { every_us } => t + every_us,
        };
        t = next.max(t + 1);
    }
    World::advance(w, to_us);
}

/// The edges the planner gives toward `target` from rest, the first
/// `first_us` after `start_us`: `n` of them.
fn planned_edges(start_us: u64, target: f32, n: usize) -> Vec<u64> {
    let mut p = StepPlanner::new(PumpConfig::default().ml_per_step());
    let mut t = start_us;
    let mut edges = Vec::new();
    while edges.len() < n {
        let Plan::Step { wait_us, .. } = p.next(target) else {
            panic!("idle toward {target}")
        };
        t += u64::from(wait_us);
        edges.push(t);
    }
    edges
}

fn edge_times(w: &W) -> Vec<u64> {
    w.borrow().edges.iter().map(|e| e.0).collect()
}

#[test]
fn edges_follow_the_plan_however_late_the_task_is_within_a_period() {
    // 2 mL/s: the ramp (periods 2047 µs down to 210 µs) and cruise.
    // The cruise period is 210 µs: services up to 200 µs late, or blind
    // every 100 µs, all give the planner's edges to the µs.
    let n = 300;
    let expected = planned_edges(1_000, 2.0, n);
    for polls in [
        Polls::AfterPulse { late_us: 0 },
        Polls::AfterPulse { late_us: 150 },
        Polls::AfterPulse {
            late_us: 210 - u64::from(STEP_HIGH_US) - 1,
        },
        Polls::Grid { every_us: 100 },
        Polls::Grid { every_us: 37 },
    ] {
        let (w, mut pump, mut seq) = rig();
        World::advance(&w, 1_000);
        pump.enable().unwrap();
        seq.set_target(2.0);
        run(&w, &mut pump, &mut seq, 1_000, expected[n - 1] + 10, polls);
        let edges = edge_times(&w);
        assert_eq!(&edges[..n], &expected[..]);
        // Every edge injects, the volume is the edges counted.
        assert!(w.borrow().edges.iter().all(|e| e.1));
        pump.sync();
        assert_eq!(i64::from(pump.position_steps()), w.borrow().motor_steps);
    }
    // Later than a period, the timer repeats the last period: the edges
    // are no longer the plan's (what a late task costs, and that this
    // test sees it).
    let (w, mut pump, mut seq) = rig();
    World::advance(&w, 1_000);
    pump.enable().unwrap();
    seq.set_target(2.0);
    let polls = Polls::AfterPulse { late_us: 400 };
    run(&w, &mut pump, &mut seq, 1_000, expected[n - 1] + 10, polls);
    assert_ne!(edge_times(&w).get(..n), Some(&expected[..]));
}

#[test]
fn a_reversal_passes_through_zero_rate() {
    let (w, mut pump, mut seq) = rig();
    pump.enable().unwrap();
    seq.set_target(2.0);
    let polls = Polls::AfterPulse { late_us: 20 };
    run(&w, &mut pump, &mut seq, 0, 50_000, polls);
    // Stop during Expand: +2 → −4 mL/s.
    seq.set_target(-4.0);
    run(&w, &mut pump, &mut seq, 50_000, 150_000, polls);
    let edges = w.borrow().edges.clone();
    // One change of direction, inject first.
    let turn = edges.iter().position(|e| !e.1).expect("no withdraw edge");
    assert!(edges[..turn].iter().all(|e| e.1));
    assert!(edges[turn..].iter().all(|e| !e.1));
    // The rate falls to zero before the turn: the last inject intervals
    // grow, the last one at least √(2s/a) = 2047 µs (a stop from below
    // that speed), and the first withdraw edge comes at least as long
    // after it.
    let gaps: Vec<u64> = edges.windows(2).map(|p| p[1].0 - p[0].0).collect();
    let before = &gaps[turn - 12..turn - 1];
    assert!(before.windows(2).all(|g| g[1] > g[0]), "{before:?}");
    assert!(gaps[turn - 2] >= 2_047, "{}", gaps[turn - 2]);
    assert!(gaps[turn - 1] >= 2_047, "{}", gaps[turn - 1]);
    // Then it ramps up the other way to 4 mL/s: 105 µs periods.
    assert_eq!(*gaps.last().unwrap(), 105);
    pump.sync();
    assert_eq!(i64::from(pump.position_steps()), w.borrow().motor_steps);
}

#[test]
fn disable_stops_pulses_at_once() {
    let (w, mut pump, mut seq) = rig();
    pump.enable().unwrap();
    seq.set_target(4.0);
    let polls = Polls::AfterPulse { late_us: 10 };
    run(&w, &mut pump, &mut seq, 0, 30_000, polls);
    // Disable inside a pulse (its edge came): as the task's `Disable`.
    let edge = w.borrow().edges.last().unwrap().0 + 105;
    World::advance(&w, edge + 1);
    assert!(w.borrow().timer.step_high());
    let before = w.borrow().edges.len();
    seq.stop_now();
    pump.disable().unwrap();
    assert!(!w.borrow().timer.step_high(), "STEP low at once");
    // The pulse whose edge came is counted; nothing follows.
    run(&w, &mut pump, &mut seq, edge + 1, edge + 100_000, polls);
    assert_eq!(w.borrow().edges.len(), before);
    pump.sync();
    assert_eq!(pump.position_steps() as usize, before);
}

#[test]
fn an_end_stop_refuses_further_pulses() {
    let (w, mut pump, mut seq) = rig();
    w.borrow_mut().empty_at_steps = Some(500);
    pump.enable().unwrap();
    seq.set_target(4.0);
    let polls = Polls::AfterPulse { late_us: 10 };
    run(&w, &mut pump, &mut seq, 0, 500_000, polls);
    // The switch triggered at the 500th edge; the next service stopped
    // the timer before the 501st.
    assert_eq!(w.borrow().edges.len(), 500);
    assert!(!w.borrow().timer.running());
    assert_eq!(seq.service(&mut pump), Err(PumpError::EndStop));
    pump.sync();
    assert_eq!(pump.position_steps(), 500);
    // Away from the switch is allowed.
    seq.set_target(-1.0);
    run(&w, &mut pump, &mut seq, 500_000, 600_000, polls);
    let w = w.borrow();
    assert!(w.edges.len() > 500);
    assert!(w.edges[500..].iter().all(|e| !e.1));
    assert_eq!(w.edges[500..].len() as i64, 500 - w.motor_steps);
}

#[test]
fn hold_ramps_down_and_the_timer_stops_after_the_last_pulse() {
    let (w, mut pump, mut seq) = rig();
    pump.enable().unwrap();
    seq.set_target(4.0);
    let polls = Polls::AfterPulse { late_us: 30 };
    run(&w, &mut pump, &mut seq, 0, 40_000, polls);
    let at_hold = w.borrow().edges.len();
    seq.set_target(0.0);
    run(&w, &mut pump, &mut seq, 40_000, 200_000, polls);
    let w = w.borrow();
    assert!(!w.timer.running());
    // 4 mL/s to rest at 200 mL/s²: v²/2a = 0.04 mL = 95.5 steps further,
    // give or take the two pulses already planned at the command.
    let further = (w.edges.len() - at_hold) as f64;
    let s = f64::from(PumpConfig::default().ml_per_step());
    assert!((further * s - 0.04).abs() <= 3.0 * s, "{further} steps");
    // The intervals grow to the last, which ends at rest (≥ √(2s/a)).
    let gaps: Vec<u64> = w.edges.windows(2).map(|p| p[1].0 - p[0].0).collect();
    let tail = &gaps[gaps.len() - 20..];
    assert!(tail.windows(2).all(|g| g[1] > g[0]), "{tail:?}");
    assert!(*tail.last().unwrap() >= 2_047);
    // The count is every edge, and nothing comes after the stop.
    let n = w.edges.len();
    drop(w);
    pump.sync();
    assert_eq!(pump.position_steps() as usize, n);
}
