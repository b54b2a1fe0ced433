//! STEP pulses from a hardware timer: the trait the pump is written
//! against ([`StepPulses`]), and an exact model of it for the host
//! ([`SimStepTimer`]): the virtual board and the tests run the same
//! sequencing code as the board, edges at the same instants.
//!
//! The model is the board's TIM1 on CH3 (PA10), counting down at 1 MHz
//! in PWM mode 1 with the auto-reload preloaded: a pulse's rising edge
//! comes when the counter reaches the compare value, the pulse stays high
//! [`STEP_HIGH_US`] and ends at the update event, which also loads the
//! period queued for the pulse after next. So the executor never times an
//! edge: it only has to queue each period within the period before it,
//! and a late poll within that period moves no edge.

use super::{STEP_HIGH_US, STEP_LOW_US};

/// Longest step period the timer is given (µs): a round 65 ms inside its
/// 16-bit auto-reload at a 1 µs tick. [`super::PumpConfig::validate`]
/// refuses mechanics whose slowest planned step would be longer.
pub const MAX_STEP_PERIOD_US: u32 = 65_000;

/// Shortest step period (µs): the pulse's [`STEP_HIGH_US`] and the
/// driver's [`STEP_LOW_US`].
pub const MIN_STEP_PERIOD_US: u32 = STEP_HIGH_US + STEP_LOW_US;

/// A STEP pulse generator: a timer that emits rising edges at the
/// periods it is given, [`STEP_HIGH_US`] high each, and counts the pulses
/// it completed. Pulses are numbered from 1 after each
/// [`StepPulses::start`]; while running, pulse `pulses() + 1` is in
/// progress (its edge may not have come yet) and one more period may be
/// queued after it.
// The board's executor is single-threaded: no `Send` bound is wanted on
// the future of `wait_pulse`.
#[allow(async_fn_in_trait)]
pub trait StepPulses {
    /// Starts from STEP low: pulse 1's rising edge `first_us` from now,
    /// pulse 2's `second_us` after it. Periods are clamped to
    /// [`MIN_STEP_PERIOD_US`] ..= [`MAX_STEP_PERIOD_US`]. Only called while
    /// stopped.
    fn start(&mut self, first_us: u32, second_us: u32);

    /// Queues the period (µs, clamped as in [`StepPulses::start`]) from
    /// the edge of the pulse after the one in progress to the edge of the
    /// next; it takes effect only when the pulse in progress completes.
    /// Not called, the last queued period repeats.
    fn queue_period(&mut self, period_us: u32);

    /// Stops after the pulse in progress: no edge after it.
    fn finish(&mut self);

    /// Stops at once with STEP low; a pulse whose edge already came
    /// counts as completed.
    fn stop(&mut self);

    /// Pulses completed since the last start.
    fn pulses(&self) -> u32;

    /// True from a start until the last pulse completed or a stop.
    fn running(&self) -> bool;

    /// Returns once [`StepPulses::pulses`] differs from `seen`, or the
    /// generator is not running.
    async fn wait_pulse(&mut self, seen: u32);
}

/// The clamp of a period to what the timer gives.
pub fn clamp_period_us(period_us: u32) -> u32 {
    period_us.clamp(MIN_STEP_PERIOD_US, MAX_STEP_PERIOD_US)
}

/// An exact model of the board's step timer on a µs clock that its
/// owner advances ([`SimStepTimer::advance`]): edges at the start time
/// plus the queued periods, whenever the owner looks.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SimStepTimer {
    now_us: u64,
    running: bool,
    /// Rising edge of the pulse in progress (µs).
    edge_us: u64,
    /// That edge already came (the pulse is high).
    edged: bool,
    /// Period after the pulse in progress (µs).
    queued_us: u32,
    /// Stop when the pulse in progress completes.
    last: bool,
    pulses: u32,
}

impl SimStepTimer {
    /// Stopped, at time 0.
    pub const fn new() -> Self {
        Self {
            now_us: 0,
            running: false,
            edge_us: 0,
            edged: false,
            queued_us: 0,
            last: false,
            pulses: 0,
        }
    }

    /// The model's clock (µs).
    pub fn now_us(&self) -> u64 {
        self.now_us
    }

    /// Runs the timer up to `to_us` (an earlier time is ignored), calling
    /// `on_edge(t_us)` for every rising edge, in order.
    pub fn advance(&mut self, to_us: u64, mut on_edge: impl FnMut(u64)) {
        while self.running {
            if !self.edged {
                if self.edge_us > to_us {
                    break;
                }
                self.edged = true;
                on_edge(self.edge_us);
            }
            let done_us = self.edge_us + u64::from(STEP_HIGH_US);
            if done_us > to_us {
                break;
            }
            // The update event: the pulse completes, the queued period
            // takes over.
            self.pulses = self.pulses.wrapping_add(1);
            self.edged = false;
            if self.last {
                self.running = false;
            } else {
                self.edge_us += u64::from(self.queued_us);
            }
        }
        self.now_us = self.now_us.max(to_us);
    }

    /// When the pulse in progress completes (µs), if running.
    pub fn next_completion_us(&self) -> Option<u64> {
        self.running
            .then_some(self.edge_us + u64::from(STEP_HIGH_US))
    }

    /// STEP's level now.
    pub fn step_high(&self) -> bool {
        self.running && self.edged
    }

    /// [`StepPulses::start`] at the model's time.
    pub fn start(&mut self, first_us: u32, second_us: u32) {
        self.running = true;
        self.edged = false;
        self.last = false;
        self.pulses = 0;
        self.edge_us = self.now_us + u64::from(clamp_period_us(first_us));
        self.queued_us = clamp_period_us(second_us);
    }

    /// [`StepPulses::queue_period`].
    pub fn queue_period(&mut self, period_us: u32) {
        self.queued_us = clamp_period_us(period_us);
    }

    /// [`StepPulses::finish`].
    pub fn finish(&mut self) {
        self.last = true;
    }

    /// [`StepPulses::stop`].
    pub fn stop(&mut self) {
        if self.running && self.edged {
            self.pulses = self.pulses.wrapping_add(1);
        }
        self.running = false;
        self.edged = false;
    }

    /// [`StepPulses::pulses`].
    pub fn pulses(&self) -> u32 {
        self.pulses
    }

    /// [`StepPulses::running`].
    pub fn running(&self) -> bool {
        self.running
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn edges_follow_the_queued_periods_whenever_advanced() {
        let mut t = SimStepTimer::new();
        t.advance(1_000, |_| {});
        t.start(500, 200);
        let mut edges = Vec::new();
        // Looked at late, in odd chunks: the same edges.
        for to in [1_499, 1_500, 1_650, 1_702, 1_703] {
            t.advance(to, |e| edges.push(e));
            if t.pulses() == 1 {
                t.queue_period(300);
            }
        }
        assert_eq!(edges, vec![1_500, 1_700]);
        t.advance(2_500, |e| edges.push(e));
        assert_eq!(edges, vec![1_500, 1_700, 2_000, 2_300]);
        t.finish();
        t.advance(10_000, |e| edges.push(e));
        assert_eq!(edges.last(), Some(&2_600));
        assert!(!t.running());
        assert_eq!(t.pulses(), 5);
    }

    #[test]
    fn stop_counts_a_pulse_already_high() {
        let mut t = SimStepTimer::new();
        t.start(100, 100);
        t.advance(101, |_| {});
        assert!(t.step_high());
        t.stop();
        assert_eq!(t.pulses(), 1);
        assert!(!t.step_high());
        t.advance(1_000, |_| panic!("no edge after a stop"));
    }
}
