//! The sensor task: an MS5837 on its I²C bus, read once per control
//! period, its gauge pressure published in [`Shared::sample`] (latest
//! wins); and the tare, on the host's request.

use core::num::NonZeroU8;

use embassy_time::{with_timeout, Delay, Duration, Instant, Ticker, Timer};
use embedded_hal_async::i2c::I2c;
use embedded_storage::nor_flash::NorFlash;

use super::log::{log_info, log_warn};
use super::{now_ms, Shared, StoreMutex};
use crate::controller::{
    pressure_zero_in_range, sensor_sees_limits, Params, PressureSample, CONTROL_PERIOD_MS,
    SENSOR_MODEL,
};
use crate::drivers::i2c_bus_clear::BusClearError;
use crate::drivers::ms5837::{Error, Model, Ms5837, Osr};
use crate::protocol::{DeviceMessage, NackReason, TareError};
use crate::sensing::{SensorHealth, RETRIES_PER_PERIOD};

/// The part fitted: [`SENSOR_MODEL`], one per build (the MS5837-02BA:
/// 300–1200 mbar absolute specified, 1 Pa resolution, ample for a head
/// buried a few decimetres deep).
pub const MODEL: Model = SENSOR_MODEL;

/// Oversampling: two conversions (pressure, temperature) must fit in one
/// control period with the bus traffic. OSR 1024 takes at most
/// 2 × 2.28 ms = 4.56 ms plus about 1.6 ms of 100 kHz I²C, 6.2 ms in 10 ms;
/// OSR 2048 (2 × 4.54 ms + 1.6 ms = 10.7 ms) would not fit.
pub const OSR: Osr = Osr::Osr1024;

/// Readings averaged for a tare (about 0.2 s).
pub const TARE_SAMPLES: NonZeroU8 = match NonZeroU8::new(32) {
    Some(n) => n,
    None => NonZeroU8::MIN,
};

/// Standard atmosphere (absolute kPa): the reference of the published
/// pressure while no zero was ever taken. Those readings are only
/// approximately gauge; the controller refuses `Start` until a tare.
pub const STANDARD_ATMOSPHERE_KPA: f32 = 101.325;

/// Wait between attempts while the sensor does not answer at boot (ms).
pub const RETRY_MS: u64 = 100;

/// Longest a reading may take before it counts as a bus error (ms): the
/// HAL's async I²C has no timeout of its own, and a part holding the bus
/// would otherwise freeze this task (the controller would still see the
/// samples go stale).
pub const READ_TIMEOUT_MS: u64 = 9;

/// Longest an init (reset wait 10 ms + PROM) may take (ms).
pub const INIT_TIMEOUT_MS: u64 = 50;

/// Longest a tare may take (ms): [`TARE_SAMPLES`] readings of at most
/// 6.2 ms each, with margin.
pub const TARE_TIMEOUT_MS: u64 = 1_000;

// The read must fit its timeout, and the timeout the period it is
// published in.
const _: () = assert!(
    2 * OSR.max_conversion_us() + 1_600 < READ_TIMEOUT_MS as u32 * 1_000
        && READ_TIMEOUT_MS as u32 <= CONTROL_PERIOD_MS
);

/// Why a sensor operation produced no value.
enum SensorFailure<E> {
    /// The driver reported an error.
    #[allow(dead_code)] // kept for debugging; the log names only the kind
    Driver(Error<E>),
    /// The bus did not complete in time.
    Timeout,
}

/// An I²C bus the sensor task can free after a failed period: a bus clear
/// ([`crate::drivers::i2c_bus_clear::clear_bus`]: SCL pulses until a device
/// releases SDA, then a STOP) and a reset of the I²C peripheral. The board
/// implements it on I2C1 (PB8/PB9), the virtual board on its simulated
/// bus.
pub trait BusRecovery {
    /// Frees and restarts the bus. `Err` when SDA stays low (a device
    /// stuck for good): the next reads fail and the failure is reported.
    fn recover_bus(&mut self) -> Result<(), BusClearError>;
}

/// Longest one read (two conversions and the bus traffic) takes (µs).
pub const READ_MAX_US: u32 = 2 * OSR.max_conversion_us() + 1_600;

// The end-to-end bounds count on a read within the board's stated time.
const _: () = assert!(READ_MAX_US <= crate::controller::BOARD_TIMING.sensor_read_ms * 1_000);

/// Initialises the part (reset, PROM + CRC-4), then publishes one gauge
/// reading every [`CONTROL_PERIOD_MS`]: absolute minus the zero in force
/// ([`Shared::zero_kpa`], which the board read from the store at boot; the
/// zero is never re-captured by itself).
///
/// Until the part answers at boot it publishes [`PressureSample::BusError`]
/// after each failed attempt. After that a failed read (an error, or no
/// result within [`READ_TIMEOUT_MS`]) is retried at once
/// ([`RETRIES_PER_PERIOD`]) unless it timed out or the period is over: a
/// retry then ends within one read time ([`READ_MAX_US`]) of the period's
/// end, so one glitch costs no reading, at worst one 2.4 ms late. A period
/// with no reading follows [`SensorHealth`]: the last
/// good reading stays published (ageing), the bus is recovered
/// ([`BusRecovery`]) and the part re-initialised (a brown-out loses the
/// PROM image and leaves ADC READ returning 0), and
/// [`PressureSample::BusError`] is published once
/// [`FAILED_PERIODS_BEFORE_BUS_ERROR`](crate::sensing::FAILED_PERIODS_BEFORE_BUS_ERROR)
/// periods in a row failed.
///
/// On a tare request ([`Shared::tare`], which the control task sends only
/// in Idle) it averages [`TARE_SAMPLES`] readings, refuses a mean outside
/// [`crate::controller::PRESSURE_ZERO_RANGE_KPA`] or one with which the
/// sensor could not see a pressure limit of the parameters in force
/// ([`sensor_sees_limits`]), stores an accepted one
/// in flash first and then puts it in force, and answers the host.
pub async fn run<I2C: I2c + BusRecovery, F: NorFlash>(
    mut sensor: Ms5837<I2C>,
    shared: &Shared,
    store: &StoreMutex<F>,
) -> ! {
    let mut delay = Delay;
    while bounded(INIT_TIMEOUT_MS, sensor.init(&mut delay))
        .await
        .is_err()
    {
        log_warn!("sensor: init failed");
        shared.sample.sender().send(PressureSample::BusError);
        if sensor.bus_mut().recover_bus().is_err() {
            log_warn!("sensor: SDA held low");
        }
        Timer::after_millis(RETRY_MS).await;
    }
    log_info!("sensor: ready");

    let period = Duration::from_millis(u64::from(CONTROL_PERIOD_MS));
    let mut ticker = Ticker::every(period);
    let mut health = SensorHealth::new();
    let mut needs_init = false;
    loop {
        ticker.next().await;
        let period_end = Instant::now() + period;
        if needs_init {
            if bounded(INIT_TIMEOUT_MS, sensor.init(&mut delay))
                .await
                .is_err()
            {
                log_warn!("sensor: re-init failed");
                failed_period(&mut sensor, shared, &mut health);
                continue;
            }
            needs_init = false;
        }
        if let Some(request) = shared.tare.try_take() {
            let seq = request.seq;
            let result = tare(&mut sensor, &mut delay, shared, store, &request.params).await;
            if result == Err(TareError::Sensor) {
                needs_init = true;
            }
            shared.reply(match result {
                Ok(()) => DeviceMessage::Ack { seq },
                Err(e) => DeviceMessage::nack(seq, NackReason::Tare(e)),
            });
            // The samples went stale during the tare: a fresh one now.
            ticker.reset();
        }
        let zero = shared.zero_kpa().unwrap_or(STANDARD_ATMOSPHERE_KPA);
        let mut reading = None;
        for attempt in 0..=RETRIES_PER_PERIOD {
            // A retry after a failure late in a read may end up to a read's
            // time past the period (the ticker then catches up at once).
            if attempt > 0 && Instant::now() > period_end {
                break;
            }
            match bounded(READ_TIMEOUT_MS, sensor.read(&mut delay)).await {
                Ok(m) => {
                    reading = Some(m);
                    break;
                }
                // A bus that does not answer within a read's time is not
                // retried: the recovery is what may free it.
                Err(SensorFailure::Timeout) => {
                    log_warn!("sensor: read timed out");
                    break;
                }
                Err(SensorFailure::Driver(_)) => {
                    log_warn!("sensor: read failed (attempt {})", attempt + 1)
                }
            }
        }
        match reading {
            Some(m) => {
                health.read_ok();
                shared.sample.sender().send(PressureSample::Reading {
                    pressure_kpa: m.pressure_kpa - zero,
                    taken_ms: now_ms(),
                });
            }
            None => {
                failed_period(&mut sensor, shared, &mut health);
                // Re-initialise now, not a period later: the next reading
                // comes as soon as the part is back.
                needs_init = bounded(INIT_TIMEOUT_MS, sensor.init(&mut delay))
                    .await
                    .is_err();
            }
        }
    }
}

/// A period without a reading: [`SensorHealth`] decides whether to publish
/// `BusError`; the bus is recovered.
fn failed_period<I2C: I2c + BusRecovery>(
    sensor: &mut Ms5837<I2C>,
    shared: &Shared,
    health: &mut SensorHealth,
) {
    let after = health.period_failed();
    if after.publish_bus_error {
        shared.sample.sender().send(PressureSample::BusError);
    }
    if after.recover {
        match sensor.bus_mut().recover_bus() {
            Ok(()) => log_info!("sensor: bus recovered"),
            Err(e) => log_warn!("sensor: bus recovery failed: {}", e),
        }
    }
}

/// Takes, checks, stores and applies a new zero.
async fn tare<I2C: I2c, F: NorFlash>(
    sensor: &mut Ms5837<I2C>,
    delay: &mut Delay,
    shared: &Shared,
    store: &StoreMutex<F>,
    params: &Params,
) -> Result<(), TareError> {
    let zero = bounded(TARE_TIMEOUT_MS, sensor.capture_zero(delay, TARE_SAMPLES))
        .await
        .map_err(|_| TareError::Sensor)?;
    let zero_kpa = zero.zero_kpa();
    if !pressure_zero_in_range(zero_kpa) {
        log_warn!("sensor: tare {} kPa out of range, refused", zero_kpa);
        return Err(TareError::OutOfRange {
            measured_kpa: zero_kpa,
        });
    }
    if let Err(field) = sensor_sees_limits(zero_kpa, params) {
        log_warn!("sensor: tare {} kPa hides a limit, refused", zero_kpa);
        return Err(TareError::SensorRange(field));
    }
    store
        .lock()
        .await
        .save_zero(zero_kpa)
        .map_err(|_| TareError::Flash)?;
    shared.set_zero_kpa(Some(zero_kpa));
    log_info!("sensor: tare {} kPa absolute, stored", zero_kpa);
    Ok(())
}

/// Runs a driver operation with a deadline; dropping the HAL future on
/// timeout stops its DMA transfer.
async fn bounded<T, E>(
    limit_ms: u64,
    op: impl core::future::Future<Output = Result<T, Error<E>>>,
) -> Result<T, SensorFailure<E>> {
    match with_timeout(Duration::from_millis(limit_ms), op).await {
        Ok(Ok(value)) => Ok(value),
        Ok(Err(e)) => Err(SensorFailure::Driver(e)),
        Err(_) => Err(SensorFailure::Timeout),
    }
}
