//! The controller itself: one [`Controller::step`] per control period, from
//! [`Inputs`] to [`Outputs`]. See [`crate::controller`] for the cycle and
//! the fault table.

use super::bounds::{
    pressure_zero_in_range, sensor_sees_limits, CONTROL_OVERRUN_LIMIT_MS, CONTROL_PERIOD_MS,
};
use super::geometry::ExpansionZone;
use super::monitors::{LeakMonitor, MismatchMonitor, SensorMonitor, StallMonitor};
use super::params::{ParamError, Params};
use super::plateau::PlateauDetector;
use super::types::{Command, CommandError, Fault, Inputs, Outputs, PumpCommand, State, Telemetry};
use crate::table::{Table, TableError};

/// Seconds per control period, for volume-per-step arithmetic.
const PERIOD_S: f32 = CONTROL_PERIOD_MS as f32 / 1000.0;

/// Why the current expansion ended (kept for tests and telemetry tools).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ExpandEnd {
    /// The volume-based diameter would pass the target within one period.
    VolumeTarget,
    /// The table-based diameter reached the target.
    TableTarget,
    /// The sand's p_e–V curve reached its plateau.
    Plateau,
    /// A `Stop` command.
    Stopped,
}

/// The burrowing-cycle state machine with its safety monitors.
#[derive(Clone, Debug)]
pub struct Controller<'t> {
    params: Params,
    table: Table<'t>,
    table_status: Result<(), TableError>,
    zone: ExpansionZone,
    state: State,
    fault: Option<Fault>,
    alarm: Option<Fault>,
    cycle: u16,
    stopping: bool,
    last_now_ms: Option<u32>,
    state_since_ms: u32,
    rest_volume_ml: f32,
    rest_pressure_kpa: f32,
    target_volume_ml: f32,
    pump_ran: bool,
    last_expand_end: Option<ExpandEnd>,
    pressure_zero_kpa: Option<f32>,
    last_host_ms: u32,
    last_fault: Option<(Fault, u32)>,
    sensor: SensorMonitor,
    plateau: PlateauDetector,
    stall: StallMonitor,
    mismatch: MismatchMonitor,
    leak: LeakMonitor,
}

/// What one step measured, shared by the monitors and the transitions.
struct Measured {
    now_ms: u32,
    volume_ml: f32,
    pressure_kpa: Option<f32>,
    fresh_taken_ms: Option<u32>,
    diameter_volume_mm: f32,
    diameter_table_mm: f32,
}

impl<'t> Controller<'t> {
    /// A controller in [`State::Idle`] with `params` and the compiled-in
    /// `table`, verified once here. A table that fails verification leaves
    /// the controller usable (monitors, telemetry) but `Start` is refused
    /// with [`CommandError::BadTable`]. Invalid `params` are refused, naming
    /// the first field out of range: the firmware never runs an unchecked
    /// set, and never swaps in another one unasked.
    pub fn new(params: Params, table: Table<'t>) -> Result<Self, ParamError> {
        params.validate()?;
        Ok(Self::checked(params, table))
    }

    /// A controller with [`Params::DEFAULT`] (valid: `params.rs` tests it)
    /// and `table`, as [`Controller::new`]; what the board boots with.
    pub fn with_default_params(table: Table<'t>) -> Self {
        Self::checked(Params::DEFAULT, table)
    }

    /// The controller over `params` already validated.
    fn checked(params: Params, table: Table<'t>) -> Self {
        Self {
            params,
            table,
            table_status: table.verify(),
            zone: ExpansionZone::of(&table),
            state: State::Idle,
            fault: None,
            alarm: None,
            cycle: 0,
            stopping: false,
            last_now_ms: None,
            state_since_ms: 0,
            rest_volume_ml: 0.0,
            rest_pressure_kpa: 0.0,
            target_volume_ml: 0.0,
            pump_ran: false,
            last_expand_end: None,
            pressure_zero_kpa: None,
            last_host_ms: 0,
            last_fault: None,
            sensor: SensorMonitor::new(),
            plateau: PlateauDetector::new(),
            stall: StallMonitor::default(),
            mismatch: MismatchMonitor::default(),
            leak: LeakMonitor::default(),
        }
    }

    /// Latches `fault` from outside a step, exactly as a monitor would:
    /// State::Fault, pump disabled, valve open, until an accepted `Reset`.
    /// The board calls it at boot after an independent-watchdog reset
    /// ([`Fault::ControlOverrun`]), so a control loop that died does not come
    /// back up in Idle as if nothing had happened.
    pub fn latch_fault(&mut self, fault: Fault) {
        self.state = State::Fault;
        self.fault = Some(fault);
        self.last_fault = Some((fault, self.last_now_ms.unwrap_or(0)));
        self.stopping = false;
    }

    /// Sets the sensor's gauge zero in force (absolute kPa), as taken by a
    /// tare or read back from storage at boot; `None` when there is none.
    /// It is reported in telemetry; `Start` is refused with
    /// [`CommandError::NoPressureZero`] unless it lies in
    /// [`PRESSURE_ZERO_RANGE_KPA`](super::PRESSURE_ZERO_RANGE_KPA). The
    /// controller never takes a zero by itself.
    pub fn set_pressure_zero(&mut self, zero_kpa: Option<f32>) {
        self.pressure_zero_kpa = zero_kpa;
    }

    /// The gauge zero in force (absolute kPa), if any.
    pub fn pressure_zero_kpa(&self) -> Option<f32> {
        self.pressure_zero_kpa
    }

    /// The last fault latched since boot and the time it latched (ms, the
    /// step clock), kept after `Reset` so a host can ask why a run stopped.
    pub fn last_fault(&self) -> Option<(Fault, u32)> {
        self.last_fault
    }

    /// Current state.
    pub fn state(&self) -> State {
        self.state
    }

    /// Latched fault, if any.
    pub fn fault(&self) -> Option<Fault> {
        self.fault
    }

    /// Monitored condition present at the last step, latched or not: how
    /// Idle reports an unhealthy sensor, a closed end-stop or a volume out
    /// of limits (and why `Start`/`Reset` answer `CauseActive`).
    pub fn alarm(&self) -> Option<Fault> {
        self.alarm
    }

    /// The table in use.
    pub fn table(&self) -> &Table<'t> {
        &self.table
    }

    /// Parameters in force.
    pub fn params(&self) -> &Params {
        &self.params
    }

    /// Cycles completed since the last `Start`.
    pub fn cycle(&self) -> u16 {
        self.cycle
    }

    /// Result of the table verification done in [`Controller::new`].
    pub fn table_status(&self) -> Result<(), TableError> {
        self.table_status
    }

    /// Pump volume captured at the last `Start` (mL): where every shrink
    /// returns to.
    pub fn rest_volume_ml(&self) -> f32 {
        self.rest_volume_ml
    }

    /// Why the last expansion ended.
    pub fn last_expand_end(&self) -> Option<ExpandEnd> {
        self.last_expand_end
    }

    /// One control step: monitors, command, transitions, outputs. Call it
    /// every [`CONTROL_PERIOD_MS`]. Never panics, whatever the inputs.
    pub fn step(&mut self, inputs: &Inputs) -> Outputs {
        let now_ms = inputs.now_ms;
        let on_time = self
            .last_now_ms
            .is_none_or(|prev| now_ms.wrapping_sub(prev) <= CONTROL_OVERRUN_LIMIT_MS);
        self.last_now_ms = Some(now_ms);
        // Any command is a host frame: it feeds the link watch before the
        // monitors look at it.
        if inputs.command.is_some() {
            self.last_host_ms = now_ms;
        }
        let link_lost = self.params.link_timeout_ms != 0
            && now_ms.wrapping_sub(self.last_host_ms) > self.params.link_timeout_ms;

        // --- Monitors ---------------------------------------------------
        let sensor = self
            .sensor
            .observe(&inputs.pressure, now_ms, self.pump_ran, &self.params);
        let m = self.measure(now_ms, inputs.pump_volume_ml, sensor.fresh_taken_ms);
        let volume_bad =
            !(m.volume_ml >= self.params.min_volume_ml && m.volume_ml <= self.params.max_volume_ml);
        let end_stop = inputs.end_stops.empty || inputs.end_stops.full;
        self.alarm = sensor
            .over_pressure
            .then_some(Fault::OverPressure)
            .or(sensor.condition)
            .or(end_stop.then_some(Fault::EndStop))
            .or(volume_bad.then_some(Fault::VolumeLimit));

        let mut plateau = false;
        let detected = match self.state {
            State::Fault => None,
            // At rest only what the valve can help with latches; the rest is
            // reported through `alarm` and blocks `Start`.
            State::Idle => sensor
                .over_pressure
                .then_some(Fault::OverPressure)
                .or(volume_bad.then_some(Fault::VolumeLimit)),
            State::Expand | State::Hold | State::Shrink | State::Advance => {
                let (mut stall, mut leak, mut mismatch) = (false, false, false);
                match self.state {
                    State::Expand => (stall, mismatch, plateau) = self.watch_expand(&m),
                    State::Shrink => {
                        stall = m.pressure_kpa.is_some_and(|p| {
                            self.stall.observe_withdrawal(
                                m.volume_ml,
                                p,
                                self.rest_pressure_kpa,
                                &self.params,
                            )
                        })
                    }
                    State::Hold => {
                        leak = m
                            .pressure_kpa
                            .is_some_and(|p| self.leak.observe(p, &self.params))
                    }
                    _ => {}
                }
                // First in the fault table's order wins.
                sensor
                    .over_pressure
                    .then_some(Fault::OverPressure)
                    .or(sensor.condition)
                    .or(end_stop.then_some(Fault::EndStop))
                    .or(volume_bad.then_some(Fault::VolumeLimit))
                    .or(stall.then_some(Fault::PumpStall))
                    .or(leak.then_some(Fault::Leak))
                    .or(mismatch.then_some(Fault::DiameterMismatch))
                    .or((!on_time).then_some(Fault::ControlOverrun))
                    .or(link_lost.then_some(Fault::LinkLoss))
            }
        };
        if let Some(fault) = detected {
            self.state = State::Fault;
            self.fault = Some(fault);
            self.last_fault = Some((fault, now_ms));
            self.state_since_ms = now_ms;
        }

        // --- Command ----------------------------------------------------
        let command_result = inputs.command.map(|c| self.command(c, &m));

        // --- Transitions ------------------------------------------------
        self.transition(&m, plateau);

        // --- Outputs ----------------------------------------------------
        let (pump, relief_valve_open, advance_drive) = match self.state {
            State::Idle | State::Hold => (PumpCommand::Hold, false, false),
            State::Expand => (
                PumpCommand::Run {
                    rate_ml_per_s: self.params.expand_rate_ml_per_s,
                },
                false,
                false,
            ),
            State::Shrink => (
                PumpCommand::Run {
                    rate_ml_per_s: -self.params.shrink_rate_ml_per_s,
                },
                false,
                false,
            ),
            State::Advance => (PumpCommand::Hold, false, true),
            State::Fault => (PumpCommand::Disable, true, false),
        };
        self.pump_ran = matches!(pump, PumpCommand::Run { .. });
        Outputs {
            pump,
            relief_valve_open,
            advance_drive,
            state: self.state,
            telemetry: Telemetry {
                t_ms: now_ms,
                volume_ml: m.volume_ml,
                pressure_kpa: m.pressure_kpa.unwrap_or(f32::NAN),
                state: self.state,
                fault: self.fault,
                diameter_volume_mm: m.diameter_volume_mm,
                diameter_table_mm: m.diameter_table_mm,
                cycle: self.cycle,
                pressure_zero_kpa: self.pressure_zero_kpa.unwrap_or(f32::NAN),
            },
            feed_watchdog: on_time,
            command_result,
        }
    }

    /// Pressure and both diameter estimates for this step.
    fn measure(&self, now_ms: u32, volume_ml: f32, fresh_taken_ms: Option<u32>) -> Measured {
        let pressure_kpa = self.sensor.last_kpa();
        let table_ok = self.table_status.is_ok();
        let diameter_volume_mm = if table_ok {
            self.zone.diameter_mm(volume_ml - self.rest_volume_ml)
        } else {
            f32::NAN
        };
        let diameter_table_mm = match pressure_kpa {
            Some(p) if table_ok => self.table.diameter_mm(p, self.params.depth_mm),
            _ => f32::NAN,
        };
        Measured {
            now_ms,
            volume_ml,
            pressure_kpa,
            fresh_taken_ms,
            diameter_volume_mm,
            diameter_table_mm,
        }
    }

    /// Expansion monitors: (stall, mismatch, plateau).
    fn watch_expand(&mut self, m: &Measured) -> (bool, bool, bool) {
        let Some(p) = m.pressure_kpa else {
            return (false, false, false);
        };
        let stall = self.stall.observe(m.volume_ml, p, &self.params);
        let mismatch = self.mismatch.observe(
            m.now_ms,
            m.diameter_volume_mm,
            m.diameter_table_mm,
            &self.params,
        );
        let plateau = match m.fresh_taken_ms {
            Some(taken_ms) => {
                let sand_kpa = p - self.table.membrane_kpa(m.diameter_volume_mm);
                self.plateau.observe(
                    taken_ms,
                    m.volume_ml - self.rest_volume_ml,
                    sand_kpa,
                    p,
                    m.diameter_volume_mm - self.zone.initial_diameter_mm,
                    &self.params,
                )
            }
            None => false,
        };
        (stall, mismatch, plateau)
    }

    /// Applies one command; a refused command changes nothing.
    fn command(&mut self, command: Command, m: &Measured) -> Result<(), CommandError> {
        if command == Command::Heartbeat {
            return Ok(());
        }
        if self.state == State::Fault {
            return match command {
                Command::Reset if self.alarm.is_some() => Err(CommandError::CauseActive),
                Command::Reset => {
                    self.fault = None;
                    self.stopping = false;
                    self.enter(State::Idle, m);
                    Ok(())
                }
                _ => Err(CommandError::Faulted),
            };
        }
        let idle = self.state == State::Idle;
        match command {
            Command::Start if !idle => Err(CommandError::Busy),
            Command::Start => {
                self.table_status.map_err(CommandError::BadTable)?;
                let zero = match self.pressure_zero_kpa {
                    Some(zero) if pressure_zero_in_range(zero) => zero,
                    _ => return Err(CommandError::NoPressureZero),
                };
                sensor_sees_limits(zero, &self.params).map_err(CommandError::SensorRange)?;
                if self.alarm.is_some() || m.pressure_kpa.is_none() {
                    return Err(CommandError::CauseActive);
                }
                self.rest_volume_ml = m.volume_ml;
                self.rest_pressure_kpa = m.pressure_kpa.unwrap_or(0.0);
                self.target_volume_ml =
                    m.volume_ml + self.zone.volume_ml(self.params.target_diameter_mm);
                self.cycle = 0;
                self.stopping = false;
                self.enter(State::Expand, m);
                Ok(())
            }
            Command::Stop => {
                if !idle {
                    self.stopping = true;
                    if self.state == State::Expand {
                        self.last_expand_end = Some(ExpandEnd::Stopped);
                    }
                    if self.state != State::Shrink {
                        self.enter(State::Shrink, m);
                    }
                }
                Ok(())
            }
            Command::Reset if idle => Ok(()),
            Command::Reset => Err(CommandError::Busy),
            Command::SetParams(_) if !idle => Err(CommandError::Busy),
            Command::SetParams(new) => {
                new.validate().map_err(CommandError::InvalidParams)?;
                self.params = new;
                Ok(())
            }
            Command::Heartbeat => Ok(()),
        }
    }

    /// At most one state change per step, after the command.
    fn transition(&mut self, m: &Measured, plateau: bool) {
        let elapsed_ms = m.now_ms.wrapping_sub(self.state_since_ms);
        match self.state {
            State::Idle | State::Fault => {}
            State::Expand => {
                let next_volume_ml = m.volume_ml + self.params.expand_rate_ml_per_s * PERIOD_S;
                let end = if next_volume_ml >= self.target_volume_ml {
                    Some(ExpandEnd::VolumeTarget)
                } else if m.diameter_table_mm >= self.params.target_diameter_mm {
                    Some(ExpandEnd::TableTarget)
                } else if plateau {
                    Some(ExpandEnd::Plateau)
                } else {
                    None
                };
                if let Some(end) = end {
                    self.last_expand_end = Some(end);
                    self.enter(State::Hold, m);
                }
            }
            State::Hold => {
                if elapsed_ms >= self.params.hold_ms {
                    self.enter(State::Shrink, m);
                }
            }
            State::Shrink => {
                if m.volume_ml <= self.rest_volume_ml + self.params.rest_tolerance_ml {
                    let next = if self.stopping {
                        State::Idle
                    } else {
                        State::Advance
                    };
                    self.enter(next, m);
                }
            }
            State::Advance => {
                if elapsed_ms >= self.params.advance_ms {
                    self.cycle = self.cycle.saturating_add(1);
                    let cycles = self.params.cycles;
                    if cycles != 0 && self.cycle >= cycles {
                        self.enter(State::Idle, m);
                    } else {
                        self.enter(State::Expand, m);
                    }
                }
            }
        }
    }

    /// Enters `state` now, starting its monitors afresh.
    fn enter(&mut self, state: State, m: &Measured) {
        match state {
            State::Expand => {
                self.plateau.reset();
                self.stall.reset(m.volume_ml, m.pressure_kpa);
                self.mismatch.reset();
            }
            State::Hold => self.leak.reset(m.pressure_kpa),
            State::Shrink => self.stall.reset(m.volume_ml, m.pressure_kpa),
            State::Idle => self.stopping = false,
            _ => {}
        }
        self.state = state;
        self.state_since_ms = m.now_ms;
    }
}
