//! Syringe pump: conversions against the closed form, and the driver
//! against digital-pin mocks listing every expected level.

use std::f64::consts::PI;

use embassy_futures::block_on;
use embedded_hal_mock::eh1::delay::{CheckedDelay, Transaction as Delay};
use embedded_hal_mock::eh1::digital::{Mock as PinMock, State, Transaction as Pin};
use embedded_hal_mock::eh1::MockError;
use urechis::controller::EndStops;
use urechis::drivers::pump::{
    Direction, PinRole, PumpConfig, PumpConfigField, PumpError, PumpPins, SwitchPolarity,
    SyringePump,
};

type Pump = SyringePump<PinMock, PinMock, PinMock, PinMock, PinMock>;

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
    step: Vec<Pin>,
    dir: Vec<Pin>,
    enable: Vec<Pin>,
    empty: Vec<Pin>,
    full: Vec<Pin>,
}

fn pump(e: &Expect, config: PumpConfig) -> Pump {
    let pins = PumpPins {
        step: PinMock::new(&e.step),
        dir: PinMock::new(&e.dir),
        enable: PinMock::new(&e.enable),
        end_empty: PinMock::new(&e.empty),
        end_full: PinMock::new(&e.full),
    };
    SyringePump::new(pins, config).unwrap_or_else(|r| panic!("config rejected: {:?}", r.error))
}

fn done(p: Pump) {
    let mut pins = p.destroy();
    pins.step.done();
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

/// One complete STEP pulse on the STEP pin.
fn pulse() -> [Pin; 2] {
    [Pin::set(State::High), Pin::set(State::Low)]
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
    // with a 1 mm lead every 3.27 µs, under the 5 µs the pulse sequence
    // takes.
    assert_eq!(bad(|c| c.microsteps = 256), Ok(()));
    assert_eq!(
        bad(|c| {
            c.microsteps = 256;
            c.lead_pitch_mm = 1.0;
        }),
        Err(Microsteps)
    );
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
        step: PinMock::new(&[]),
        dir: PinMock::new(&[]),
        enable: PinMock::new(&[]),
        end_empty: PinMock::new(&[]),
        end_full: PinMock::new(&[]),
    };
    let rejected = SyringePump::new(pins, config).err().expect("must reject");
    assert_eq!(rejected.error.field, PumpConfigField::Microsteps);
    let mut pins = rejected.pins;
    pins.step.done();
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
fn disabled_pump_refuses_to_step_without_touching_pins() {
    let e = Expect::default();
    let mut p = pump(&e, low_active());
    let mut delay = CheckedDelay::new(&[]);
    assert_eq!(
        block_on(p.step(Direction::Inject, &mut delay)),
        Err(PumpError::Disabled)
    );
    assert_eq!(p.position_steps(), 0);
    done(p);
    delay.done();
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
fn step_sequence_dir_then_pulse_and_position() {
    // Inject, inject, withdraw. Switches open (active-low: read high).
    let e = Expect {
        enable: vec![Pin::set(State::Low)],
        empty: vec![Pin::get(State::High), Pin::get(State::High)],
        full: vec![Pin::get(State::High)],
        dir: vec![
            Pin::set(State::High), // inject = DIR high (default)
            Pin::set(State::High),
            Pin::set(State::Low), // withdraw
        ],
        step: [pulse(), pulse(), pulse()].concat(),
    };
    let mut delay = CheckedDelay::new(&[
        // 1st step: DIR level new → 1 µs setup, 2 µs high, 2 µs low.
        Delay::delay_us(1),
        Delay::delay_us(2),
        Delay::delay_us(2),
        // 2nd step: same DIR level, no setup wait.
        Delay::delay_us(2),
        Delay::delay_us(2),
        // 3rd step: DIR changed → setup again.
        Delay::delay_us(1),
        Delay::delay_us(2),
        Delay::delay_us(2),
    ]);
    let mut p = pump(&e, low_active());
    p.enable().unwrap();
    block_on(p.step(Direction::Inject, &mut delay)).unwrap();
    assert_eq!(p.position_steps(), 1);
    block_on(p.step(Direction::Inject, &mut delay)).unwrap();
    assert_eq!(p.position_steps(), 2);
    block_on(p.step(Direction::Withdraw, &mut delay)).unwrap();
    assert_eq!(p.position_steps(), 1);
    assert!(rel_err(f64::from(p.volume_ml()), default_ml_per_step()) < 1e-6);
    p.zero_position();
    assert_eq!(p.position_steps(), 0);
    assert_eq!(p.volume_ml(), 0.0);
    done(p);
    delay.done();
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
        step: pulse().to_vec(),
        ..Expect::default()
    };
    let mut delay =
        CheckedDelay::new(&[Delay::delay_us(1), Delay::delay_us(2), Delay::delay_us(2)]);
    let mut p = pump(&e, config);
    p.enable().unwrap();
    block_on(p.step(Direction::Inject, &mut delay)).unwrap();
    assert_eq!(p.position_steps(), 1);
    done(p);
    delay.done();
}

#[test]
fn a_broken_end_stop_wire_reads_triggered_and_refuses_the_step() {
    // The default wiring, normally-closed switches to GND with pull-ups:
    // an open circuit (a broken wire, a loose connector) reads high, as a
    // switch at the end does.
    let e = Expect {
        enable: vec![Pin::set(State::Low)],
        empty: vec![Pin::get(State::High), Pin::get(State::High)],
        full: vec![Pin::get(State::Low)],
        ..Expect::default()
    };
    let mut delay = CheckedDelay::new(&[]);
    let mut p = pump(&e, PumpConfig::default());
    p.enable().unwrap();
    assert_eq!(
        block_on(p.step(Direction::Inject, &mut delay)),
        Err(PumpError::EndStop)
    );
    assert_eq!(
        p.end_stops(),
        Ok(EndStops {
            empty: true,
            full: false
        })
    );
    assert_eq!(p.position_steps(), 0);
    done(p);
    delay.done();
}

#[test]
fn closed_end_stop_refuses_with_no_pin_motion() {
    // Active-low: a closed switch reads low.
    let e = Expect {
        enable: vec![Pin::set(State::Low)],
        empty: vec![Pin::get(State::Low)],
        full: vec![Pin::get(State::Low)],
        ..Expect::default()
    };
    let mut delay = CheckedDelay::new(&[]);
    let mut p = pump(&e, low_active());
    p.enable().unwrap();
    assert_eq!(
        block_on(p.step(Direction::Inject, &mut delay)),
        Err(PumpError::EndStop)
    );
    assert_eq!(
        block_on(p.step(Direction::Withdraw, &mut delay)),
        Err(PumpError::EndStop)
    );
    assert_eq!(p.position_steps(), 0);
    done(p);
    delay.done();
}

#[test]
fn only_the_end_stop_ahead_blocks() {
    // Plunger fully in (`empty` closed): withdrawing is still allowed, and
    // only the `full` switch is read for it.
    let e = Expect {
        enable: vec![Pin::set(State::Low)],
        full: vec![Pin::get(State::High)],
        dir: vec![Pin::set(State::Low)],
        step: pulse().to_vec(),
        ..Expect::default()
    };
    let mut delay =
        CheckedDelay::new(&[Delay::delay_us(1), Delay::delay_us(2), Delay::delay_us(2)]);
    let mut p = pump(&e, low_active());
    p.enable().unwrap();
    block_on(p.step(Direction::Withdraw, &mut delay)).unwrap();
    assert_eq!(p.position_steps(), -1);
    assert!(rel_err(f64::from(p.volume_ml()), -default_ml_per_step()) < 1e-6);
    done(p);
    delay.done();
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
fn unreadable_end_stop_refuses_the_step() {
    let io = MockError::Io(std::io::ErrorKind::Other);
    let e = Expect {
        enable: vec![Pin::set(State::Low)],
        empty: vec![
            Pin::get(State::High).with_error(io.clone()),
            Pin::get(State::High),
        ],
        full: vec![Pin::get(State::High).with_error(io)],
        ..Expect::default()
    };
    let mut delay = CheckedDelay::new(&[]);
    let mut p = pump(&e, low_active());
    p.enable().unwrap();
    assert_eq!(
        block_on(p.step(Direction::Inject, &mut delay)),
        Err(PumpError::Pin(PinRole::EndEmpty))
    );
    assert_eq!(p.position_steps(), 0);
    assert_eq!(p.end_stops(), Err(PumpError::Pin(PinRole::EndFull)));
    done(p);
    delay.done();
}

#[test]
fn a_step_counts_once_step_went_high() {
    let io = MockError::Io(std::io::ErrorKind::Other);
    let e = Expect {
        enable: vec![Pin::set(State::Low)],
        empty: vec![Pin::get(State::High), Pin::get(State::High)],
        dir: vec![Pin::set(State::High), Pin::set(State::High)],
        step: vec![
            // Rising edge refused: no step.
            Pin::set(State::High).with_error(io.clone()),
            // Rising edge made, falling edge failed: the motor moved.
            Pin::set(State::High),
            Pin::set(State::Low).with_error(io),
        ],
        ..Expect::default()
    };
    let mut delay = CheckedDelay::new(&[Delay::delay_us(1), Delay::delay_us(2)]);
    let mut p = pump(&e, low_active());
    p.enable().unwrap();
    assert_eq!(
        block_on(p.step(Direction::Inject, &mut delay)),
        Err(PumpError::Pin(PinRole::Step))
    );
    assert_eq!(p.position_steps(), 0);
    assert_eq!(
        block_on(p.step(Direction::Inject, &mut delay)),
        Err(PumpError::Pin(PinRole::Step))
    );
    assert_eq!(p.position_steps(), 1);
    done(p);
    delay.done();
}

#[test]
fn disable_blocks_further_steps() {
    let e = Expect {
        enable: vec![Pin::set(State::Low), Pin::set(State::High)],
        empty: vec![Pin::get(State::High)],
        dir: vec![Pin::set(State::High)],
        step: pulse().to_vec(),
        ..Expect::default()
    };
    let mut delay =
        CheckedDelay::new(&[Delay::delay_us(1), Delay::delay_us(2), Delay::delay_us(2)]);
    let mut p = pump(&e, low_active());
    p.enable().unwrap();
    block_on(p.step(Direction::Inject, &mut delay)).unwrap();
    p.disable().unwrap();
    assert_eq!(
        block_on(p.step(Direction::Inject, &mut delay)),
        Err(PumpError::Disabled)
    );
    assert_eq!(p.position_steps(), 1);
    done(p);
    delay.done();
}

#[test]
fn accepted_cycle_rates_fit_the_pump() {
    // Every rate the controller accepts must be reachable by the pump, or
    // the pump clamps it and the cycle (and its stall bound) runs slower
    // than its parameters say: one constant bounds both.
    use urechis::controller::ParamField;
    use urechis::drivers::pump::MAX_RATE_ML_PER_S;
    assert_eq!(MAX_RATE_ML_PER_S, 4.0);
    for field in [ParamField::ExpandRateMlPerS, ParamField::ShrinkRateMlPerS] {
        assert_eq!(field.range().max, MAX_RATE_ML_PER_S);
    }
    let pump = urechis::drivers::pump::PumpConfig::default();
    // The clamp: 10 mL/s steps at the 4 mL/s interval.
    assert_eq!(
        pump.step_interval_us(10.0),
        pump.step_interval_us(MAX_RATE_ML_PER_S)
    );
}
