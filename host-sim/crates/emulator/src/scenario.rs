//! Named emulation scenarios: a plant, the controller's parameters, what is
//! injected when, and the outcome the firmware promises.
//!
//! Every scenario starts the same way: the controller boots with
//! [`Params::DEFAULT`], receives the scenario's parameters as a `SetParams`
//! command at the first step, and `Start` at [`START_MS`]. A fault is
//! injected either at a fixed time or a given time after the controller
//! entered a state for the n-th time (so it lands in the intended phase
//! whatever the plant's timing).

use anyhow::{bail, Result};
use urechis::controller::{Fault, Params, State};

use super::plant::{PlantConfig, PlantFault};
use super::sensor::SensorFault;
use model::effects::EffectInstance;

/// When the `Start` command is sent (ms): after the sensor has delivered.
pub const START_MS: u32 = 100;

/// When an injection happens.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Trigger {
    /// At this time (ms since boot, rounded up to a control step).
    AtMs(u32),
    /// `after_ms` after the controller entered `state` for the `nth` time
    /// (1 = the first).
    AfterEntering {
        /// The state.
        state: State,
        /// Which entry (1-based).
        nth: u32,
        /// Delay after that entry (ms).
        after_ms: u32,
    },
}

/// The controller's entries into each state so far (how many, and when
/// the latest): what [`Trigger::AfterEntering`] waits for. One record
/// keeps the emulator and the virtual board firing injections alike.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StateEntries {
    entries: Vec<(State, u32, u32)>,
    previous: Option<State>,
    first_ms: Option<u32>,
}

impl StateEntries {
    /// Notes the controller in `state` at `now_ms` (ms): an entry when it
    /// differs from the last one noted (the first, Idle, is none).
    pub fn note(&mut self, state: State, now_ms: u32) {
        if self.previous.unwrap_or(State::Idle) == state {
            self.previous = Some(state);
            return;
        }
        self.previous = Some(state);
        self.first_ms.get_or_insert(now_ms);
        match self.entries.iter_mut().find(|(s, _, _)| *s == state) {
            Some(e) => {
                e.1 += 1;
                e.2 = now_ms;
            }
            None => self.entries.push((state, 1, now_ms)),
        }
    }

    /// When the controller first left Idle (ms), if it has.
    pub fn first_ms(&self) -> Option<u32> {
        self.first_ms
    }

    /// Whether `trigger` is due: [`Trigger::AtMs`] against `scenario_ms`,
    /// the scenario's own clock (ms; `None` while it has not started), and
    /// [`Trigger::AfterEntering`] against `now_ms`, the clock the entries
    /// were noted on.
    pub fn due(&self, trigger: &Trigger, scenario_ms: Option<u32>, now_ms: u32) -> bool {
        match *trigger {
            Trigger::AtMs(t) => scenario_ms.is_some_and(|s| s >= t),
            Trigger::AfterEntering {
                state,
                nth,
                after_ms,
            } => self
                .entries
                .iter()
                .find(|(s, _, _)| *s == state)
                .is_some_and(|&(_, n, since)| n == nth && now_ms >= since + after_ms),
        }
    }
}

/// A fault put into the plant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Injection {
    /// When.
    pub at: Trigger,
    /// What.
    pub fault: PlantFault,
}

/// The moment a fault detection is timed from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reference {
    /// The step at which the fault was injected into the plant.
    Injection,
    /// The first millisecond the true line pressure exceeded
    /// `max_pressure_kpa`.
    OverLimit,
    /// The first millisecond, during a hold, the true line pressure fell
    /// more than the controller's leak limit (`Params::leak_limit_kpa`)
    /// below that hold's peak.
    HoldDrop,
    /// The first millisecond a pump end-stop switch was closed.
    EndStopClosed,
    /// The first millisecond the true line pressure fell below
    /// `sensor_min_kpa` (suction).
    BelowRange,
    /// The later of the injection and the step that started the pumping
    /// stretch the fault latched in: the firmware's frozen clock only runs
    /// while the pump runs (a steady reading at constant volume is normal).
    FrozenWhilePumping,
}

/// What the scenario must end with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Expectation {
    /// The cycles all complete, no fault; each advance covers the drive's
    /// speed × `advance_ms`.
    Completes {
        /// Cycles to complete.
        cycles: u16,
    },
    /// This fault latches within the firmware's stated bound
    /// ([`urechis::controller::detection_bound_ms`]) of `reference`, plus
    /// the sensor's sample age where the reference is a plant event the
    /// controller can only see through the sensor.
    Faults {
        /// The fault.
        fault: Fault,
        /// Timed from.
        reference: Reference,
    },
}

/// One emulation: plant, controller parameters, injections, expectation.
#[derive(Clone, Debug)]
pub struct Scenario {
    /// Name (`--scenario NAME`, the run id in the trace).
    pub name: String,
    /// One line on what it shows.
    pub summary: String,
    /// Sand cover above the actuator axis (mm).
    pub depth_mm: f64,
    /// The controller's parameters (sent with `SetParams`).
    pub params: Params,
    /// The plant.
    pub plant: PlantConfig,
    /// Faults put into the plant.
    pub injections: Vec<Injection>,
    /// Longest the emulation runs (ms since boot).
    pub max_ms: u32,
    /// How long to go on after the controller settles in Idle (after the
    /// start) or Fault (ms): long enough to see the pump stay stopped and
    /// the line vent.
    pub tail_ms: u32,
    /// Expected outcome.
    pub expect: Expectation,
}

/// Names of the built-in scenarios, in `--list` order.
pub const NAMES: [&str; 15] = [
    "normal_40mm",
    "normal_100mm",
    "blocked_line",
    "blocked_line_soft",
    "sensor_dropout",
    "frozen_sensor",
    "sensor_hang",
    "sensor_glitch",
    "sensor_burst",
    "stuck_sda",
    "leak",
    "stalled_pump",
    "stalled_pump_shrink",
    "trapped_air",
    "syringe_empty",
];

/// Cycles of the normal burrowing scenarios.
pub const NORMAL_CYCLES: u16 = 20;

/// The parameters of every built-in scenario: the firmware defaults with
/// a cycle count and the depth.
fn params(depth_mm: f64, cycles: u16) -> Params {
    Params {
        depth_mm: depth_mm as f32,
        cycles,
        ..Params::DEFAULT
    }
}

/// The built-in scenario `name`.
pub fn named(name: &str) -> Result<Scenario> {
    let plant = PlantConfig::paper;
    let expand = |nth, after_ms| Trigger::AfterEntering {
        state: State::Expand,
        nth,
        after_ms,
    };
    let faults = |fault, reference| Expectation::Faults { fault, reference };
    let s = match name {
        "normal_40mm" | "normal_100mm" => {
            let depth = if name == "normal_40mm" { 40.0 } else { 100.0 };
            Scenario {
                name: name.into(),
                summary: format!(
                    "{NORMAL_CYCLES} burrowing cycles at {depth} mm: expand, hold, shrink, advance"
                ),
                depth_mm: depth,
                params: params(depth, NORMAL_CYCLES),
                plant: plant(),
                injections: vec![],
                max_ms: 200_000,
                tail_ms: 500,
                expect: Expectation::Completes {
                    cycles: NORMAL_CYCLES,
                },
            }
        }
        "blocked_line" => Scenario {
            name: name.into(),
            summary: "a rigid line (glass syringe, PEEK tubing: 0.0005 mL/kPa) blocks between the \
                      sensor and the head during the 2nd expansion: the pump pressurises the line \
                      at 4000 kPa/s"
                .into(),
            depth_mm: 40.0,
            params: params(40.0, 5),
            plant: PlantConfig {
                // Stiff enough that one control period past the blockage
                // overshoots the limit (at 0.001 mL/kPa the period's
                // 20 kPa stayed under it in the solver's softer sand: the
                // table target stopped the pump, the shrink then sucked on
                // the line, SensorOutOfRange, as blocked_line_soft).
                line_compliance_ml_per_kpa: 0.0005,
                ..plant()
            },
            injections: vec![Injection {
                at: expand(2, 300),
                fault: PlantFault::BlockLine,
            }],
            max_ms: 30_000,
            tail_ms: 1_000,
            expect: faults(Fault::OverPressure, Reference::OverLimit),
        },
        "blocked_line_soft" => Scenario {
            name: name.into(),
            summary: "a compliant line (0.02 mL/kPa) blocks during the 2nd expansion: the table \
                      reads the target long before the limit and ends the expansion; the shrink \
                      then sucks on the blocked line"
                .into(),
            depth_mm: 40.0,
            params: params(40.0, 5),
            plant: plant(),
            injections: vec![Injection {
                at: expand(2, 300),
                fault: PlantFault::BlockLine,
            }],
            max_ms: 30_000,
            tail_ms: 1_000,
            expect: faults(Fault::SensorOutOfRange, Reference::BelowRange),
        },
        "sensor_dropout" => sensor_fault(
            name,
            "the sensor stops answering on the bus mid-expansion",
            SensorFault::Dropout,
            Fault::SensorBus,
        ),
        "frozen_sensor" => Scenario {
            expect: faults(Fault::SensorFrozen, Reference::FrozenWhilePumping),
            ..sensor_fault(
                name,
                "the sensor returns the same conversion again and again mid-expansion",
                SensorFault::Frozen,
                Fault::SensorFrozen,
            )
        },
        "sensor_hang" => sensor_fault(
            name,
            "the sensor task stops publishing mid-expansion: the last reading ages",
            SensorFault::Hang,
            Fault::SensorStale,
        ),
        "sensor_glitch" => Scenario {
            summary: "one read attempt fails on the bus in every expansion: the retry within \
                      the period reads, the cycles complete"
                .into(),
            depth_mm: 40.0,
            params: params(40.0, 5),
            injections: (1..=5)
                .map(|nth| Injection {
                    at: expand(nth, 500),
                    fault: PlantFault::Sensor(SensorFault::Glitch(1)),
                })
                .collect(),
            max_ms: 60_000,
            tail_ms: 500,
            expect: Expectation::Completes { cycles: 5 },
            ..sensor_fault(name, "", SensorFault::Glitch(1), Fault::SensorBus)
        },
        "sensor_burst" => sensor_fault(
            name,
            "a burst of 40 failed bus attempts mid-expansion: retries and recoveries do not \
             help, the bus fault latches",
            SensorFault::Glitch(40),
            Fault::SensorBus,
        ),
        "stuck_sda" => Scenario {
            summary: "a device holds SDA low mid-expansion: the bus clear frees it, the part is \
                      re-initialised and the cycles complete"
                .into(),
            max_ms: 60_000,
            tail_ms: 500,
            expect: Expectation::Completes { cycles: 5 },
            ..sensor_fault(name, "", SensorFault::StuckSda, Fault::SensorBus)
        },
        "leak" => Scenario {
            name: name.into(),
            summary: "a pin-hole leak (0.2 mL/s per kPa): the pressure decays during the hold"
                .into(),
            depth_mm: 40.0,
            params: params(40.0, 5),
            plant: PlantConfig {
                effects: vec![EffectInstance::new("leak", &[("ml_per_s_per_kpa", 0.2)])?],
                ..plant()
            },
            injections: vec![],
            max_ms: 30_000,
            tail_ms: 1_000,
            expect: faults(Fault::Leak, Reference::HoldDrop),
        },
        "stalled_pump" => Scenario {
            name: name.into(),
            summary: "the motor loses its steps mid-expansion: the driver counts, the plunger \
                      stays"
                .into(),
            depth_mm: 40.0,
            params: params(40.0, 5),
            plant: plant(),
            injections: vec![Injection {
                at: expand(1, 200),
                fault: PlantFault::PumpStall,
            }],
            max_ms: 30_000,
            tail_ms: 1_000,
            expect: faults(Fault::PumpStall, Reference::Injection),
        },
        "stalled_pump_shrink" => Scenario {
            name: name.into(),
            summary: "the motor loses its steps 100 ms into the first shrink: the driver counts, \
                      the plunger stays and the pressure does not fall"
                .into(),
            depth_mm: 40.0,
            params: params(40.0, 5),
            plant: plant(),
            injections: vec![Injection {
                at: Trigger::AfterEntering {
                    state: State::Shrink,
                    nth: 1,
                    after_ms: 100,
                },
                fault: PlantFault::PumpStall,
            }],
            max_ms: 30_000,
            tail_ms: 1_000,
            expect: faults(Fault::PumpStall, Reference::Injection),
        },
        "trapped_air" => Scenario {
            name: name.into(),
            summary: "10 mL of air in the line: the gas takes V0·p/(P0 + p) of the pumped \
                      water (about 0.24 mL at 2.5 kPa); the cycles still complete"
                .into(),
            depth_mm: 40.0,
            params: params(40.0, 5),
            plant: PlantConfig {
                effects: vec![EffectInstance::new(
                    "trapped_air",
                    &[("gas_volume_ml", 10.0)],
                )?],
                ..plant()
            },
            injections: vec![],
            max_ms: 60_000,
            tail_ms: 500,
            expect: Expectation::Completes { cycles: 5 },
        },
        "syringe_empty" => Scenario {
            name: name.into(),
            summary: "the barrel holds only 1.5 mL: the plunger reaches the empty end-stop \
                      mid-expansion"
                .into(),
            depth_mm: 40.0,
            params: params(40.0, 5),
            plant: PlantConfig {
                fill_ml: 1.5,
                ..plant()
            },
            injections: vec![],
            max_ms: 30_000,
            tail_ms: 1_000,
            expect: faults(Fault::EndStop, Reference::EndStopClosed),
        },
        _ => bail!(
            "unknown scenario `{name}`; the built-in ones are: {}",
            NAMES.join(", ")
        ),
    };
    Ok(s)
}

/// A sensor failure injected 500 ms into the first expansion.
fn sensor_fault(name: &str, summary: &str, fault: SensorFault, expect: Fault) -> Scenario {
    Scenario {
        name: name.into(),
        summary: summary.into(),
        depth_mm: 40.0,
        params: params(40.0, 5),
        plant: PlantConfig::paper(),
        injections: vec![Injection {
            at: Trigger::AfterEntering {
                state: State::Expand,
                nth: 1,
                after_ms: 500,
            },
            fault: PlantFault::Sensor(fault),
        }],
        max_ms: 30_000,
        tail_ms: 1_000,
        expect: Expectation::Faults {
            fault: expect,
            reference: Reference::Injection,
        },
    }
}

/// Every built-in scenario, in [`NAMES`] order.
pub fn all() -> Result<Vec<Scenario>> {
    NAMES.iter().map(|n| named(n)).collect()
}

/// `--list`: every scenario with its summary and expected outcome.
pub fn list_text() -> Result<String> {
    let mut text = String::new();
    for s in all()? {
        let expect = match s.expect {
            Expectation::Completes { cycles } => format!("completes {cycles} cycles"),
            Expectation::Faults { fault, reference } => {
                format!("{fault:?} within its stated bound of {reference:?}")
            }
        };
        text.push_str(&format!("{:<16} {} → {expect}\n", s.name, s.summary));
    }
    Ok(text)
}
