//! Phases and cycles read from the pump's volume history alone, the way
//! any experiment folder allows: a step is *expand*, *hold* or *shrink* by
//! the sign of the pump flow, and a new burrowing cycle (fresh sand, the
//! animal having advanced) starts when expansion resumes after the volume
//! came most of the way back down.

use serde::{Deserialize, Serialize};

/// What the pump is doing at a step.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Phase {
    /// Pumping in.
    Expand,
    /// Not moving.
    Hold,
    /// Pulling back.
    Shrink,
}

impl Phase {
    /// All phases, in report order.
    pub const ALL: [Phase; 3] = [Phase::Expand, Phase::Hold, Phase::Shrink];

    /// Lower-case name.
    pub fn as_str(self) -> &'static str {
        match self {
            Phase::Expand => "expand",
            Phase::Hold => "hold",
            Phase::Shrink => "shrink",
        }
    }

    /// The phase of pump flow `flow_ml_s` with dead band `hold_ml_s`.
    pub fn of_flow(flow_ml_s: f64, hold_ml_s: f64) -> Phase {
        if flow_ml_s > hold_ml_s {
            Phase::Expand
        } else if flow_ml_s < -hold_ml_s {
            Phase::Shrink
        } else {
            Phase::Hold
        }
    }
}

/// Default dead band of [`Phase::of_flow`] (mL/s).
pub const HOLD_FLOW_ML_S: f64 = 0.02;

/// Smallest rise (mL) that counts as an expansion for cycle detection.
pub const MIN_CYCLE_RISE_ML: f64 = 0.05;

/// Fraction of the rise the volume must come back down before the next
/// expansion counts as a new cycle.
pub const RETURN_FRACTION: f64 = 0.75;

/// Cycle detector over the pump volume.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CycleDetector {
    bottom_ml: f64,
    peak_ml: f64,
    armed: bool,
    /// Cycles started so far after the first (0 during the first).
    pub count: u32,
}

impl CycleDetector {
    /// A detector at the start of a run, volume `volume_ml`.
    pub fn new(volume_ml: f64) -> Self {
        Self {
            bottom_ml: volume_ml,
            peak_ml: volume_ml,
            armed: false,
            count: 0,
        }
    }

    /// Feeds one step; true when it starts a new cycle.
    pub fn update(&mut self, volume_ml: f64, phase: Phase) -> bool {
        if self.armed {
            self.bottom_ml = self.bottom_ml.min(volume_ml);
            if phase == Phase::Expand {
                self.armed = false;
                self.peak_ml = volume_ml;
                self.count += 1;
                return true;
            }
            return false;
        }
        self.peak_ml = self.peak_ml.max(volume_ml);
        let rise = self.peak_ml - self.bottom_ml;
        if rise > MIN_CYCLE_RISE_ML && volume_ml <= self.bottom_ml + (1.0 - RETURN_FRACTION) * rise
        {
            self.armed = true;
            self.bottom_ml = volume_ml;
        }
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_full_cycles_not_wiggles() {
        let mut c = CycleDetector::new(0.0);
        let mut starts = 0;
        // Up to 4, partly back to 2.5 and up again (same cycle), down to
        // 0.2, hold, up (new cycle).
        let path = [
            (1.0, Phase::Expand),
            (4.0, Phase::Expand),
            (2.5, Phase::Shrink),
            (3.5, Phase::Expand),
            (0.2, Phase::Shrink),
            (0.2, Phase::Hold),
            (1.0, Phase::Expand),
        ];
        for (v, ph) in path {
            starts += usize::from(c.update(v, ph));
        }
        assert_eq!(starts, 1);
        assert_eq!(c.count, 1);
        assert_eq!(Phase::of_flow(0.01, HOLD_FLOW_ML_S), Phase::Hold);
        assert_eq!(Phase::of_flow(-1.0, HOLD_FLOW_ML_S), Phase::Shrink);
    }
}
