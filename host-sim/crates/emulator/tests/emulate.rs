//! The emulator's named scenarios: the firmware's own controller against
//! the plant, each asserting its expected outcome with measured numbers
//! (cycles and advance per cycle for normal burrowing; for faults the
//! Fault state within the firmware's stated bound, a stopped pump and the
//! time above the pressure limit), plus the trace folder, determinism and
//! the QEMU replay recordings.

use emulator::outcome::{evaluate, Outcome};
use emulator::replay::{encode, index_rs, record, INDEX_FILE, REPLAY_DIR, REPLAY_SCENARIOS};
use emulator::{named, run, Trace, DEFAULT_SEED};
use rig::Experiment;
use sand::{ParametricSand, SolverSand};
use urechis::controller::{
    detection_bound_ms, end_to_end_bound_ms, ExpansionZone, Fault, Params, PressureSample,
    PumpCommand, State, BOARD_TIMING, CONTROL_PERIOD_MS, PLATEAU_CONFIRM_SAMPLES,
    PLATEAU_WINDOW_SAMPLES,
};
use urechis::replay::{check, Field, ReplayError};
use urechis::table::generated::TABLE;

fn run_named(name: &str) -> (Trace, Outcome) {
    let trace = run(&named(name).unwrap(), DEFAULT_SEED).unwrap();
    let outcome = evaluate(&trace);
    assert!(outcome.passed(), "{}", outcome.text());
    (trace, outcome)
}

/// Asserts a fault scenario's common promises and returns its latency.
fn assert_fault(outcome: &Outcome, fault: Fault, allowance_ms: u32) -> i64 {
    let d = outcome.detection.expect("a detection");
    assert_eq!(outcome.fault, Some(fault));
    assert_eq!(outcome.final_state, State::Fault);
    assert_eq!(d.bound_ms, detection_bound_ms(fault, &Params::DEFAULT));
    assert_eq!(d.sensor_allowance_ms, allowance_ms);
    assert!(
        d.latency_ms >= 0 && d.latency_ms <= i64::from(d.bound_ms + allowance_ms),
        "{}",
        outcome.text()
    );
    assert!(outcome.pump_disabled_in_fault);
    assert_eq!(outcome.steps_after_fault, 0);
    // End to end, with the plant's valve in the loop: from the reference
    // to the line venting, within the bound stated with the board's
    // timing; the valve opened its response after the fault step.
    let end_to_end = end_to_end_bound_ms(fault, &Params::DEFAULT, &BOARD_TIMING);
    assert_eq!(d.end_to_end_bound_ms, end_to_end);
    let vented = d.vented_ms.expect("the valve opened");
    assert_eq!(vented, d.detected_ms + BOARD_TIMING.valve_response_ms);
    assert!(
        d.end_to_end_ms()
            .is_some_and(|e| e <= i64::from(end_to_end)),
        "{}",
        outcome.text()
    );
    d.latency_ms
}

#[test]
fn the_emulated_sensor_is_timed_like_the_boards() {
    // The emulator's sample age (a period plus the conversion lag) must
    // not be shorter than what the board's end-to-end bounds allow for,
    // nor its period other than the board's.
    let s = emulator::sensor::SensorConfig::default();
    assert_eq!(s.period_ms, BOARD_TIMING.sensor_period_ms);
    assert!(s.read_phase_ms <= BOARD_TIMING.sensor_read_ms);
    assert!(s.max_sample_age_ms() <= BOARD_TIMING.sensor_period_ms + BOARD_TIMING.sensor_read_ms);
}

/// Every step from the fault on: pump disabled, valve open, drive off;
/// the plunger does not move.
fn assert_safe_after_fault(trace: &Trace) {
    let first = trace
        .steps
        .iter()
        .position(|s| s.outputs.state == State::Fault)
        .unwrap();
    let after = &trace.steps[first..];
    for s in after {
        assert_eq!(s.outputs.pump, PumpCommand::Disable);
        assert!(s.outputs.relief_valve_open && !s.outputs.advance_drive);
    }
    let displaced = after[1].truth.displaced_ml;
    assert!(after[1..].iter().all(|s| s.truth.displaced_ml == displaced));
}

/// Diameter (mm) where the sand's dp_e/dV falls to `fraction` of its
/// value at D0: p_e = σ'v(K0 + (N − K0)·tanh(x/ΔDc)) and dV/dD = π·L·D/2,
/// so the ratio is sech²(x/ΔDc)·D0/D (bisection).
fn plateau_diameter_mm(fraction: f64) -> f64 {
    // The plant's sand: the parametric law fitted to the committed solver
    // results, as the model's baseline builds it.
    let solver = SolverSand::committed().unwrap();
    let sand = ParametricSand::fitted_to_solver(&solver).params;
    let d0 = sand.initial_diameter_mm;
    let ratio = |d: f64| {
        let c = ((d - d0) / sand.characteristic_diameter_increase_mm).cosh();
        d0 / d / (c * c)
    };
    let (mut lo, mut hi) = (d0, d0 + 20.0);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if ratio(mid) > fraction {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    lo
}

/// Diameter (mm) where the plant's p_i (the default skin and the
/// parametric sand fitted to the committed solver results, as the model's
/// baseline builds them) reaches `pressure_kpa` at `depth_mm` (bisection).
fn plant_diameter_mm(pressure_kpa: f64, depth_mm: f64) -> f64 {
    use model::pressure_model::{PressureModel, SkinSandModel};
    let solver = SolverSand::committed().unwrap();
    let plant = SkinSandModel {
        sand: ParametricSand::fitted_to_solver(&solver),
        ..SkinSandModel::paper_default()
    };
    let (mut lo, mut hi) = (18.7, 30.0);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if plant.internal_pressure_kpa(mid, depth_mm) < pressure_kpa {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    lo
}

fn assert_normal(name: &str, depth_mm: f64) {
    let (trace, o) = run_named(name);
    assert_eq!(trace.scenario.depth_mm, depth_mm);
    assert_eq!(o.cycles, 20);
    assert_eq!(o.final_state, State::Idle);
    assert_eq!(o.fault, None);
    // The drive moves 1 mm/s for advance_ms = 1000 ms: 1 mm per cycle,
    // to the millisecond sub-step.
    assert_eq!(o.expected_advance_mm, 1.0);
    assert_eq!(o.advance_per_cycle_mm.len(), 20);
    for a in &o.advance_per_cycle_mm {
        assert!((a - 1.0).abs() < 1.5e-3, "advance {a} mm");
    }
    // Every expansion stops on the sand's plateau (the paper's early
    // stop), between where the sand's slope falls to
    // plateau_slope_fraction of its initial value and that point plus the
    // detector's lag: a window, the confirmation and one period of pumping.
    // Either pressure rule may end it there, never the pumped volume: the
    // plateau detector, or the table's diameter estimate reaching the
    // target first. The plant's parametric sand is fitted to the solver's
    // rows along D with one N and one ΔDc for all depths (K 3.74); the
    // solver's K at 25 mm is 3.59 at 40 mm and 3.28 at 100 mm, so the
    // plant pushes back harder than the table expects and the table's
    // estimate reaches 25 mm before the true D does: where the plant's own
    // p_i(D) meets the table's p_i at 25 mm (24.06 mm at 40 mm, 22.62 mm at
    // 100 mm), give or take the sensor's noise and one lag of pumping.
    let params = trace.scenario.params;
    assert_eq!(o.expand_ends.len(), 20);
    let zone = ExpansionZone::of(&TABLE);
    let d_r = plateau_diameter_mm(f64::from(params.plateau_slope_fraction));
    let lag_ml = f64::from(params.expand_rate_ml_per_s) * f64::from(CONTROL_PERIOD_MS) / 1000.0
        * (PLATEAU_WINDOW_SAMPLES + usize::from(PLATEAU_CONFIRM_SAMPLES) + 1) as f64;
    let after_lag = |d: f64| f64::from(zone.diameter_mm(zone.volume_ml(d as f32) + lag_ml as f32));
    let d_max = after_lag(d_r);
    let target_kpa = f64::from(TABLE.pressure_kpa(params.target_diameter_mm, depth_mm as f32));
    let noise_kpa = trace.scenario.plant.sensor.noise_kpa;
    let (t_lo, t_at) = (
        plant_diameter_mm(target_kpa - 4.0 * noise_kpa, depth_mm),
        plant_diameter_mm(target_kpa, depth_mm),
    );
    let t_hi = after_lag(t_at);
    assert_eq!(o.peak_diameter_mm.len(), 20);
    for (d, end) in o.peak_diameter_mm.iter().zip(&o.expand_ends) {
        match end.as_str() {
            "Plateau" => assert!(
                *d > d_r && *d < d_max,
                "peak {d} mm outside ({d_r}, {d_max})"
            ),
            "TableTarget" => assert!(
                *d > t_lo && *d < t_hi,
                "peak {d} mm outside ({t_lo}, {t_hi}), the plant's D at the table's target"
            ),
            _ => panic!("an expansion ended by {end}: {:?}", o.expand_ends),
        }
    }
    // Never near the limit, never below the table's range.
    assert!(o.over_limit.peak_kpa < 0.5 * f64::from(params.max_pressure_kpa));
    assert_eq!(o.over_limit.longest_ms, 0);
}

#[test]
fn normal_burrowing_at_40_mm() {
    assert_normal("normal_40mm", 40.0);
}

#[test]
fn normal_burrowing_at_100_mm() {
    assert_normal("normal_100mm", 100.0);
}

#[test]
fn deeper_sand_pushes_back_harder() {
    // p_e grows with σ'v = γ'h (the skin's share is the same at both):
    // the peak pressure at 100 mm exceeds the 40 mm one by at least 0.9
    // of what the table adds between those depths at the target diameter
    // (1.92 kPa), where the expansions stop.
    let (trace, shallow) = run_named("normal_40mm");
    let (_, deep) = run_named("normal_100mm");
    let d = trace.scenario.params.target_diameter_mm;
    let rise = f64::from(TABLE.pressure_kpa(d, 100.0) - TABLE.pressure_kpa(d, 40.0));
    assert!(rise > 1.5, "{rise}");
    assert!(
        deep.over_limit.peak_kpa - shallow.over_limit.peak_kpa > 0.9 * rise,
        "{} and {} kPa against the table's rise of {rise} kPa",
        deep.over_limit.peak_kpa,
        shallow.over_limit.peak_kpa
    );
}

#[test]
fn blocked_rigid_line_over_pressure_is_caught_and_vented() {
    let (trace, o) = run_named("blocked_line");
    let age = trace.scenario.plant.sensor.max_sample_age_ms();
    assert_fault(&o, Fault::OverPressure, age);
    assert_safe_after_fault(&trace);
    // The expansion rate into the rigid line's compliance (2 mL/s into
    // 0.0005 mL/kPa: 4000 kPa/s); the pump runs at most the
    // detection bound plus the sample age past the limit.
    let sc = &trace.scenario;
    let rate_kpa_per_ms =
        f64::from(sc.params.expand_rate_ml_per_s) / sc.plant.line_compliance_ml_per_kpa / 1000.0;
    assert!((rate_kpa_per_ms - 4.0).abs() < 1e-9, "{rate_kpa_per_ms}");
    let limit = o.over_limit.limit_kpa;
    assert!(o.over_limit.peak_kpa > limit);
    assert!(o.over_limit.peak_kpa <= limit + rate_kpa_per_ms * f64::from(10 + age));
    let allowed = o.over_limit.allowed_ms.unwrap();
    assert!(o.over_limit.longest_ms > 0 && o.over_limit.longest_ms <= allowed);
    // The valve vents the pump's side of the blockage to ambient; the
    // head behind it stays pressurised.
    let end = trace.steps.last().unwrap().truth;
    assert!(end.blocked && end.line_kpa.abs() < 0.01, "{end:?}");
    // Behind it, the zone's own p_i at the diameter it reached: the
    // plant's, within the sensor's noise.
    let behind = plant_diameter_mm(end.behind_kpa, trace.scenario.depth_mm);
    assert!(
        end.behind_kpa > 0.5 && (behind - end.diameter_mm).abs() < 0.1,
        "{end:?}: the plant's p_i reaches {} kPa at {behind} mm",
        end.behind_kpa
    );
}

#[test]
fn a_valve_slower_than_the_bounds_assume_is_caught() {
    // The rigid blocked line with a valve four times slower than the 50 ms
    // the end-to-end bounds assume: the controller still latches
    // OverPressure within its own bound, but the line vents too late and
    // stays above the limit too long, and the run fails on both.
    let mut sc = named("blocked_line").unwrap();
    sc.plant.valve_response_ms = 4 * BOARD_TIMING.valve_response_ms;
    let o = evaluate(&run(&sc, DEFAULT_SEED).unwrap());
    assert!(!o.passed(), "{}", o.text());
    let d = o.detection.expect("a detection");
    assert_eq!(o.fault, Some(Fault::OverPressure));
    assert!(d.latency_ms <= i64::from(d.bound_ms + d.sensor_allowance_ms));
    assert!(d.end_to_end_ms().unwrap() > i64::from(d.end_to_end_bound_ms));
    assert!(
        o.failures.iter().any(|f| f.contains("end-to-end bound")),
        "{:?}",
        o.failures
    );
    assert!(
        o.failures.iter().any(|f| f.contains("line pressure above")),
        "{:?}",
        o.failures
    );
    // The valve the bounds assume passes the same run.
    sc.plant.valve_response_ms = BOARD_TIMING.valve_response_ms;
    let o = evaluate(&run(&sc, DEFAULT_SEED).unwrap());
    assert!(o.passed(), "{}", o.text());
}

#[test]
fn blocked_compliant_line_stops_on_the_table_then_faults_on_suction() {
    let (trace, o) = run_named("blocked_line_soft");
    assert_fault(
        &o,
        Fault::SensorOutOfRange,
        trace.scenario.plant.sensor.max_sample_age_ms(),
    );
    assert_safe_after_fault(&trace);
    // The first, normal expansion ends by a pressure rule (as at 40 mm in
    // `assert_normal`); the blocked one on the table: the line's pressure
    // says the head reached the target long before the limit.
    assert_eq!(o.expand_ends.len(), 2);
    assert!(["Plateau", "TableTarget"].contains(&o.expand_ends[0].as_str()));
    assert_eq!(o.expand_ends[1], "TableTarget");
    assert!(o.over_limit.peak_kpa < 0.5 * o.over_limit.limit_kpa);
    assert_eq!(o.over_limit.longest_ms, 0);
}

#[test]
fn sensor_dropout_is_a_bus_fault_within_its_bound() {
    let (trace, o) = run_named("sensor_dropout");
    let latency = assert_fault(&o, Fault::SensorBus, 0);
    // Two failed sensor periods, then three steps of BusError: never
    // faster than three periods.
    assert!(latency > 3 * i64::from(CONTROL_PERIOD_MS));
    assert_safe_after_fault(&trace);
}

/// Longest gap between the times of successive fresh readings the
/// controller saw from `from_ms` on (ms).
fn longest_reading_gap_ms(trace: &Trace, from_ms: u32) -> u32 {
    let mut taken = trace
        .steps
        .iter()
        .filter_map(|s| match s.inputs.pressure {
            PressureSample::Reading { taken_ms, .. } if taken_ms >= from_ms => Some(taken_ms),
            _ => None,
        })
        .collect::<Vec<_>>();
    taken.dedup();
    taken.windows(2).map(|w| w[1] - w[0]).max().unwrap_or(0)
}

#[test]
fn one_bus_glitch_is_retried_within_the_period() {
    // Seed 1 draws no random bus error in this run, so every gap is the
    // injected glitches': none loses a reading.
    let (trace, o) = run_named("sensor_glitch");
    assert_eq!((o.fault, o.cycles), (None, 5));
    assert_eq!(trace.injected.len(), 5);
    let first = trace.injected[0].at_ms;
    assert_eq!(
        longest_reading_gap_ms(&trace, first - 20),
        CONTROL_PERIOD_MS
    );
}

#[test]
fn a_burst_of_bus_errors_latches_the_bus_fault_within_its_bound() {
    let (trace, o) = run_named("sensor_burst");
    // 40 failed attempts outlast every retry and recovery: two failed
    // periods, then three steps of BusError.
    let latency = assert_fault(&o, Fault::SensorBus, 0);
    assert!(latency > 3 * i64::from(CONTROL_PERIOD_MS), "{latency}");
    assert_safe_after_fault(&trace);
}

#[test]
fn a_held_sda_is_cleared_and_the_cycles_complete() {
    let (trace, o) = run_named("stuck_sda");
    assert_eq!((o.fault, o.cycles), (None, 5));
    // One failed period, the bus clear and the re-init cost readings, but
    // fewer than the stale limit allows.
    let gap = longest_reading_gap_ms(&trace, trace.injected[0].at_ms - 20);
    let stale = Params::DEFAULT.sensor_stale_ms;
    assert!(gap > CONTROL_PERIOD_MS && gap <= stale, "{gap}");
}

#[test]
fn a_pump_stalled_while_shrinking_is_caught() {
    let (trace, o) = run_named("stalled_pump_shrink");
    let latency = assert_fault(&o, Fault::PumpStall, 0);
    // One block of 1 mL at the 4 mL/s shrink rate takes 250 ms: never
    // faster than that.
    assert!(latency >= 250, "{latency}");
    let at = trace
        .steps
        .iter()
        .find(|s| s.outputs.state == State::Fault)
        .unwrap();
    assert!(trace
        .steps
        .iter()
        .any(|s| s.outputs.state == State::Shrink && s.inputs.now_ms < at.inputs.now_ms));
    assert_safe_after_fault(&trace);
}

#[test]
fn frozen_sensor_is_caught_while_the_pump_runs() {
    let (trace, o) = run_named("frozen_sensor");
    assert_fault(&o, Fault::SensorFrozen, 0);
    assert_safe_after_fault(&trace);
}

#[test]
fn hung_sensor_task_is_stale() {
    let (trace, o) = run_named("sensor_hang");
    assert_fault(&o, Fault::SensorStale, 0);
    assert_safe_after_fault(&trace);
}

#[test]
fn leak_is_caught_in_the_hold() {
    let (trace, o) = run_named("leak");
    assert_fault(
        &o,
        Fault::Leak,
        trace.scenario.plant.sensor.max_sample_age_ms(),
    );
    assert_safe_after_fault(&trace);
    let i = trace
        .steps
        .iter()
        .position(|s| s.outputs.state == State::Fault)
        .unwrap();
    assert_eq!(trace.steps[i - 1].outputs.state, State::Hold);
}

#[test]
fn stalled_pump_is_caught_within_two_blocks() {
    let (trace, o) = run_named("stalled_pump");
    assert_fault(&o, Fault::PumpStall, 0);
    assert_safe_after_fault(&trace);
    // The driver kept counting while the plunger stood still.
    let at_stall = trace.injected[0].at_ms;
    let s0 = trace
        .steps
        .iter()
        .find(|s| s.inputs.now_ms == at_stall)
        .unwrap();
    let end = trace.steps.last().unwrap();
    assert!(end.truth.counted_steps > s0.truth.counted_steps);
    assert!((end.truth.displaced_ml - s0.truth.displaced_ml).abs() < 1e-12);
}

#[test]
fn empty_syringe_closes_the_end_stop() {
    let (trace, o) = run_named("syringe_empty");
    assert_fault(&o, Fault::EndStop, 0);
    assert_safe_after_fault(&trace);
    let end = trace.steps.last().unwrap().truth;
    assert_eq!(end.barrel_ml, 0.0);
    assert!(end.end_stops.empty);
    // All 1.5 mL went out, to one microstep.
    let step = f64::from(trace.scenario.plant.pump.ml_per_step());
    assert!(
        (end.displaced_ml - 1.5).abs() <= step,
        "{}",
        end.displaced_ml
    );
}

#[test]
fn trapped_air_takes_its_boyle_volume_and_the_cycles_complete() {
    let (trace, o) = run_named("trapped_air");
    assert_eq!(o.cycles, 5);
    assert_eq!(o.fault, None);
    // At every step, pumped − in the head = V0·p/(P0 + p) (no other
    // effect holds volume): Boyle with P0 = atmosphere + water column.
    let rig = &trace.scenario.plant.rig;
    let p0 = constants::ATMOSPHERE_KPA
        + rig.fluid.density_kg_m3
            * constants::GRAVITY_M_S2
            * 1e-6
            * (rig.fluid.water_above_sand_mm + 40.0);
    let mut checked = 0;
    for s in trace.steps.iter().filter(|s| s.truth.internal_kpa > 1.0) {
        let held = s.truth.delivered_ml - s.truth.actuator_volume_ml;
        let boyle = 10.0 * s.truth.internal_kpa / (p0 + s.truth.internal_kpa);
        // The model's geometry is the firmware's f32 rule: 1e-4 mL.
        assert!((held - boyle).abs() < 1e-4, "{held} vs {boyle}");
        checked += 1;
    }
    assert!(checked > 100, "{checked}");
}

#[test]
fn the_same_seed_gives_the_same_run_and_another_seed_other_noise() {
    let sc = named("leak").unwrap();
    let a = run(&sc, 5).unwrap();
    let b = run(&sc, 5).unwrap();
    // Debug text: exact for floats, and NaN (no reading yet) equals NaN.
    assert_eq!(format!("{:?}", a.steps), format!("{:?}", b.steps));
    let c = run(&sc, 6).unwrap();
    assert_ne!(a.steps[50].inputs.pressure, c.steps[50].inputs.pressure);
}

#[test]
fn trace_folder_reads_back_as_an_experiment() {
    let (trace, outcome) = run_named("blocked_line");
    let dir = tempfile::tempdir().unwrap();
    let written = emulator::trace::write(&trace, &outcome, dir.path()).unwrap();
    assert_eq!(written.len(), 5);
    let exp = Experiment::read(dir.path()).unwrap();
    assert_eq!(exp.rig, trace.scenario.plant.rig);
    assert_eq!(exp.runs.len(), 1);
    let run = &exp.runs[0];
    assert_eq!(run.id, "blocked_line");
    assert_eq!(run.depth_mm, 40.0);
    // One row per step with a reading (the first steps have none yet).
    let with_reading = trace
        .steps
        .iter()
        .filter(|s| s.outputs.telemetry.pressure_kpa.is_finite())
        .count();
    assert_eq!(run.samples.len(), with_reading);
    assert_eq!(exp.extra_columns[0], "state");
    let last = run.samples.last().unwrap();
    assert_eq!(last.extra[0], "Fault");
    assert_eq!(last.extra[1], "OverPressure");
    assert!(run.samples.iter().all(|s| s.diameter_mm.is_some()));

    let states = std::fs::read_to_string(dir.path().join("states.tsv")).unwrap();
    let lines: Vec<&str> = states.lines().collect();
    assert_eq!(lines[0], "t_s\tstate\tfault\tcycle");
    assert_eq!(lines[1], "0\tIdle\t\t0");
    assert!(lines.last().unwrap().contains("\tFault\tOverPressure\t"));
    let svg = std::fs::read_to_string(dir.path().join("plot.svg")).unwrap();
    assert!(svg.starts_with("<svg") && svg.contains("max_pressure_kpa"));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("outcome.json")).unwrap())
            .unwrap();
    assert_eq!(json["fault"], "OverPressure");
}

#[test]
fn every_scenario_has_a_name_and_unknown_ones_are_refused() {
    for name in emulator::NAMES {
        assert_eq!(named(name).unwrap().name, name);
    }
    let err = named("teleport").unwrap_err().to_string();
    assert!(err.contains("normal_40mm"), "{err}");
}

// --- QEMU parity -----------------------------------------------------------

fn repo() -> std::path::PathBuf {
    std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../..")
}

#[test]
fn committed_recordings_are_what_the_host_decides_now() {
    for name in REPLAY_SCENARIOS {
        let fresh = record(name, DEFAULT_SEED).unwrap();
        let path = repo().join(REPLAY_DIR).join(format!("{name}.bin"));
        let committed = std::fs::read(&path).unwrap();
        assert!(
            fresh == committed,
            "{} is stale: run `cargo sim emulate --export-replay`",
            path.display()
        );
    }
    let index = std::fs::read_to_string(repo().join(INDEX_FILE)).unwrap();
    assert_eq!(index, index_rs(&REPLAY_SCENARIOS));
}

#[test]
fn host_replays_every_recording_step_by_step() {
    for rec in urechis_qemu_tests::replay_data::RECORDINGS {
        let summary = check(rec.bytes, TABLE).unwrap_or_else(|e| panic!("{}: {e}", rec.name));
        let head = urechis::replay::header(rec.bytes).unwrap();
        assert_eq!((head.name, summary.steps), (rec.name, head.steps));
        assert!(summary.steps > 100);
    }
    assert_eq!(
        urechis_qemu_tests::replay_data::RECORDINGS.len(),
        REPLAY_SCENARIOS.len()
    );
}

#[test]
fn replay_catches_a_changed_decision_and_a_changed_input() {
    let mut trace = run(&named("leak").unwrap(), DEFAULT_SEED).unwrap();
    let bytes = encode(&trace).unwrap();
    assert!(check(&bytes, TABLE).is_ok());

    // A recorded pump command the controller would not give.
    let k = 120;
    let original = trace.steps[k].clone();
    trace.steps[k].outputs.pump = PumpCommand::Disable;
    match check(&encode(&trace).unwrap(), TABLE) {
        Err(ReplayError::Mismatch { step, field, .. }) => {
            assert_eq!((step, field), (k as u32, Field::Pump))
        }
        other => panic!("{other:?}"),
    }
    trace.steps[k] = original;

    // A different reading: the decisions may agree, the telemetry cannot.
    if let urechis::controller::PressureSample::Reading { pressure_kpa, .. } =
        &mut trace.steps[k].inputs.pressure
    {
        *pressure_kpa += 0.001;
    }
    assert!(matches!(
        check(&encode(&trace).unwrap(), TABLE),
        Err(ReplayError::TelemetryDigest { .. } | ReplayError::Mismatch { .. })
    ));

    // Another table.
    let mut other = TABLE;
    other.checksum ^= 1;
    assert!(matches!(
        check(&bytes, other),
        Err(ReplayError::TableChecksum { .. })
    ));
    // Truncation is an error, not a panic.
    assert!(matches!(
        check(&bytes[..bytes.len() - 3], TABLE),
        Err(ReplayError::Truncated(_))
    ));
}
