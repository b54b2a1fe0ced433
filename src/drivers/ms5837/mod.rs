//! TE Connectivity MS5837 pressure sensor (MS5837-02BA for water, 0..2 bar
//! absolute; MS5837-30BA, 0..30 bar) over async I²C.
//!
//! Protocol (both datasheets): 7-bit address 0x76; RESET 0x1E; PROM words
//! 0..=6 read with 0xA0 + 2·i (16-bit big-endian); CONVERT D1 (pressure)
//! 0x40 + OSR offset, CONVERT D2 (temperature) 0x50 + OSR offset; ADC READ
//! 0x00 returns 24 bits big-endian, or 0 if no conversion has finished.
//!
//! Each register access is one `write_read` (repeated start), as the Linux
//! and Zephyr MS5837 drivers do on real parts; the datasheet draws command
//! and read as separate frames, which the part also accepts.
//!
//! The arithmetic lives in [`calibration`] (PROM + CRC-4) and
//! [`compensation`] (first and second order) as pure functions; this module
//! only moves bytes.

pub mod calibration;
pub mod compensation;
pub mod gauge;

use core::num::NonZeroU8;

use embedded_hal_async::delay::DelayNs;
use embedded_hal_async::i2c::I2c;

pub use calibration::{crc4, Calibration, CrcMismatch, PROM_WORDS};
pub use compensation::{
    compensate, compensate_first_order, compensate_raw, Measurement, Model, RawMeasurement,
};
pub use gauge::GaugeZero;

/// 7-bit I²C address (fixed; the part has no address pin).
pub const ADDRESS: u8 = 0x76;
/// Command: reset, reloads the PROM into the part's registers.
pub const CMD_RESET: u8 = 0x1E;
/// Command: read PROM word i at `CMD_PROM_READ + 2·i`, i in 0..=6.
pub const CMD_PROM_READ: u8 = 0xA0;
/// Command: convert D1 (pressure) at `CMD_CONVERT_D1 + Osr::command_offset`.
pub const CMD_CONVERT_D1: u8 = 0x40;
/// Command: convert D2 (temperature) at `CMD_CONVERT_D2 + Osr::command_offset`.
pub const CMD_CONVERT_D2: u8 = 0x50;
/// Command: read the 24-bit result of the last conversion.
pub const CMD_ADC_READ: u8 = 0x00;
/// Wait after RESET before reading the PROM (µs). The MS5837 datasheets give
/// no figure; the MS5611 family reloads in 2.8 ms, and 10 ms is the margin
/// the common open-source MS5837 drivers use.
pub const RESET_DELAY_US: u32 = 10_000;

/// ADC oversampling ratio: resolution against conversion time.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Osr {
    /// OSR 256: fastest, noisiest.
    Osr256,
    /// OSR 512.
    Osr512,
    /// OSR 1024.
    Osr1024,
    /// OSR 2048.
    Osr2048,
    /// OSR 4096.
    Osr4096,
    /// OSR 8192: finest resolution, slowest.
    Osr8192,
}

impl Osr {
    /// Added to [`CMD_CONVERT_D1`]/[`CMD_CONVERT_D2`] to select this OSR.
    pub const fn command_offset(self) -> u8 {
        match self {
            Osr::Osr256 => 0x0,
            Osr::Osr512 => 0x2,
            Osr::Osr1024 => 0x4,
            Osr::Osr2048 => 0x6,
            Osr::Osr4096 => 0x8,
            Osr::Osr8192 => 0xA,
        }
    }

    /// Datasheet maximum conversion time (µs): the wait between a CONVERT
    /// command and ADC READ.
    pub const fn max_conversion_us(self) -> u32 {
        match self {
            Osr::Osr256 => 600,
            Osr::Osr512 => 1_170,
            Osr::Osr1024 => 2_280,
            Osr::Osr2048 => 4_540,
            Osr::Osr4096 => 9_040,
            Osr::Osr8192 => 18_080,
        }
    }
}

/// A driver error.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Error<E> {
    /// The I²C transaction failed (NAK, arbitration loss, bus error…).
    Bus(E),
    /// The PROM's stored CRC-4 disagrees with the words read.
    Crc {
        /// CRC-4 stored in PROM word 0, bits 15..12.
        expected: u8,
        /// CRC-4 computed from the words read.
        computed: u8,
    },
    /// ADC READ returned 0: the conversion had not finished (or was never
    /// started, e.g. after a brown-out reset of the part).
    AdcNotReady,
    /// `read` before a successful `init`: no calibration yet.
    NotInitialized,
}

impl<E> From<CrcMismatch> for Error<E> {
    fn from(m: CrcMismatch) -> Self {
        Error::Crc {
            expected: m.expected,
            computed: m.computed,
        }
    }
}

/// An MS5837 on an async I²C bus.
pub struct Ms5837<I2C> {
    i2c: I2C,
    model: Model,
    osr: Osr,
    calibration: Option<Calibration>,
}

impl<I2C: I2c> Ms5837<I2C> {
    /// A driver for `model` converting at `osr`. Touches no bus: call
    /// [`Ms5837::init`] before reading.
    pub fn new(i2c: I2C, model: Model, osr: Osr) -> Self {
        Self {
            i2c,
            model,
            osr,
            calibration: None,
        }
    }

    /// Gives the bus back.
    pub fn destroy(self) -> I2C {
        self.i2c
    }

    /// The bus, for a recovery between transfers (bus clear, peripheral
    /// reset); call [`Ms5837::init`] afterwards.
    pub fn bus_mut(&mut self) -> &mut I2C {
        &mut self.i2c
    }

    /// The sensor variant.
    pub fn model(&self) -> Model {
        self.model
    }

    /// The oversampling ratio used for both conversions.
    pub fn osr(&self) -> Osr {
        self.osr
    }

    /// Changes the oversampling ratio for later reads.
    pub fn set_osr(&mut self, osr: Osr) {
        self.osr = osr;
    }

    /// The calibration read by the last successful [`Ms5837::init`].
    pub fn calibration(&self) -> Option<&Calibration> {
        self.calibration.as_ref()
    }

    /// Resets the part, waits [`RESET_DELAY_US`], reads the 7 PROM words and
    /// checks their CRC-4. On any error the driver keeps no calibration.
    pub async fn init<D: DelayNs>(
        &mut self,
        delay: &mut D,
    ) -> Result<Calibration, Error<I2C::Error>> {
        self.calibration = None;
        self.i2c
            .write(ADDRESS, &[CMD_RESET])
            .await
            .map_err(Error::Bus)?;
        delay.delay_us(RESET_DELAY_US).await;
        let mut prom = [0u16; PROM_WORDS];
        for (cmd, word) in (CMD_PROM_READ..).step_by(2).zip(prom.iter_mut()) {
            let mut buf = [0u8; 2];
            self.i2c
                .write_read(ADDRESS, &[cmd], &mut buf)
                .await
                .map_err(Error::Bus)?;
            *word = u16::from_be_bytes(buf);
        }
        let calibration = Calibration::from_prom(&prom)?;
        self.calibration = Some(calibration);
        Ok(calibration)
    }

    /// Starts one conversion (`convert` = [`CMD_CONVERT_D1`] or
    /// [`CMD_CONVERT_D2`]), waits the OSR's maximum conversion time and reads
    /// the 24-bit result.
    async fn convert<D: DelayNs>(
        &mut self,
        convert: u8,
        delay: &mut D,
    ) -> Result<u32, Error<I2C::Error>> {
        self.i2c
            .write(ADDRESS, &[convert | self.osr.command_offset()])
            .await
            .map_err(Error::Bus)?;
        delay.delay_us(self.osr.max_conversion_us()).await;
        let mut buf = [0u8; 3];
        self.i2c
            .write_read(ADDRESS, &[CMD_ADC_READ], &mut buf)
            .await
            .map_err(Error::Bus)?;
        let [b2, b1, b0] = buf;
        match u32::from_be_bytes([0, b2, b1, b0]) {
            0 => Err(Error::AdcNotReady),
            value => Ok(value),
        }
    }

    /// Converts D1 (pressure) then D2 (temperature) and returns the raw
    /// 24-bit ADC values `(d1, d2)`. Takes 2 × [`Osr::max_conversion_us`].
    pub async fn read_adc<D: DelayNs>(
        &mut self,
        delay: &mut D,
    ) -> Result<(u32, u32), Error<I2C::Error>> {
        let d1 = self.convert(CMD_CONVERT_D1, delay).await?;
        let d2 = self.convert(CMD_CONVERT_D2, delay).await?;
        Ok((d1, d2))
    }

    /// One compensated reading in exact integer units (Pa, 0.01 °C).
    pub async fn read_raw<D: DelayNs>(
        &mut self,
        delay: &mut D,
    ) -> Result<RawMeasurement, Error<I2C::Error>> {
        let calibration = self.calibration.ok_or(Error::NotInitialized)?;
        let (d1, d2) = self.read_adc(delay).await?;
        Ok(compensate_raw(self.model, &calibration, d1, d2))
    }

    /// One compensated reading: absolute pressure (kPa) and temperature (°C).
    pub async fn read<D: DelayNs>(
        &mut self,
        delay: &mut D,
    ) -> Result<Measurement, Error<I2C::Error>> {
        self.read_raw(delay).await.map(Measurement::from)
    }

    /// Captures the gauge zero as the mean of `samples` absolute readings,
    /// taken back to back (each 2 × [`Osr::max_conversion_us`]). Call it
    /// with the actuator at rest in free water. Any failed reading aborts.
    pub async fn capture_zero<D: DelayNs>(
        &mut self,
        delay: &mut D,
        samples: NonZeroU8,
    ) -> Result<GaugeZero, Error<I2C::Error>> {
        // Integer sum in Pa: exact, at most 255 · 2³¹ < 2⁶³.
        let mut sum_pa: i64 = 0;
        for _ in 0..samples.get() {
            sum_pa += i64::from(self.read_raw(delay).await?.pressure_pa);
        }
        let mean_pa = sum_pa as f64 / f64::from(samples.get());
        Ok(GaugeZero::from_mean_pa(mean_pa))
    }
}
