//! Replay of a recorded emulator run: the controller's inputs at every step
//! and the decisions the host's controller made, in a compact binary that
//! `host-sim emulate --export-replay` writes ([`Recorder`]) and this
//! module checks ([`check`]) by feeding the same inputs through the same
//! [`Controller`] (here compiled for the Cortex-M4 and run under QEMU; the
//! host runs the same check in host-sim's tests).
//!
//! Every step's state, latched fault, pump command (rate bit for bit),
//! relief valve, advance drive, watchdog feed, cycle count and command
//! result must match; a CRC-32 over every step's telemetry frame (the
//! protocol's own encoding, so the diameters and pressures to the bit)
//! must match at the end.
//!
//! # Format (little-endian), version [`VERSION`]
//!
//! ```text
//! header: "URRP" · u16 version · u32 table checksum · f32 pressure zero (absolute kPa, NaN = none)
//!         · u32 steps · u8 name length · name
//! step:   u8 in-flags
//!         [u32 now_ms]            unless IN_NEXT_PERIOD (= previous + CONTROL_PERIOD_MS)
//!         [f32 pressure_kpa]      when the sample is a Reading
//!         [u16 age_ms | u32 taken_ms]  Reading: now − taken, or the stamp itself with IN_TAKEN_ABS
//!         [f32 pump_volume_ml]    unless IN_SAME_VOLUME (bit-identical to the previous step)
//!         [u8 len · frame]        with IN_COMMAND: the Command as a protocol frame
//!         u8 state (low nibble) | fault code (high nibble, 0 = none)
//!         u8 out-flags
//!         [f32 rate_ml_per_s]     with OUT_NEW_RATE
//!         [u16 cycle]             with OUT_NEW_CYCLE
//!         [u8 len · frame]        with OUT_RESULT: the command result as a protocol frame
//! trailer: u32 CRC-32 over every step's telemetry frame
//! ```

use crate::controller::{
    Command, CommandError, Controller, EndStops, Fault, Inputs, Outputs, PressureSample,
    PumpCommand, State, CONTROL_PERIOD_MS,
};
use crate::protocol::{decode_frame, encode, ProtocolError, MAX_FRAME};
use crate::table::{Table, CHECKSUM_ALGORITHM};

/// File magic.
pub const MAGIC: [u8; 4] = *b"URRP";
/// Format version.
pub const VERSION: u16 = 2;

const SAMPLE_MASK: u8 = 0b11;
const SAMPLE_READING: u8 = 0;
const SAMPLE_BUS_ERROR: u8 = 1;
const SAMPLE_MISSING: u8 = 2;
const IN_EMPTY: u8 = 1 << 2;
const IN_FULL: u8 = 1 << 3;
const IN_COMMAND: u8 = 1 << 4;
const IN_NEXT_PERIOD: u8 = 1 << 5;
const IN_SAME_VOLUME: u8 = 1 << 6;
const IN_TAKEN_ABS: u8 = 1 << 7;

const PUMP_MASK: u8 = 0b11;
const PUMP_DISABLE: u8 = 0;
const PUMP_HOLD: u8 = 1;
const PUMP_RUN: u8 = 2;
const OUT_VALVE: u8 = 1 << 2;
const OUT_ADVANCE: u8 = 1 << 3;
const OUT_WATCHDOG: u8 = 1 << 4;
const OUT_RESULT: u8 = 1 << 5;
const OUT_NEW_RATE: u8 = 1 << 6;
const OUT_NEW_CYCLE: u8 = 1 << 7;

fn state_code(state: State) -> u8 {
    State::ALL.iter().position(|s| *s == state).unwrap_or(0) as u8
}

fn fault_code(fault: Option<Fault>) -> u8 {
    fault.map_or(0, |f| {
        Fault::ALL
            .iter()
            .position(|x| *x == f)
            .map_or(0, |i| i as u8 + 1)
    })
}

/// A frame too long for one length byte or the encoder's buffer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EncodeError;

/// Writes a recording step by step into a byte sink.
#[derive(Clone, Copy, Debug, Default)]
pub struct Recorder {
    prev_now_ms: Option<u32>,
    prev_volume_bits: Option<u32>,
    prev_rate_bits: Option<u32>,
    prev_cycle: u16,
    digest: u32,
    steps: u32,
}

/// Folds one step's telemetry into the running digest (0 at the start):
/// CRC-32 of (previous digest ‖ the telemetry's protocol frame).
fn fold_telemetry(digest: u32, outputs: &Outputs) -> Result<u32, EncodeError> {
    let mut buf = [0u8; MAX_FRAME];
    let frame = encode(&outputs.telemetry, &mut buf).map_err(|_| EncodeError)?;
    let mut crc = CHECKSUM_ALGORITHM.digest();
    crc.update(&digest.to_le_bytes());
    crc.update(frame);
    Ok(crc.finalize())
}

impl Recorder {
    /// The header for `steps` steps of run `name` against table checksum
    /// `table_checksum`, the controller set to pressure zero
    /// `pressure_zero_kpa` (absolute kPa; NaN for none) at boot.
    pub fn header(
        table_checksum: u32,
        pressure_zero_kpa: f32,
        steps: u32,
        name: &str,
        out: &mut impl FnMut(&[u8]),
    ) -> Result<(), EncodeError> {
        let len = u8::try_from(name.len()).map_err(|_| EncodeError)?;
        out(&MAGIC);
        out(&VERSION.to_le_bytes());
        out(&table_checksum.to_le_bytes());
        out(&pressure_zero_kpa.to_bits().to_le_bytes());
        out(&steps.to_le_bytes());
        out(&[len]);
        out(name.as_bytes());
        Ok(())
    }

    /// Appends one step: what the controller saw and what it decided.
    pub fn step(
        &mut self,
        inputs: &Inputs,
        outputs: &Outputs,
        out: &mut impl FnMut(&[u8]),
    ) -> Result<(), EncodeError> {
        let mut flags = 0u8;
        let (sample, reading) = match inputs.pressure {
            PressureSample::Reading {
                pressure_kpa,
                taken_ms,
            } => (SAMPLE_READING, Some((pressure_kpa, taken_ms))),
            PressureSample::BusError => (SAMPLE_BUS_ERROR, None),
            PressureSample::Missing => (SAMPLE_MISSING, None),
        };
        flags |= sample;
        if inputs.end_stops.empty {
            flags |= IN_EMPTY;
        }
        if inputs.end_stops.full {
            flags |= IN_FULL;
        }
        if inputs.command.is_some() {
            flags |= IN_COMMAND;
        }
        let next = self
            .prev_now_ms
            .is_some_and(|p| p.wrapping_add(CONTROL_PERIOD_MS) == inputs.now_ms);
        if next {
            flags |= IN_NEXT_PERIOD;
        }
        let volume_bits = inputs.pump_volume_ml.to_bits();
        if self.prev_volume_bits == Some(volume_bits) {
            flags |= IN_SAME_VOLUME;
        }
        let age = reading.map(|(_, taken)| inputs.now_ms.wrapping_sub(taken));
        let age16 = age.and_then(|a| u16::try_from(a).ok());
        if reading.is_some() && age16.is_none() {
            flags |= IN_TAKEN_ABS;
        }
        out(&[flags]);
        if !next {
            out(&inputs.now_ms.to_le_bytes());
        }
        if let Some((pressure_kpa, taken_ms)) = reading {
            out(&pressure_kpa.to_bits().to_le_bytes());
            match age16 {
                Some(a) => out(&a.to_le_bytes()),
                None => out(&taken_ms.to_le_bytes()),
            }
        }
        if self.prev_volume_bits != Some(volume_bits) {
            out(&volume_bits.to_le_bytes());
        }
        if let Some(command) = &inputs.command {
            let mut buf = [0u8; MAX_FRAME];
            write_frame(encode(command, &mut buf), out)?;
        }
        self.prev_now_ms = Some(inputs.now_ms);
        self.prev_volume_bits = Some(volume_bits);

        out(&[state_code(outputs.state) | (fault_code(outputs.telemetry.fault) << 4)]);
        let mut flags = match outputs.pump {
            PumpCommand::Disable => PUMP_DISABLE,
            PumpCommand::Hold => PUMP_HOLD,
            PumpCommand::Run { .. } => PUMP_RUN,
        };
        for (on, bit) in [
            (outputs.relief_valve_open, OUT_VALVE),
            (outputs.advance_drive, OUT_ADVANCE),
            (outputs.feed_watchdog, OUT_WATCHDOG),
            (outputs.command_result.is_some(), OUT_RESULT),
        ] {
            if on {
                flags |= bit;
            }
        }
        let rate_bits = match outputs.pump {
            PumpCommand::Run { rate_ml_per_s } => Some(rate_ml_per_s.to_bits()),
            _ => None,
        };
        let new_rate = rate_bits.is_some() && rate_bits != self.prev_rate_bits;
        if new_rate {
            flags |= OUT_NEW_RATE;
            self.prev_rate_bits = rate_bits;
        }
        let cycle = outputs.telemetry.cycle;
        let new_cycle = cycle != self.prev_cycle;
        if new_cycle {
            flags |= OUT_NEW_CYCLE;
            self.prev_cycle = cycle;
        }
        out(&[flags]);
        if let (true, Some(bits)) = (new_rate, rate_bits) {
            out(&bits.to_le_bytes());
        }
        if new_cycle {
            out(&cycle.to_le_bytes());
        }
        if let Some(result) = &outputs.command_result {
            let mut buf = [0u8; MAX_FRAME];
            write_frame(encode(result, &mut buf), out)?;
        }
        self.digest = fold_telemetry(self.digest, outputs)?;
        self.steps += 1;
        Ok(())
    }

    /// Steps recorded so far.
    pub fn steps(&self) -> u32 {
        self.steps
    }

    /// The trailer: the telemetry CRC.
    pub fn finish(&self, out: &mut impl FnMut(&[u8])) {
        out(&self.digest.to_le_bytes());
    }
}

/// An encoded frame as `u8 length · frame`.
fn write_frame(
    frame: Result<&[u8], ProtocolError>,
    out: &mut impl FnMut(&[u8]),
) -> Result<(), EncodeError> {
    let frame = frame.map_err(|_| EncodeError)?;
    let len = u8::try_from(frame.len()).map_err(|_| EncodeError)?;
    out(&[len]);
    out(frame);
    Ok(())
}

/// A recorded output that differs from the replayed controller's.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Field {
    /// State after the step.
    State,
    /// Latched fault.
    Fault,
    /// Pump command kind (0 Disable, 1 Hold, 2 Run).
    Pump,
    /// Pump rate bits.
    Rate,
    /// Relief valve.
    Valve,
    /// Advance drive.
    Advance,
    /// Watchdog feed.
    Watchdog,
    /// Completed cycles.
    Cycle,
    /// The command's result (1 = equal, 0 = differs).
    CommandResult,
}

/// Why a replay failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ReplayError {
    /// The bytes end early (offset where more was needed).
    Truncated(usize),
    /// Not a replay file.
    BadMagic,
    /// Another format version.
    Version(u16),
    /// Recorded against another table: regenerate the replay.
    TableChecksum {
        /// In the file.
        recorded: u32,
        /// Compiled in.
        compiled: u32,
    },
    /// A code or frame in step `.0` does not decode.
    Corrupt(u32),
    /// A decision differs.
    Mismatch {
        /// Step index.
        step: u32,
        /// Its time (ms).
        now_ms: u32,
        /// Which output.
        field: Field,
        /// Recorded value (code or bits).
        expected: u32,
        /// Replayed value (code or bits).
        got: u32,
    },
    /// Every decision matched but the telemetry digest differs.
    TelemetryDigest {
        /// Recorded.
        expected: u32,
        /// Replayed.
        got: u32,
    },
    /// Bytes after the trailer.
    Trailing(usize),
}

impl core::fmt::Display for ReplayError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match *self {
            ReplayError::Truncated(at) => write!(f, "truncated at byte {at}"),
            ReplayError::BadMagic => write!(f, "not a replay file"),
            ReplayError::Version(v) => write!(f, "format version {v}, expected {VERSION}"),
            ReplayError::TableChecksum { recorded, compiled } => write!(
                f,
                "recorded against table {recorded:#010x}, compiled-in table is {compiled:#010x}: \
                 re-export the replay"
            ),
            ReplayError::Corrupt(step) => write!(f, "step {step} does not decode"),
            ReplayError::Mismatch {
                step,
                now_ms,
                field,
                expected,
                got,
            } => write!(
                f,
                "step {step} (t = {now_ms} ms): {field:?} recorded {expected:#x}, replayed {got:#x}"
            ),
            ReplayError::TelemetryDigest { expected, got } => write!(
                f,
                "telemetry digest recorded {expected:#010x}, replayed {got:#010x}"
            ),
            ReplayError::Trailing(n) => write!(f, "{n} bytes after the trailer"),
        }
    }
}

/// What a replay file says about itself.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Header<'a> {
    /// Scenario name.
    pub name: &'a str,
    /// Checksum of the table it was recorded against.
    pub table_checksum: u32,
    /// Pressure zero the controller was given at boot (absolute kPa; NaN
    /// for none).
    pub pressure_zero_kpa: f32,
    /// Steps recorded.
    pub steps: u32,
}

/// A passed replay.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Summary {
    /// Steps replayed.
    pub steps: u32,
    /// Telemetry digest (equal to the recorded one).
    pub digest: u32,
}

/// Reads little-endian values off a byte slice.
struct Cursor<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Cursor<'a> {
    fn take(&mut self, n: usize) -> Result<&'a [u8], ReplayError> {
        let end = self
            .at
            .checked_add(n)
            .ok_or(ReplayError::Truncated(self.at))?;
        let s = self
            .bytes
            .get(self.at..end)
            .ok_or(ReplayError::Truncated(self.at))?;
        self.at = end;
        Ok(s)
    }
    fn array<const N: usize>(&mut self) -> Result<[u8; N], ReplayError> {
        let mut a = [0u8; N];
        a.copy_from_slice(self.take(N)?);
        Ok(a)
    }
    fn u8(&mut self) -> Result<u8, ReplayError> {
        Ok(self.array::<1>()?[0])
    }
    fn u16(&mut self) -> Result<u16, ReplayError> {
        Ok(u16::from_le_bytes(self.array()?))
    }
    fn u32(&mut self) -> Result<u32, ReplayError> {
        Ok(u32::from_le_bytes(self.array()?))
    }
    /// A `u8 length · frame` copied into `buf` (decoding works in place).
    fn frame<'b>(&mut self, buf: &'b mut [u8; MAX_FRAME]) -> Result<&'b mut [u8], ReplayError> {
        let len = usize::from(self.u8()?);
        let bytes = self.take(len)?;
        // The stored frame ends with its delimiter; the decoder wants it off.
        let body = bytes
            .split_last()
            .map(|(_, body)| body)
            .ok_or(ReplayError::Truncated(self.at))?;
        let dst = buf
            .get_mut(..body.len())
            .ok_or(ReplayError::Truncated(self.at))?;
        dst.copy_from_slice(body);
        Ok(dst)
    }
}

/// Reads the header.
pub fn header(bytes: &[u8]) -> Result<Header<'_>, ReplayError> {
    read_header(&mut Cursor { bytes, at: 0 })
}

fn read_header<'a>(c: &mut Cursor<'a>) -> Result<Header<'a>, ReplayError> {
    if c.array::<4>()? != MAGIC {
        return Err(ReplayError::BadMagic);
    }
    let version = c.u16()?;
    if version != VERSION {
        return Err(ReplayError::Version(version));
    }
    let table_checksum = c.u32()?;
    let pressure_zero_kpa = f32::from_bits(c.u32()?);
    let steps = c.u32()?;
    let len = usize::from(c.u8()?);
    let name = core::str::from_utf8(c.take(len)?).map_err(|_| ReplayError::BadMagic)?;
    Ok(Header {
        name,
        table_checksum,
        pressure_zero_kpa,
        steps,
    })
}

/// Replays `bytes` through a fresh [`Controller`] (booted with
/// [`crate::controller::Params::DEFAULT`] and `table`, as the emulator boots it) and checks
/// every decision and the telemetry digest.
pub fn check(bytes: &[u8], table: Table<'_>) -> Result<Summary, ReplayError> {
    let mut c = Cursor { bytes, at: 0 };
    let head = read_header(&mut c)?;
    if head.table_checksum != table.checksum {
        return Err(ReplayError::TableChecksum {
            recorded: head.table_checksum,
            compiled: table.checksum,
        });
    }
    let mut ctrl = Controller::with_default_params(table);
    ctrl.set_pressure_zero((!head.pressure_zero_kpa.is_nan()).then_some(head.pressure_zero_kpa));
    let mut now_ms = 0u32;
    let mut volume_bits = 0u32;
    let mut rate_bits = 0u32;
    let mut cycle = 0u16;
    let mut digest = 0u32;
    for step in 0..head.steps {
        let corrupt = |_| ReplayError::Corrupt(step);
        // --- inputs ---
        let flags = c.u8()?;
        now_ms = if flags & IN_NEXT_PERIOD != 0 {
            now_ms.wrapping_add(CONTROL_PERIOD_MS)
        } else {
            c.u32()?
        };
        let pressure = match flags & SAMPLE_MASK {
            SAMPLE_READING => {
                let pressure_kpa = f32::from_bits(c.u32()?);
                let taken_ms = if flags & IN_TAKEN_ABS != 0 {
                    c.u32()?
                } else {
                    now_ms.wrapping_sub(u32::from(c.u16()?))
                };
                PressureSample::Reading {
                    pressure_kpa,
                    taken_ms,
                }
            }
            SAMPLE_BUS_ERROR => PressureSample::BusError,
            SAMPLE_MISSING => PressureSample::Missing,
            _ => return Err(ReplayError::Corrupt(step)),
        };
        if flags & IN_SAME_VOLUME == 0 {
            volume_bits = c.u32()?;
        }
        let mut buf = [0u8; MAX_FRAME];
        let command = if flags & IN_COMMAND != 0 {
            Some(decode_frame::<Command>(c.frame(&mut buf)?).map_err(corrupt)?)
        } else {
            None
        };
        let inputs = Inputs {
            now_ms,
            pressure,
            pump_volume_ml: f32::from_bits(volume_bits),
            end_stops: EndStops {
                empty: flags & IN_EMPTY != 0,
                full: flags & IN_FULL != 0,
            },
            command,
        };
        // --- recorded decisions ---
        let codes = c.u8()?;
        let out_flags = c.u8()?;
        if out_flags & OUT_NEW_RATE != 0 {
            rate_bits = c.u32()?;
        }
        if out_flags & OUT_NEW_CYCLE != 0 {
            cycle = c.u16()?;
        }
        let result = if out_flags & OUT_RESULT != 0 {
            Some(decode_frame::<Result<(), CommandError>>(c.frame(&mut buf)?).map_err(corrupt)?)
        } else {
            None
        };
        // --- replay and compare ---
        let out = ctrl.step(&inputs);
        let (pump_kind, got_rate) = match out.pump {
            PumpCommand::Disable => (PUMP_DISABLE, None),
            PumpCommand::Hold => (PUMP_HOLD, None),
            PumpCommand::Run { rate_ml_per_s } => (PUMP_RUN, Some(rate_ml_per_s.to_bits())),
        };
        let bit = |on: bool| u32::from(on);
        let checks = [
            (
                Field::State,
                u32::from(codes & 0x0f),
                u32::from(state_code(out.state)),
            ),
            (
                Field::Fault,
                u32::from(codes >> 4),
                u32::from(fault_code(out.telemetry.fault)),
            ),
            (
                Field::Pump,
                u32::from(out_flags & PUMP_MASK),
                u32::from(pump_kind),
            ),
            (
                Field::Rate,
                if out_flags & PUMP_MASK == PUMP_RUN {
                    rate_bits
                } else {
                    0
                },
                got_rate.unwrap_or(0),
            ),
            (
                Field::Valve,
                bit(out_flags & OUT_VALVE != 0),
                bit(out.relief_valve_open),
            ),
            (
                Field::Advance,
                bit(out_flags & OUT_ADVANCE != 0),
                bit(out.advance_drive),
            ),
            (
                Field::Watchdog,
                bit(out_flags & OUT_WATCHDOG != 0),
                bit(out.feed_watchdog),
            ),
            (
                Field::Cycle,
                u32::from(cycle),
                u32::from(out.telemetry.cycle),
            ),
            (Field::CommandResult, 1, bit(result == out.command_result)),
        ];
        for (field, expected, got) in checks {
            if expected != got {
                return Err(ReplayError::Mismatch {
                    step,
                    now_ms,
                    field,
                    expected,
                    got,
                });
            }
        }
        digest = fold_telemetry(digest, &out).map_err(|_| ReplayError::Corrupt(step))?;
    }
    let expected = c.u32()?;
    if expected != digest {
        return Err(ReplayError::TelemetryDigest {
            expected,
            got: digest,
        });
    }
    if c.at != bytes.len() {
        return Err(ReplayError::Trailing(bytes.len() - c.at));
    }
    Ok(Summary {
        steps: head.steps,
        digest,
    })
}
