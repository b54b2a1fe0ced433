//! The host link: frames in through the streaming decoder, frames out, over
//! any `embedded-io-async` UART (USART2 on the board, the ST-LINK virtual
//! COM port at [`BAUD_RATE`] 8N1; a pseudo-terminal in the virtual board).
//! Which message means what is in [`crate::protocol`]; this module only
//! moves them, and writes an uploaded table into the store.

use core::sync::atomic::Ordering;

use embassy_futures::select::{select, Either};
use embassy_time::Timer;
use embedded_io_async::{Read, Write};
use embedded_storage::nor_flash::NorFlash;

use super::log::{log_error, log_info, log_warn};
use super::{Shared, StoreMutex};
use crate::controller::{CommandError, State};
use crate::protocol::{
    encode_device, DeviceMessage, Hello, HostCommand, HostDecoder, HostMessage, NackReason,
    UploadError, MAX_FRAME,
};

/// Baud rate of the virtual COM port.
pub const BAUD_RATE: u32 = 115_200;

/// Receives host frames. Every valid frame marks [`Shared::host_seen`]
/// (the link watch). `Ping` is answered here; the table upload
/// (`TableBegin`, `TableChunk`, `TableCommit`) is written into `store`
/// here, in Idle only; every other request goes to the control task
/// ([`Shared::requests`]). A damaged frame is counted
/// ([`Shared::frame_errors`]), answered with a `Nack` and has no other
/// effect. A UART error (overrun, framing, noise) drops the partial frame.
pub async fn rx<R: Read, F: NorFlash>(mut rx: R, shared: &Shared, store: &StoreMutex<F>) -> ! {
    let mut decoder = HostDecoder::new();
    let mut buf = [0u8; 32];
    loop {
        let n = match rx.read(&mut buf).await {
            Ok(0) => {
                // End of stream (a host-side UART that closed): wait for
                // it to come back rather than spin.
                Timer::after_millis(10).await;
                continue;
            }
            Ok(n) => n,
            Err(_) => {
                log_warn!("link: rx error");
                decoder.reset();
                continue;
            }
        };
        for &byte in buf.get(..n).unwrap_or(&[]) {
            match decoder.push(byte) {
                None => {}
                Some(Ok(msg)) => {
                    shared.host_seen.store(true, Ordering::Relaxed);
                    route(msg, shared, store).await;
                }
                Some(Err(e)) => {
                    shared.frame_errors.fetch_add(1, Ordering::Relaxed);
                    shared.reply(DeviceMessage::frame_reject(e));
                }
            }
        }
    }
}

/// Sends one decoded host message where it is answered.
async fn route<F: NorFlash>(msg: HostMessage, shared: &Shared, store: &StoreMutex<F>) {
    let seq = msg.seq;
    let upload = match &msg.body {
        HostCommand::Ping => {
            shared.reply(DeviceMessage::Pong { seq });
            return;
        }
        HostCommand::TableBegin { len_bytes, crc32 } => Some((*len_bytes, *crc32, None)),
        HostCommand::TableChunk { offset, data } => Some((*offset, 0, Some(data))),
        HostCommand::TableCommit => Some((0, 0, None)),
        _ => None,
    };
    let Some((a, b, data)) = upload else {
        if shared.requests.try_send(msg).is_err() {
            // The control loop is behind: refuse rather than wait.
            shared.reply(DeviceMessage::nack(
                seq,
                NackReason::Command(CommandError::Busy),
            ));
        }
        return;
    };
    let result = if shared.state() != State::Idle {
        Err(UploadError::NotIdle)
    } else {
        let mut store = store.lock().await;
        match (&msg.body, data) {
            (HostCommand::TableBegin { .. }, _) => store.begin_upload(a, b),
            (HostCommand::TableChunk { .. }, Some(data)) => store.write_chunk(a, data),
            _ => store.commit_upload().map(|checksum| {
                log_info!(
                    "link: table {=u32:#010x} stored, in use from the next boot",
                    checksum
                );
            }),
        }
    };
    shared.reply(match result {
        Ok(()) => DeviceMessage::Ack { seq },
        Err(e) => {
            log_warn!("link: table upload refused: {}", e);
            DeviceMessage::nack(seq, NackReason::Upload(e))
        }
    });
}

/// Sends `hello` once, then replies (first) and telemetry as they come,
/// one frame each.
pub async fn tx<W: Write>(mut tx: W, shared: &Shared, hello: Hello) -> ! {
    let mut frame = [0u8; MAX_FRAME];
    let mut next = DeviceMessage::Hello(hello);
    loop {
        match encode_device(&next, &mut frame) {
            Ok(bytes) => {
                if tx.write_all(bytes).await.is_err() {
                    log_warn!("link: tx error");
                }
            }
            Err(e) => log_error!("link: cannot encode {}: {}", next, e),
        }
        // `select` polls the replies first, so they overtake telemetry.
        next = match select(shared.replies.receive(), shared.telemetry.receive()).await {
            Either::First(msg) => msg,
            Either::Second(sample) => DeviceMessage::Sample(sample),
        };
    }
}
