//! Host runs of the controller: every self-test scenario (the exact bodies
//! QEMU runs on the Cortex-M4), plus host-only unit tests.

use urechis::controller::*;
use urechis::selftest::{self, Bench, LawTable, Plant, SandLaw, SCENARIOS};

macro_rules! scenario_tests {
    ($($name:ident),* $(,)?) => {
        $(
            #[test]
            fn $name() {
                let s = SCENARIOS
                    .iter()
                    .find(|s| s.name == stringify!($name))
                    .expect("scenario listed in selftest::SCENARIOS");
                assert_eq!((s.run)(), Ok(()));
            }
        )*

        #[test]
        fn every_scenario_has_a_host_test() {
            let tested = [$(stringify!($name)),*];
            for s in SCENARIOS {
                assert!(tested.contains(&s.name), "no host test for {}", s.name);
            }
            assert_eq!(tested.len(), SCENARIOS.len());
        }
    };
}

scenario_tests!(
    normal_cycles_40mm,
    normal_cycles_100mm,
    plateau_stops_expansion_early,
    stop_shrinks_then_idles,
    set_params_rejected_whole,
    bad_table_refuses_start,
    fault_over_pressure,
    fault_sensor_bus,
    fault_sensor_out_of_range,
    fault_sensor_frozen,
    fault_sensor_stale,
    fault_end_stop,
    fault_pump_stall,
    fault_leak,
    fault_volume_limit,
    fault_diameter_mismatch,
    fault_control_overrun,
    fault_link_loss,
    pressure_zero_gates_start,
);

#[test]
fn trace_crc_is_deterministic() {
    let crc = selftest::normal_cycle_trace_crc32().unwrap();
    assert_eq!(crc, selftest::normal_cycle_trace_crc32().unwrap());
    println!("normal_cycle_trace_crc32 = {crc:#010x}");
}

// ---------------------------------------------------------------------------
// Host-only unit tests
// ---------------------------------------------------------------------------

fn slow() -> SandLaw {
    SandLaw {
        rise_mm: selftest::SLOW_RISE_MM,
    }
}

fn reading(pressure_kpa: f32, taken_ms: u32) -> PressureSample {
    PressureSample::Reading {
        pressure_kpa,
        taken_ms,
    }
}

#[test]
fn start_refused_while_a_cause_is_present_and_idle_does_not_latch_it() {
    let store = LawTable::new(slow());
    let mut bench = Bench::new(Params::DEFAULT, store.table(), Plant::new(slow(), 40.0)).unwrap();
    // No sample yet: the bus monitor counts Missing.
    bench.plant.sample_override = Some(PressureSample::Missing);
    let out = bench.step(Some(Command::Start));
    assert_eq!(out.command_result, Some(Err(CommandError::CauseActive)));
    for _ in 0..50 {
        bench.step(None);
    }
    assert_eq!(
        (bench.ctrl.state(), bench.ctrl.fault()),
        (State::Idle, None)
    );
    assert_eq!(bench.ctrl.alarm(), Some(Fault::SensorBus));
    bench.plant.sample_override = None;
    // Closed end-stop at rest: reported, not latched, blocks Start.
    bench.plant.end_stops.full = true;
    let out = bench.step(Some(Command::Start));
    assert_eq!(out.command_result, Some(Err(CommandError::CauseActive)));
    assert_eq!(
        (out.state, out.pump, out.relief_valve_open),
        (State::Idle, PumpCommand::Hold, false)
    );
    assert_eq!(bench.ctrl.alarm(), Some(Fault::EndStop));
    bench.plant.end_stops.full = false;
    // NaN readings at rest: reported only.
    bench.plant.sample_override = Some(reading(f32::NAN, 0));
    for _ in 0..20 {
        assert_eq!(bench.step(None).state, State::Idle);
    }
    assert_eq!(bench.ctrl.alarm(), Some(Fault::SensorOutOfRange));
    bench.plant.sample_override = None;
    bench.step(None);
    assert_eq!(bench.ctrl.alarm(), None);
    assert_eq!(
        bench.step(Some(Command::Start)).command_result,
        Some(Ok(()))
    );
}

#[test]
fn command_results_by_state() {
    let store = LawTable::new(slow());
    let mut bench = Bench::new(Params::DEFAULT, store.table(), Plant::new(slow(), 40.0)).unwrap();
    bench.step(None);
    assert_eq!(
        bench.step(Some(Command::Reset)).command_result,
        Some(Ok(()))
    );
    assert_eq!(bench.step(Some(Command::Stop)).command_result, Some(Ok(())));
    assert_eq!(bench.ctrl.state(), State::Idle);
    bench.start().unwrap();
    for (cmd, want) in [
        (Command::Start, Err(CommandError::Busy)),
        (Command::Reset, Err(CommandError::Busy)),
        (Command::SetParams(Params::DEFAULT), Err(CommandError::Busy)),
    ] {
        let out = bench.step(Some(cmd));
        assert_eq!(out.command_result, Some(want));
        assert_eq!(out.state, State::Expand);
    }
    assert_eq!(bench.step(None).command_result, None);
}

#[test]
fn invalid_initial_params_are_refused_by_name() {
    let store = LawTable::new(slow());
    let bad = Params {
        expand_rate_ml_per_s: f32::NAN,
        ..Params::DEFAULT
    };
    let Err(err) = Controller::new(bad, store.table()) else {
        panic!("NaN rate accepted");
    };
    assert_eq!(err.field, ParamField::ExpandRateMlPerS);
    let good = Params {
        cycles: 2,
        ..Params::DEFAULT
    };
    let ctrl = Controller::new(good, store.table()).expect("valid set refused");
    assert_eq!(*ctrl.params(), good);
    assert_eq!(ctrl.table_status(), Ok(()));
    let ctrl = Controller::with_default_params(store.table());
    assert_eq!(*ctrl.params(), Params::DEFAULT);
}

#[test]
fn a_cycle_across_the_clock_wrap_runs_normally() {
    let store = LawTable::new(slow());
    let params = Params {
        cycles: 1,
        ..Params::DEFAULT
    };
    let mut bench = Bench::new(params, store.table(), Plant::new(slow(), 40.0)).unwrap();
    bench.now_ms = u32::MAX - 2_000;
    bench.start().unwrap();
    let out = bench
        .run_until(
            1000,
            |o, _| o.state == State::Idle || o.state == State::Fault,
            "never ended",
        )
        .unwrap();
    assert_eq!((out.state, bench.ctrl.cycle()), (State::Idle, 1));
    assert!(bench.now_ms < 10_000, "the clock did wrap");
}

#[test]
fn cycles_zero_runs_until_stop() {
    let store = LawTable::new(slow());
    let mut bench = Bench::new(Params::DEFAULT, store.table(), Plant::new(slow(), 40.0)).unwrap();
    bench.start().unwrap();
    bench.run_until(5000, |_, _| false, "").ok();
    let cycles = bench.ctrl.cycle();
    // 50 s at about 4.7 s per cycle.
    assert!((10..=11).contains(&cycles), "{cycles}");
    assert_ne!(bench.ctrl.state(), State::Idle);
    // Stop during an advance: a shrink with nothing to withdraw, then Idle.
    bench
        .run_until(1000, |o, _| o.state == State::Advance, "no advance")
        .unwrap();
    let out = bench.step(Some(Command::Stop));
    assert_eq!((out.state, out.advance_drive), (State::Idle, false));
    // Stop during a hold.
    bench.start().unwrap();
    bench
        .run_until(1000, |o, _| o.state == State::Hold, "no hold")
        .unwrap();
    assert_eq!(bench.step(Some(Command::Stop)).state, State::Shrink);
    let out = bench
        .run_until(1000, |o, _| o.state != State::Shrink, "no end")
        .unwrap();
    assert_eq!(out.state, State::Idle);
}

#[test]
fn frozen_reading_at_constant_volume_is_normal_but_not_while_pumping() {
    let store = LawTable::new(slow());
    // A long stall block: the shrink's stall rule (no fall in 1 mL =
    // 250 ms) would otherwise name the frozen reading first as a stall.
    let params = Params {
        hold_ms: 2000,
        stall_volume_ml: 5.0,
        ..Params::DEFAULT
    };
    let mut bench = Bench::new(params, store.table(), Plant::new(slow(), 40.0)).unwrap();
    bench.start().unwrap();
    bench
        .run_until(1000, |o, _| o.state == State::Hold, "no hold")
        .unwrap();
    bench.plant.frozen_kpa = Some(bench.plant.last_reading_kpa());
    let out = bench
        .run_until(1000, |o, _| o.state != State::Hold, "hold never ended")
        .unwrap();
    assert_eq!(out.state, State::Shrink, "a steady reading in Hold tripped");
    let shrink_ms = out.telemetry.t_ms;
    let out = bench
        .run_until(100, |o, _| o.state == State::Fault, "frozen not caught")
        .unwrap();
    assert_eq!(out.telemetry.fault, Some(Fault::SensorFrozen));
    assert!(out.telemetry.t_ms - shrink_ms <= SENSOR_FROZEN_DETECT_MS);
}

#[test]
fn interleaved_bus_errors_below_the_count_are_tolerated() {
    let store = LawTable::new(slow());
    let params = Params {
        cycles: 1,
        ..Params::DEFAULT
    };
    let mut bench = Bench::new(params, store.table(), Plant::new(slow(), 40.0)).unwrap();
    bench.start().unwrap();
    for k in 0..1000u32 {
        // Two failed reads out of every three.
        bench.plant.sample_override = (k % 3 != 0).then_some(PressureSample::BusError);
        let out = bench.step(None);
        assert_ne!(
            out.state,
            State::Fault,
            "step {k}: {:?}",
            out.telemetry.fault
        );
        if out.state == State::Idle {
            return;
        }
    }
    panic!("cycle did not complete");
}

/// The compiled-in table with a plant that follows it exactly: the defaults
/// run clean cycles on the firmware's own table at several depths, never
/// pass the target, and come back to rest.
#[test]
fn defaults_run_clean_cycles_on_the_generated_table() {
    let table = urechis::table::generated::TABLE;
    let zone = ExpansionZone::of(&table);
    for depth_mm in [20.0_f32, 40.0, 100.0, 200.0] {
        let params = Params {
            depth_mm,
            cycles: 2,
            ..Params::DEFAULT
        };
        let mut ctrl = Controller::new(params, table).unwrap();
        ctrl.set_pressure_zero(Some(selftest::BENCH_ZERO_KPA));
        let (mut pump_ml, mut now_ms, mut dither) = (0.0_f32, 0_u32, 1.0_f32);
        let mut max_mm = 0.0_f32;
        let mut ends = Vec::new();
        let mut prev = State::Idle;
        for k in 0..3000 {
            dither = -dither;
            let d = zone.diameter_mm(pump_ml);
            max_mm = max_mm.max(d);
            let inputs = Inputs {
                now_ms,
                pressure: reading(table.pressure_kpa(d, depth_mm) + 0.002 * dither, now_ms),
                pump_volume_ml: pump_ml,
                end_stops: EndStops::default(),
                command: if k == 2 {
                    Some(Command::Start)
                } else {
                    (k % 50 == 0).then_some(Command::Heartbeat)
                },
            };
            let out = ctrl.step(&inputs);
            assert_ne!(
                out.state,
                State::Fault,
                "h={depth_mm}: {:?}",
                out.telemetry.fault
            );
            if prev == State::Expand && out.state == State::Hold {
                ends.push(ctrl.last_expand_end().unwrap());
            }
            prev = out.state;
            if let PumpCommand::Run { rate_ml_per_s } = out.pump {
                pump_ml += rate_ml_per_s * 0.01;
            }
            now_ms += CONTROL_PERIOD_MS;
            if k > 2 && out.state == State::Idle {
                break;
            }
        }
        assert_eq!(
            (ctrl.state(), ctrl.cycle()),
            (State::Idle, 2),
            "h={depth_mm}"
        );
        assert_eq!(ends.len(), 2);
        assert!(max_mm < params.target_diameter_mm, "h={depth_mm}: {max_mm}");
        assert!(
            pump_ml.abs() <= params.rest_tolerance_ml + 0.04,
            "h={depth_mm}: {pump_ml}"
        );
        println!("h={depth_mm} mm: ends {ends:?}, max D {max_mm:.2} mm");
    }
}

#[test]
fn garbage_volume_while_expanding_is_a_volume_fault_not_a_stall() {
    for garbage in [f32::NAN, 1e30, f32::INFINITY, -1e30] {
        let store = LawTable::new(slow());
        let mut bench =
            Bench::new(Params::DEFAULT, store.table(), Plant::new(slow(), 40.0)).unwrap();
        bench.start().unwrap();
        bench
            .run_until(
                300,
                |o, _| o.telemetry.diameter_volume_mm >= 21.0,
                "no expansion",
            )
            .unwrap();
        bench.plant.volume_override = Some(garbage);
        let out = bench.step(None);
        assert_eq!(out.telemetry.fault, Some(Fault::VolumeLimit), "{garbage}");
        // Over-pressure outranks it.
        bench.plant.offset_kpa = 100.0;
        assert_eq!(bench.step(None).telemetry.fault, Some(Fault::VolumeLimit));
        assert_eq!(bench.ctrl.alarm(), Some(Fault::OverPressure));
    }
}

#[test]
fn a_fault_latched_at_boot_holds_the_safe_state_until_reset() {
    // The board latches ControlOverrun after a watchdog reset.
    let store = LawTable::new(slow());
    let mut bench = Bench::new(Params::DEFAULT, store.table(), Plant::new(slow(), 40.0)).unwrap();
    bench.ctrl.latch_fault(Fault::ControlOverrun);
    for _ in 0..5 {
        let out = bench.step(Some(Command::Start));
        assert_eq!(out.command_result, Some(Err(CommandError::Faulted)));
        assert_eq!(
            (
                out.state,
                out.pump,
                out.relief_valve_open,
                out.telemetry.fault
            ),
            (
                State::Fault,
                PumpCommand::Disable,
                true,
                Some(Fault::ControlOverrun)
            )
        );
    }
    let out = bench.step(Some(Command::Reset));
    assert_eq!(out.command_result, Some(Ok(())));
    assert_eq!(out.state, State::Idle);
    assert_eq!(
        bench.step(Some(Command::Start)).command_result,
        Some(Ok(()))
    );
}
