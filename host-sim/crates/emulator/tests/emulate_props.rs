//! Randomized emulation: short scenarios (3 s of simulated time) over
//! depths, the effect library, controller parameters, plant parameters and
//! fault injections at random times, each run through the firmware's own
//! controller. Shrinking reduces a failure to a minimal scenario (fewer
//! effects and injections, smaller values).
//!
//! Invariants, at every control step:
//! - **no pump motion in Fault**: a Fault step commands `Disable`, opens
//!   the relief valve, stops the drive, and the plunger does not move (no
//!   microstep counted) in the period that follows;
//! - **faults latch**: once in Fault (no `Reset` is ever sent), every later
//!   step is Fault with the same fault;
//! - **over-pressure bounded**: the line pressure stays above the limit
//!   (as the sensor, bias and noise included, must show it) no longer than
//!   the firmware's detection bound plus the sensor's sample age plus the
//!   valve's stated response and venting time ([`OverLimit`]; not claimed
//!   with a frozen sensor, which is blind while the pump stands still);
//! - **volume never beyond the syringe**: the plunger stays within the
//!   barrel, and the reported volume never passes `max_volume_ml` or
//!   `min_volume_ml` by more than one control period of pumping;
//! - the watchdog is fed at every step (the loop is never late).

use emulator::outcome::{evaluate, OverLimit};
use emulator::plant::{PlantConfig, PlantFault};
use emulator::scenario::{Expectation, Injection, Scenario, Trigger};
use emulator::sensor::SensorFault;
use emulator::{run, Trace};
use model::effects::{EffectInstance, REGISTRY};
use proptest::prelude::*;
use proptest::test_runner::Config;
use urechis::controller::{Params, PumpCommand, State, CONTROL_PERIOD_MS};

/// Simulated time per case (ms).
const CASE_MS: u32 = 3_000;

/// The random part of a scenario.
#[derive(Clone, Debug)]
struct Case {
    depth_mm: f64,
    params: Params,
    fill_ml: f64,
    line_compliance_ml_per_kpa: f64,
    noise_kpa: f64,
    bus_error_probability: f64,
    /// (registry index, strength in [−1, 1]) per effect switched on.
    effects: Vec<(usize, f64)>,
    injections: Vec<(u32, PlantFault)>,
    seed: u64,
}

fn params() -> impl Strategy<Value = Params> {
    (
        (
            0.2f32..3.0,
            0.2f32..4.0,
            19.5f32..30.0,
            0u32..800,
            0u32..600,
            0u16..4,
        ),
        (3.0f32..17.9, 0.5f32..8.0, 0.0f32..0.5, 0.2f32..3.0),
        (0.2f32..2.0, 0.0f32..0.5, 50u32..500, 20u32..200, 1u8..6),
    )
        .prop_map(
            |(
                (expand, shrink, target, hold_ms, advance_ms, cycles),
                (max_p, max_v, plateau, leak_drop),
                (stall_v, stall_rise, frozen_ms, stale_ms, bus_steps),
            )| Params {
                expand_rate_ml_per_s: expand,
                shrink_rate_ml_per_s: shrink,
                target_diameter_mm: target,
                hold_ms,
                advance_ms,
                cycles,
                max_pressure_kpa: max_p,
                max_volume_ml: max_v,
                plateau_slope_fraction: plateau,
                leak_max_drop_kpa: leak_drop,
                stall_volume_ml: stall_v,
                stall_min_rise_kpa: stall_rise,
                sensor_frozen_ms: frozen_ms,
                sensor_stale_ms: stale_ms,
                sensor_bus_error_steps: bus_steps,
                ..Params::DEFAULT
            },
        )
}

fn plant_fault() -> impl Strategy<Value = PlantFault> {
    prop_oneof![
        Just(PlantFault::BlockLine),
        Just(PlantFault::PumpStall),
        Just(PlantFault::Sensor(SensorFault::Dropout)),
        Just(PlantFault::Sensor(SensorFault::Frozen)),
        Just(PlantFault::Sensor(SensorFault::Hang)),
    ]
}

fn case() -> impl Strategy<Value = Case> {
    (
        0.0f64..150.0,
        params(),
        (0.5f64..30.0, 0.0005f64..0.05, 0.0f64..0.03, 0.0f64..0.02),
        proptest::collection::vec((0..REGISTRY.len(), -1.0f64..1.0), 0..4),
        proptest::collection::vec((0u32..CASE_MS, plant_fault()), 0..3),
        any::<u64>(),
    )
        .prop_map(
            |(depth_mm, mut params, (fill, compliance, noise, bus), effects, injections, seed)| {
                params.depth_mm = depth_mm as f32;
                Case {
                    depth_mm,
                    params,
                    fill_ml: fill,
                    line_compliance_ml_per_kpa: compliance,
                    noise_kpa: noise,
                    bus_error_probability: bus,
                    effects,
                    injections,
                    seed,
                }
            },
        )
}

/// The scenario of a case: the paper's plant with the case's changes.
fn scenario(case: &Case) -> Scenario {
    let mut plant = PlantConfig::paper();
    plant.fill_ml = case.fill_ml;
    plant.line_compliance_ml_per_kpa = case.line_compliance_ml_per_kpa;
    plant.sensor.noise_kpa = case.noise_kpa;
    plant.sensor.bus_error_probability = case.bus_error_probability;
    // rig.toml's noise is left alone: it is only the trace's metadata, and
    // one rig keeps the model's skin curve built once for every case.
    for &(index, strength) in &case.effects {
        let spec = REGISTRY[index];
        // Effects that cannot act in this rig (piston friction with a
        // line sensor) and repeats are skipped.
        let usable = (spec.not_applicable)(&plant.rig).is_none()
            && !plant.effects.iter().any(|e| std::ptr::eq(e.spec, spec));
        if !usable {
            continue;
        }
        // The primary parameter from its neutral default towards a bound,
        // cubed so that most cases are mild.
        let p = &spec.params[0];
        let reach = if strength >= 0.0 {
            p.upper - p.default
        } else {
            p.default - p.lower
        };
        let value = p.clamp(p.default + strength.powi(3) * reach);
        let mut e = EffectInstance::with_defaults(spec.name).unwrap();
        e.set(p.name, value).unwrap();
        plant.effects.push(e);
    }
    Scenario {
        name: "random".into(),
        summary: format!("{case:?}"),
        depth_mm: case.depth_mm,
        params: case.params,
        plant,
        injections: case
            .injections
            .iter()
            .map(|&(at, fault)| Injection {
                at: Trigger::AtMs(at),
                fault,
            })
            .collect(),
        max_ms: CASE_MS,
        tail_ms: CASE_MS,
        expect: Expectation::Completes { cycles: 0 },
    }
}

fn check_invariants(trace: &Trace) -> Result<(), TestCaseError> {
    let sc = &trace.scenario;
    let params = &sc.params;
    let steps = &trace.steps;
    let stroke = f64::from(sc.plant.pump.stroke_ml);
    // One period of pumping at the pump's top rate, plus a microstep.
    let slack = f64::from(urechis::drivers::pump::MAX_RATE_ML_PER_S) * f64::from(CONTROL_PERIOD_MS)
        / 1000.0
        + f64::from(sc.plant.pump.ml_per_step());
    let mut latched = None;
    for (i, s) in steps.iter().enumerate() {
        let out = &s.outputs;
        let t = s.inputs.now_ms;
        prop_assert!(out.feed_watchdog, "watchdog starved at {t} ms");
        if out.state == State::Fault {
            prop_assert_eq!(
                out.pump,
                PumpCommand::Disable,
                "pump not disabled at {} ms",
                t
            );
            prop_assert!(out.relief_valve_open && !out.advance_drive);
            if let Some(next) = steps.get(i + 1) {
                prop_assert_eq!(
                    next.truth.counted_steps,
                    s.truth.counted_steps,
                    "microsteps in the period after Fault at {} ms",
                    t
                );
                prop_assert_eq!(next.truth.displaced_ml, s.truth.displaced_ml);
            }
            let fault = out.telemetry.fault;
            prop_assert!(fault.is_some());
            match latched {
                None => latched = Some(fault),
                Some(f) => prop_assert_eq!(f, fault, "the fault changed at {} ms", t),
            }
        } else {
            prop_assert!(
                latched.is_none(),
                "left Fault at {} ms for {:?}",
                t,
                out.state
            );
        }
        let barrel = s.truth.barrel_ml;
        prop_assert!(
            (0.0..=stroke).contains(&barrel),
            "barrel {barrel} mL at {t} ms"
        );
        let v = f64::from(s.inputs.pump_volume_ml);
        prop_assert!(
            v <= f64::from(params.max_volume_ml) + slack
                && v >= f64::from(params.min_volume_ml) - slack,
            "reported volume {v} mL at {t} ms beyond [{}, {}] ± {slack}",
            params.min_volume_ml,
            params.max_volume_ml
        );
    }
    let o: OverLimit = evaluate(trace).over_limit;
    if let Some(allowed) = o.allowed_ms {
        prop_assert!(
            o.longest_ms <= allowed,
            "above {} kPa (threshold {:.4}) for {} ms, allowed {} ms (peak {:.2} kPa)",
            o.limit_kpa,
            o.threshold_kpa,
            o.longest_ms,
            allowed,
            o.peak_kpa
        );
    }
    Ok(())
}

proptest! {
    #![proptest_config(Config {
        cases: 1000,
        ..Config::default()
    })]

    #[test]
    fn random_scenarios_keep_the_safety_invariants(case in case()) {
        let trace = run(&scenario(&case), case.seed).unwrap();
        check_invariants(&trace)?;
    }
}

/// The generator reaches what the invariants are about: faults of several
/// kinds, over-pressure excursions, end-stops (a fixed sample, so a change
/// that made the generator tame would show here).
#[test]
fn the_generator_reaches_faults_and_over_pressure() {
    use proptest::strategy::ValueTree;
    use proptest::test_runner::TestRunner;
    let mut runner = TestRunner::deterministic();
    let strategy = case();
    let mut kinds = std::collections::BTreeSet::new();
    let mut over = 0;
    for _ in 0..200 {
        let c = strategy.new_tree(&mut runner).unwrap().current();
        let trace = run(&scenario(&c), c.seed).unwrap();
        if let Some(f) = trace.steps.last().unwrap().outputs.telemetry.fault {
            kinds.insert(format!("{f:?}"));
        }
        over += usize::from(evaluate(&trace).over_limit.longest_ms > 0);
    }
    eprintln!("faults reached: {kinds:?}; {over} of 200 cases above the limit");
    assert!(kinds.len() >= 6, "{kinds:?}");
    assert!(over >= 5, "{over} cases above the limit");
}
