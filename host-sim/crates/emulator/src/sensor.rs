//! The line pressure sensor as the controller sees it: an MS5837 read by the
//! board's sensor task (`src/board/sensor.rs`) once per control period.
//!
//! Each read samples the true line pressure `conversion_lag_ms` before it
//! completes (the D1 conversion comes first), adds seeded white noise (the
//! part's RMS resolution at the board's oversampling), rounds to the part's
//! resolution ([`Model::pa_per_count`]), converts with the driver's own
//! [`Measurement`] and subtracts a gauge zero captured like the board's
//! tare ([`GaugeZero::from_samples`] over [`SensorConfig::tare_samples`]
//! readings at rest). The controller sees the newest published sample, with
//! `taken_ms` = when the read completed.
//!
//! A failed read goes through the firmware's own rules
//! ([`urechis::sensing`]): retried within the period, then a failed period
//! (the last good reading stays published), a bus recovery and a re-init
//! of the part, and [`PressureSample::BusError`] once the failure persists.
//! A re-init that succeeds costs the next [`REINIT_SKIPPED_READS`] reads.
//!
//! Failures, as the board would meet them:
//! - random bus errors, each read attempt with `bus_error_probability`;
//! - [`SensorFault::Dropout`]: every attempt fails from then on;
//! - [`SensorFault::Glitch`]: the next attempts fail, then the part
//!   answers again;
//! - [`SensorFault::StuckSda`]: a device holds SDA low: every attempt fails
//!   until a bus recovery frees it;
//! - [`SensorFault::Frozen`]: the part returns the last good conversion
//!   again and again (bit-identical readings, fresh timestamps);
//! - [`SensorFault::Hang`]: the sensor task stops publishing; the last
//!   sample stays, ageing.

use std::collections::VecDeque;

use anyhow::{anyhow, Result};

use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, Normal};
use rand_pcg::Pcg64Mcg;
use urechis::controller::PressureSample;
use urechis::drivers::ms5837::{GaugeZero, Measurement, Model, RawMeasurement, RESET_DELAY_US};
use urechis::sensing::{SensorHealth, RETRIES_PER_PERIOD};

pub use constants::ATMOSPHERE_KPA;

/// How the sensor is read.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SensorConfig {
    /// The part (resolution).
    pub model: Model,
    /// RMS noise of one reading (kPa). MS5837-02BA datasheet, OSR 1024
    /// (the board's): 0.039 mbar = 0.0039 kPa.
    pub noise_kpa: f64,
    /// Absolute pressure at the gauge zero (kPa).
    pub atmosphere_kpa: f64,
    /// Time between reads (ms): the board reads once per control period.
    pub period_ms: u32,
    /// When, within each period, a read completes (ms after the control
    /// step at the period's start); must be below `period_ms`.
    pub read_phase_ms: u32,
    /// How long before completing a read the pressure was sampled (ms).
    pub conversion_lag_ms: u32,
    /// Chance that one read fails on the bus (NAK, CRC, timeout).
    pub bus_error_probability: f64,
    /// Readings averaged for the gauge zero (the board's `TARE_SAMPLES`).
    pub tare_samples: usize,
}

impl Default for SensorConfig {
    /// The board's MS5837-02BA at OSR 1024, read every 10 ms; the read
    /// completes 6 ms into the period (two 2.28 ms conversions plus bus
    /// traffic, `src/board/sensor.rs`), its pressure sampled 5 ms earlier;
    /// one read in a thousand fails on the bus.
    fn default() -> Self {
        Self {
            model: Model::Bar02,
            noise_kpa: 0.0039,
            atmosphere_kpa: ATMOSPHERE_KPA,
            period_ms: urechis::controller::CONTROL_PERIOD_MS,
            read_phase_ms: 6,
            conversion_lag_ms: 5,
            bus_error_probability: 1e-3,
            tare_samples: 32,
        }
    }
}

impl SensorConfig {
    /// Oldest a delivered reading's pressure can be when the controller
    /// reads it (ms): a whole period plus the conversion lag.
    pub fn max_sample_age_ms(&self) -> u32 {
        self.period_ms + self.conversion_lag_ms
    }
}

/// Reads lost after a failed period whose re-init succeeded: the part's
/// reset wait (10 ms) and its PROM (≈ 2 ms at 100 kHz) end about 17 ms
/// after the failed read, and the board reads again at once; the model
/// skips the next two read slots (the next reading 30 ms after the failed
/// one, later than the board's ≈ 23 ms), so the scenarios err towards a
/// stale reading.
pub const REINIT_SKIPPED_READS: u8 = (RESET_DELAY_US / 1_000 / 10 + 1) as u8;

/// A sensor failure injected by a scenario.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SensorFault {
    /// Every read fails on the bus.
    Dropout,
    /// The next this many bus attempts (reads or re-inits) fail, then the
    /// part answers again: electrical noise on the cable.
    Glitch(u8),
    /// A device holds SDA low (it lost clocks mid-byte): every attempt
    /// fails until a bus recovery clocks it free.
    StuckSda,
    /// Every read returns the last good conversion, bit for bit.
    Frozen,
    /// The sensor task stops publishing.
    Hang,
}

/// The emulated sensor and its task.
#[derive(Clone, Debug)]
pub struct Sensor {
    config: SensorConfig,
    noise: Normal<f64>,
    noise_rng: Pcg64Mcg,
    bus_rng: Pcg64Mcg,
    zero: GaugeZero,
    /// True line pressure (kPa) at each of the last milliseconds, newest last.
    history: VecDeque<f64>,
    published: PressureSample,
    last_good_kpa: Option<f32>,
    fault: Option<SensorFault>,
    health: SensorHealth,
    skip_reads: u8,
    recoveries: u32,
    /// A real driver (the virtual board's firmware) reads the part: the
    /// modelled read task stands down.
    driven: bool,
}

impl Sensor {
    /// A sensor tared with the line at `rest_kpa` (true gauge pressure at
    /// rest, normally 0), noise and bus errors drawn from `seed`. Fails on
    /// a negative or non-finite noise level.
    pub fn new(config: SensorConfig, seed: u64, rest_kpa: f64) -> Result<Self> {
        let noise = Normal::new(0.0, config.noise_kpa)
            .map_err(|e| anyhow!("sensor noise_kpa = {}: {e}", config.noise_kpa))?;
        // Separate streams so that changing the bus-error rate does not
        // shift the noise sequence.
        let mut noise_rng = Pcg64Mcg::seed_from_u64(seed ^ 0x5e45_0a15_e000_0001);
        let tare: Vec<f32> = (0..config.tare_samples.max(1))
            .map(|_| convert(&config, &noise, &mut noise_rng, rest_kpa))
            .collect();
        let zero = GaugeZero::from_samples(&tare)
            .ok_or_else(|| anyhow!("sensor tare at {rest_kpa} kPa gave no finite zero"))?;
        Ok(Self {
            config,
            noise,
            noise_rng,
            bus_rng: Pcg64Mcg::seed_from_u64(seed ^ 0x5e45_0a15_e000_0002),
            zero,
            history: VecDeque::new(),
            published: PressureSample::Missing,
            last_good_kpa: None,
            fault: None,
            health: SensorHealth::new(),
            skip_reads: 0,
            recoveries: 0,
            driven: false,
        })
    }

    /// Its configuration.
    pub fn config(&self) -> &SensorConfig {
        &self.config
    }

    /// The gauge zero captured at start (absolute kPa).
    pub fn zero_kpa(&self) -> f32 {
        self.zero.zero_kpa()
    }

    /// Injects (or clears, with `None`) a failure.
    pub fn set_fault(&mut self, fault: Option<SensorFault>) {
        self.fault = fault;
    }

    /// The failure in force.
    pub fn fault(&self) -> Option<SensorFault> {
        self.fault
    }

    /// Bus recoveries the sensor task made so far.
    pub fn recoveries(&self) -> u32 {
        self.recoveries
    }

    /// One bus attempt on a real driver (the virtual board's): whether the
    /// injected fault fails it (Dropout, StuckSda, a Glitch with attempts
    /// left, using one); no random errors.
    pub fn injected_attempt_fails(&mut self) -> bool {
        match self.fault {
            Some(SensorFault::Glitch(_) | SensorFault::Dropout | SensorFault::StuckSda) => {
                self.attempt_fails()
            }
            _ => false,
        }
    }

    /// A real driver reads the part from now on (the virtual board's
    /// firmware, through [`Sensor::injected_attempt_fails`] and
    /// [`Sensor::bus_cleared`]): [`Sensor::tick`] no longer runs the
    /// modelled read task, whose own retries and bus clear would race the
    /// driver's, using up a glitch's failed attempts or freeing a held SDA
    /// before the firmware's bus clear does.
    pub fn attach_driver(&mut self) {
        self.driven = true;
    }

    /// A bus clear freed the bus: a held SDA is released.
    pub fn bus_cleared(&mut self) {
        if self.fault == Some(SensorFault::StuckSda) {
            self.fault = None;
        }
    }

    /// One bus attempt: fails under Dropout, StuckSda, a Glitch with
    /// attempts left (using one), or at random.
    fn attempt_fails(&mut self) -> bool {
        match self.fault {
            Some(SensorFault::Dropout | SensorFault::StuckSda) => true,
            Some(SensorFault::Glitch(n)) => {
                self.fault = n
                    .checked_sub(1)
                    .and_then(|left| (left > 0).then_some(SensorFault::Glitch(left)));
                true
            }
            _ => self.bus_rng.random::<f64>() < self.config.bus_error_probability,
        }
    }

    /// The newest published sample: what the controller sees.
    pub fn sample(&self) -> PressureSample {
        self.published
    }

    /// Records the true line pressure `true_kpa` at the end of millisecond
    /// `t_ms` (call once per millisecond, in order) and completes a read
    /// when one is due.
    pub fn tick(&mut self, t_ms: u32, true_kpa: f64) {
        let keep = self.config.conversion_lag_ms as usize + 1;
        self.history.push_back(true_kpa);
        while self.history.len() > keep {
            self.history.pop_front();
        }
        let period = self.config.period_ms.max(1);
        if self.driven || t_ms % period != self.config.read_phase_ms % period {
            return;
        }
        // The oldest kept value is `conversion_lag_ms` old (or the oldest
        // there is, right after start).
        let sampled_kpa = self.history.front().copied().unwrap_or(true_kpa);
        if self.fault == Some(SensorFault::Hang) {
            return;
        }
        if self.skip_reads > 0 {
            self.skip_reads -= 1;
            return;
        }
        let answered = (0..=RETRIES_PER_PERIOD).any(|_| !self.attempt_fails());
        if !answered {
            let after = self.health.period_failed();
            if after.publish_bus_error {
                self.published = PressureSample::BusError;
            }
            if after.recover {
                self.recoveries += 1;
                // The bus clear frees a held SDA; the re-init is one more
                // attempt, and costs reads when it succeeds.
                if self.fault == Some(SensorFault::StuckSda) {
                    self.fault = None;
                }
                if !self.attempt_fails() {
                    self.skip_reads = REINIT_SKIPPED_READS;
                }
            }
            return;
        }
        self.health.read_ok();
        let sample = match self.fault {
            Some(SensorFault::Frozen) => match self.last_good_kpa {
                Some(pressure_kpa) => PressureSample::Reading {
                    pressure_kpa,
                    taken_ms: t_ms,
                },
                None => PressureSample::BusError,
            },
            // Healthy, or a glitch that just ended (Dropout and StuckSda
            // never answer).
            _ => {
                let pressure_kpa = self.zero.gauge_kpa(convert(
                    &self.config,
                    &self.noise,
                    &mut self.noise_rng,
                    sampled_kpa,
                ));
                self.last_good_kpa = Some(pressure_kpa);
                PressureSample::Reading {
                    pressure_kpa,
                    taken_ms: t_ms,
                }
            }
        };
        self.published = sample;
    }
}

/// One conversion of a true gauge pressure: absolute, noisy, rounded to the
/// part's resolution, through the driver's conversion (absolute kPa).
fn convert(
    config: &SensorConfig,
    noise: &Normal<f64>,
    rng: &mut Pcg64Mcg,
    true_gauge_kpa: f64,
) -> f32 {
    let noise_kpa = noise.sample(rng);
    let pa = (config.atmosphere_kpa + true_gauge_kpa + noise_kpa) * 1000.0;
    let per_count = config.model.pa_per_count() as f64;
    // `as` saturates like the driver's i32 result.
    let pressure_pa = ((pa / per_count).round() * per_count) as i32;
    Measurement::from(RawMeasurement {
        temperature_centi_c: 2000,
        pressure_pa,
    })
    .pressure_kpa
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quiet() -> SensorConfig {
        SensorConfig {
            noise_kpa: 0.0,
            bus_error_probability: 0.0,
            ..SensorConfig::default()
        }
    }

    /// Ticks `sensor` from `from` to `to` ms with true pressure `p(t)`.
    fn feed(sensor: &mut Sensor, from: u32, to: u32, p: impl Fn(u32) -> f64) {
        for t in from..=to {
            sensor.tick(t, p(t));
        }
    }

    #[test]
    fn reads_the_pressure_lag_ms_before_completing_quantised_to_1_pa() {
        let config = quiet();
        let mut s = Sensor::new(config, 7, 0.0).unwrap();
        assert_eq!(s.sample(), PressureSample::Missing);
        // A ramp of 1 kPa/s + 0.0004 kPa: the read completing at 16 ms
        // sampled t = 11 ms.
        feed(&mut s, 1, 16, |t| f64::from(t) * 1e-3 + 0.0004);
        let PressureSample::Reading {
            pressure_kpa,
            taken_ms,
        } = s.sample()
        else {
            panic!("no reading: {:?}", s.sample());
        };
        assert_eq!(taken_ms, 16);
        // 101.325 + 0.0114 kPa rounds to 101336 Pa; the zero is 101325 Pa.
        let want = 101.336_f32 - 101.325_f32;
        assert_eq!(pressure_kpa, want);
    }

    #[test]
    fn noise_has_its_rms_and_the_tare_zeroes_it() {
        let config = SensorConfig {
            noise_kpa: 0.01,
            bus_error_probability: 0.0,
            ..SensorConfig::default()
        };
        let mut s = Sensor::new(config, 3, 0.0).unwrap();
        let mut readings = Vec::new();
        for k in 0..2000u32 {
            feed(&mut s, 10 * k + 1, 10 * k + 10, |_| 2.0);
            if let PressureSample::Reading { pressure_kpa, .. } = s.sample() {
                readings.push(f64::from(pressure_kpa));
            }
        }
        let n = readings.len() as f64;
        let mean = readings.iter().sum::<f64>() / n;
        let rms = (readings.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / n).sqrt();
        // 2000 readings: the mean within 4 standard errors (plus the
        // tare's own error, 0.01/√32) of 2 kPa; the RMS within 5 %.
        assert!(
            (mean - 2.0).abs() < 4.0 * 0.01 / n.sqrt() + 4.0 * 0.01 / 32f64.sqrt(),
            "{mean}"
        );
        assert!((rms / 0.01 - 1.0).abs() < 0.05, "{rms}");
    }

    #[test]
    fn faults_as_the_board_delivers_them() {
        let mut s = Sensor::new(quiet(), 1, 0.0).unwrap();
        feed(&mut s, 1, 10, |_| 1.0);
        let good = s.sample();
        s.set_fault(Some(SensorFault::Frozen));
        feed(&mut s, 11, 20, |_| 5.0);
        match (good, s.sample()) {
            (
                PressureSample::Reading {
                    pressure_kpa: a, ..
                },
                PressureSample::Reading {
                    pressure_kpa: b,
                    taken_ms,
                },
            ) => {
                assert_eq!(a.to_bits(), b.to_bits());
                assert_eq!(taken_ms, 16);
            }
            other => panic!("{other:?}"),
        }
        s.set_fault(Some(SensorFault::Dropout));
        // One failed period keeps the last reading (and recovers the bus);
        // the second publishes the error.
        feed(&mut s, 21, 30, |_| 5.0);
        assert!(matches!(s.sample(), PressureSample::Reading { .. }));
        assert_eq!(s.recoveries(), 1);
        feed(&mut s, 31, 40, |_| 5.0);
        assert_eq!(s.sample(), PressureSample::BusError);
        s.set_fault(Some(SensorFault::Hang));
        feed(&mut s, 41, 70, |_| 5.0);
        assert_eq!(
            s.sample(),
            PressureSample::BusError,
            "nothing new published"
        );
    }

    #[test]
    fn failed_periods_come_at_the_square_of_the_error_rate() {
        // Each attempt fails with p = 0.1; a period fails only when its
        // retry fails too (p² = 0.01), and a single failed period
        // publishes no error.
        let config = SensorConfig {
            bus_error_probability: 0.1,
            ..quiet()
        };
        let mut s = Sensor::new(config, 11, 0.0).unwrap();
        let (mut errors, mut before) = (0, s.sample());
        let n = 5000u32;
        for k in 0..n {
            feed(&mut s, 10 * k + 1, 10 * k + 10, |_| 0.0);
            let now = s.sample();
            errors += u32::from(now == PressureSample::BusError && before != now);
            before = now;
        }
        // About 5000 read slots (two skipped after each recovery):
        // Binomial(≈ 4900, 0.01), mean ≈ 49, sd ≈ 7; within 4 sd.
        let r = f64::from(s.recoveries());
        assert!((r - 49.0).abs() < 4.0 * 7.0, "{r}");
        // Two failed periods with no reading between (≈ 1 % of the
        // recoveries: ≈ 0.5 expected) are rare.
        assert!(errors < 5, "{errors}");
    }
}
