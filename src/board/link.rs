//! The host link on USART2 (the ST-LINK virtual COM port, 115200 8N1):
//! frames in through a DMA ring buffer and the streaming decoder, frames out
//! by DMA. Which message means what is in [`crate::protocol`]; this module
//! only moves them.

use core::sync::atomic::Ordering;

use embassy_futures::select::{select, Either};
use embassy_stm32::mode::Async;
use embassy_stm32::usart::{RingBufferedUartRx, UartTx};

use super::channels::{REPLIES, REPLIES_DROPPED, REQUESTS, TELEMETRY};
use crate::controller::CommandError;
use crate::protocol::{
    encode_device, DeviceMessage, Hello, HostCommand, HostDecoder, HostMessage, NackReason,
    MAX_FRAME,
};
use crate::table::generated::TABLE;

/// Baud rate of the virtual COM port.
pub const BAUD_RATE: u32 = 115_200;

/// Size of the RX DMA ring (bytes): 22 ms of line time at 115200 baud, read
/// out on every idle line or half-full ring.
pub const RX_RING_BYTES: usize = 256;

/// Receives host frames. A decoded request goes to the control task
/// ([`REQUESTS`]), except `Ping`, answered here; a damaged frame is
/// answered with a `Nack` and has no other effect. A UART error (overrun,
/// framing, noise) drops the partial frame.
#[embassy_executor::task]
pub async fn rx_task(mut rx: RingBufferedUartRx<'static>) -> ! {
    let mut decoder = HostDecoder::new();
    let mut buf = [0u8; 32];
    loop {
        let received = match rx.read(&mut buf).await {
            Ok(n) => buf.get(..n).unwrap_or(&[]),
            Err(e) => {
                defmt::warn!("link: rx error {}", e);
                decoder.reset();
                continue;
            }
        };
        for &byte in received {
            match decoder.push(byte) {
                None => {}
                Some(Ok(msg)) => route(msg),
                Some(Err(e)) => reply(DeviceMessage::frame_reject(e)),
            }
        }
    }
}

/// Sends one decoded host message where it is answered.
fn route(msg: HostMessage) {
    if msg.body == HostCommand::Ping {
        reply(DeviceMessage::Pong { seq: msg.seq });
        return;
    }
    if REQUESTS.try_send(msg).is_err() {
        // The control loop is behind: refuse rather than wait.
        reply(DeviceMessage::Nack {
            seq: Some(msg.seq),
            reason: NackReason::Command(CommandError::Busy),
        });
    }
}

/// Queues a reply for the TX task; counts it if the queue is full.
pub fn reply(msg: DeviceMessage) {
    if REPLIES.try_send(msg).is_err() {
        REPLIES_DROPPED.fetch_add(1, Ordering::Relaxed);
    }
}

/// Sends [`Hello`] once, then replies (first) and telemetry as they come,
/// one frame each.
#[embassy_executor::task]
pub async fn tx_task(mut tx: UartTx<'static, Async>) -> ! {
    let mut frame = [0u8; MAX_FRAME];
    let mut next = DeviceMessage::Hello(Hello::new(&TABLE));
    loop {
        match encode_device(&next, &mut frame) {
            Ok(bytes) => {
                if let Err(e) = tx.write(bytes).await {
                    defmt::warn!("link: tx error {}", e);
                }
            }
            Err(e) => defmt::error!("link: cannot encode {}: {}", next, e),
        }
        // `select` polls the replies first, so they overtake telemetry.
        next = match select(REPLIES.receive(), TELEMETRY.receive()).await {
            Either::First(msg) => msg,
            Either::Second(sample) => DeviceMessage::Sample(sample),
        };
    }
}
