//! A serial port speaking the firmware's protocol ([`urechis::protocol`],
//! the only implementation: frames are encoded and decoded by the
//! firmware's own code).

use std::collections::VecDeque;
use std::io::{ErrorKind, Read, Write};
use std::time::{Duration, Instant};

use anyhow::{anyhow, bail, Context, Result};
use serialport::{SerialPort, SerialPortType};
use urechis::controller::Telemetry;
use urechis::protocol::{
    encode_host, DeviceDecoder, DeviceMessage, FrameError, Hello, HostCommand, HostMessage, Info,
    NackReason, MAX_FRAME, PROTOCOL_VERSION,
};

/// Baud rate of the board's link (the ST-LINK virtual COM port).
pub const BAUD_RATE: u32 = 115_200;

/// Longest wait for a reply (ms). A tare takes about 0.2 s on the board; a
/// table erase up to a few seconds.
pub const REPLY_TIMEOUT_MS: u64 = 1_000;

/// Longest wait for the reply to a command that erases flash (ms).
pub const ERASE_TIMEOUT_MS: u64 = 8_000;

/// USB vendor id of STMicroelectronics.
pub const ST_VID: u16 = 0x0483;

/// USB product ids of the ST-LINK probes with a virtual COM port (V2,
/// V2-1 as on the NUCLEO boards, V3).
pub const STLINK_PIDS: [u16; 10] = [
    0x3748, 0x374A, 0x374B, 0x374D, 0x374E, 0x374F, 0x3752, 0x3753, 0x3754, 0x3757,
];

/// The ST-LINK virtual COM port: the one serial port with ST's vendor id
/// and an ST-LINK product id. Fails, naming what it saw, when there is
/// none or more than one.
pub fn find_stlink_port() -> Result<String> {
    let ports = serialport::available_ports().context("listing the serial ports")?;
    let found: Vec<String> = ports
        .iter()
        .filter(|p| match &p.port_type {
            SerialPortType::UsbPort(usb) => usb.vid == ST_VID && STLINK_PIDS.contains(&usb.pid),
            _ => false,
        })
        .map(|p| p.port_name.clone())
        .collect();
    match found.as_slice() {
        [one] => Ok(one.clone()),
        [] => bail!(
            "no ST-LINK virtual COM port found (USB {ST_VID:04x}:{{{}}}) among {} serial \
             port(s): plug the NUCLEO in, or give --port PATH",
            STLINK_PIDS
                .iter()
                .map(|p| format!("{p:04x}"))
                .collect::<Vec<_>>()
                .join(","),
            ports.len()
        ),
        many => bail!(
            "several ST-LINK virtual COM ports found ({}): choose one with --port PATH",
            many.join(", ")
        ),
    }
}

/// Frames the host dropped, by cause.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RxErrors {
    /// Frames whose CRC-16 failed.
    pub crc: u64,
    /// Frames dropped for any other reason (COBS, length, decoding).
    pub other: u64,
}

/// An open link to a board.
pub struct Link {
    port: Box<dyn SerialPort>,
    name: String,
    decoder: DeviceDecoder,
    seq: u8,
    errors: RxErrors,
    /// Bytes received so far.
    received: u64,
    /// Messages read while waiting for something else (telemetry during a
    /// request), in order.
    backlog: VecDeque<DeviceMessage>,
    /// The last `Hello` seen (the board booted).
    hello: Option<Hello>,
}

impl Link {
    /// Opens `path` at 115200 8N1, drops whatever was waiting in it and
    /// sends a lone delimiter so the board's decoder starts clean.
    pub fn open(path: &str) -> Result<Link> {
        let port = serialport::new(path, BAUD_RATE)
            .timeout(Duration::from_millis(20))
            .open()
            .with_context(|| format!("port {path}: cannot open it"))?;
        Link::over(port, path)
    }

    /// A link over an already open port called `name` (in messages).
    pub fn over(port: Box<dyn SerialPort>, name: &str) -> Result<Link> {
        let mut link = Link {
            port,
            name: name.to_owned(),
            decoder: DeviceDecoder::new(),
            seq: 0,
            errors: RxErrors::default(),
            received: 0,
            backlog: VecDeque::new(),
            hello: None,
        };
        // Old telemetry a virtual port kept while nobody listened.
        let _ = link.port.clear(serialport::ClearBuffer::Input);
        link.write(&[0])?;
        Ok(link)
    }

    /// The port's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Frames dropped so far.
    pub fn errors(&self) -> RxErrors {
        self.errors
    }

    /// The last `Hello` seen.
    pub fn hello(&self) -> Option<&Hello> {
        self.hello.as_ref()
    }

    fn write(&mut self, bytes: &[u8]) -> Result<()> {
        self.port
            .write_all(bytes)
            .and_then(|()| self.port.flush())
            .with_context(|| format!("port {}: writing failed (closed?)", self.name))
    }

    /// Sends `body` with the next sequence number; returns that number.
    pub fn send(&mut self, body: HostCommand) -> Result<u8> {
        self.seq = self.seq.wrapping_add(1);
        let msg = HostMessage {
            seq: self.seq,
            body,
        };
        let mut buf = [0u8; MAX_FRAME];
        let frame = encode_host(&msg, &mut buf)
            .map_err(|e| anyhow!("cannot encode {:?}: {e:?}", msg.body))?
            .to_vec();
        self.write(&frame)?;
        Ok(self.seq)
    }

    /// The next message, waiting at most `timeout`; `None` when none came.
    /// Damaged frames are counted ([`Link::errors`]), never returned.
    pub fn next(&mut self, timeout: Duration) -> Result<Option<DeviceMessage>> {
        if let Some(m) = self.backlog.pop_front() {
            return Ok(Some(m));
        }
        let deadline = Instant::now() + timeout;
        let mut buf = [0u8; 256];
        loop {
            let n = match self.port.read(&mut buf) {
                Ok(0) => bail!("port {}: closed (end of stream)", self.name),
                Ok(n) => n,
                Err(e) if e.kind() == ErrorKind::TimedOut || e.kind() == ErrorKind::WouldBlock => 0,
                Err(e) if e.kind() == ErrorKind::Interrupted => 0,
                Err(e) => bail!("port {}: reading failed (closed?): {e}", self.name),
            };
            self.received += n as u64;
            for &b in buf.get(..n).unwrap_or(&[]) {
                match self.decoder.push(b) {
                    Some(Ok(msg)) => {
                        if let DeviceMessage::Hello(h) = msg {
                            self.hello = Some(h);
                        }
                        self.backlog.push_back(msg);
                    }
                    Some(Err(FrameError::Crc)) => self.errors.crc += 1,
                    Some(Err(_)) => self.errors.other += 1,
                    None => {}
                }
            }
            if let Some(m) = self.backlog.pop_front() {
                return Ok(Some(m));
            }
            if Instant::now() >= deadline {
                return Ok(None);
            }
        }
    }

    /// Sends `body` and waits up to `timeout_ms` for its reply (the
    /// message echoing its sequence number, or a `Nack` for a frame the
    /// board could not read). Telemetry and other messages that arrive
    /// meanwhile are handed to `other`.
    pub fn request_with(
        &mut self,
        body: HostCommand,
        timeout_ms: u64,
        other: &mut dyn FnMut(&DeviceMessage),
    ) -> Result<DeviceMessage> {
        let what = command_name(&body);
        let seq = self.send(body)?;
        let deadline = Instant::now() + Duration::from_millis(timeout_ms);
        let received_before = self.received;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            // Telemetry keeps coming: the deadline holds whatever arrives.
            let msg = if left.is_zero() {
                None
            } else {
                self.next(left)?
            };
            let Some(msg) = msg else {
                let heard = self.received - received_before;
                if heard == 0 {
                    bail!(
                        "port {}: no answer to {what} within {timeout_ms} ms (is a board with \
                         the urechis firmware on this port, and powered?)",
                        self.name
                    );
                }
                bail!(
                    "port {}: no reply to {what} within {timeout_ms} ms; {heard} byte(s) came \
                     ({} frame(s) failed their CRC, {} were no protocol frames): not a board \
                     speaking this protocol, or another baud rate",
                    self.name,
                    self.errors.crc,
                    self.errors.other
                );
            };
            if reply_seq(&msg) == Some(seq) {
                return Ok(msg);
            }
            if let DeviceMessage::Nack {
                seq: None,
                reason: NackReason::Frame(e),
            } = msg
            {
                bail!(
                    "port {}: the board could not read {what} ({e:?}): it speaks another \
                     protocol version than this host-sim ({PROTOCOL_VERSION}), or the line \
                     damaged the frame",
                    self.name
                );
            }
            other(&msg);
        }
    }

    /// [`Link::request_with`], dropping other messages.
    pub fn request(&mut self, body: HostCommand) -> Result<DeviceMessage> {
        self.request_with(body, REPLY_TIMEOUT_MS, &mut |_| {})
    }

    /// Sends a command answered by `Ack`/`Nack`: `Ok(Ok(()))` when
    /// accepted, `Ok(Err(reason))` when refused.
    pub fn command(
        &mut self,
        body: HostCommand,
        timeout_ms: u64,
    ) -> Result<Result<(), NackReason>> {
        let what = command_name(&body);
        match self.request_with(body, timeout_ms, &mut |_| {})? {
            DeviceMessage::Ack { .. } => Ok(Ok(())),
            DeviceMessage::Nack { reason, .. } => Ok(Err(reason)),
            other => bail!("port {}: unexpected reply to {what}: {other:?}", self.name),
        }
    }

    /// Checks that a board speaking this protocol is there (`Ping`, then
    /// `GetInfo` and its protocol version) and returns what it runs.
    pub fn connect(&mut self) -> Result<Info> {
        match self.request(HostCommand::Ping)? {
            DeviceMessage::Pong { .. } => {}
            other => bail!("port {}: unexpected reply to Ping: {other:?}", self.name),
        }
        if let Some(h) = self.hello {
            check_version(&self.name, h.protocol_version)?;
        }
        let info = match self.request(HostCommand::GetInfo)? {
            DeviceMessage::Info { info, .. } => info,
            other => bail!("port {}: unexpected reply to GetInfo: {other:?}", self.name),
        };
        check_version(&self.name, info.protocol_version)?;
        Ok(info)
    }

    /// The board's parameters.
    pub fn params(&mut self) -> Result<urechis::controller::Params> {
        match self.request(HostCommand::GetParams)? {
            DeviceMessage::Params { params, .. } => Ok(params),
            other => bail!(
                "port {}: unexpected reply to GetParams: {other:?}",
                self.name
            ),
        }
    }

    /// Waits for the next telemetry sample (at most `timeout`).
    pub fn next_sample(&mut self, timeout: Duration) -> Result<Option<Telemetry>> {
        let deadline = Instant::now() + timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.next(left)? {
                Some(DeviceMessage::Sample(t)) => return Ok(Some(t)),
                Some(_) => {}
                None => return Ok(None),
            }
        }
    }
}

fn check_version(port: &str, version: u16) -> Result<()> {
    if version != PROTOCOL_VERSION {
        bail!(
            "port {port}: the board speaks protocol {version}, this host-sim speaks \
             {PROTOCOL_VERSION}: flash the firmware of this repository (cargo run --release)"
        );
    }
    Ok(())
}

/// The sequence number a reply echoes.
fn reply_seq(msg: &DeviceMessage) -> Option<u8> {
    match *msg {
        DeviceMessage::Ack { seq }
        | DeviceMessage::Params { seq, .. }
        | DeviceMessage::Pong { seq }
        | DeviceMessage::Info { seq, .. } => Some(seq),
        DeviceMessage::Nack { seq, .. } => seq,
        DeviceMessage::Sample(_) | DeviceMessage::Hello(_) => None,
    }
}

/// A command's name in messages.
pub fn command_name(body: &HostCommand) -> &'static str {
    match body {
        HostCommand::Start => "Start",
        HostCommand::Stop => "Stop",
        HostCommand::Reset => "Reset",
        HostCommand::GetParams => "GetParams",
        HostCommand::SetParams(_) => "SetParams",
        HostCommand::Ping => "Ping",
        HostCommand::Heartbeat => "Heartbeat",
        HostCommand::Tare => "Tare",
        HostCommand::GetInfo => "GetInfo",
        HostCommand::TableBegin { .. } => "TableBegin",
        HostCommand::TableChunk { .. } => "TableChunk",
        HostCommand::TableCommit => "TableCommit",
    }
}
