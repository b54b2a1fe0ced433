//! Gauge pressure: absolute pressure minus a zero captured with the actuator
//! at rest in free water (the experiment data's `pressure_kpa` convention).

/// The absolute pressure (kPa) that reads as zero gauge pressure.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GaugeZero {
    zero_kpa: f32,
}

impl GaugeZero {
    /// A zero at this absolute pressure (kPa); `None` if it is not finite.
    pub fn new(zero_kpa: f32) -> Option<Self> {
        zero_kpa.is_finite().then_some(Self { zero_kpa })
    }

    /// The mean of absolute pressure samples (kPa) taken at rest; `None` if
    /// there are none or any is not finite.
    pub fn from_samples(samples_kpa: &[f32]) -> Option<Self> {
        if samples_kpa.is_empty() {
            return None;
        }
        // f64 sum: exact enough for any realistic count, no drift from order.
        let sum: f64 = samples_kpa.iter().map(|&p| f64::from(p)).sum();
        Self::new((sum / samples_kpa.len() as f64) as f32)
    }

    /// From a mean of integer pressures (Pa), always finite.
    pub(super) fn from_mean_pa(mean_pa: f64) -> Self {
        Self {
            zero_kpa: (mean_pa / 1000.0) as f32,
        }
    }

    /// The captured zero, absolute (kPa).
    pub fn zero_kpa(&self) -> f32 {
        self.zero_kpa
    }

    /// Gauge pressure (kPa) of an absolute reading (kPa).
    pub fn gauge_kpa(&self, absolute_kpa: f32) -> f32 {
        absolute_kpa - self.zero_kpa
    }
}
