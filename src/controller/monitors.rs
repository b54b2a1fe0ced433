//! The safety monitors, each a small state machine of its own that the
//! controller feeds every step. They only observe and report a condition;
//! the controller decides what latches (see the fault table in
//! [`crate::controller`]).

use super::params::Params;
use super::types::{Fault, PressureSample};

/// What the sensor monitor concluded from one step's sample.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SensorReport {
    /// A sensor health problem present now (bus, range, frozen or stale).
    pub condition: Option<Fault>,
    /// The newest reading exceeds `max_pressure_kpa` (kept across bus errors
    /// until a reading below the limit arrives).
    pub over_pressure: bool,
    /// This step brought a reading that can be used: finite and not below
    /// the sensor's range (its `taken_ms`).
    pub fresh_taken_ms: Option<u32>,
}

/// Pressure sensor health: bus errors, plausibility, frozen value,
/// staleness; keeps the last usable reading.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SensorMonitor {
    bus_errors: u8,
    last_kpa: Option<f32>,
    over_pressure: bool,
    /// Bits of the reading being timed for the frozen check, and when that
    /// value was first seen with the pump running.
    frozen_bits: Option<u32>,
    frozen_since_ms: u32,
}

impl SensorMonitor {
    /// A monitor that has seen nothing yet.
    pub const fn new() -> Self {
        Self {
            bus_errors: 0,
            last_kpa: None,
            over_pressure: false,
            frozen_bits: None,
            frozen_since_ms: 0,
        }
    }

    /// Last usable reading (kPa), over-pressure ones included.
    pub fn last_kpa(&self) -> Option<f32> {
        self.last_kpa
    }

    /// Judges this step's `sample` at time `now_ms`. `pump_ran` says whether
    /// the pump was stepping since the previous step (the frozen check only
    /// runs then: at constant volume a steady reading is normal).
    pub fn observe(
        &mut self,
        sample: &PressureSample,
        now_ms: u32,
        pump_ran: bool,
        params: &Params,
    ) -> SensorReport {
        match *sample {
            PressureSample::BusError | PressureSample::Missing => {
                self.bus_errors = self.bus_errors.saturating_add(1);
                let bus = self.bus_errors >= params.sensor_bus_error_steps;
                SensorReport {
                    condition: bus.then_some(Fault::SensorBus),
                    over_pressure: self.over_pressure,
                    fresh_taken_ms: None,
                }
            }
            PressureSample::Reading {
                pressure_kpa,
                taken_ms,
            } => {
                self.bus_errors = 0;
                // +∞ compares above the limit: a saturated reading is taken
                // as real over-pressure, whatever the sensor's range.
                self.over_pressure = pressure_kpa > params.max_pressure_kpa;
                let plausible = pressure_kpa.is_finite() && pressure_kpa >= params.sensor_min_kpa;
                if plausible {
                    self.last_kpa = Some(pressure_kpa);
                }
                let bits = pressure_kpa.to_bits();
                if !pump_ran || self.frozen_bits != Some(bits) {
                    self.frozen_bits = Some(bits);
                    self.frozen_since_ms = now_ms;
                }
                let frozen = pump_ran
                    && now_ms.wrapping_sub(self.frozen_since_ms) >= params.sensor_frozen_ms;
                // A timestamp ahead of the clock wraps to a huge age: stale.
                let stale = now_ms.wrapping_sub(taken_ms) > params.sensor_stale_ms;
                let condition = if !plausible && !self.over_pressure {
                    Some(Fault::SensorOutOfRange)
                } else if frozen {
                    Some(Fault::SensorFrozen)
                } else if stale {
                    Some(Fault::SensorStale)
                } else {
                    None
                };
                SensorReport {
                    condition,
                    over_pressure: self.over_pressure,
                    fresh_taken_ms: plausible.then_some(taken_ms),
                }
            }
        }
    }
}

/// Pump stall: over each block of `stall_volume_ml` injected while
/// expanding, the internal pressure must rise by `stall_min_rise_kpa`;
/// over each block withdrawn while shrinking it must fall by as much,
/// unless it is already within that of the pressure at rest (near the end
/// of a shrink there is nothing left to fall).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StallMonitor {
    start: Option<(f32, f32)>,
}

impl StallMonitor {
    /// Starts a new block at `volume_ml` and `pressure_kpa` (None: at the
    /// first reading).
    pub fn reset(&mut self, volume_ml: f32, pressure_kpa: Option<f32>) {
        self.start = pressure_kpa.map(|p| (volume_ml, p));
    }

    /// True when a whole block went by with too little pressure rise.
    pub fn observe(&mut self, volume_ml: f32, pressure_kpa: f32, params: &Params) -> bool {
        let Some((v0, p0)) = self.start else {
            self.start = Some((volume_ml, pressure_kpa));
            return false;
        };
        // Written so that a NaN volume never completes a block (the volume
        // monitor reports it).
        let block_done = volume_ml - v0 >= params.stall_volume_ml;
        if !block_done {
            return false;
        }
        // Written so that NaN counts as no response.
        let responded = pressure_kpa - p0 >= params.stall_min_rise_kpa;
        if !responded {
            return true;
        }
        self.start = Some((volume_ml, pressure_kpa));
        false
    }

    /// The shrink's rule: true when a whole block was withdrawn while the
    /// pressure neither fell by `stall_min_rise_kpa` nor came within that
    /// of `rest_kpa` (the pressure at rest, taken at `Start`).
    pub fn observe_withdrawal(
        &mut self,
        volume_ml: f32,
        pressure_kpa: f32,
        rest_kpa: f32,
        params: &Params,
    ) -> bool {
        let Some((v0, p0)) = self.start else {
            self.start = Some((volume_ml, pressure_kpa));
            return false;
        };
        let block_done = v0 - volume_ml >= params.stall_volume_ml;
        if !block_done {
            return false;
        }
        // Written so that NaN counts as no response.
        let responded = p0 - pressure_kpa >= params.stall_min_rise_kpa
            || pressure_kpa - rest_kpa <= params.stall_min_rise_kpa;
        if !responded {
            return true;
        }
        self.start = Some((volume_ml, pressure_kpa));
        false
    }
}

/// Volume- and table-based diameters disagreeing by more than
/// `diameter_mismatch_mm` for `diameter_mismatch_ms`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MismatchMonitor {
    since_ms: Option<u32>,
}

impl MismatchMonitor {
    /// Forgets any running disagreement.
    pub fn reset(&mut self) {
        self.since_ms = None;
    }

    /// True once the disagreement has lasted long enough. A NaN diameter
    /// (no reading yet) neither starts nor ends one.
    pub fn observe(&mut self, now_ms: u32, volume_mm: f32, table_mm: f32, params: &Params) -> bool {
        let gap_mm = libm::fabsf(volume_mm - table_mm);
        if gap_mm.is_nan() {
            return false;
        }
        if gap_mm <= params.diameter_mismatch_mm {
            self.since_ms = None;
            return false;
        }
        let since = *self.since_ms.get_or_insert(now_ms);
        now_ms.wrapping_sub(since) >= params.diameter_mismatch_ms
    }
}

/// Leak: at constant volume the pressure must not fall more than
/// [`Params::leak_limit_kpa`] below the hold's peak.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LeakMonitor {
    peak_kpa: Option<f32>,
}

impl LeakMonitor {
    /// Starts a hold at `pressure_kpa`.
    pub fn reset(&mut self, pressure_kpa: Option<f32>) {
        self.peak_kpa = pressure_kpa;
    }

    /// Pressure drop below the hold's peak so far (kPa).
    pub fn drop_kpa(&self, pressure_kpa: f32) -> f32 {
        self.peak_kpa.map_or(0.0, |peak| peak - pressure_kpa)
    }

    /// True when the pressure fell too far below the hold's peak.
    pub fn observe(&mut self, pressure_kpa: f32, params: &Params) -> bool {
        let peak = match self.peak_kpa {
            Some(peak) if peak >= pressure_kpa => peak,
            _ => pressure_kpa,
        };
        self.peak_kpa = Some(peak);
        peak - pressure_kpa > params.leak_limit_kpa(peak)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn reading(pressure_kpa: f32, taken_ms: u32) -> PressureSample {
        PressureSample::Reading {
            pressure_kpa,
            taken_ms,
        }
    }

    #[test]
    fn bus_errors_count_consecutively() {
        let p = Params::DEFAULT;
        let mut m = SensorMonitor::new();
        assert_eq!(
            m.observe(&PressureSample::Missing, 0, false, &p).condition,
            None
        );
        assert_eq!(
            m.observe(&PressureSample::BusError, 10, false, &p)
                .condition,
            None
        );
        assert_eq!(m.observe(&reading(1.0, 20), 20, false, &p).condition, None);
        for t in [30, 40] {
            assert_eq!(
                m.observe(&PressureSample::BusError, t, false, &p).condition,
                None
            );
        }
        assert_eq!(
            m.observe(&PressureSample::BusError, 50, false, &p)
                .condition,
            Some(Fault::SensorBus)
        );
    }

    #[test]
    fn frozen_only_counts_while_the_pump_runs() {
        let p = Params::DEFAULT;
        let mut m = SensorMonitor::new();
        for t in (0..2000).step_by(10) {
            assert_eq!(m.observe(&reading(1.0, t), t, false, &p).condition, None);
        }
        // The step at 1990 ms was the last with the pump stopped; it runs
        // from then on (`pump_ran` from 2000 ms), so the value is frozen
        // once 300 ms have passed since 1990 ms.
        for t in (2000..2290).step_by(10) {
            assert_eq!(
                m.observe(&reading(1.0, t), t, true, &p).condition,
                None,
                "t={t}"
            );
        }
        assert_eq!(
            m.observe(&reading(1.0, 2290), 2290, true, &p).condition,
            Some(Fault::SensorFrozen)
        );
        // Any change restarts the clock.
        assert_eq!(
            m.observe(&reading(1.0001, 2300), 2300, true, &p).condition,
            None
        );
    }

    #[test]
    fn stale_and_future_timestamps() {
        let p = Params::DEFAULT;
        let mut m = SensorMonitor::new();
        assert_eq!(
            m.observe(&reading(1.0, 950), 1000, false, &p).condition,
            None
        );
        assert_eq!(
            m.observe(&reading(1.0, 949), 1000, false, &p).condition,
            Some(Fault::SensorStale)
        );
        assert_eq!(
            m.observe(&reading(1.0, 1001), 1000, false, &p).condition,
            Some(Fault::SensorStale)
        );
        // Across the u32 wrap.
        assert_eq!(
            m.observe(&reading(1.0, u32::MAX - 5), 4, false, &p)
                .condition,
            None
        );
    }

    #[test]
    fn garbage_is_out_of_range_and_high_is_over_pressure() {
        let p = Params::DEFAULT;
        let mut m = SensorMonitor::new();
        for bad in [f32::NAN, f32::NEG_INFINITY, -20.5] {
            let r = m.observe(&reading(bad, 0), 0, false, &p);
            assert_eq!(
                (r.condition, r.over_pressure),
                (Some(Fault::SensorOutOfRange), false)
            );
        }
        for high in [15.01, 1e30, f32::INFINITY] {
            let r = m.observe(&reading(high, 0), 0, false, &p);
            assert_eq!((r.condition, r.over_pressure), (None, true));
        }
        // Over-pressure is remembered across bus errors.
        assert!(
            m.observe(&PressureSample::BusError, 10, false, &p)
                .over_pressure
        );
        assert!(!m.observe(&reading(14.99, 20), 20, false, &p).over_pressure);
    }

    #[test]
    fn stall_needs_a_rise_per_block() {
        let p = Params::DEFAULT;
        let mut s = StallMonitor::default();
        s.reset(0.0, Some(1.0));
        assert!(!s.observe(0.99, 1.0, &p));
        assert!(!s.observe(1.0, 1.06, &p));
        assert!(!s.observe(1.99, 1.06, &p));
        assert!(s.observe(2.0, 1.1, &p));
    }

    #[test]
    fn a_shrink_must_lower_the_pressure_until_rest() {
        let p = Params::DEFAULT;
        let mut s = StallMonitor::default();
        s.reset(4.0, Some(3.0));
        // Healthy: 1 mL out, the pressure fell 1 kPa.
        assert!(!s.observe_withdrawal(3.01, 2.5, 0.2, &p));
        assert!(!s.observe_withdrawal(3.0, 2.0, 0.2, &p));
        // Stalled: 1 mL counted, the pressure stayed.
        assert!(s.observe_withdrawal(2.0, 1.98, 0.2, &p));
        // At rest there is nothing left to fall: no stall.
        let mut s = StallMonitor::default();
        s.reset(1.0, Some(0.24));
        assert!(!s.observe_withdrawal(0.0, 0.24, 0.2, &p));
        assert!(s.observe_withdrawal(-1.0, f32::NAN, 0.2, &p));
    }

    #[test]
    fn leak_is_measured_from_the_peak() {
        let p = Params::DEFAULT;
        let mut l = LeakMonitor::default();
        l.reset(Some(3.0));
        // Peak 4 kPa: the limit is a quarter of it, 1 kPa.
        assert!(!l.observe(4.0, &p));
        assert!(!l.observe(3.0, &p));
        assert!(l.observe(2.99, &p));
    }

    #[test]
    fn leak_limit_is_a_fraction_of_the_peak_above_a_floor() {
        let p = Params::DEFAULT;
        // 2.5 kPa (40 mm of sand): 0.625 kPa, where the old absolute
        // 1.5 kPa let a leak take 1.28 kPa in one hold unseen.
        assert_eq!(p.leak_limit_kpa(2.5), 0.625);
        assert_eq!(p.leak_limit_kpa(8.0), 2.0);
        // Low pressures (free water): the floor, 10× the sensor's noise.
        assert_eq!(p.leak_limit_kpa(0.8), 0.3);
        let mut l = LeakMonitor::default();
        l.reset(Some(0.8));
        assert!(!l.observe(0.5, &p));
        assert!(l.observe(0.49, &p));
    }

    #[test]
    fn mismatch_must_last() {
        let p = Params::DEFAULT;
        let mut m = MismatchMonitor::default();
        assert!(!m.observe(0, 20.0, 22.6, &p));
        assert!(!m.observe(490, 20.0, 22.6, &p));
        assert!(m.observe(500, 20.0, 22.6, &p));
        assert!(!m.observe(510, 20.0, 22.5, &p));
        assert!(!m.observe(1000, 20.0, f32::NAN, &p));
    }
}
