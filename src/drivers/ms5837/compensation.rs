//! First- and second-order compensation of the MS5837's raw ADC values, per
//! the MS5837-02BA and MS5837-30BA datasheets ("Pressure and temperature
//! calculation" and "Second order temperature compensation").
//!
//! Pure integer arithmetic, as the datasheets specify it. Divisions by 2ⁿ
//! are arithmetic right shifts, i.e. they round towards −∞: the 30BA
//! datasheet's worked example (TEMP = 1981 from dT = −5962) only comes out
//! that way (truncating towards zero gives 1982).

use super::calibration::Calibration;

/// Largest value a 24-bit ADC result can take; larger inputs are saturated
/// to it so the arithmetic below cannot overflow.
pub const ADC_MAX: u32 = 0x00FF_FFFF;

/// The sensor variant: the two share the protocol but not the arithmetic.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Model {
    /// MS5837-02BA: 0..2 bar absolute (300..1200 mbar specified accuracy);
    /// pressure resolved in 0.01 mbar (1 Pa).
    Bar02,
    /// MS5837-30BA: 0..30 bar absolute; pressure resolved in 0.1 mbar (10 Pa).
    Bar30,
}

impl Model {
    /// Pascals per count of the datasheet's pressure result P.
    pub const fn pa_per_count(self) -> i64 {
        match self {
            // P in 0.01 mbar = 1 Pa.
            Model::Bar02 => 1,
            // P in 0.1 mbar = 10 Pa.
            Model::Bar30 => 10,
        }
    }

    /// Absolute pressure range over which the datasheet specifies the
    /// part's accuracy (kPa): 02BA 300–1200 mbar, 30BA 0–30 bar. Outside
    /// it a reading is not to be trusted, so no limit may rely on one.
    pub const fn specified_kpa(self) -> (f32, f32) {
        match self {
            Model::Bar02 => (30.0, 120.0),
            Model::Bar30 => (0.0, 3000.0),
        }
    }
}

/// A compensated reading in the sensor's exact integer units.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RawMeasurement {
    /// Temperature (0.01 °C): the datasheet's TEMP (first order) or TEMP2.
    pub temperature_centi_c: i32,
    /// Absolute pressure (Pa): the datasheet's P or P2 times
    /// [`Model::pa_per_count`], saturated to the `i32` range.
    pub pressure_pa: i32,
}

/// A compensated reading in engineering units.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Measurement {
    /// Absolute pressure (kPa).
    pub pressure_kpa: f32,
    /// Sensor temperature (°C).
    pub temperature_c: f32,
}

impl From<RawMeasurement> for Measurement {
    fn from(raw: RawMeasurement) -> Self {
        Self {
            // Both conversions are exact in f64; one rounding to f32.
            pressure_kpa: (f64::from(raw.pressure_pa) / 1000.0) as f32,
            temperature_c: (f64::from(raw.temperature_centi_c) / 100.0) as f32,
        }
    }
}

/// First-order quantities of the datasheet, kept for the second order.
struct FirstOrder {
    /// dT = D2 − C5·2⁸.
    dt: i64,
    /// TEMP (0.01 °C).
    temp: i64,
    /// OFF: offset at the actual temperature.
    off: i64,
    /// SENS: sensitivity at the actual temperature.
    sens: i64,
}

fn first_order(model: Model, cal: &Calibration, d1: u32, d2: u32) -> (FirstOrder, i64) {
    let d1 = i64::from(d1.min(ADC_MAX));
    let d2 = i64::from(d2.min(ADC_MAX));
    let dt = d2 - (i64::from(cal.t_ref) << 8);
    let temp = 2000 + ((dt * i64::from(cal.tempsens)) >> 23);
    let (off, sens) = match model {
        Model::Bar02 => (
            (i64::from(cal.off_t1) << 17) + ((i64::from(cal.tco) * dt) >> 6),
            (i64::from(cal.sens_t1) << 16) + ((i64::from(cal.tcs) * dt) >> 7),
        ),
        Model::Bar30 => (
            (i64::from(cal.off_t1) << 16) + ((i64::from(cal.tco) * dt) >> 7),
            (i64::from(cal.sens_t1) << 15) + ((i64::from(cal.tcs) * dt) >> 8),
        ),
    };
    (
        FirstOrder {
            dt,
            temp,
            off,
            sens,
        },
        d1,
    )
}

/// P = (D1·SENS/2²¹ − OFF)/2ⁿ in the model's counts, converted to Pa and
/// saturated to `i32`.
fn pressure_pa(model: Model, d1: i64, sens: i64, off: i64) -> i32 {
    // Worst case over all 16-bit coefficients and 24-bit ADC values:
    // |SENS2| < 2^36.6, so |D1·SENS2| < 2^60.6 fits i64 (checked by the
    // full-range property test, which runs with overflow checks on).
    let scaled = (d1 * sens) >> 21;
    let shift = match model {
        Model::Bar02 => 15,
        Model::Bar30 => 13,
    };
    saturate_i32(((scaled - off) >> shift) * model.pa_per_count())
}

fn saturate_i32(x: i64) -> i32 {
    i32::try_from(x).unwrap_or(if x < 0 { i32::MIN } else { i32::MAX })
}

/// First-order compensation only (the datasheet's TEMP and P), e.g. to check
/// against the datasheet examples. `d1`/`d2` are the 24-bit pressure and
/// temperature ADC values; larger values are saturated to [`ADC_MAX`].
pub fn compensate_first_order(model: Model, cal: &Calibration, d1: u32, d2: u32) -> RawMeasurement {
    let (f, d1) = first_order(model, cal, d1, d2);
    RawMeasurement {
        temperature_centi_c: saturate_i32(f.temp),
        pressure_pa: pressure_pa(model, d1, f.sens, f.off),
    }
}

/// Full compensation, first and second order (the datasheet's TEMP2 and
/// P2), in exact integer units. `d1`/`d2` are the 24-bit pressure and
/// temperature ADC values; larger values are saturated to [`ADC_MAX`].
pub fn compensate_raw(model: Model, cal: &Calibration, d1: u32, d2: u32) -> RawMeasurement {
    let (f, d1) = first_order(model, cal, d1, d2);
    // All inputs are bounded (24-bit D, 16-bit C), so every product below fits
    // i64: |dT| < 2²⁴, |TEMP − 2000| < 2¹⁷.
    let dt2 = f.dt * f.dt;
    let t = f.temp - 2000;
    let t2 = t * t;
    let (ti, offi, sensi) = match model {
        Model::Bar02 => {
            if f.temp < 2000 {
                ((11 * dt2) >> 35, (31 * t2) >> 3, (63 * t2) >> 5)
            } else {
                (0, 0, 0)
            }
        }
        Model::Bar30 => {
            if f.temp < 2000 {
                let (mut offi, mut sensi) = ((3 * t2) >> 1, (5 * t2) >> 3);
                if f.temp < -1500 {
                    let v = (f.temp + 1500) * (f.temp + 1500);
                    offi += 7 * v;
                    sensi += 4 * v;
                }
                ((3 * dt2) >> 33, offi, sensi)
            } else {
                ((2 * dt2) >> 37, t2 >> 4, 0)
            }
        }
    };
    RawMeasurement {
        temperature_centi_c: saturate_i32(f.temp - ti),
        pressure_pa: pressure_pa(model, d1, f.sens - sensi, f.off - offi),
    }
}

/// Full compensation (first and second order) in engineering units: absolute
/// pressure (kPa) and temperature (°C).
pub fn compensate(model: Model, cal: &Calibration, d1: u32, d2: u32) -> Measurement {
    compensate_raw(model, cal, d1, d2).into()
}
