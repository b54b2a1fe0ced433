//! The closed loop: the firmware's own [`Controller`] (the root crate's code,
//! with the compiled-in table [`TABLE`]) against the [`Plant`], one
//! [`Controller::step`] every [`CONTROL_PERIOD_MS`], the plant advanced in
//! 1 ms sub-steps in between. Everything is deterministic: fixed steps, no
//! wall clock, every random draw from the seed.

use anyhow::Result;
use urechis::controller::{
    Command, Controller, ExpandEnd, Inputs, Outputs, State, CONTROL_PERIOD_MS,
};
use urechis::table::generated::TABLE;

use super::plant::{Plant, PlantFault, Truth};
use super::scenario::{Scenario, StateEntries, START_MS};

/// One control step as it happened.
#[derive(Clone, Debug, PartialEq)]
pub struct StepRecord {
    /// What the controller saw.
    pub inputs: Inputs,
    /// What it decided.
    pub outputs: Outputs,
    /// The plant's true state when the inputs were taken.
    pub truth: Truth,
    /// Why the controller's latest expansion ended, after this step.
    pub expand_end: Option<ExpandEnd>,
}

/// An injection as it happened.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Injected {
    /// Time of the step at which it was put into the plant (ms).
    pub at_ms: u32,
    /// What.
    pub fault: PlantFault,
}

/// A whole emulated run.
#[derive(Clone, Debug)]
pub struct Trace {
    /// The scenario that ran.
    pub scenario: Scenario,
    /// Its seed.
    pub seed: u64,
    /// Every control step, in order.
    pub steps: Vec<StepRecord>,
    /// The injections, in order.
    pub injected: Vec<Injected>,
    /// Line pressure at the sensor (kPa) at every millisecond, index =
    /// time in ms ([`Truth::line_kpa`]).
    pub line_kpa_ms: Vec<f32>,
    /// What the sensor element sensed (kPa), index = time in ms
    /// ([`Truth::sensed_kpa`]).
    pub sensed_kpa_ms: Vec<f32>,
    /// Whether a pump end-stop was closed, index = time in ms.
    pub end_stop_ms: Vec<bool>,
    /// Whether the relief valve was open (as it was, not as commanded)
    /// through the millisecond ending at the index.
    pub valve_open_ms: Vec<bool>,
    /// The pressure zero the controller was given at boot (absolute kPa).
    pub pressure_zero_kpa: f32,
}

/// The emulated host sends a `Heartbeat` this often when it has no other
/// command (ms), as `host-sim board run` does.
pub const HEARTBEAT_MS: u32 = 500;

impl Trace {
    /// Outputs of the last step.
    pub fn last_outputs(&self) -> Option<&Outputs> {
        self.steps.last().map(|s| &s.outputs)
    }
}

/// Runs `scenario` with `seed` until it settles (Idle after the start, or
/// Fault) plus its tail, or its time limit.
pub fn run(scenario: &Scenario, seed: u64) -> Result<Trace> {
    let mut plant = Plant::new(&scenario.plant, scenario.depth_mm, seed)?;
    let mut ctrl = Controller::with_default_params(TABLE);
    // The board's zero, taken by a tare at rest before the run.
    ctrl.set_pressure_zero(Some(plant.pressure_zero_kpa()));
    let mut steps = Vec::new();
    let mut injected = Vec::new();
    let mut pending: Vec<_> = scenario.injections.clone();
    // Index = time in ms: the state at 0, then the end of every millisecond.
    let start = plant.truth();
    let mut line_kpa_ms = vec![start.line_kpa as f32];
    let mut sensed_kpa_ms = vec![start.sensed_kpa as f32];
    let mut end_stop_ms = vec![start.end_stops.empty || start.end_stops.full];
    let mut valve_open_ms = vec![start.valve_open];
    let mut entries = StateEntries::default();
    let mut settled_at: Option<u32> = None;
    let mut now_ms = 0u32;
    loop {
        // Injections due now.
        pending.retain(|inj| {
            let due = entries.due(&inj.at, Some(now_ms), now_ms);
            if due {
                plant.inject(inj.fault);
                injected.push(Injected {
                    at_ms: now_ms,
                    fault: inj.fault,
                });
            }
            !due
        });
        let command = if now_ms == 0 {
            Some(Command::SetParams(scenario.params))
        } else if now_ms == START_MS {
            Some(Command::Start)
        } else if now_ms.is_multiple_of(HEARTBEAT_MS) {
            // The host is connected: it feeds the link watch.
            Some(Command::Heartbeat)
        } else {
            None
        };
        let inputs = Inputs {
            now_ms,
            pressure: plant.sample(),
            pump_volume_ml: plant.pump_volume_ml(),
            end_stops: plant.end_stops(),
            command,
        };
        let truth = plant.truth();
        let outputs = ctrl.step(&inputs);
        entries.note(outputs.state, now_ms);
        steps.push(StepRecord {
            inputs,
            outputs,
            truth,
            expand_end: ctrl.last_expand_end(),
        });
        plant.apply(&outputs, now_ms);
        plant.run_period(now_ms, CONTROL_PERIOD_MS, |_, t| {
            line_kpa_ms.push(t.line_kpa as f32);
            sensed_kpa_ms.push(t.sensed_kpa as f32);
            let stops = t.end_stops;
            end_stop_ms.push(stops.empty || stops.full);
            valve_open_ms.push(t.valve_open);
        })?;
        now_ms += CONTROL_PERIOD_MS;

        let settled = outputs.state == State::Fault
            || (entries.first_ms().is_some() && outputs.state == State::Idle);
        if settled {
            let since = *settled_at.get_or_insert(now_ms);
            if now_ms >= since + scenario.tail_ms {
                break;
            }
        } else {
            settled_at = None;
        }
        if now_ms >= scenario.max_ms {
            break;
        }
    }
    Ok(Trace {
        scenario: scenario.clone(),
        seed,
        steps,
        injected,
        line_kpa_ms,
        sensed_kpa_ms,
        end_stop_ms,
        valve_open_ms,
        pressure_zero_kpa: plant.pressure_zero_kpa(),
    })
}
