//! The link's errors over a real pseudo-terminal, with a scripted device on
//! the other end: each ends in a message that names the port.

use std::io::{Read, Write};
use std::thread;
use std::time::Duration;

use boardlink::Link;
use serialport::{SerialPort, TTYPort};
use urechis::protocol::{
    encode_device, DeviceMessage, FirmwareVersion, HostCommand, HostDecoder, Info, StoredTable,
    TableSource, MAX_FRAME, PROTOCOL_VERSION,
};

/// A pty whose master side runs `device` on a thread; returns the slave's
/// path (kept open by the returned port).
fn pty(device: impl FnOnce(TTYPort) + Send + 'static) -> (String, TTYPort) {
    let (master, slave) = TTYPort::pair().unwrap();
    let name = slave.name().unwrap();
    thread::spawn(move || device(master));
    (name, slave)
}

fn frame(msg: &DeviceMessage) -> Vec<u8> {
    let mut buf = [0u8; MAX_FRAME];
    encode_device(msg, &mut buf).unwrap().to_vec()
}

fn info(protocol_version: u16) -> Info {
    let t = urechis::table::generated::TABLE;
    Info {
        protocol_version,
        firmware_version: FirmwareVersion::CURRENT,
        table_format_version: t.format_version,
        table_checksum: t.checksum,
        table_placeholder: t.placeholder,
        table_source: TableSource::CompiledIn,
        stored_table: StoredTable::Absent,
        pressure_zero_kpa: f32::NAN,
        state: urechis::controller::State::Idle,
        fault: None,
        alarm: None,
        last_fault: None,
        last_fault_ms: 0,
        uptime_ms: 0,
        frame_errors: 0,
        telemetry_dropped: 0,
    }
}

/// A device that answers Ping and GetInfo (with `version`), and sends one
/// frame with a broken CRC before each reply.
fn device(version: u16) -> impl FnOnce(TTYPort) + Send + 'static {
    move |mut port: TTYPort| {
        port.set_timeout(Duration::from_millis(50)).unwrap();
        let mut decoder = HostDecoder::new();
        let mut buf = [0u8; 64];
        for _ in 0..200 {
            let n = match port.read(&mut buf) {
                Ok(n) => n,
                Err(_) => continue,
            };
            for &b in &buf[..n] {
                let Some(Ok(msg)) = decoder.push(b) else {
                    continue;
                };
                let reply = match msg.body {
                    HostCommand::Ping => DeviceMessage::Pong { seq: msg.seq },
                    HostCommand::GetInfo => DeviceMessage::Info {
                        seq: msg.seq,
                        info: info(version),
                    },
                    _ => continue,
                };
                let mut damaged = frame(&DeviceMessage::Ack { seq: 99 });
                damaged[2] ^= 0x10;
                port.write_all(&damaged).unwrap();
                port.write_all(&frame(&reply)).unwrap();
            }
        }
    }
}

#[test]
fn another_protocol_version_is_refused_by_name() {
    let (name, _keep) = pty(device(PROTOCOL_VERSION + 1));
    let mut link = Link::open(&name).unwrap();
    let err = link.connect().unwrap_err().to_string();
    assert!(
        err.contains(&name) && err.contains(&format!("protocol {}", PROTOCOL_VERSION + 1)),
        "{err}"
    );
    // The damaged frames were counted, not returned.
    assert_eq!(link.errors().crc, 2);
}

#[test]
fn the_same_version_connects() {
    let (name, _keep) = pty(device(PROTOCOL_VERSION));
    let mut link = Link::open(&name).unwrap();
    assert_eq!(link.connect().unwrap().protocol_version, PROTOCOL_VERSION);
}

#[test]
fn silence_and_noise_are_named() {
    let (name, _keep) = pty(|port| {
        thread::sleep(Duration::from_secs(3));
        drop(port);
    });
    let mut link = Link::open(&name).unwrap();
    let err = link.connect().unwrap_err().to_string();
    assert!(err.contains(&name) && err.contains("no answer"), "{err}");

    let (name, _keep) = pty(|mut port| {
        for _ in 0..30 {
            let _ = port.write_all(b"hello from some other device\r\n");
            thread::sleep(Duration::from_millis(50));
        }
    });
    let mut link = Link::open(&name).unwrap();
    let err = link.connect().unwrap_err().to_string();
    assert!(
        err.contains(&name) && err.contains("not a board speaking this protocol"),
        "{err}"
    );
}
