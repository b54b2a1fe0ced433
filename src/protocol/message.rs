//! The messages of the host link: what the host asks ([`HostMessage`]) and
//! what the device says ([`DeviceMessage`]). Plain serde data; their byte
//! layout is the postcard encoding described in the [module docs](super).
//!
//! Variant order is part of the wire format (postcard sends the variant
//! index): append new variants at the end and bump [`PROTOCOL_VERSION`]
//! whenever an existing layout changes.

use serde::{Deserialize, Serialize};

use super::frame::FrameError;
use crate::controller::{Command, CommandError, Params, Telemetry};
use crate::table::Table;

/// Version of the wire format (framing, CRC and message layouts), sent in
/// [`Hello`]. Bump it on any incompatible change.
pub const PROTOCOL_VERSION: u16 = 1;

/// A host → device message: a command with the host's sequence number, echoed
/// in the reply so the host can match replies to requests.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct HostMessage {
    /// Sequence number chosen by the host (wraps at 255).
    pub seq: u8,
    /// What the host asks.
    pub body: HostCommand,
}

/// What the host can ask. Wire tags 0..=5 in this order.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
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
}

impl HostCommand {
    /// The controller command this host command carries, or `None` for the
    /// requests the link answers itself ([`HostCommand::GetParams`],
    /// [`HostCommand::Ping`]).
    pub fn to_controller(&self) -> Option<Command> {
        match *self {
            HostCommand::Start => Some(Command::Start),
            HostCommand::Stop => Some(Command::Stop),
            HostCommand::Reset => Some(Command::Reset),
            HostCommand::SetParams(params) => Some(Command::SetParams(params)),
            HostCommand::GetParams | HostCommand::Ping => None,
        }
    }
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

/// A device → host message. Wire tags 0..=5 in this order.
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

    /// The reply to a host frame that failed to decode.
    pub fn frame_reject(error: FrameError) -> DeviceMessage {
        DeviceMessage::Nack {
            seq: None,
            reason: NackReason::Frame(error),
        }
    }
}
