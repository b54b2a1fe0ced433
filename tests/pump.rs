//! Syringe pump: conversions against the closed form, and the driver
//! against digital-pin mocks listing every expected level.

use std::f64::consts::PI;

use std::cell::RefCell;
use std::rc::Rc;

use embedded_hal_mock::eh1::digital::{Mock as PinMock, State, Transaction as Pin};
use embedded_hal_mock::eh1::MockError;
use urechis::controller::EndStops;
use urechis::drivers::pump::{
    Direction, PinRole, PumpConfig, PumpConfigField, PumpError, PumpPins, SimStepTimer, StepPulses,
    SwitchPolarity, SyringePump,
};

/// The step timer: the host model, its clock advanced by the test.
#[derive(Clone, Default)]
struct TestStep(Rc<RefCell<SimStepTimer>>);

impl StepPulses for TestStep {
    fn start(&mut self, first_us: u32, second_us: u32) {
        self.0.borrow_mut().start(first_us, second_us);
    }
    fn queue_period(&mut self, period_us: u32) {
        self.0.borrow_mut().queue_period(period_us);
    }
    fn finish(&mut self) {
        self.0.borrow_mut().finish();
    }
    fn stop(&mut self) {
        self.0.borrow_mut().stop();
    }
    fn pulses(&self) -> u32 {
        self.0.borrow().pulses()
    }
    fn running(&self) -> bool {
        self.0.borrow().running()
    }
    async fn wait_pulse(&mut self, _seen: u32) {}
}

type Pump = SyringePump<TestStep, PinMock, PinMock, PinMock, PinMock>;

/// Volume per microstep with the defaults (mL), closed form in f64:
/// π/4 · 29.21² mm² · 2 mm / (200 · 16) / 1000.
fn default_ml_per_step() -> f64 {
    PI / 4.0 * 29.21 * 29.21 * 2.0 / (200.0 * 16.0) / 1000.0
}

fn rel_err(a: f64, b: f64) -> f64 {
    ((a - b) / b).abs()
}

/// Expected transactions per pin.
#[derive(Default)]
struct Expect {
    dir: Vec<Pin>,
    enable: Vec<Pin>,
    empty: Vec<Pin>,
    full: Vec<Pin>,
}

fn pump(e: &Expect, config: PumpConfig) -> Pump {
    pump_and_timer(e, config).0
}

/// A pump and its timer, whose clock the test advances.
fn pump_and_timer(e: &Expect, config: PumpConfig) -> (Pump, Rc<RefCell<SimStepTimer>>) {
    let step = TestStep::default();
    let timer = Rc::clone(&step.0);
    let pins = PumpPins {
        step,
        dir: PinMock::new(&e.dir),
        enable: PinMock::new(&e.enable),
        end_empty: PinMock::new(&e.empty),
        end_full: PinMock::new(&e.full),
    };
    let pump =
        SyringePump::new(pins, config).unwrap_or_else(|r| panic!("config rejected: {:?}", r.error));
    (pump, timer)
}

fn done(p: Pump) {
    let mut pins = p.destroy();
    pins.dir.done();
    pins.enable.done();
    pins.end_empty.done();
    pins.end_full.done();
}

/// The driver's tests below read the switches as "triggered = low" (the
/// default is the other way, normally-closed switches: see
/// `end_stops_follow_polarity`).
fn low_active() -> PumpConfig {
    PumpConfig {
        end_stop_polarity: SwitchPolarity::ActiveLow,
        ..PumpConfig::default()
    }
}

// --- Conversions -----------------------------------------------------------

#[test]
fn defaults_are_the_documented_hardware() {
    let c = PumpConfig::default();
    assert_eq!(c.lead_pitch_mm, 2.0);
    assert_eq!(c.full_steps_per_rev, 200);
    assert_eq!(c.microsteps, 16);
    assert_eq!(c.syringe_bore_mm, 29.21);
    // Normally-closed switches to GND with pull-ups: at the end the switch
    // opens and the pin reads high, and so does a broken wire.
    assert_eq!(c.end_stop_polarity, SwitchPolarity::ActiveHigh);
    assert_eq!(c.validate(), Ok(()));
}

#[test]
fn volume_per_step_matches_closed_form() {
    let c = PumpConfig::default();
    // 4.18825e-4 mL per microstep, 2387.63 microsteps per mL.
    assert!(rel_err(f64::from(c.ml_per_step()), default_ml_per_step()) < 1e-6);
    assert!(rel_err(f64::from(c.steps_per_ml()), 1.0 / default_ml_per_step()) < 1e-6);
    assert!((f64::from(c.steps_per_ml()) - 2387.63).abs() < 0.01);
    // One revolution = one lead (2 mm) of a 29.21 mm bore: 1.34027 mL.
    let rev_ml = PI / 4.0 * 29.21 * 29.21 * 2.0 / 1000.0;
    assert!(rel_err(f64::from(c.ml_from_steps(3200)), rev_ml) < 1e-6);
    assert!(rel_err(f64::from(c.ml_from_steps(-3200)), -rev_ml) < 1e-6);
    assert_eq!(c.ml_from_steps(0), 0.0);
}

#[test]
fn steps_from_ml_rounds_and_saturates() {
    let c = PumpConfig::default();
    assert_eq!(c.steps_from_ml(1.0), 2388); // 2387.63 rounds up
    assert_eq!(c.steps_from_ml(-1.0), -2388);
    assert_eq!(c.steps_from_ml(9.8), 23399); // 9.8 · 2387.63 = 23398.77
    assert_eq!(c.steps_from_ml(f32::NAN), 0);
    assert_eq!(c.steps_from_ml(1e30), i32::MAX);
    assert_eq!(c.steps_from_ml(f32::NEG_INFINITY), i32::MIN);
    for n in [-100_000, -3201, -1, 0, 1, 2, 3200, 119_378] {
        assert_eq!(c.steps_from_ml(c.ml_from_steps(n)), n);
    }
}

#[test]
fn step_interval_follows_rate_and_clamps() {
    let c = PumpConfig::default();
    // 1 mL/s: 1e6 µs / 2387.63 = 418.83 µs → 419 (rounded up: never faster).
    assert_eq!(c.step_interval_us(1.0), Some(419));
    assert_eq!(c.step_interval_us(-1.0), Some(419));
    // 0.1 mL/s: 4188.25 µs → 4189.
    assert_eq!(c.step_interval_us(0.1), Some(4189));
    // 2 mL/s: 209.41 µs → 210.
    assert_eq!(c.step_interval_us(2.0), Some(210));
    // Above the 4 mL/s maximum: clamped to it, 104.70 µs → 105.
    assert_eq!(c.step_interval_us(5.0), Some(105));
    assert_eq!(c.step_interval_us(4.0), Some(105));
    // No motion.
    assert_eq!(c.step_interval_us(0.0), None);
    assert_eq!(c.step_interval_us(-0.0), None);
    assert_eq!(c.step_interval_us(f32::NAN), None);
    assert_eq!(c.step_interval_us(f32::INFINITY), None);
    // 1e-9 mL/s would be 4.2e11 µs between steps, beyond u32.
    assert_eq!(c.step_interval_us(1e-9), None);
}

#[test]
fn validate_names_the_first_bad_field() {
    let bad = |f: fn(&mut PumpConfig)| {
        let mut c = PumpConfig::default();
        f(&mut c);
        c.validate().map_err(|e| e.field)
    };
    use PumpConfigField::*;
    assert_eq!(bad(|c| c.lead_pitch_mm = 0.0), Err(LeadPitchMm));
    assert_eq!(bad(|c| c.lead_pitch_mm = f32::NAN), Err(LeadPitchMm));
    assert_eq!(bad(|c| c.full_steps_per_rev = 0), Err(FullStepsPerRev));
    assert_eq!(bad(|c| c.microsteps = 0), Err(Microsteps));
    assert_eq!(bad(|c| c.microsteps = 3), Err(Microsteps));
    assert_eq!(bad(|c| c.microsteps = 512), Err(Microsteps));
    assert_eq!(bad(|c| c.microsteps = 256), Ok(()));
    assert_eq!(bad(|c| c.syringe_bore_mm = -29.21), Err(SyringeBoreMm));
    assert_eq!(
        bad(|c| c.syringe_bore_mm = f32::INFINITY),
        Err(SyringeBoreMm)
    );
    // 4 mL/s at 256 microsteps: one every 6.55 µs with a 2 mm lead, legal;
    // with a 1 mm lead every 3.27 µs, under the 5 µs a pulse takes (3 µs
    // high, 2 µs low).
    assert_eq!(bad(|c| c.microsteps = 256), Ok(()));
    assert_eq!(
        bad(|c| {
            c.microsteps = 256;
            c.lead_pitch_mm = 1.0;
        }),
        Err(Microsteps)
    );
    // The slowest step, 2 × 1.676e-3 mL / 0.05 mL/s = 67 ms at 4
    // microsteps, is longer than the timer's 65 ms; 33.5 ms at 8 fits.
    assert_eq!(bad(|c| c.microsteps = 4), Err(Microsteps));
    assert_eq!(bad(|c| c.microsteps = 8), Ok(()));
    assert_eq!(bad(|c| c.stroke_ml = f32::NAN), Err(StrokeMl));
    // 1e6 mL = 2.39e9 microsteps, beyond i32::MAX / 2.
    assert_eq!(bad(|c| c.stroke_ml = 1.0e6), Err(StrokeMl));
}

#[test]
fn direction_from_rate() {
    assert_eq!(Direction::from_rate(0.5), Some(Direction::Inject));
    assert_eq!(Direction::from_rate(-0.5), Some(Direction::Withdraw));
    assert_eq!(Direction::from_rate(0.0), None);
    assert_eq!(Direction::from_rate(f32::NAN), None);
}

// --- Driver ------------------------------------------------------------------

#[test]
fn new_rejects_a_bad_config_and_returns_the_pins() {
    let config = PumpConfig {
        microsteps: 3,
        ..PumpConfig::default()
    };
    let pins = PumpPins {
        step: TestStep::default(),
        dir: PinMock::new(&[]),
        enable: PinMock::new(&[]),
        end_empty: PinMock::new(&[]),
        end_full: PinMock::new(&[]),
    };
    let rejected = SyringePump::new(pins, config).err().expect("must reject");
    assert_eq!(rejected.error.field, PumpConfigField::Microsteps);
    let mut pins = rejected.pins;
    assert!(!pins.step.running());
    pins.dir.done();
    pins.enable.done();
    pins.end_empty.done();
    pins.end_full.done();
}

#[test]
fn enable_is_active_low() {
    let e = Expect {
        enable: vec![Pin::set(State::Low), Pin::set(State::High)],
        ..Expect::default()
    };
    let mut p = pump(&e, low_active());
    assert!(!p.is_enabled());
    p.enable().unwrap();
    assert!(p.is_enabled());
    p.disable().unwrap();
    assert!(!p.is_enabled());
    done(p);
}

#[test]
fn disabled_pump_refuses_to_start_without_touching_pins() {
    let e = Expect::default();
    let mut p = pump(&e, low_active());
    assert_eq!(
        p.start(Direction::Inject, 1_000, 1_000),
        Err(PumpError::Disabled)
    );
    assert!(!p.running());
    assert_eq!(p.position_steps(), 0);
    done(p);
}

#[test]
fn failed_enable_leaves_the_pump_disabled() {
    let e = Expect {
        enable: vec![Pin::set(State::Low).with_error(MockError::Io(std::io::ErrorKind::Other))],
        ..Expect::default()
    };
    let mut p = pump(&e, low_active());
    assert_eq!(p.enable(), Err(PumpError::Pin(PinRole::Enable)));
    assert!(!p.is_enabled());
    done(p);
}

#[test]
fn start_writes_dir_then_counts_the_timer_pulses() {
    // Inject three pulses, withdraw one. Switches open (active-low: read
    // high).
    let e = Expect {
        enable: vec![Pin::set(State::Low)],
        empty: vec![Pin::get(State::High)],
        full: vec![Pin::get(State::High)],
        dir: vec![
            Pin::set(State::High), // inject = DIR high (default)
            Pin::set(State::Low),  // withdraw
        ],
    };
    let (mut p, timer) = pump_and_timer(&e, low_active());
    p.enable().unwrap();
    p.start(Direction::Inject, 1_000, 500).unwrap();
    // DIR changes only while stopped.
    assert_eq!(
        p.start(Direction::Withdraw, 1_000, 500),
        Err(PumpError::Running)
    );
    timer.borrow_mut().advance(1_000 + 500 + 500 + 3, |_| {});
    assert_eq!(p.sync(), 3);
    assert_eq!(p.position_steps(), 3);
    p.finish();
    timer.borrow_mut().advance(10_000, |_| {});
    assert_eq!(p.sync(), 4);
    assert!(!p.running());
    p.start(Direction::Withdraw, 1_000, 500).unwrap();
    timer.borrow_mut().advance(11_100, |_| {});
    p.stop();
    assert_eq!(p.position_steps(), 3);
    assert!(rel_err(f64::from(p.volume_ml()), 3.0 * default_ml_per_step()) < 1e-6);
    p.zero_position().unwrap();
    assert_eq!(p.position_steps(), 0);
    assert_eq!(p.sync(), 1);
    assert_eq!(p.position_steps(), 0);
    assert_eq!(p.volume_ml(), 0.0);
    done(p);
}

#[test]
fn inverted_dir_config_flips_the_level() {
    let config = PumpConfig {
        inject_dir_high: false,
        ..low_active()
    };
    let e = Expect {
        enable: vec![Pin::set(State::Low)],
        empty: vec![Pin::get(State::High)],
        dir: vec![Pin::set(State::Low)],
        ..Expect::default()
    };
    let mut p = pump(&e, config);
    p.enable().unwrap();
    p.start(Direction::Inject, 1_000, 1_000).unwrap();
    assert!(p.running());
    done(p);
}

#[test]
fn a_broken_end_stop_wire_reads_triggered_and_refuses_the_start() {
    // The default wiring, normally-closed switches to GND with pull-ups:
    // an open circuit (a broken wire, a loose connector) reads high, as a
    // switch at the end does.
    let e = Expect {
        enable: vec![Pin::set(State::Low)],
        empty: vec![Pin::get(State::High), Pin::get(State::High)],
        full: vec![Pin::get(State::Low)],
        ..Expect::default()
    };
    let mut p = pump(&e, PumpConfig::default());
    p.enable().unwrap();
    assert_eq!(
        p.start(Direction::Inject, 1_000, 1_000),
        Err(PumpError::EndStop)
    );
    assert!(!p.running());
    assert_eq!(
        p.end_stops(),
        Ok(EndStops {
            empty: true,
            full: false
        })
    );
    assert_eq!(p.position_steps(), 0);
    done(p);
}

#[test]
fn only_the_end_stop_ahead_blocks() {
    // Active-low: a closed switch reads low. Plunger fully in (`empty`
    // closed): injecting is refused, withdrawing allowed, and only the
    // switch ahead is read.
    let e = Expect {
        enable: vec![Pin::set(State::Low)],
        empty: vec![Pin::get(State::Low)],
        full: vec![Pin::get(State::High)],
        dir: vec![Pin::set(State::Low)],
    };
    let mut p = pump(&e, low_active());
    p.enable().unwrap();
    assert_eq!(
        p.start(Direction::Inject, 1_000, 1_000),
        Err(PumpError::EndStop)
    );
    p.start(Direction::Withdraw, 1_000, 1_000).unwrap();
    assert!(p.running());
    done(p);
}

#[test]
fn end_stops_follow_polarity() {
    let e = Expect {
        empty: vec![Pin::get(State::Low), Pin::get(State::High)],
        full: vec![Pin::get(State::High), Pin::get(State::High)],
        ..Expect::default()
    };
    let mut p = pump(&e, low_active());
    assert_eq!(
        p.end_stops(),
        Ok(EndStops {
            empty: true,
            full: false
        })
    );
    assert_eq!(
        p.end_stops(),
        Ok(EndStops {
            empty: false,
            full: false
        })
    );
    done(p);

    // The default: normally closed, a broken (open) wire reads high =
    // triggered.
    let active_high = PumpConfig::default();
    let e = Expect {
        empty: vec![Pin::get(State::Low)],
        full: vec![Pin::get(State::High)],
        ..Expect::default()
    };
    let mut p = pump(&e, active_high);
    assert_eq!(
        p.end_stops(),
        Ok(EndStops {
            empty: false,
            full: true
        })
    );
    done(p);
}

#[test]
fn unreadable_end_stop_or_dir_refuses_the_start() {
    let io = MockError::Io(std::io::ErrorKind::Other);
    let e = Expect {
        enable: vec![Pin::set(State::Low)],
        empty: vec![
            Pin::get(State::High).with_error(io.clone()),
            Pin::get(State::High),
            Pin::get(State::High),
        ],
        full: vec![Pin::get(State::High).with_error(io.clone())],
        dir: vec![Pin::set(State::High).with_error(io)],
    };
    let mut p = pump(&e, low_active());
    p.enable().unwrap();
    assert_eq!(
        p.start(Direction::Inject, 1_000, 1_000),
        Err(PumpError::Pin(PinRole::EndEmpty))
    );
    assert_eq!(
        p.start(Direction::Inject, 1_000, 1_000),
        Err(PumpError::Pin(PinRole::Dir))
    );
    assert!(!p.running());
    assert_eq!(p.end_stops(), Err(PumpError::Pin(PinRole::EndFull)));
    done(p);
}

#[test]
fn disable_stops_the_timer_and_blocks_further_starts() {
    let e = Expect {
        enable: vec![Pin::set(State::Low), Pin::set(State::High)],
        empty: vec![Pin::get(State::High)],
        dir: vec![Pin::set(State::High)],
        ..Expect::default()
    };
    let (mut p, timer) = pump_and_timer(&e, low_active());
    p.enable().unwrap();
    p.start(Direction::Inject, 100, 100).unwrap();
    // Stopped inside the first pulse: its edge came, it counts.
    timer.borrow_mut().advance(101, |_| {});
    p.disable().unwrap();
    assert!(!p.running());
    assert!(!timer.borrow().step_high());
    assert_eq!(p.position_steps(), 1);
    timer
        .borrow_mut()
        .advance(10_000, |_| panic!("an edge after disable"));
    assert_eq!(
        p.start(Direction::Inject, 100, 100),
        Err(PumpError::Disabled)
    );
    done(p);
}

#[test]
fn accepted_cycle_rates_fit_the_pump() {
    // Every rate the controller accepts must be reachable by the pump, or
    // the pump clamps it and the cycle (and its stall bound) runs slower
    // than its parameters say: one constant bounds both.
    use urechis::controller::ParamField;
    use urechis::drivers::pump::{MAX_RATE_ML_PER_S, MIN_RATE_ML_PER_S};
    assert_eq!(MAX_RATE_ML_PER_S, 4.0);
    assert_eq!(MIN_RATE_ML_PER_S, 0.05);
    for field in [ParamField::ExpandRateMlPerS, ParamField::ShrinkRateMlPerS] {
        assert_eq!(field.range().max, MAX_RATE_ML_PER_S);
        assert_eq!(field.range().min, MIN_RATE_ML_PER_S);
    }
    let pump = urechis::drivers::pump::PumpConfig::default();
    // The clamp: 10 mL/s steps at the 4 mL/s interval.
    assert_eq!(
        pump.step_interval_us(10.0),
        pump.step_interval_us(MAX_RATE_ML_PER_S)
    );
}
