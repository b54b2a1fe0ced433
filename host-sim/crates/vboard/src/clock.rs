//! The virtual board's clock: embassy-time's driver for the host, in step
//! with wall time by default and `speed` times faster on request
//! ([`set_speed`], at most [`MAX_SPEED`], as far as the host keeps up).
//! One clock per process (embassy-time has one driver), shared by every
//! virtual board in it.

use std::sync::{Condvar, Mutex, MutexGuard, OnceLock};
use std::thread;
use std::time::{Duration, Instant};

use anyhow::{ensure, Result};
use embassy_time_driver::Driver;
use embassy_time_queue_utils::Queue;

/// Fastest clock accepted (board seconds per wall second). The board's
/// deadlines are in board time, so every millisecond the host is late
/// costs `speed` board milliseconds: on the build VM's Intel host 2× kept
/// every deadline (the sensor's 9 ms read, the 10 ms control period) with
/// both cores loaded, 4× did not (the sensor reads time out and the board
/// faults, as a real one would with a bus that slow); on its AMD host a
/// run at 1.5× or 2× faults with a control overrun in most runs, idle,
/// for a cause not yet found (`tests/board_cli.rs`, the ignored test).
pub const MAX_SPEED: f64 = 10.0;

struct Inner {
    queue: Queue,
}

struct Clock {
    inner: Mutex<Inner>,
    alarm: Mutex<bool>,
    wake: Condvar,
}

/// The clock's origin and speed, fixed at first use.
struct Epoch {
    zero: Instant,
    speed: f64,
}

static EPOCH: OnceLock<Epoch> = OnceLock::new();

embassy_time_driver::time_driver_impl!(static CLOCK: Clock = Clock {
    inner: Mutex::new(Inner { queue: Queue::new() }),
    alarm: Mutex::new(false),
    wake: Condvar::new(),
});

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

fn epoch(speed: f64) -> &'static Epoch {
    EPOCH.get_or_init(|| {
        thread::spawn(alarm_thread);
        Epoch {
            zero: Instant::now(),
            speed,
        }
    })
}

/// Makes the board clock run `speed` times as fast as wall time (1 =
/// in step). Must come before the clock is first read; afterwards only
/// the speed in force is accepted again.
pub fn set_speed(speed: f64) -> Result<()> {
    ensure!(
        speed.is_finite() && (1.0..=MAX_SPEED).contains(&speed),
        "clock speed {speed} is outside 1..={MAX_SPEED}"
    );
    let e = epoch(speed);
    ensure!(
        e.speed == speed,
        "the virtual board clock already runs at {}× in this process",
        e.speed
    );
    Ok(())
}

/// The clock's speed (board seconds per wall second).
pub fn speed() -> f64 {
    epoch(1.0).speed
}

impl Driver for Clock {
    fn now(&self) -> u64 {
        let e = epoch(1.0);
        (e.zero.elapsed().as_secs_f64() * e.speed * 1e6) as u64
    }

    fn schedule_wake(&self, at: u64, waker: &core::task::Waker) {
        if lock(&self.inner).queue.schedule_wake(at, waker) {
            *lock(&self.alarm) = true;
            self.wake.notify_one();
        }
    }
}

/// Wakes the timers that are due, then sleeps until the next one (or a
/// new, earlier one).
fn alarm_thread() {
    loop {
        let e = epoch(1.0);
        let now = CLOCK.now();
        let next = lock(&CLOCK.inner).queue.next_expiration(now);
        let wait_us = (next.saturating_sub(now) as f64 / e.speed).min(1e6);
        let mut signaled = lock(&CLOCK.alarm);
        if !*signaled {
            let (s, _) = CLOCK
                .wake
                .wait_timeout(signaled, Duration::from_micros(wait_us as u64))
                .unwrap_or_else(|e| e.into_inner());
            signaled = s;
        }
        *signaled = false;
    }
}
