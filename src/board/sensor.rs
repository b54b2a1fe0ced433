//! The sensor task: an MS5837 on I²C1, read once per control period, its
//! gauge pressure published in [`SAMPLE`] (latest wins).

use core::num::NonZeroU8;

use embassy_stm32::i2c::{self, I2c, Master};
use embassy_stm32::mode::Async;
use embassy_time::{with_timeout, Delay, Duration, Ticker, Timer};

use super::channels::SAMPLE;
use super::now_ms;
use crate::controller::{PressureSample, CONTROL_PERIOD_MS};
use crate::drivers::ms5837::{Error, GaugeZero, Model, Ms5837, Osr};

/// The sensor's I²C bus as the board builds it.
pub type SensorBus = I2c<'static, Async, Master>;

/// The sensor as the board builds it.
pub type Sensor = Ms5837<SensorBus>;

/// The part fitted: 0..2 bar absolute, 1 Pa resolution, ample for a head
/// buried a few decimetres deep.
pub const MODEL: Model = Model::Bar02;

/// Oversampling: two conversions (pressure, temperature) must fit in one
/// control period with the bus traffic. OSR 1024 takes at most
/// 2 × 2.28 ms = 4.56 ms plus about 1.6 ms of 100 kHz I²C, 6.2 ms in 10 ms;
/// OSR 2048 (2 × 4.54 ms + 1.6 ms = 10.7 ms) would not fit.
pub const OSR: Osr = Osr::Osr1024;

/// Readings averaged for the gauge zero at boot (about 0.16 s).
pub const TARE_SAMPLES: NonZeroU8 = match NonZeroU8::new(32) {
    Some(n) => n,
    None => NonZeroU8::MIN,
};

/// Wait between attempts while the sensor does not answer at boot (ms).
pub const RETRY_MS: u64 = 100;

/// Longest a reading may take before it counts as a bus error (ms): the
/// HAL's async I²C has no timeout of its own, and a part holding the bus
/// would otherwise freeze this task (the controller would still see the
/// samples go stale).
pub const READ_TIMEOUT_MS: u64 = 9;

/// Longest an init (reset wait 10 ms + PROM) may take (ms).
pub const INIT_TIMEOUT_MS: u64 = 50;

/// Longest the tare may take (ms): [`TARE_SAMPLES`] readings of at most
/// 6.2 ms each, with margin.
pub const TARE_TIMEOUT_MS: u64 = 1_000;

/// Why a sensor operation produced no value.
#[derive(Clone, Copy, Debug, defmt::Format)]
enum SensorFailure {
    /// The driver reported an error.
    Driver(Error<i2c::Error>),
    /// The bus did not complete in time.
    Timeout,
}

// The read must fit its timeout, and the timeout the period it is
// published in.
const _: () = assert!(
    2 * OSR.max_conversion_us() + 1_600 < READ_TIMEOUT_MS as u32 * 1_000
        && READ_TIMEOUT_MS as u32 <= CONTROL_PERIOD_MS
);

/// Initialises the part (reset, PROM + CRC-4), captures the gauge zero with
/// the actuator at rest in free water, then publishes one gauge reading
/// every [`CONTROL_PERIOD_MS`].
///
/// Until the zero is captured it publishes [`PressureSample::BusError`]
/// after each failed attempt, so the controller sees a missing sensor
/// rather than a reading against a wrong zero. After a read that fails or
/// does not finish within [`READ_TIMEOUT_MS`] it publishes `BusError` and
/// re-initialises the part (a brown-out loses the PROM image and leaves ADC
/// READ returning 0); the zero is kept. A part that holds SDA low is not
/// recovered here: the controller faults on the bus errors.
#[embassy_executor::task]
pub async fn sensor_task(mut sensor: Sensor) -> ! {
    let mut delay = Delay;
    let zero = tare(&mut sensor, &mut delay).await;
    defmt::info!("sensor: gauge zero {} kPa absolute", zero.zero_kpa());

    let mut ticker = Ticker::every(Duration::from_millis(u64::from(CONTROL_PERIOD_MS)));
    let mut needs_init = false;
    loop {
        ticker.next().await;
        if needs_init {
            if let Err(e) = bounded(INIT_TIMEOUT_MS, sensor.init(&mut delay)).await {
                defmt::warn!("sensor: re-init failed: {}", e);
                SAMPLE.sender().send(PressureSample::BusError);
                continue;
            }
            needs_init = false;
        }
        let sample = match bounded(READ_TIMEOUT_MS, sensor.read(&mut delay)).await {
            Ok(m) => PressureSample::Reading {
                pressure_kpa: zero.gauge_kpa(m.pressure_kpa),
                taken_ms: now_ms(),
            },
            Err(e) => {
                defmt::warn!("sensor: read failed: {}", e);
                needs_init = true;
                PressureSample::BusError
            }
        };
        SAMPLE.sender().send(sample);
    }
}

/// Initialises the part and captures the gauge zero, retrying every
/// [`RETRY_MS`] until both succeed.
async fn tare(sensor: &mut Sensor, delay: &mut Delay) -> GaugeZero {
    loop {
        let attempt = match bounded(INIT_TIMEOUT_MS, sensor.init(delay)).await {
            Ok(_) => bounded(TARE_TIMEOUT_MS, sensor.capture_zero(delay, TARE_SAMPLES)).await,
            Err(e) => Err(e),
        };
        match attempt {
            Ok(zero) => return zero,
            Err(e) => {
                defmt::warn!("sensor: init/tare failed: {}", e);
                SAMPLE.sender().send(PressureSample::BusError);
                Timer::after_millis(RETRY_MS).await;
            }
        }
    }
}

/// Runs a driver operation with a deadline; dropping the HAL future on
/// timeout stops its DMA transfer.
async fn bounded<T>(
    limit_ms: u64,
    op: impl core::future::Future<Output = Result<T, Error<i2c::Error>>>,
) -> Result<T, SensorFailure> {
    match with_timeout(Duration::from_millis(limit_ms), op).await {
        Ok(Ok(value)) => Ok(value),
        Ok(Err(e)) => Err(SensorFailure::Driver(e)),
        Err(_) => Err(SensorFailure::Timeout),
    }
}
