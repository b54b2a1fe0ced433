//! A spinning `embedded_hal_async` delay for the pump's microsecond STEP/DIR
//! timing: an executor timer wake-up per 2 µs pulse would cost more than the
//! pulse itself and could stretch it unpredictably.

use embassy_time::{block_for, Duration};
use embedded_hal_async::delay::DelayNs;

/// Delays by spinning on the embassy clock (1 µs ticks). Only for waits of a
/// few microseconds: it blocks the executor for their whole length.
#[derive(Clone, Copy, Debug, Default)]
pub struct BusyWait;

impl DelayNs for BusyWait {
    async fn delay_ns(&mut self, ns: u32) {
        // `block_for` counts tick edges, so its first tick may be partial:
        // one extra tick makes the wait at least `ns` (STEP high ≥ 1.9 µs).
        block_for(Duration::from_nanos(u64::from(ns)) + Duration::from_ticks(1));
    }
}
