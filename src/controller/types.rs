//! The controller's inputs and outputs: what one control step sees and
//! decides. Plain data, shared by the board, the emulator, QEMU and the
//! host-link protocol.

use serde::{Deserialize, Serialize};

use super::params::{ParamError, ParamField, Params};
use crate::table::TableError;

/// Phase of the burrowing cycle.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum State {
    /// Pump held, waiting for a start command.
    Idle,
    /// Injecting water: the head swells radially.
    Expand,
    /// Volume held constant at full expansion (sand collapses around the head).
    Hold,
    /// Withdrawing water: the head shrinks back towards D0.
    Shrink,
    /// Head at rest diameter, moving forward (external advance drive on).
    Advance,
    /// Latched safe state: pump disabled, relief valve open, until `Reset`.
    Fault,
}

impl State {
    /// Every state, in declaration order (plots, codecs and tests walk it).
    pub const ALL: [State; 6] = [
        State::Idle,
        State::Expand,
        State::Hold,
        State::Shrink,
        State::Advance,
        State::Fault,
    ];
}

/// Why the controller entered [`State::Fault`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Fault {
    /// Internal pressure above `max_pressure_kpa` (independent of the table).
    OverPressure,
    /// The sensor bus failed for too many consecutive reads.
    SensorBus,
    /// A reading outside the sensor's plausible range.
    SensorOutOfRange,
    /// The reading has not changed by a single bit for too long.
    SensorFrozen,
    /// The newest reading is older than the staleness bound.
    SensorStale,
    /// A pump end-stop switch triggered: the plunger at an end, or a
    /// broken switch wire (normally-closed switches).
    EndStop,
    /// Pump stepped with no pressure response (stalled motor, open line).
    PumpStall,
    /// Pressure decayed at constant volume beyond the bound (leak).
    Leak,
    /// Pumped volume beyond the allowed stroke of the syringe.
    VolumeLimit,
    /// Volume-based and table-based diameters disagree grossly.
    DiameterMismatch,
    /// Control steps arrived late (loop overrun); the watchdog is starved.
    ControlOverrun,
    /// No host frame for longer than `link_timeout_ms` while a cycle ran:
    /// the host (or its cable) is gone.
    LinkLoss,
    /// The firmware panicked or took a HardFault: its handler drove the
    /// outputs safe and reset the MCU, and the next boot comes up latched
    /// with this fault ([`crate::reset_cause`]).
    Panic,
}

impl Fault {
    /// Every fault kind, in declaration order (codecs and tests walk it).
    pub const ALL: [Fault; 13] = [
        Fault::OverPressure,
        Fault::SensorBus,
        Fault::SensorOutOfRange,
        Fault::SensorFrozen,
        Fault::SensorStale,
        Fault::EndStop,
        Fault::PumpStall,
        Fault::Leak,
        Fault::VolumeLimit,
        Fault::DiameterMismatch,
        Fault::ControlOverrun,
        Fault::LinkLoss,
        Fault::Panic,
    ];
}

/// A command from the host link (or the board's button).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Command {
    /// Start the cycle from Idle.
    Start,
    /// Finish safely: shrink to rest volume, then Idle.
    Stop,
    /// Clear a latched fault once its cause is gone (else `CauseActive`);
    /// returns to Idle. A no-op in Idle, `Busy` in the other states.
    Reset,
    /// Replace all parameters (Idle only); an invalid set is rejected whole.
    SetParams(Params),
    /// The host is there: no effect but keeping the link watch
    /// (`link_timeout_ms`) fed. Every other command feeds it too. Accepted
    /// in every state.
    Heartbeat,
}

/// Why a command was refused. A refused command has no side effect.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum CommandError {
    /// The command needs Idle and the controller is elsewhere.
    Busy,
    /// A fault is latched: `Reset` first.
    Faulted,
    /// The compiled-in table failed verification: the cycle cannot start.
    BadTable(TableError),
    /// The parameter set is out of range (first offending field).
    InvalidParams(ParamError),
    /// `Reset` (or `Start`) while a monitored cause is present: over-pressure,
    /// unhealthy sensor (or no reading yet), triggered end-stop, volume out of
    /// limits. See `Controller::alarm`.
    CauseActive,
    /// `Start` without a pressure zero in
    /// [`PRESSURE_ZERO_RANGE_KPA`](super::PRESSURE_ZERO_RANGE_KPA): tare
    /// first (or again).
    NoPressureZero,
    /// `Start` with a zero at which the fitted sensor cannot see this
    /// limit ([`sensor_sees_limits`](super::sensor_sees_limits)): the
    /// field to lower (or raise), or tare where the atmosphere is lower.
    SensorRange(ParamField),
}

/// The latest pressure sample as the sensor task delivers it.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PressureSample {
    /// A converted reading: gauge pressure (kPa) and when it was taken (ms,
    /// same clock as [`Inputs::now_ms`]).
    Reading {
        /// Gauge pressure (kPa), zeroed in free water.
        pressure_kpa: f32,
        /// Time the conversion finished (ms).
        taken_ms: u32,
    },
    /// The last bus transaction failed (NAK, timeout, CRC, status error).
    BusError,
    /// No sample yet since boot.
    Missing,
}

/// Pump end-stop switches (true = triggered: the plunger at that end, or
/// the switch's wire broken).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct EndStops {
    /// Piston fully pushed in: no more water can be injected.
    pub empty: bool,
    /// Piston fully withdrawn: no more water can be drawn back.
    pub full: bool,
}

/// Everything one control step sees.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Inputs {
    /// Monotonic time (ms, wraps after 49 days; all differences wrapping).
    pub now_ms: u32,
    /// Latest pressure sample.
    pub pressure: PressureSample,
    /// Net volume pushed by the pump since power-up (mL), from its step count.
    pub pump_volume_ml: f32,
    /// End-stop switches.
    pub end_stops: EndStops,
    /// A command received since the previous step, if any.
    pub command: Option<Command>,
}

/// What the pump must do until the next step.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PumpCommand {
    /// Driver disabled (ENABLE off): the motor cannot move. The fault state.
    Disable,
    /// Driver enabled, no steps: holds the volume.
    Hold,
    /// Step at this volume rate (mL/s); positive injects, negative withdraws.
    Run {
        /// Volume rate (mL/s).
        rate_ml_per_s: f32,
    },
}

/// One telemetry sample, streamed to the host every step (or decimated).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Telemetry {
    /// Time of the step (ms).
    pub t_ms: u32,
    /// Net pumped volume (mL).
    pub volume_ml: f32,
    /// Last valid pressure reading (kPa); NaN before the first one.
    pub pressure_kpa: f32,
    /// State after the step.
    pub state: State,
    /// Latched fault, if any.
    pub fault: Option<Fault>,
    /// Outer diameter estimated from the pumped volume (mm).
    pub diameter_volume_mm: f32,
    /// Outer diameter read from the table at the measured pressure (mm).
    pub diameter_table_mm: f32,
    /// Completed cycles since the last start.
    pub cycle: u16,
    /// The sensor's gauge zero in force (absolute kPa), as taken by the
    /// last tare; NaN when there is none.
    pub pressure_zero_kpa: f32,
}

/// Everything one control step decides.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Outputs {
    /// Pump command.
    pub pump: PumpCommand,
    /// Relief valve (normally open part): true = open, line vented.
    pub relief_valve_open: bool,
    /// External advance drive on (only in [`State::Advance`]).
    pub advance_drive: bool,
    /// State after this step.
    pub state: State,
    /// Telemetry of this step.
    pub telemetry: Telemetry,
    /// True when this step ran on time and healthy: only then may the
    /// independent watchdog be fed.
    pub feed_watchdog: bool,
    /// Result of `Inputs::command`, if one was given.
    pub command_result: Option<Result<(), CommandError>>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn all_lists_every_state_once_in_declaration_order() {
        for (i, s) in State::ALL.iter().enumerate() {
            // Exhaustive: a new state fails to compile here until listed.
            let k = match s {
                State::Idle => 0,
                State::Expand => 1,
                State::Hold => 2,
                State::Shrink => 3,
                State::Advance => 4,
                State::Fault => 5,
            };
            assert_eq!(k, i);
        }
    }

    #[test]
    fn all_lists_every_fault_once_in_declaration_order() {
        for (i, f) in Fault::ALL.iter().enumerate() {
            let k = match f {
                Fault::OverPressure => 0,
                Fault::SensorBus => 1,
                Fault::SensorOutOfRange => 2,
                Fault::SensorFrozen => 3,
                Fault::SensorStale => 4,
                Fault::EndStop => 5,
                Fault::PumpStall => 6,
                Fault::Leak => 7,
                Fault::VolumeLimit => 8,
                Fault::DiameterMismatch => 9,
                Fault::ControlOverrun => 10,
                Fault::LinkLoss => 11,
                Fault::Panic => 12,
            };
            assert_eq!(k, i);
        }
    }
}
