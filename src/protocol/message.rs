//! The messages of the host link: what the host asks ([`HostMessage`]) and
//! what the device says ([`DeviceMessage`]). Plain serde data; their byte
//! layout is the postcard encoding described in the [module docs](super).
//!
//! Variant order is part of the wire format (postcard sends the variant
//! index): append new variants at the end and bump [`PROTOCOL_VERSION`]
//! whenever an existing layout changes.

use serde::{Deserialize, Serialize};

use super::frame::FrameError;
use crate::controller::{Command, CommandError, Fault, ParamField, Params, State, Telemetry};
use crate::table::image::ImageError;
use crate::table::Table;

/// Version of the wire format (framing, CRC and message layouts), sent in
/// [`Hello`] and [`Info`]. Bump it on any incompatible change.
///
/// 2: `Heartbeat`, `Tare`, `GetInfo` and the table upload; `Info`;
/// telemetry carries the pressure zero; `Params` has `link_timeout_ms`.
/// 3: `Fault::Panic`; `CommandError::SensorRange` and
/// `TareError::SensorRange` (a limit the fitted sensor cannot see).
pub const PROTOCOL_VERSION: u16 = 3;

/// Largest table-image piece in one [`HostCommand::TableChunk`] (bytes):
/// with its offset and the message's other bytes it stays well inside
/// [`MAX_PAYLOAD`](super::MAX_PAYLOAD).
pub const TABLE_CHUNK_BYTES: usize = 128;

/// The bytes of one table-image piece.
pub type ChunkData = heapless::Vec<u8, TABLE_CHUNK_BYTES>;

/// A host → device message: a command with the host's sequence number, echoed
/// in the reply so the host can match replies to requests.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct HostMessage {
    /// Sequence number chosen by the host (wraps at 255).
    pub seq: u8,
    /// What the host asks.
    pub body: HostCommand,
}

/// What the host can ask. Wire tags 0..=11 in this order.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum HostCommand {
    /// Start the cycle from Idle (controller [`Command::Start`]).
    Start,
    /// Finish safely (controller [`Command::Stop`]).
    Stop,
    /// Clear a latched fault (controller [`Command::Reset`]).
    Reset,
    /// Ask for the parameter set in use; answered with [`DeviceMessage::Params`].
    GetParams,
    /// Replace all parameters (controller [`Command::SetParams`]).
    SetParams(Params),
    /// Liveness check; answered with [`DeviceMessage::Pong`].
    Ping,
    /// The host is there (controller [`Command::Heartbeat`]): feeds the
    /// link watch (`Params::link_timeout_ms`) while a cycle runs. `Ack`.
    Heartbeat,
    /// Take the sensor's gauge zero now (Idle only), with the head at rest
    /// in free water: the mean of a burst of readings, checked against
    /// [`PRESSURE_ZERO_RANGE_KPA`](crate::controller::PRESSURE_ZERO_RANGE_KPA),
    /// stored in flash and used from then on. `Ack`, or `Nack` with
    /// [`NackReason::Tare`].
    Tare,
    /// Ask what the device runs; answered with [`DeviceMessage::Info`].
    GetInfo,
    /// Begin a table upload (Idle only): the image
    /// ([`crate::table::image`]) that follows is `len_bytes` long with
    /// CRC-32 `crc32` (the table's algorithm) over all of it. Erases the
    /// stored table. `Ack`, or `Nack` with [`NackReason::Upload`].
    TableBegin {
        /// Image length (bytes).
        len_bytes: u32,
        /// CRC-32/ISO-HDLC of the whole image.
        crc32: u32,
    },
    /// The next piece of the image, at `offset` bytes from its start
    /// (pieces in order, no gaps). `Ack` or `Nack`.
    TableChunk {
        /// Position of `data` in the image (bytes).
        offset: u32,
        /// At most [`TABLE_CHUNK_BYTES`] bytes.
        data: ChunkData,
    },
    /// End the upload: the device checks length, CRC-32 and the table
    /// itself ([`Table::verify`]) and answers `Ack`, or `Nack` with
    /// [`NackReason::Upload`] (the stored image is then erased). A stored
    /// table is used from the next boot on.
    TableCommit,
}

impl HostCommand {
    /// The controller command this host command carries, or `None` for the
    /// requests the link answers itself ([`HostCommand::GetParams`],
    /// [`HostCommand::Ping`]).
    ///
    /// Every host frame shows the host is there: the board feeds the link
    /// watch with [`Command::Heartbeat`] for those ([`HostCommand::link_feed`]).
    pub fn to_controller(&self) -> Option<Command> {
        match *self {
            HostCommand::Start => Some(Command::Start),
            HostCommand::Stop => Some(Command::Stop),
            HostCommand::Reset => Some(Command::Reset),
            HostCommand::SetParams(params) => Some(Command::SetParams(params)),
            HostCommand::Heartbeat => Some(Command::Heartbeat),
            HostCommand::GetParams
            | HostCommand::Ping
            | HostCommand::Tare
            | HostCommand::GetInfo
            | HostCommand::TableBegin { .. }
            | HostCommand::TableChunk { .. }
            | HostCommand::TableCommit => None,
        }
    }

    /// What the controller is given for this frame: its own command, or a
    /// [`Command::Heartbeat`] for the requests answered elsewhere (every
    /// host frame feeds the link watch).
    pub fn link_feed(&self) -> Command {
        self.to_controller().unwrap_or(Command::Heartbeat)
    }
}

/// Why a table upload was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum UploadError {
    /// A cycle runs or a fault is latched: uploads only in Idle.
    NotIdle,
    /// A chunk or commit without a `TableBegin` before it.
    NotStarted,
    /// The announced length is below a header or above the flash area.
    Length,
    /// A chunk out of order, overlapping, or past the announced length.
    Offset,
    /// Commit before every byte arrived.
    Incomplete,
    /// The CRC-32 over the received image differs from the announced one.
    Crc,
    /// The flash refused an erase, write or read.
    Flash,
    /// The image arrived whole but is no valid table.
    Image(ImageError),
}

/// Why a tare was refused; the zero in force is unchanged.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum TareError {
    /// Only in Idle.
    NotIdle,
    /// The sensor gave no readings.
    Sensor,
    /// The mean reading (absolute kPa) is outside
    /// [`PRESSURE_ZERO_RANGE_KPA`](crate::controller::PRESSURE_ZERO_RANGE_KPA).
    OutOfRange {
        /// What was measured (absolute kPa).
        measured_kpa: f32,
    },
    /// The flash refused to store it.
    Flash,
    /// A tare is already under way.
    Busy,
    /// With this zero the fitted sensor could not see this limit of the
    /// parameters in force
    /// ([`sensor_sees_limits`](crate::controller::sensor_sees_limits)).
    SensorRange(ParamField),
}

/// Why the device refused a host message.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum NackReason {
    /// The frame arrived but the controller refused the command (no side
    /// effect).
    Command(CommandError),
    /// The frame itself was malformed and was dropped unread.
    Frame(FrameError),
    /// A table upload step was refused.
    Upload(UploadError),
    /// A tare was refused.
    Tare(TareError),
}

/// Firmware version, from the crate version at build time.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FirmwareVersion {
    /// Semver major.
    pub major: u16,
    /// Semver minor.
    pub minor: u16,
    /// Semver patch.
    pub patch: u16,
}

impl FirmwareVersion {
    /// The version of this build (`CARGO_PKG_VERSION`).
    pub const CURRENT: FirmwareVersion = FirmwareVersion {
        major: parse_u16(env!("CARGO_PKG_VERSION_MAJOR")),
        minor: parse_u16(env!("CARGO_PKG_VERSION_MINOR")),
        patch: parse_u16(env!("CARGO_PKG_VERSION_PATCH")),
    };
}

/// Decimal string → u16 at compile time; a component that does not fit
/// reads as `u16::MAX` rather than failing the build.
const fn parse_u16(text: &str) -> u16 {
    match u16::from_str_radix(text, 10) {
        Ok(v) => v,
        Err(_) => u16::MAX,
    }
}

/// What the device announces at boot, so a host tool knows what it talks to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Hello {
    /// [`PROTOCOL_VERSION`] of the firmware.
    pub protocol_version: u16,
    /// Firmware version.
    pub firmware_version: FirmwareVersion,
    /// Stored CRC-32 of the compiled-in pressure→diameter table.
    pub table_checksum: u32,
    /// True while the table comes from the placeholder law, not the
    /// project's physics.
    pub table_placeholder: bool,
}

impl Hello {
    /// The announcement for this build and `table`.
    pub fn new(table: &Table<'_>) -> Hello {
        Hello {
            protocol_version: PROTOCOL_VERSION,
            firmware_version: FirmwareVersion::CURRENT,
            table_checksum: table.checksum,
            table_placeholder: table.placeholder,
        }
    }
}

/// Where the table in use came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum TableSource {
    /// The table compiled into the firmware.
    CompiledIn,
    /// A table uploaded with `TableBegin`…`TableCommit`, read from flash
    /// and verified at boot.
    Uploaded,
}

/// What the flash's table area held at boot.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum StoredTable {
    /// Nothing was ever stored (erased flash).
    Absent,
    /// A valid image, in use.
    Valid,
    /// An image that failed its check: the compiled-in table is used.
    Rejected(ImageError),
}

/// Reply to [`HostCommand::GetInfo`]: what the device runs and how it is.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Info {
    /// [`PROTOCOL_VERSION`] of the firmware.
    pub protocol_version: u16,
    /// Firmware version.
    pub firmware_version: FirmwareVersion,
    /// Format version of the table in use.
    pub table_format_version: u16,
    /// CRC-32 of the table in use ([`Table::checksum`]).
    pub table_checksum: u32,
    /// True while the table in use comes from the placeholder law.
    pub table_placeholder: bool,
    /// Where the table in use came from.
    pub table_source: TableSource,
    /// What the flash's table area held at boot.
    pub stored_table: StoredTable,
    /// Gauge zero in force (absolute kPa); NaN when none was taken.
    pub pressure_zero_kpa: f32,
    /// Controller state.
    pub state: State,
    /// Latched fault, if any.
    pub fault: Option<Fault>,
    /// A monitored condition present now, latched or not (in Idle: why
    /// `Start` answers `CauseActive`).
    pub alarm: Option<Fault>,
    /// The last fault latched since boot (kept after `Reset`): its cause.
    pub last_fault: Option<Fault>,
    /// When it latched (ms since boot).
    pub last_fault_ms: u32,
    /// Time since boot (ms).
    pub uptime_ms: u32,
    /// Host frames the device dropped (CRC, COBS, …) since boot.
    pub frame_errors: u32,
    /// Telemetry samples dropped because the link fell behind, since boot.
    pub telemetry_dropped: u32,
}

/// A device → host message. Wire tags 0..=6 in this order.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum DeviceMessage {
    /// The command with this sequence number was accepted.
    Ack {
        /// Sequence number of the host message.
        seq: u8,
    },
    /// A host message was refused; it had no side effect.
    Nack {
        /// Sequence number of the host message; `None` when the frame was too
        /// broken to read one.
        seq: Option<u8>,
        /// Why.
        reason: NackReason,
    },
    /// Reply to [`HostCommand::GetParams`]: the parameter set in use.
    Params {
        /// Sequence number of the request.
        seq: u8,
        /// The parameters.
        params: Params,
    },
    /// One telemetry sample (streamed, not a reply).
    Sample(Telemetry),
    /// Reply to [`HostCommand::Ping`].
    Pong {
        /// Sequence number of the request.
        seq: u8,
    },
    /// Sent once at boot.
    Hello(Hello),
    /// Reply to [`HostCommand::GetInfo`].
    Info {
        /// Sequence number of the request.
        seq: u8,
        /// What the device runs and how it is.
        info: Info,
    },
}

impl DeviceMessage {
    /// The reply to host message `seq` whose controller command returned
    /// `result`: [`DeviceMessage::Ack`] or [`DeviceMessage::Nack`].
    pub fn command_reply(seq: u8, result: Result<(), CommandError>) -> DeviceMessage {
        match result {
            Ok(()) => DeviceMessage::Ack { seq },
            Err(e) => DeviceMessage::Nack {
                seq: Some(seq),
                reason: NackReason::Command(e),
            },
        }
    }

    /// A refusal of host message `seq` for `reason`.
    pub fn nack(seq: u8, reason: NackReason) -> DeviceMessage {
        DeviceMessage::Nack {
            seq: Some(seq),
            reason,
        }
    }

    /// The reply to a host frame that failed to decode.
    pub fn frame_reject(error: FrameError) -> DeviceMessage {
        DeviceMessage::Nack {
            seq: None,
            reason: NackReason::Frame(error),
        }
    }
}
