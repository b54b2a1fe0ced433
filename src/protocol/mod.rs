//! Host link: framed, checksummed commands and telemetry over the virtual
//! COM port.
//!
//! The board talks to the host over USART2, which the NUCLEO's ST-LINK
//! exposes as a USB virtual COM port: **115200 baud, 8 data bits, no parity,
//! 1 stop bit**, no flow control. Both directions use the same framing; this
//! section is the whole specification, enough to write a host tool in any
//! language.
//!
//! # Frame
//!
//! ```text
//! payload  = postcard(message)                      1..=240 bytes
//! raw      = payload ‖ CRC-16(payload), MSB first   payload + 2 bytes
//! frame    = COBS(raw) ‖ 0x00                       raw + 2 bytes (< 254)
//! ```
//!
//! | bytes | content |
//! |---|---|
//! | `0 .. n` | COBS encoding of `payload ‖ crc_hi ‖ crc_lo`; never contains 0x00 |
//! | `n` | 0x00, the delimiter |
//!
//! - **CRC**: CRC-16/IBM-3740 (a.k.a. CCITT-FALSE): width 16, polynomial
//!   0x1021, initial value 0xFFFF, input and output not reflected, final XOR
//!   0x0000; check value 0x29B1 over the ASCII bytes `123456789`. Computed over
//!   the payload only and appended big-endian.
//! - **COBS** (Cheshire & Baker 1999, zero as the sentinel): each block is a
//!   code byte `c` followed by `c − 1` non-zero bytes; a zero follows every
//!   block except the last and except blocks with `c = 0xFF`. Frames are
//!   shorter than 254 bytes, so the encoding is always exactly one byte
//!   longer than `raw`.
//! - **Limits**: a frame is at most [`MAX_FRAME`] = 244 bytes with its
//!   delimiter ([`MAX_PAYLOAD`] = 240 payload bytes); longer runs between
//!   delimiters are dropped as [`FrameError::Overlong`].
//! - **Empty frames** (two 0x00 in a row) are ignored. A sender may send one
//!   0x00 before its first frame to end whatever noise the receiver saw.
//!
//! A receiver collects bytes up to each 0x00 and then checks, in order:
//! length, COBS, at least three decoded bytes, CRC, postcard decoding, no
//! bytes left after the message ([`FrameError`] names each). A rejected frame
//! has no effect: decoding restarts after its delimiter, so the next good
//! frame is read normally. On the device a rejected host frame is answered
//! with [`DeviceMessage::Nack`] carrying `seq: None` and
//! [`NackReason::Frame`].
//!
//! ## Error detection
//!
//! Any single-bit error in a COBS data byte that leaves it non-zero is a
//! single-bit error of `payload ‖ CRC` and is always detected (CRC-16 with
//! this polynomial detects all 1-, 2- and 3-bit errors and all bursts up to 16
//! bits in frames of this length). A flip in a COBS code byte or in a
//! delimiter reshapes the frame; the COBS, length, CRC, postcard and
//! trailing-byte checks then reject it, but only probabilistically (a random
//! reshaped frame passes the CRC with probability 2⁻¹⁶). Measured: 0 of
//! 64 042 184 single-bit flips over 300 000 random device messages were
//! accepted (`tests/protocol.rs`, `single_bit_flip_survey`).
//!
//! # Payload encoding (postcard 1.x)
//!
//! | type | bytes |
//! |---|---|
//! | `u8` | 1 byte |
//! | `u16`, `u32` | unsigned LEB128 varint: 7 bits per byte, least significant group first, high bit = more bytes follow (u16 ≤ 3 bytes, u32 ≤ 5) |
//! | `f32` | 4 bytes, IEEE-754, little-endian |
//! | `bool` | 0x00 or 0x01 |
//! | `Option<T>` | 0x00 (None) or 0x01 followed by `T` |
//! | enum | variant index as a varint, then the variant's fields |
//! | struct | its fields in declaration order, no padding, no names |
//!
//! # Messages
//!
//! This is version 3 ([`PROTOCOL_VERSION`]); a host must check the
//! version in `Hello` or `Info` and refuse another one.
//!
//! Host → device: [`HostMessage`] `{ seq: u8, body: HostCommand }`; every
//! command gets exactly one reply echoing `seq`.
//!
//! | tag | [`HostCommand`] | fields | reply |
//! |---|---|---|---|
//! | 0 | `Start` | – | `Ack` or `Nack` |
//! | 1 | `Stop` | – | `Ack` or `Nack` |
//! | 2 | `Reset` | – | `Ack` or `Nack` |
//! | 3 | `GetParams` | – | `Params` |
//! | 4 | `SetParams` | [`Params`](crate::controller::Params) | `Ack` or `Nack` |
//! | 5 | `Ping` | – | `Pong` |
//! | 6 | `Heartbeat` | – | `Ack` |
//! | 7 | `Tare` | – | `Ack` or `Nack` (`Tare(`[`TareError`]`)`), after about 0.2 s |
//! | 8 | `GetInfo` | – | `Info` |
//! | 9 | `TableBegin` | `len_bytes: u32`, `crc32: u32` | `Ack` or `Nack` (`Upload(`[`UploadError`]`)`) |
//! | 10 | `TableChunk` | `offset: u32`, `data:` length varint + up to [`TABLE_CHUNK_BYTES`] bytes | `Ack` or `Nack` |
//! | 11 | `TableCommit` | – | `Ack` or `Nack` |
//!
//! Device → host: [`DeviceMessage`].
//!
//! | tag | variant | fields |
//! |---|---|---|
//! | 0 | `Ack` | `seq: u8` |
//! | 1 | `Nack` | `seq: Option<u8>`, `reason:` [`NackReason`] (0 = `Command(`[`CommandError`](crate::controller::CommandError)`)`, 1 = `Frame(`[`FrameError`]`)`, 2 = `Upload(`[`UploadError`]`)`, 3 = `Tare(`[`TareError`]`)`) |
//! | 2 | `Params` | `seq: u8`, `params:` [`Params`](crate::controller::Params) |
//! | 3 | `Sample` | [`Telemetry`](crate::controller::Telemetry) |
//! | 4 | `Pong` | `seq: u8` |
//! | 5 | `Hello` | [`Hello`]: `protocol_version: u16`, `firmware_version: { major, minor, patch: u16 }`, `table_checksum: u32`, `table_placeholder: bool` |
//! | 6 | `Info` | `seq: u8`, `info:` [`Info`] (versions, the table in use and where it came from, what the flash held, the pressure zero, state, fault, last fault and when, uptime, frame errors, dropped telemetry) |
//!
//! `Params`, `Telemetry` and the enums inside them (`State`, `Fault`,
//! `CommandError`, …) are encoded field by field and variant by variant in
//! the order they are declared in [`crate::controller`]; reordering them is a
//! wire change and bumps [`PROTOCOL_VERSION`]. The device sends `Hello` once
//! at boot and a `Sample` per control step (or decimated).
//!
//! ## Sessions
//!
//! - **Link watch**: while a cycle runs, the device stops it into the safe
//!   state with `Fault::LinkLoss` when no host frame arrived for
//!   `Params::link_timeout_ms` (default 2 s). A host that runs a cycle sends
//!   `Heartbeat` (or any other frame) at least every 0.5 s. A cycle without
//!   a cycle limit (`cycles` = 0) cannot turn the watch off.
//! - **Tare**: with the head at rest in free water, `Tare` takes the
//!   sensor's gauge zero, checks it against
//!   [`PRESSURE_ZERO_RANGE_KPA`](crate::controller::PRESSURE_ZERO_RANGE_KPA)
//!   and stores it in flash; `Start` is refused (`NoPressureZero`) until a
//!   zero in range is in force. Telemetry and `Info` carry it.
//! - **Table upload** (Idle only): `TableBegin` with the image's length and
//!   CRC-32 (the table's algorithm, [`crate::table::CHECKSUM_ALGORITHM`],
//!   over the whole image of [`crate::table::image`]) erases the stored
//!   table; `TableChunk`s follow in order from offset 0, each acknowledged
//!   before the next; `TableCommit` checks length, CRC-32 and the table
//!   itself. The device uses a stored table from its next boot on and
//!   reports it in `Info` (`table_source`, `stored_table`).
//!
//! # Examples
//!
//! `HostMessage { seq: 1, body: Ping }`: payload `01 05`, CRC 0x7E9B,
//! frame `05 01 05 7E 9B 00`.
//!
//! `HostMessage { seq: 7, body: Start }`: payload `07 00`, CRC 0x8498,
//! frame `02 07 03 84 98 00`.
//!
//! `DeviceMessage::Ack { seq: 1 }`: payload `00 01`, CRC 0x0D2E,
//! frame `01 04 01 0D 2E 00`.
//!
//! `Start` refused because the fitted sensor could not see the trip
//! (`Nack { seq: Some(17), reason: Command(SensorRange(MaxPressureKpa)) }`):
//! payload `01 01 11 00 06 07`, CRC 0x56B3, frame
//! `04 01 01 11 05 06 07 56 B3 00`.
//!
//! `DeviceMessage::Sample` with `t_ms = 1000`, `volume_ml = 0.5`,
//! `pressure_kpa = 1.25`, `state = Expand`, `fault = None`,
//! `diameter_volume_mm = 19.0`, `diameter_table_mm = 19.25`, `cycle = 2`,
//! `pressure_zero_kpa = 101.25` (26-byte payload, 30-byte frame):
//!
//! ```text
//! payload 03 | E8 07 | 00 00 00 3F | 00 00 A0 3F | 01 | 00 | 00 00 98 41 | 00 00 9A 41 | 02    | 00 80 CA 42
//!         tag  t_ms    volume_ml     pressure_kpa  st  flt  d_volume      d_table       cycle   zero
//! crc     E1 C2
//! frame   04 03 E8 07 01 01 02 3F 01 04 A0 3F 01 01 01 03 98 41 01 04 9A 41 02 06 80 CA 42 E1 C2 00
//! ```
//!
//! A `Sample` frame is 30 to 36 bytes, about 2.6–3.1 ms at 115200 baud
//! (11 520 bytes/s), so the link carries 100 samples/s at about a third of
//! its capacity.
//!
//! # Use
//!
//! ```
//! use urechis::protocol::{encode_host, HostCommand, HostDecoder, HostMessage, MAX_FRAME};
//!
//! let mut buf = [0u8; MAX_FRAME];
//! let frame = encode_host(&HostMessage { seq: 1, body: HostCommand::Ping }, &mut buf).unwrap();
//! assert_eq!(frame, [0x05, 0x01, 0x05, 0x7E, 0x9B, 0x00]);
//!
//! let mut decoder = HostDecoder::new();
//! let got: Vec<_> = frame.iter().filter_map(|&b| decoder.push(b)).collect();
//! assert_eq!(got, [Ok(HostMessage { seq: 1, body: HostCommand::Ping })]);
//! ```
//!
//! # Fuzzing
//!
//! `fuzz/fuzz_targets/decode_frame.rs` feeds arbitrary bytes to both stream
//! decoders and checks that nothing panics and that every decoded message
//! re-encodes to a frame that decodes to the same message. It is not part of
//! CI; run it with `cargo install cargo-fuzz`, then from `fuzz/`:
//!
//! ```text
//! cargo +nightly fuzz run decode_frame corpus/decode_frame seeds/decode_frame
//! ```
//!
//! (`seeds/` holds the example frames above; add `-- -max_total_time=60` for
//! a bounded run.)

// Layers, each using only those above it: `frame` (generic COBS + CRC
// framing, `FrameError`), `message` (the message types, which carry a
// `FrameError` in `NackReason`), `codec` (the typed encoders and decoders).
mod codec;
mod frame;
mod message;

pub use codec::*;
pub use frame::*;
pub use message::*;
