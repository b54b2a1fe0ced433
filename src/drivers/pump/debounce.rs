//! Debouncing of the end-stop switches: a reported level changes only once
//! the raw reading has held the new level for [`END_STOP_DEBOUNCE_US`].
//! A microswitch's contacts bounce for up to a few milliseconds, and a long
//! cable to a normally-closed switch picks up spikes that would otherwise
//! stop a cycle for nothing. Both directions wait the same time; the
//! driver itself still refuses to start into a switch the raw reading
//! shows triggered, and the pump task stops the step timer when it does
//! ([`super::StepSequencer::service`]), so the debounce never lets the
//! plunger run on.

use crate::controller::EndStops;

/// How long a switch must read its new level before the report follows
/// (µs): 2 ms, longer than a microswitch's bounce (typically < 1 ms) and
/// 12 µm of plunger travel at the pump's top rate (6 mm/s).
pub const END_STOP_DEBOUNCE_US: u32 = 2_000;

/// One switch.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Debounced {
    triggered: bool,
    /// When the raw reading first differed from `triggered` (µs).
    differs_since_us: Option<u32>,
}

impl Debounced {
    fn update(&mut self, raw: bool, now_us: u32) -> bool {
        if raw == self.triggered {
            self.differs_since_us = None;
        } else {
            let since = *self.differs_since_us.get_or_insert(now_us);
            if now_us.wrapping_sub(since) >= END_STOP_DEBOUNCE_US {
                self.triggered = raw;
                self.differs_since_us = None;
            }
        }
        self.triggered
    }
}

/// Both end-stops, debounced. Starts with both triggered: until the
/// switches have read "not at the end" for the debounce time, nothing may
/// move.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EndStopDebounce {
    empty: Debounced,
    full: Debounced,
}

impl Default for EndStopDebounce {
    fn default() -> Self {
        Self::new()
    }
}

impl EndStopDebounce {
    /// Both switches reported triggered.
    pub const fn new() -> Self {
        let start = Debounced {
            triggered: true,
            differs_since_us: None,
        };
        Self {
            empty: start,
            full: start,
        }
    }

    /// Takes the raw readings at `now_us` (a free-running µs clock; wraps)
    /// and returns the debounced ones.
    pub fn update(&mut self, raw: EndStops, now_us: u32) -> EndStops {
        EndStops {
            empty: self.empty.update(raw.empty, now_us),
            full: self.full.update(raw.full, now_us),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stops(empty: bool, full: bool) -> EndStops {
        EndStops { empty, full }
    }

    #[test]
    fn a_level_must_hold_for_the_debounce_time() {
        let mut d = EndStopDebounce::new();
        // Boot: triggered until released for 2 ms.
        assert_eq!(d.update(stops(false, false), 0), stops(true, true));
        assert_eq!(d.update(stops(false, false), 1_999), stops(true, true));
        assert_eq!(d.update(stops(false, false), 2_000), stops(false, false));
        // A 1 ms spike (a bounce, noise on the cable) is ignored.
        assert_eq!(d.update(stops(true, false), 10_000), stops(false, false));
        assert_eq!(d.update(stops(false, false), 11_000), stops(false, false));
        assert_eq!(d.update(stops(true, false), 11_500), stops(false, false));
        assert_eq!(d.update(stops(true, false), 13_000), stops(false, false));
        // Held 2 ms: reported, across the clock's wrap too.
        assert_eq!(d.update(stops(true, false), 13_500), stops(true, false));
        let mut d = EndStopDebounce::new();
        d.update(stops(false, false), u32::MAX - 1_000);
        assert_eq!(d.update(stops(false, false), 999), stops(false, false));
    }
}
