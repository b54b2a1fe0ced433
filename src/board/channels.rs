//! The only paths between tasks. Latest-value state (a pressure sample, the
//! pump's position, the pump command) goes through `Watch`/`Signal`, where a
//! newer value replaces an older one; messages that must not be lost
//! silently (host requests, replies, telemetry) go through bounded
//! `Channel`s whose senders never block the control loop.

use core::sync::atomic::AtomicU32;

use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::channel::Channel;
use embassy_sync::signal::Signal;
use embassy_sync::watch::Watch;

use crate::controller::{EndStops, PressureSample, PumpCommand, Telemetry};
use crate::protocol::{DeviceMessage, HostMessage};

/// What the pump task reports about the plunger.
#[derive(Clone, Copy, Debug, PartialEq, defmt::Format)]
pub struct PumpStatus {
    /// Net volume pushed since power-up (mL, positive = injected).
    pub volume_ml: f32,
    /// End-stop switches; an unreadable switch reads as closed.
    pub end_stops: EndStops,
}

/// Latest pressure sample from the sensor task (latest wins).
pub static SAMPLE: Watch<CriticalSectionRawMutex, PressureSample, 1> = Watch::new();

/// Latest plunger volume and end-stops from the pump task (latest wins).
pub static PUMP_STATUS: Watch<CriticalSectionRawMutex, PumpStatus, 1> = Watch::new();

/// The pump command of the latest control step (latest wins: the pump task
/// wakes on it at once, so Disable/Hold stop the motor within one step).
pub static PUMP_COMMAND: Signal<CriticalSectionRawMutex, PumpCommand> = Signal::new();

/// Depth of [`REQUESTS`]: the control loop takes one request per 10 ms step,
/// far more than a host at 115200 baud sends.
pub const REQUESTS_DEPTH: usize = 4;

/// Host requests for the control task (commands and `GetParams`). A full
/// queue is answered with a `Nack` by the link, never waited on.
pub static REQUESTS: Channel<CriticalSectionRawMutex, HostMessage, REQUESTS_DEPTH> = Channel::new();

/// Depth of [`REPLIES`].
pub const REPLIES_DEPTH: usize = 4;

/// Replies to the host (Ack/Nack/Params/Pong), sent before telemetry.
pub static REPLIES: Channel<CriticalSectionRawMutex, DeviceMessage, REPLIES_DEPTH> = Channel::new();

/// Depth of [`TELEMETRY`]: 80 ms of samples at one per control step.
pub const TELEMETRY_DEPTH: usize = 8;

/// Telemetry samples for the host, one per control step.
pub static TELEMETRY: Channel<CriticalSectionRawMutex, Telemetry, TELEMETRY_DEPTH> = Channel::new();

/// Telemetry samples dropped because [`TELEMETRY`] was full (the link fell
/// behind); the control loop counts instead of waiting.
pub static TELEMETRY_DROPPED: AtomicU32 = AtomicU32::new(0);

/// Replies dropped because [`REPLIES`] was full.
pub static REPLIES_DROPPED: AtomicU32 = AtomicU32::new(0);
