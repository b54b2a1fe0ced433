//! Property tests of the controller over random input sequences: plausible
//! plant readings mixed with garbage (NaN, ±∞, huge, negative), bus
//! errors, stale and future timestamps, closed end-stops, garbage volumes,
//! time jumps (backwards and across the u32 wrap) and random commands,
//! including invalid parameter sets.
//!
//! Invariants checked after every step:
//! - the step never panics, and replaying the same inputs gives
//!   bit-identical outputs;
//! - Fault ⇔ a latched fault ⇔ relief valve open; in Fault the pump is
//!   disabled (never `Run`) and the advance drive off;
//! - a fault only clears through an accepted `Reset`, which leads to Idle;
//! - an over-pressure reading always gives Fault in that step, whatever the
//!   state (Idle included);
//! - a refused or invalid `SetParams` never changes `params()`;
//! - the pump runs only in Expand and Shrink, the advance drive only in
//!   Advance;
//! - the watchdog is fed exactly when the step came on time.

use proptest::prelude::*;
use urechis::controller::*;
use urechis::table::generated::TABLE;

#[derive(Clone, Debug)]
enum Pressure {
    /// What the plant would read, plus an offset (kPa).
    Plant(f32),
    /// A raw value.
    Raw(f32),
    BusError,
    Missing,
}

#[derive(Clone, Debug)]
struct Event {
    dt_ms: u32,
    pressure: Pressure,
    /// Age of the reading (ms; may be "in the future" through wrapping).
    age_ms: u32,
    /// Replace the pump count by this garbage.
    volume: Option<f32>,
    end_stops: EndStops,
    command: Option<Command>,
}

fn garbage_f32() -> impl Strategy<Value = f32> {
    prop_oneof![
        Just(f32::NAN),
        Just(f32::INFINITY),
        Just(f32::NEG_INFINITY),
        Just(f32::MAX),
        Just(-f32::MAX),
        Just(f32::MIN_POSITIVE),
        any::<f32>(),
        -1e6_f32..1e6,
    ]
}

fn params_strategy() -> impl Strategy<Value = Params> {
    // Either the defaults with one field moved anywhere (often out of
    // range), or a plausible valid variation.
    prop_oneof![
        (0..RANGES.len(), garbage_f32()).prop_map(|(i, v)| {
            let mut p = Params::DEFAULT;
            if let Some(r) = RANGES.get(i) {
                p.set(r.field, v);
            }
            p
        }),
        (
            0.0_f32..200.0,
            19.0_f32..30.0,
            0.1_f32..5.0,
            0u16..4,
            0u32..2000
        )
            .prop_map(
                |(depth_mm, target_diameter_mm, expand_rate_ml_per_s, cycles, hold_ms)| Params {
                    depth_mm,
                    target_diameter_mm,
                    expand_rate_ml_per_s,
                    cycles,
                    hold_ms,
                    ..Params::DEFAULT
                }
            ),
    ]
}

/// `quiet`: relative weight of "no command" against 10 for the others.
fn command_strategy(quiet: u32) -> impl Strategy<Value = Option<Command>> {
    prop_oneof![
        quiet => Just(None),
        4 => Just(Some(Command::Start)),
        1 => Just(Some(Command::Stop)),
        3 => Just(Some(Command::Reset)),
        2 => params_strategy().prop_map(|p| Some(Command::SetParams(p))),
    ]
}

/// `calm`: relative weight of a healthy, on-time step against about 10 for
/// all the disturbances together (calm sequences get through whole cycles).
fn event_strategy(calm: u32) -> impl Strategy<Value = Event> {
    let dt = prop_oneof![
        calm => Just(CONTROL_PERIOD_MS),
        2 => 0u32..=40,
        1 => any::<u32>(),
    ];
    let pressure = prop_oneof![
        calm => (-0.05_f32..0.05).prop_map(Pressure::Plant),
        2 => (25.0_f32..1e4).prop_map(Pressure::Raw),
        2 => garbage_f32().prop_map(Pressure::Raw),
        2 => Just(Pressure::BusError),
        1 => Just(Pressure::Missing),
    ];
    let age = prop_oneof![calm => 0u32..=15, 1 => any::<u32>()];
    let volume = prop_oneof![calm => Just(None), 1 => garbage_f32().prop_map(Some)];
    let end_stops = prop_oneof![
        calm => Just(EndStops::default()),
        1 => (any::<bool>(), any::<bool>()).prop_map(|(empty, full)| EndStops { empty, full }),
    ];
    (
        dt,
        pressure,
        age,
        volume,
        end_stops,
        command_strategy(4 * calm),
    )
        .prop_map(
            |(dt_ms, pressure, age_ms, volume, end_stops, command)| Event {
                dt_ms,
                pressure,
                age_ms,
                volume,
                end_stops,
                command,
            },
        )
}

/// Noisy sequences (a disturbance every few steps), calm ones (one in a
/// few hundred steps) and quiet long ones (whole cycles).
fn sequence_strategy() -> impl Strategy<Value = Vec<Event>> {
    prop_oneof![
        prop::collection::vec(event_strategy(30), 1..400),
        prop::collection::vec(event_strategy(3000), 1..800),
        // Quiet and long enough for whole cycles (expand ≈ 1–2 s, hold,
        // shrink, advance): without these a whole cycle was down to luck
        // (1 Advance in 200 sequences with the parametric table, 0 with
        // the solver's).
        prop::collection::vec(event_strategy(100_000), 600..1500),
    ]
}

/// Turns events into controller inputs, integrating the pump like a plant
/// whose head follows the table.
fn inputs_for(start_ms: u32, events: &[Event]) -> Vec<Inputs> {
    let zone = ExpansionZone::of(&TABLE);
    let (mut now_ms, mut pump_ml) = (start_ms, 0.0_f32);
    let mut ctrl = Controller::with_default_params(TABLE);
    ctrl.set_pressure_zero(Some(urechis::selftest::BENCH_ZERO_KPA));
    let mut out = Vec::with_capacity(events.len());
    // The host is connected: with no other command it sends a heartbeat
    // every HEARTBEAT_MS (sequences with a link loss come from the gaps
    // in time the events themselves make).
    let mut last_host_ms = start_ms;
    for e in events {
        now_ms = now_ms.wrapping_add(e.dt_ms);
        let due = now_ms.wrapping_sub(last_host_ms) >= urechis::selftest::HEARTBEAT_MS;
        let command = e.command.or(due.then_some(Command::Heartbeat));
        if command.is_some() {
            last_host_ms = now_ms;
        }
        let depth_mm = ctrl.params().depth_mm;
        let pressure = match e.pressure {
            Pressure::Plant(offset) => PressureSample::Reading {
                pressure_kpa: TABLE.pressure_kpa(zone.diameter_mm(pump_ml), depth_mm) + offset,
                taken_ms: now_ms.wrapping_sub(e.age_ms),
            },
            Pressure::Raw(pressure_kpa) => PressureSample::Reading {
                pressure_kpa,
                taken_ms: now_ms.wrapping_sub(e.age_ms),
            },
            Pressure::BusError => PressureSample::BusError,
            Pressure::Missing => PressureSample::Missing,
        };
        let inputs = Inputs {
            now_ms,
            pressure,
            pump_volume_ml: e.volume.unwrap_or(pump_ml),
            end_stops: e.end_stops,
            command,
        };
        // The plant follows the controller it is driving.
        let o = ctrl.step(&inputs);
        if let PumpCommand::Run { rate_ml_per_s } = o.pump {
            pump_ml += rate_ml_per_s * e.dt_ms.min(1000) as f32 / 1000.0;
        }
        out.push(inputs);
    }
    out
}

fn check_sequence(start_ms: u32, events: &[Event]) -> Result<(), TestCaseError> {
    let inputs = inputs_for(start_ms, events);
    let mut ctrl = Controller::with_default_params(TABLE);
    ctrl.set_pressure_zero(Some(urechis::selftest::BENCH_ZERO_KPA));
    let mut replay = Controller::with_default_params(TABLE);
    replay.set_pressure_zero(Some(urechis::selftest::BENCH_ZERO_KPA));
    let mut prev_state = ctrl.state();
    let mut prev_now: Option<u32> = None;
    for (k, i) in inputs.iter().enumerate() {
        let params_before = *ctrl.params();
        let out = ctrl.step(i);
        let again = replay.step(i);
        prop_assert_eq!(
            format!("{out:?}"),
            format!("{again:?}"),
            "step {} not deterministic",
            k
        );

        // State consistency.
        prop_assert_eq!(out.state, ctrl.state());
        prop_assert_eq!(out.telemetry.state, out.state);
        prop_assert_eq!(out.telemetry.fault, ctrl.fault());
        prop_assert_eq!(out.state == State::Fault, ctrl.fault().is_some());

        // Safe outputs in Fault; the valve opens only there.
        prop_assert_eq!(out.relief_valve_open, out.state == State::Fault);
        if out.state == State::Fault {
            prop_assert_eq!(out.pump, PumpCommand::Disable);
            prop_assert!(!out.advance_drive);
        }
        let runs = matches!(out.pump, PumpCommand::Run { .. });
        prop_assert_eq!(runs, matches!(out.state, State::Expand | State::Shrink));
        prop_assert_eq!(out.advance_drive, out.state == State::Advance);

        // Latching: only an accepted Reset leaves Fault, and into Idle.
        if prev_state == State::Fault && out.state != State::Fault {
            prop_assert_eq!(i.command, Some(Command::Reset));
            prop_assert_eq!(out.command_result, Some(Ok(())));
            prop_assert_eq!(out.state, State::Idle);
        }
        if prev_state == State::Fault {
            if let Some(Command::Start | Command::Stop | Command::SetParams(_)) = i.command {
                prop_assert_eq!(out.command_result, Some(Err(CommandError::Faulted)));
            }
        }

        // Over-pressure: Fault in the step that sees it, in every state.
        if let PressureSample::Reading { pressure_kpa, .. } = i.pressure {
            if pressure_kpa > params_before.max_pressure_kpa {
                prop_assert_eq!(out.state, State::Fault, "step {}: {} kPa", k, pressure_kpa);
            }
        }

        // Parameters change only through an accepted, valid SetParams.
        match i.command {
            Some(Command::SetParams(p)) if out.command_result == Some(Ok(())) => {
                prop_assert!(p.validate().is_ok());
                prop_assert_eq!(*ctrl.params(), p);
            }
            Some(Command::SetParams(p)) => {
                prop_assert_eq!(*ctrl.params(), params_before);
                if let Err(e) = p.validate() {
                    // (A fault found in this very step refuses it as Faulted.)
                    if prev_state == State::Idle && out.state == State::Idle {
                        prop_assert_eq!(
                            out.command_result,
                            Some(Err(CommandError::InvalidParams(e)))
                        );
                    }
                }
            }
            _ => prop_assert_eq!(*ctrl.params(), params_before),
        }
        prop_assert_eq!(out.command_result.is_some(), i.command.is_some());

        // Watchdog: fed exactly when on time.
        let on_time = prev_now.is_none_or(|p| i.now_ms.wrapping_sub(p) <= CONTROL_OVERRUN_LIMIT_MS);
        prop_assert_eq!(out.feed_watchdog, on_time);

        prev_state = out.state;
        prev_now = Some(i.now_ms);
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn invariants_hold_on_random_sequences(
        start_ms in prop_oneof![Just(0u32), Just(u32::MAX - 500), any::<u32>()],
        events in sequence_strategy(),
    ) {
        check_sequence(start_ms, &events)?;
    }
}

/// The generator must actually reach the states the invariants are about;
/// otherwise the property test proves little.
#[test]
fn random_sequences_reach_every_state() {
    use proptest::strategy::ValueTree;
    use proptest::test_runner::TestRunner;
    let mut runner = TestRunner::deterministic();
    let strategy = sequence_strategy();
    let mut seen = [false; 6];
    let mut resets_accepted = 0;
    for _ in 0..200 {
        let events = strategy.new_tree(&mut runner).unwrap().current();
        let mut ctrl = Controller::with_default_params(TABLE);
        ctrl.set_pressure_zero(Some(urechis::selftest::BENCH_ZERO_KPA));
        let mut prev = State::Idle;
        for i in inputs_for(0, &events) {
            let out = ctrl.step(&i);
            seen[out.state as usize] = true;
            if prev == State::Fault && out.state == State::Idle {
                resets_accepted += 1;
            }
            prev = out.state;
        }
    }
    println!("states seen: {seen:?}, resets accepted: {resets_accepted}");
    assert_eq!(seen, [true; 6], "states seen: {seen:?}");
    assert!(resets_accepted > 0);
}
