//! The sensor task: an MS5837 on its I²C bus, read once per control
//! period, its gauge pressure published in [`Shared::sample`] (latest
//! wins); and the tare, on the host's request.

use core::num::NonZeroU8;

use embassy_time::{with_timeout, Delay, Duration, Ticker, Timer};
use embedded_hal_async::i2c::I2c;
use embedded_storage::nor_flash::NorFlash;

use super::log::{log_info, log_warn};
use super::{now_ms, Shared, StoreMutex};
use crate::controller::{
    pressure_zero_in_range, sensor_sees_limits, Params, PressureSample, CONTROL_PERIOD_MS,
    SENSOR_MODEL,
};
use crate::drivers::ms5837::{Error, Model, Ms5837, Osr};
use crate::protocol::{DeviceMessage, NackReason, TareError};

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

/// Initialises the part (reset, PROM + CRC-4), then publishes one gauge
/// reading every [`CONTROL_PERIOD_MS`]: absolute minus the zero in force
/// ([`Shared::zero_kpa`], which the board read from the store at boot; the
/// zero is never re-captured by itself).
///
/// Until the part answers it publishes [`PressureSample::BusError`] after
/// each failed attempt. After a read that fails or does not finish within
/// [`READ_TIMEOUT_MS`] it publishes `BusError` and re-initialises the part
/// (a brown-out loses the PROM image and leaves ADC READ returning 0). A
/// part that holds SDA low is not recovered here: the controller faults on
/// the bus errors.
///
/// On a tare request ([`Shared::tare`], which the control task sends only
/// in Idle) it averages [`TARE_SAMPLES`] readings, refuses a mean outside
/// [`crate::controller::PRESSURE_ZERO_RANGE_KPA`] or one with which the
/// sensor could not see a pressure limit of the parameters in force
/// ([`sensor_sees_limits`]), stores an accepted one
/// in flash first and then puts it in force, and answers the host.
pub async fn run<I2C: I2c, F: NorFlash>(
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
        Timer::after_millis(RETRY_MS).await;
    }
    log_info!("sensor: ready");

    let mut ticker = Ticker::every(Duration::from_millis(u64::from(CONTROL_PERIOD_MS)));
    let mut needs_init = false;
    loop {
        ticker.next().await;
        if needs_init {
            if bounded(INIT_TIMEOUT_MS, sensor.init(&mut delay))
                .await
                .is_err()
            {
                log_warn!("sensor: re-init failed");
                shared.sample.sender().send(PressureSample::BusError);
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
        let sample = match bounded(READ_TIMEOUT_MS, sensor.read(&mut delay)).await {
            Ok(m) => PressureSample::Reading {
                pressure_kpa: m.pressure_kpa - zero,
                taken_ms: now_ms(),
            },
            Err(_) => {
                log_warn!("sensor: read failed");
                needs_init = true;
                PressureSample::BusError
            }
        };
        shared.sample.sender().send(sample);
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
