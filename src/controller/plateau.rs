//! Early stop on the sand's plateau.
//!
//! The sand's share of the internal pressure, `p_e = p − p_skin(D)`, rises
//! steeply while the grains are pushed from rest, then flattens as they
//! slide and collapse around the head (the paper's p_e–D curve). Once it is
//! flat, injecting more only stretches the skin. The detector fits a least
//! squares line to the last [`PLATEAU_WINDOW_SAMPLES`] fresh readings of
//! `p_e` against pumped volume, remembers the largest slope of this
//! expansion (its initial, linear part), and reports the plateau when:
//!
//! - the early stop is enabled (`plateau_slope_fraction > 0`);
//! - the largest slope reached `plateau_min_slope_kpa_per_ml` (there is a
//!   sand curve at all: in free water there is none);
//! - the volume-based diameter has grown `plateau_min_expansion_mm` past D0;
//! - the current slope is below `plateau_slope_fraction` × the largest;
//! - and the internal pressure itself still responds, rising at least at
//!   the stall monitor's rate (`stall_min_rise_kpa / stall_volume_ml`): a
//!   flat internal pressure is a stalled pump or an open line, which the
//!   stall monitor must judge, not a plateau;
//! - the internal pressure rises at that rate over the newest half of the
//!   window too, so the tail of a rising window cannot mask a pump that has
//!   just stalled;
//! - the reading is alive: fewer than [`PLATEAU_STATIC_READINGS`]
//!   bit-identical readings in a row (a frozen sensor makes p_e look flat
//!   while the skin estimate keeps rising; the sensor monitor judges it);
//! - all of the above for [`PLATEAU_CONFIRM_SAMPLES`] fresh readings in a
//!   row. While a frozen sensor or a stalled pump slides into the window,
//!   the fitted slopes pass through the plateau's signature for a sample or
//!   two before the internal slope falls to nothing; the confirmation keeps
//!   that transient from ending the expansion (the sensor and stall
//!   monitors then judge it).

use heapless::HistoryBuf;

use super::params::Params;

/// Readings in the sliding window (one per control step at 100 Hz: 0.2 s,
/// 0.4 mL at the default 2 mL/s).
pub const PLATEAU_WINDOW_SAMPLES: usize = 20;

/// Consecutive fresh readings that must all show the plateau (0.1 mL at
/// the default 2 mL/s).
pub const PLATEAU_CONFIRM_SAMPLES: u8 = 5;

/// Bit-identical consecutive readings that make the reading count as
/// static: no plateau is confirmed on them. A live sensor at the MS5837's
/// resolution (about 1 Pa) with its noise (a few Pa) repeats a value three
/// times in a row rarely; a frozen one does so at once.
pub const PLATEAU_STATIC_READINGS: u8 = 3;

#[derive(Clone, Copy, Debug, PartialEq)]
struct Sample {
    /// Pumped volume past rest (mL).
    volume_ml: f32,
    /// Sand pressure estimate p_e (kPa).
    sand_kpa: f32,
    /// Measured internal pressure p_i (kPa).
    internal_kpa: f32,
}

/// Sliding-window plateau detector for one expansion.
#[derive(Clone, Debug)]
pub struct PlateauDetector {
    window: HistoryBuf<Sample, PLATEAU_WINDOW_SAMPLES>,
    /// Largest windowed p_e slope seen this expansion (kPa/mL).
    peak_slope_kpa_per_ml: f32,
    /// `taken_ms` of the newest sample in the window, so a reading the
    /// sensor task delivers twice counts once.
    last_taken_ms: Option<u32>,
    /// Consecutive fresh readings showing the plateau.
    confirmed: u8,
    /// Consecutive fresh readings bit-identical to the previous one, plus one.
    static_run: u8,
}

impl Default for PlateauDetector {
    fn default() -> Self {
        Self::new()
    }
}

impl PlateauDetector {
    /// An empty detector.
    pub const fn new() -> Self {
        Self {
            window: HistoryBuf::new(),
            peak_slope_kpa_per_ml: 0.0,
            last_taken_ms: None,
            confirmed: 0,
            static_run: 0,
        }
    }

    /// Forgets everything: call when an expansion starts.
    pub fn reset(&mut self) {
        *self = Self::new();
    }

    /// Largest windowed p_e slope of this expansion so far (kPa/mL).
    pub fn peak_slope_kpa_per_ml(&self) -> f32 {
        self.peak_slope_kpa_per_ml
    }

    /// Adds a reading taken at `taken_ms` with `volume_ml` pumped past rest,
    /// sand pressure `sand_kpa` and internal pressure `internal_kpa`, and
    /// says whether the plateau is reached (see the module docs).
    /// `expansion_mm` is the volume-based diameter minus D0.
    pub fn observe(
        &mut self,
        taken_ms: u32,
        volume_ml: f32,
        sand_kpa: f32,
        internal_kpa: f32,
        expansion_mm: f32,
        params: &Params,
    ) -> bool {
        if self.last_taken_ms == Some(taken_ms) {
            return false;
        }
        self.last_taken_ms = Some(taken_ms);
        let repeated = self
            .window
            .recent()
            .is_some_and(|prev| prev.internal_kpa.to_bits() == internal_kpa.to_bits());
        self.static_run = if repeated {
            self.static_run.saturating_add(1)
        } else {
            1
        };
        self.window.write(Sample {
            volume_ml,
            sand_kpa,
            internal_kpa,
        });
        if !self.window.is_full() {
            self.confirmed = 0;
            return false;
        }
        let (Some((sand_slope, internal_slope)), Some((_, recent_internal_slope))) =
            (self.slopes(0), self.slopes(PLATEAU_WINDOW_SAMPLES / 2))
        else {
            self.confirmed = 0;
            return false;
        };
        if sand_slope > self.peak_slope_kpa_per_ml {
            self.peak_slope_kpa_per_ml = sand_slope;
        }
        let fraction = params.plateau_slope_fraction;
        let response_kpa_per_ml = params.stall_min_rise_kpa / params.stall_volume_ml;
        let looks_flat = fraction > 0.0
            && self.peak_slope_kpa_per_ml >= params.plateau_min_slope_kpa_per_ml
            && expansion_mm >= params.plateau_min_expansion_mm
            && sand_slope < fraction * self.peak_slope_kpa_per_ml
            && internal_slope >= response_kpa_per_ml
            && recent_internal_slope >= response_kpa_per_ml
            && self.static_run < PLATEAU_STATIC_READINGS;
        self.confirmed = if looks_flat {
            self.confirmed.saturating_add(1)
        } else {
            0
        };
        self.confirmed >= PLATEAU_CONFIRM_SAMPLES
    }

    /// Least-squares slopes (kPa/mL) of p_e and p_i against volume over the
    /// window less its `skip` oldest samples; None when the volumes do not
    /// spread (or are not finite).
    fn slopes(&self, skip: usize) -> Option<(f32, f32)> {
        let n = self.window.len().saturating_sub(skip) as f32;
        let (mut sv, mut se, mut si) = (0.0_f32, 0.0_f32, 0.0_f32);
        for s in self.window.oldest_ordered().skip(skip) {
            sv += s.volume_ml;
            se += s.sand_kpa;
            si += s.internal_kpa;
        }
        let (mv, me, mi) = (sv / n, se / n, si / n);
        let (mut sxx, mut sxe, mut sxi) = (0.0_f32, 0.0_f32, 0.0_f32);
        for s in self.window.oldest_ordered().skip(skip) {
            let dv = s.volume_ml - mv;
            sxx += dv * dv;
            sxe += dv * (s.sand_kpa - me);
            sxi += dv * (s.internal_kpa - mi);
        }
        // Written so that NaN fails too.
        let spread = sxx > 1e-12;
        if !spread {
            return None;
        }
        let (sand, internal) = (sxe / sxx, sxi / sxx);
        (sand.is_finite() && internal.is_finite()).then_some((sand, internal))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn feed(det: &mut PlateauDetector, slope: impl Fn(f32) -> f32, steps: u32) -> Option<u32> {
        let params = Params::DEFAULT;
        let mut pe = 0.0;
        for k in 0..steps {
            let v = 0.02 * k as f32;
            pe += slope(v) * 0.02;
            // p_i = p_e + a skin rising at 0.1 kPa/mL.
            if det.observe(k * 10, v, pe, pe + 0.1 * v, 2.0, &params) {
                return Some(k);
            }
        }
        None
    }

    #[test]
    fn straight_line_is_not_a_plateau_and_its_slope_is_exact() {
        let mut det = PlateauDetector::new();
        assert_eq!(feed(&mut det, |_| 3.0, 200), None);
        assert!((det.peak_slope_kpa_per_ml() - 3.0).abs() < 1e-3);
    }

    #[test]
    fn step_down_in_slope_is_found_within_one_window() {
        let mut det = PlateauDetector::new();
        // Slope 3 kPa/mL until 2 mL (step 100), then 0.1: the windowed slope
        // falls below 0.1 × 3 within one window of the change; then the
        // confirmation adds its samples.
        let k = feed(&mut det, |v| if v < 2.0 { 3.0 } else { 0.1 }, 400).unwrap();
        let last = 100 + PLATEAU_WINDOW_SAMPLES as u32 + u32::from(PLATEAU_CONFIRM_SAMPLES);
        assert!((101..=last).contains(&k), "k={k}");
    }

    /// Feeds p_e rising at 3 kPa/mL, then at 0.5 kPa/mL from 1 mL (still
    /// above the plateau's 0.1 × 3): a sand curve bending towards its
    /// plateau. At 2 mL (step 100) the reading goes wrong:
    /// `after(k, p_before)` gives the internal reading from then on.
    fn feed_failure(after: impl Fn(u32, f32) -> f32) -> Option<u32> {
        let params = Params::DEFAULT;
        let mut det = PlateauDetector::new();
        let mut last = 0.0;
        for k in 0..400 {
            let v = 0.02 * k as f32;
            // Skin estimate rising at 0.1 kPa/mL, as in `feed`.
            let skin = 0.1 * v;
            let sand = if v < 1.0 {
                3.0 * v
            } else {
                3.0 + 0.5 * (v - 1.0)
            };
            let internal = if k < 100 { sand + skin } else { after(k, last) };
            if k < 100 {
                last = internal;
            }
            if det.observe(k * 10, v, internal - skin, internal, 2.0, &params) {
                return Some(k);
            }
        }
        None
    }

    #[test]
    fn a_frozen_reading_is_not_a_plateau() {
        // The reading sticks at its last value: p_e = p − skin falls, which
        // looks like the plateau's flat p_e, but nothing is measured.
        assert_eq!(feed_failure(|_, last| last), None);
    }

    #[test]
    fn a_stalled_pump_is_not_a_plateau() {
        // The pump counts steps but the pressure only wobbles (±2 Pa): the
        // internal pressure no longer responds to the counted volume.
        let wobble = |k: u32, last: f32| last + if k.is_multiple_of(2) { 0.002 } else { -0.002 };
        assert_eq!(feed_failure(wobble), None);
    }

    #[test]
    fn duplicate_readings_count_once() {
        let mut det = PlateauDetector::new();
        let p = Params::DEFAULT;
        for _ in 0..50 {
            det.observe(7, 0.0, 0.0, 0.0, 2.0, &p);
        }
        assert!(!det.window.is_full());
    }
}
