//! The board's tasks, written once over `embedded-hal(-async)`,
//! `embedded-io-async`, `embedded-storage` and embassy's time and sync
//! crates, so that the same code runs on the NUCLEO (one embassy task per
//! role, thin wrappers in `board` with the concrete STM32 types) and on the
//! host in host-sim's virtual board (against the emulated plant, with a
//! pseudo-terminal as the UART and a RAM sector as the flash).
//!
//! | task | owns | publishes | reads |
//! |---|---|---|---|
//! | [`sensor::run`] | the MS5837 on its I²C bus | [`Shared::sample`] (latest wins); tare replies | tare requests, the zero |
//! | [`control::run`] | the controller, relief valve, advance drive, watchdog ([`ControlIo`]) | [`Shared::pump_command`], [`Shared::telemetry`], [`Shared::replies`] | sample, pump status, [`Shared::requests`] |
//! | [`pump::run`] | the STEP timer ([`StepPulses`](crate::drivers::pump::StepPulses)), DIR/ENABLE, end-stops | [`Shared::pump_status`] (latest wins) | pump command, completed pulses |
//! | [`link::rx`] | UART RX | [`Shared::requests`], `Pong`/`Nack` and table-upload replies | — |
//! | [`link::tx`] | UART TX | frames on the wire | replies, telemetry |
//!
//! They talk only through [`Shared`] (and the flash through
//! [`StoreMutex`]). Every decision is made by
//! [`crate::controller::Controller::step`] in the control task.

pub mod control;
pub mod link;
mod log;
pub mod pump;
pub mod sensor;

use core::sync::atomic::{AtomicBool, AtomicU32, AtomicU8, Ordering};

use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::channel::Channel;
use embassy_sync::mutex::Mutex;
use embassy_sync::signal::Signal;
use embassy_sync::watch::Watch;

use embedded_storage::nor_flash::NorFlash;

use crate::controller::{EndStops, Params, PressureSample, PumpCommand, State, Telemetry};
use crate::protocol::{DeviceMessage, HostMessage, StoredTable};
use crate::store::Store;
use crate::table::image::{ImageError, TableBuf};

pub use control::ControlIo;

/// What the pump task reports about the plunger.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PumpStatus {
    /// Net volume pushed since power-up (mL, positive = injected).
    pub volume_ml: f32,
    /// End-stop switches, debounced; an unreadable switch reads as
    /// triggered.
    pub end_stops: EndStops,
}

/// A tare for the sensor task: the host's sequence number, and the
/// parameters in force, whose pressure limits the new zero must leave
/// visible ([`crate::controller::sensor_sees_limits`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TareRequest {
    /// The host's sequence number, echoed in the reply.
    pub seq: u8,
    /// The parameters in force when the tare was asked for.
    pub params: Params,
}

/// Depth of [`Shared::requests`]: the control loop takes one request per
/// 10 ms step, far more than a host at 115200 baud sends.
pub const REQUESTS_DEPTH: usize = 4;

/// Depth of [`Shared::replies`].
pub const REPLIES_DEPTH: usize = 4;

/// Depth of [`Shared::telemetry`]: 80 ms of samples at one per control
/// step.
pub const TELEMETRY_DEPTH: usize = 8;

/// The flash store shared by the tasks that write it (the link's table
/// upload, the sensor's tare). An async mutex: nobody holds a critical
/// section while the flash erases.
pub type StoreMutex<F> = Mutex<CriticalSectionRawMutex, Store<F>>;

/// The only paths between the tasks. Latest-value state (a pressure sample,
/// the pump's position, the pump command) goes through `Watch`/`Signal`,
/// where a newer value replaces an older one; messages that must not be
/// lost silently (host requests, replies, telemetry) go through bounded
/// `Channel`s whose senders never block the control loop.
pub struct Shared {
    /// Latest pressure sample from the sensor task (latest wins).
    pub sample: Watch<CriticalSectionRawMutex, PressureSample, 1>,
    /// Latest plunger volume and end-stops from the pump task.
    pub pump_status: Watch<CriticalSectionRawMutex, PumpStatus, 1>,
    /// The pump command of the latest control step (latest wins: the pump
    /// task wakes on it at once, so Disable/Hold stop the motor within one
    /// step).
    pub pump_command: Signal<CriticalSectionRawMutex, PumpCommand>,
    /// Host requests for the control task. A full queue is answered with a
    /// `Nack` by the link, never waited on.
    pub requests: Channel<CriticalSectionRawMutex, HostMessage, REQUESTS_DEPTH>,
    /// Replies to the host (Ack/Nack/Params/Info/Pong), sent before
    /// telemetry.
    pub replies: Channel<CriticalSectionRawMutex, DeviceMessage, REPLIES_DEPTH>,
    /// Telemetry samples for the host, one per control step.
    pub telemetry: Channel<CriticalSectionRawMutex, Telemetry, TELEMETRY_DEPTH>,
    /// A tare asked for by the host, for the sensor task.
    pub tare: Signal<CriticalSectionRawMutex, TareRequest>,
    /// The gauge zero in force (absolute kPa, f32 bits; 0 = none, as 0 kPa
    /// absolute is never a zero): set by the board at boot from the store
    /// and by the sensor task after a tare; the control task hands it to
    /// the controller. (All-zero initial values keep [`Shared`] out of the
    /// flash image.)
    pub zero_bits: AtomicU32,
    /// The controller's state after the last step ([`State`] as its index
    /// in [`State::ALL`]): the link refuses uploads unless Idle.
    pub state: AtomicU8,
    /// A valid host frame arrived since the control task last looked: it
    /// feeds the link watch with a `Heartbeat` when no command came.
    pub host_seen: AtomicBool,
    /// Telemetry samples dropped because the queue was full.
    pub telemetry_dropped: AtomicU32,
    /// Replies dropped because the queue was full.
    pub replies_dropped: AtomicU32,
    /// Host frames rejected by the decoder (CRC, COBS, …).
    pub frame_errors: AtomicU32,
}

impl Shared {
    /// Everything empty; no zero; Idle.
    pub const fn new() -> Self {
        Self {
            sample: Watch::new(),
            pump_status: Watch::new(),
            pump_command: Signal::new(),
            requests: Channel::new(),
            replies: Channel::new(),
            telemetry: Channel::new(),
            tare: Signal::new(),
            zero_bits: AtomicU32::new(0),
            state: AtomicU8::new(0),
            host_seen: AtomicBool::new(false),
            telemetry_dropped: AtomicU32::new(0),
            replies_dropped: AtomicU32::new(0),
            frame_errors: AtomicU32::new(0),
        }
    }

    /// Queues a reply for the TX task; counts it if the queue is full.
    pub fn reply(&self, msg: DeviceMessage) {
        if self.replies.try_send(msg).is_err() {
            self.replies_dropped.fetch_add(1, Ordering::Relaxed);
        }
    }

    /// The gauge zero in force (absolute kPa), if any.
    pub fn zero_kpa(&self) -> Option<f32> {
        let bits = self.zero_bits.load(Ordering::Relaxed);
        (bits != 0).then_some(f32::from_bits(bits))
    }

    /// Makes `zero_kpa` the zero in force (`None`: no zero).
    pub fn set_zero_kpa(&self, zero_kpa: Option<f32>) {
        let bits = zero_kpa.map_or(0, f32::to_bits);
        self.zero_bits.store(bits, Ordering::Relaxed);
    }

    /// The controller's state after the last step.
    pub fn state(&self) -> State {
        let i = usize::from(self.state.load(Ordering::Relaxed));
        State::ALL.get(i).copied().unwrap_or(State::Fault)
    }

    fn set_state(&self, state: State) {
        let i = State::ALL.iter().position(|s| *s == state).unwrap_or(5);
        // Six states: the index fits a u8.
        self.state.store(i as u8, Ordering::Relaxed);
    }
}

impl Default for Shared {
    fn default() -> Self {
        Self::new()
    }
}

/// Reads the stored table at boot: the table to use (checked, in RAM) if
/// there is a valid one, and what the table area held, for `Info`. An
/// absent or damaged table leaves the compiled-in one in use.
pub fn stored_table<F: NorFlash>(store: &mut Store<F>) -> (Option<TableBuf>, StoredTable) {
    match store.load_table() {
        Ok(buf) => {
            log::log_info!("table: uploaded {=u32:#010x} in use", buf.table().checksum);
            (Some(buf), StoredTable::Valid)
        }
        Err(ImageError::Absent) => {
            log::log_info!("table: none stored, the compiled-in table is in use");
            (None, StoredTable::Absent)
        }
        Err(e) => {
            log::log_error!(
                "table: stored table refused ({}), the compiled-in table is in use",
                e
            );
            (None, StoredTable::Rejected(e))
        }
    }
}

/// Milliseconds since boot on the embassy clock, truncated to `u32` (wraps
/// after 49 days; the controller takes all differences wrapping).
pub fn now_ms() -> u32 {
    // Truncation is the documented wrap of `Inputs::now_ms`.
    embassy_time::Instant::now().as_millis() as u32
}
