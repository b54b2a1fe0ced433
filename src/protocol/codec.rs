//! The protocol's messages over the framing: typed encoders and stream
//! decoders for [`HostMessage`] and [`DeviceMessage`]. The layer above both
//! `frame` (generic framing) and `message` (the message types).

use super::frame::{encode, FrameDecoder, ProtocolError, MAX_PAYLOAD};
use super::message::{DeviceMessage, HostMessage};

// Postcard never needs more than 1.5× a message's in-memory size for types
// built from numbers, bools, options and enums (u16 → 3 bytes, u32 → 5, f32 →
// 4, tags 1); the 8 bytes cover zero-sized parts. Growing `Params` or
// `Telemetry` past the buffer breaks the build here, not the link.
const _: () = assert!(
    core::mem::size_of::<DeviceMessage>() * 3 / 2 + 8 <= MAX_PAYLOAD
        && core::mem::size_of::<HostMessage>() * 3 / 2 + 8 <= MAX_PAYLOAD,
    "a protocol message may not fit MAX_PAYLOAD"
);

/// Encodes a device message into `out` as one frame, delimiter included.
pub fn encode_device<'a>(
    msg: &DeviceMessage,
    out: &'a mut [u8],
) -> Result<&'a [u8], ProtocolError> {
    encode(msg, out)
}

/// Encodes a host message into `out` as one frame, delimiter included.
pub fn encode_host<'a>(msg: &HostMessage, out: &'a mut [u8]) -> Result<&'a [u8], ProtocolError> {
    encode(msg, out)
}

/// Device-side decoder of host messages.
pub type HostDecoder = FrameDecoder<HostMessage>;

/// Host-side decoder of device messages.
pub type DeviceDecoder = FrameDecoder<DeviceMessage>;
