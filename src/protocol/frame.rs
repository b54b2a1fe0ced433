//! Framing: postcard payload + CRC-16, COBS-encoded, 0x00-terminated. Encoding
//! into a caller's buffer and a streaming, bounded decoder that resynchronises
//! at the next delimiter after any damage.
//!
//! Generic over the serde message type: this layer knows nothing of the
//! protocol's messages (the typed encoders and decoders are in `codec`).

use core::marker::PhantomData;

use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

/// Largest postcard payload of any message (bytes). Kept below 252 so that
/// payload plus CRC is a single COBS block (exactly one byte of overhead).
/// A compile-time check next to the typed encoders keeps every protocol
/// message below it.
pub const MAX_PAYLOAD: usize = 240;

/// Length of the CRC appended to the payload (bytes).
pub const CRC_LEN: usize = 2;

/// Longest COBS-encoded frame, without its 0x00 delimiter (bytes): the
/// decoder's default buffer.
pub const MAX_ENCODED: usize = cobs::max_encoding_length(MAX_PAYLOAD + CRC_LEN);

/// Longest frame on the wire, delimiter included (bytes): a buffer this large
/// always suffices for [`encode`] of a message whose payload fits
/// [`MAX_PAYLOAD`], as every protocol message's does.
pub const MAX_FRAME: usize = MAX_ENCODED + 1;

/// Frame delimiter; COBS guarantees it never occurs inside a frame.
pub const DELIMITER: u8 = 0x00;

/// CRC-16/IBM-3740 (a.k.a. CCITT-FALSE): polynomial 0x1021, initial value
/// 0xFFFF, no reflection, no final XOR; check value 0x29B1 over `"123456789"`.
/// Sent most significant byte first after the payload.
pub const CRC: crc::Crc<u16> = crc::Crc::<u16>::new(&crc::CRC_16_IBM_3740);

/// Why a message could not be encoded. Never happens for the protocol's
/// messages with a [`MAX_FRAME`]-byte buffer.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ProtocolError {
    /// The serialized message is longer than [`MAX_PAYLOAD`].
    PayloadTooLong,
    /// The output buffer cannot hold the frame.
    BufferTooSmall,
}

/// Why a received frame was dropped. A dropped frame has no other effect:
/// the decoder starts afresh with the next byte.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FrameError {
    /// More bytes than the decoder's buffer before the delimiter.
    Overlong,
    /// Not a valid COBS encoding (a block runs past the end of the frame).
    Cobs,
    /// Decoded frame shorter than the CRC plus one payload byte.
    TooShort,
    /// The CRC does not match the payload.
    Crc,
    /// The CRC matches but postcard cannot read a message from the payload
    /// (unknown tag, bad bool/option byte, payload ends early).
    Decode,
    /// A whole message was read but payload bytes are left over.
    TrailingBytes,
}

/// Encodes any serde message into `out` as one frame: COBS(postcard(msg) ‖
/// CRC-16 big-endian) followed by [`DELIMITER`]. Returns the frame, a prefix of
/// `out`.
pub fn encode<'a, T: Serialize>(msg: &T, out: &'a mut [u8]) -> Result<&'a [u8], ProtocolError> {
    let mut raw = [0u8; MAX_PAYLOAD + CRC_LEN];
    let payload_len = postcard::to_slice(msg, raw.split_at_mut(MAX_PAYLOAD).0)
        .map_err(|_| ProtocolError::PayloadTooLong)?
        .len();
    let raw_len = payload_len + CRC_LEN;
    let crc = CRC.checksum(
        raw.get(..payload_len)
            .ok_or(ProtocolError::PayloadTooLong)?,
    );
    raw.get_mut(payload_len..raw_len)
        .ok_or(ProtocolError::PayloadTooLong)?
        .copy_from_slice(&crc.to_be_bytes());
    let unencoded = raw.get(..raw_len).ok_or(ProtocolError::PayloadTooLong)?;
    let len = cobs::try_encode(unencoded, out).map_err(|_| ProtocolError::BufferTooSmall)?;
    *out.get_mut(len).ok_or(ProtocolError::BufferTooSmall)? = DELIMITER;
    out.get(..=len).ok_or(ProtocolError::BufferTooSmall)
}

/// Decodes one frame given without its delimiter, in place (`encoded` is
/// overwritten). Checks, in order: no 0x00 inside, COBS, length, CRC,
/// postcard, no trailing bytes.
pub fn decode_frame<T: DeserializeOwned>(encoded: &mut [u8]) -> Result<T, FrameError> {
    if encoded.contains(&DELIMITER) {
        return Err(FrameError::Cobs);
    }
    let len = cobs::decode_in_place(encoded).map_err(|_| FrameError::Cobs)?;
    let decoded = encoded.get(..len).ok_or(FrameError::Cobs)?;
    if decoded.len() <= CRC_LEN {
        return Err(FrameError::TooShort);
    }
    let (payload, crc) = decoded.split_at(decoded.len() - CRC_LEN);
    if CRC.checksum(payload).to_be_bytes() != crc {
        return Err(FrameError::Crc);
    }
    let (msg, rest) = postcard::take_from_bytes::<T>(payload).map_err(|_| FrameError::Decode)?;
    if !rest.is_empty() {
        return Err(FrameError::TrailingBytes);
    }
    Ok(msg)
}

/// Streaming frame decoder: feed received bytes one at a time.
///
/// `N` is the longest encoded frame accepted, delimiter excluded (default
/// [`MAX_ENCODED`]). Empty frames (0x00 0x00) are skipped silently, so a
/// sender may emit a lone 0x00 to flush a receiver that saw line noise.
#[derive(Debug)]
pub struct FrameDecoder<T, const N: usize = MAX_ENCODED> {
    buf: heapless::Vec<u8, N>,
    overflowed: bool,
    _msg: PhantomData<fn() -> T>,
}

impl<T: DeserializeOwned, const N: usize> FrameDecoder<T, N> {
    /// An empty decoder.
    pub const fn new() -> Self {
        FrameDecoder {
            buf: heapless::Vec::new(),
            overflowed: false,
            _msg: PhantomData,
        }
    }

    /// Feeds one received byte. Returns `Some` at each non-empty frame's
    /// delimiter: the message, or why the frame was dropped.
    pub fn push(&mut self, byte: u8) -> Option<Result<T, FrameError>> {
        if byte != DELIMITER {
            // Past the buffer, drop everything up to the next delimiter.
            if !self.overflowed && self.buf.push(byte).is_err() {
                self.overflowed = true;
            }
            return None;
        }
        let result = if self.overflowed {
            Some(Err(FrameError::Overlong))
        } else if self.buf.is_empty() {
            None
        } else {
            Some(decode_frame(self.buf.as_mut_slice()))
        };
        self.reset();
        result
    }

    /// Drops any partial frame (e.g. after a UART overrun).
    pub fn reset(&mut self) {
        self.buf.clear();
        self.overflowed = false;
    }
}

impl<T: DeserializeOwned, const N: usize> Default for FrameDecoder<T, N> {
    fn default() -> Self {
        Self::new()
    }
}
