//! MS5837 driver against an I²C mock: every case lists the exact bus
//! transactions. Commands and timings are written out again here from the
//! datasheets, not imported, so a wrong constant in the driver fails a test.

use core::num::NonZeroU8;

use embassy_futures::block_on;
use embedded_hal::i2c::{ErrorKind, NoAcknowledgeSource};
use embedded_hal_mock::eh1::delay::{CheckedDelay, Transaction as Delay};
use embedded_hal_mock::eh1::i2c::{Mock as I2cMock, Transaction as I2c};
use proptest::prelude::*;
use urechis::drivers::ms5837::{
    compensate, compensate_first_order, compensate_raw, crc4, Calibration, Error, GaugeZero, Model,
    Ms5837, Osr, RawMeasurement,
};

// --- Datasheet protocol, written out again -------------------------------
const ADDR: u8 = 0x76;
const RESET: u8 = 0x1E;
const PROM_READ: [u8; 7] = [0xA0, 0xA2, 0xA4, 0xA6, 0xA8, 0xAA, 0xAC];
const CONVERT_D1_OSR4096: u8 = 0x48;
const CONVERT_D2_OSR4096: u8 = 0x58;
const ADC_READ: u8 = 0x00;
/// Max conversion time at OSR 4096 (datasheet table: 9.04 ms).
const CONVERSION_OSR4096_US: u32 = 9_040;
/// Wait after RESET.
const RESET_MS: u32 = 10;

/// Datasheet example coefficients C1..C6 of the MS5837-30BA.
const C_30BA: [u16; 6] = [34982, 36352, 20328, 22354, 26646, 26146];
/// Datasheet example coefficients C1..C6 of the MS5837-02BA (the same
/// example as the MS5637-02BA datasheet's).
const C_02BA: [u16; 6] = [46372, 43981, 29059, 27842, 31553, 28165];

/// TE AN520 transcribed literally (16-bit remainder, feedback 0x3000, a zero
/// word 7 appended, CRC nibble of word 0 cleared), independent of the
/// driver's CRC-catalog formulation.
fn an520(prom: &[u16; 7]) -> u8 {
    let mut n_prom = [0u16; 8];
    n_prom[..7].copy_from_slice(prom);
    n_prom[0] &= 0x0FFF;
    let mut n_rem: u16 = 0;
    for cnt in 0..16 {
        if cnt % 2 == 1 {
            n_rem ^= n_prom[cnt >> 1] & 0x00FF;
        } else {
            n_rem ^= n_prom[cnt >> 1] >> 8;
        }
        for _ in 0..8 {
            n_rem = if n_rem & 0x8000 != 0 {
                (n_rem << 1) ^ 0x3000
            } else {
                n_rem << 1
            };
        }
    }
    ((n_rem >> 12) & 0xF) as u8
}

/// A PROM image with a correct CRC nibble: factory bits 0x340 (version
/// field 0x1A) and the given C1..C6.
fn prom(c: [u16; 6]) -> [u16; 7] {
    let mut p = [0x0340, c[0], c[1], c[2], c[3], c[4], c[5]];
    p[0] |= u16::from(an520(&p)) << 12;
    p
}

fn calibration(c: [u16; 6]) -> Calibration {
    Calibration {
        factory: 0,
        sens_t1: c[0],
        off_t1: c[1],
        tcs: c[2],
        tco: c[3],
        t_ref: c[4],
        tempsens: c[5],
    }
}

fn init_transactions(words: &[u16; 7]) -> Vec<I2c> {
    let mut t = vec![I2c::write(ADDR, vec![RESET])];
    for (cmd, word) in PROM_READ.iter().zip(words) {
        t.push(I2c::write_read(
            ADDR,
            vec![*cmd],
            word.to_be_bytes().to_vec(),
        ));
    }
    t
}

fn adc_bytes(value: u32) -> Vec<u8> {
    value.to_be_bytes()[1..].to_vec()
}

fn read_transactions(d1: u32, d2: u32) -> Vec<I2c> {
    vec![
        I2c::write(ADDR, vec![CONVERT_D1_OSR4096]),
        I2c::write_read(ADDR, vec![ADC_READ], adc_bytes(d1)),
        I2c::write(ADDR, vec![CONVERT_D2_OSR4096]),
        I2c::write_read(ADDR, vec![ADC_READ], adc_bytes(d2)),
    ]
}

fn read_delays() -> Vec<Delay> {
    vec![
        Delay::delay_us(CONVERSION_OSR4096_US),
        Delay::delay_us(CONVERSION_OSR4096_US),
    ]
}

// --- CRC-4 ----------------------------------------------------------------

#[test]
fn crc4_matches_an520_on_datasheet_coefficients() {
    for c in [C_30BA, C_02BA] {
        let p = prom(c);
        assert_eq!(crc4(&p), an520(&p));
        // The stored nibble does not take part in its own CRC.
        let mut q = p;
        q[0] ^= 0xF000;
        assert_eq!(crc4(&q), crc4(&p));
    }
    // Fixed values of the literal AN520 loop (kept so a change in both
    // implementations at once still fails).
    assert_eq!(
        an520(&[0x0340, 34982, 36352, 20328, 22354, 26646, 26146]),
        0x9
    );
    assert_eq!(an520(&[0, 0, 0, 0, 0, 0, 0]), 0);
}

proptest! {
    #[test]
    fn crc4_equals_an520_for_any_prom(words in prop::array::uniform7(any::<u16>())) {
        prop_assert_eq!(crc4(&words), an520(&words));
    }

    #[test]
    fn from_prom_accepts_exactly_the_right_nibble(
        words in prop::array::uniform7(any::<u16>()),
        nibble in 0u16..16,
    ) {
        let mut p = words;
        p[0] = (p[0] & 0x0FFF) | (nibble << 12);
        let good = u16::from(an520(&p)) == nibble;
        match Calibration::from_prom(&p) {
            Ok(cal) => {
                prop_assert!(good);
                prop_assert_eq!(cal.to_prom(), p);
            }
            Err(e) => {
                prop_assert!(!good);
                prop_assert_eq!(u16::from(e.expected), nibble);
                prop_assert_eq!(e.computed, an520(&p));
            }
        }
    }

    /// Any coefficients, any 32-bit ADC values: no overflow panic (tests run
    /// with overflow checks), and the temperature stays in the range the
    /// bounded arithmetic allows.
    #[test]
    fn compensation_never_panics(
        c in prop::array::uniform6(any::<u16>()),
        d1 in any::<u32>(),
        d2 in any::<u32>(),
        bar30 in any::<bool>(),
    ) {
        let model = if bar30 { Model::Bar30 } else { Model::Bar02 };
        let raw = compensate_raw(model, &calibration(c), d1, d2);
        prop_assert!(raw.temperature_centi_c.abs() < 1 << 19);
        let m = compensate(model, &calibration(c), d1, d2);
        prop_assert!(m.pressure_kpa.is_finite() && m.temperature_c.is_finite());
    }

    /// With real coefficients the pressure never falls as D1 rises.
    #[test]
    fn pressure_is_monotonic_in_d1(d1 in 1u32..0xFF_FFFE, d2 in 5_000_000u32..8_500_000) {
        for (model, c) in [(Model::Bar30, C_30BA), (Model::Bar02, C_02BA)] {
            let cal = calibration(c);
            let lo = compensate_raw(model, &cal, d1, d2).pressure_pa;
            let hi = compensate_raw(model, &cal, d1 + 1, d2).pressure_pa;
            prop_assert!(hi >= lo);
        }
    }
}

// --- Compensation against the datasheets -----------------------------------

#[test]
fn bar30_datasheet_example_first_order() {
    // MS5837-30BA datasheet: D1 = 4958179, D2 = 6815414 → dT = −5962,
    // TEMP = 1981 (19.81 °C), P = 39998 (3999.8 mbar = 399980 Pa).
    let raw = compensate_first_order(Model::Bar30, &calibration(C_30BA), 4_958_179, 6_815_414);
    assert_eq!(
        raw,
        RawMeasurement {
            temperature_centi_c: 1981,
            pressure_pa: 399_980
        }
    );
}

#[test]
fn bar30_datasheet_example_second_order() {
    // TEMP = 1981 < 2000: Ti = 3·5962²/2³³ = 0; OFFi = 3·19²/2 = 541;
    // SENSi = 5·19²/8 = 225. OFF2 = 2381323464 − 541 = 2381322923,
    // SENS2 = 1145816755 − 225 = 1145816530,
    // P2 = (4958179·1145816530/2²¹ − 2381322923)/2¹³ = 39998 (floors).
    let cal = calibration(C_30BA);
    let raw = compensate_raw(Model::Bar30, &cal, 4_958_179, 6_815_414);
    assert_eq!(raw.temperature_centi_c, 1981);
    assert_eq!(raw.pressure_pa, 399_980);
    let m = compensate(Model::Bar30, &cal, 4_958_179, 6_815_414);
    assert_eq!(m.pressure_kpa, 399.98_f32);
    assert_eq!(m.temperature_c, 19.81_f32);
}

#[test]
fn bar02_datasheet_example() {
    // MS5837-02BA example: dT = 8077636 − 31553·256 = 68,
    // TEMP = 2000 + 68·28165/2²³ = 2000, OFF = 43981·2¹⁷ + 27842·68/2⁶ =
    // 5764707214, SENS = 46372·2¹⁶ + 29059·68/2⁷ = 3039050829,
    // P = (6465444·SENS/2²¹ − OFF)/2¹⁵ = 110002 (1100.02 mbar = 110002 Pa).
    // TEMP is not below 20 °C, so the second order changes nothing.
    let cal = calibration(C_02BA);
    let expected = RawMeasurement {
        temperature_centi_c: 2000,
        pressure_pa: 110_002,
    };
    assert_eq!(
        compensate_first_order(Model::Bar02, &cal, 6_465_444, 8_077_636),
        expected
    );
    assert_eq!(
        compensate_raw(Model::Bar02, &cal, 6_465_444, 8_077_636),
        expected
    );
}

#[test]
fn bar02_second_order_below_20_c() {
    // D2 = 7500000: dT = −577568, TEMP = 2000 + ⌊−577568·28165/2²³⌋ = 60.
    // OFF = 5513417503, SENS = 2907913919, P (first order) = 105333.
    // Ti = 11·dT²/2³⁵ = 106; OFFi = 31·1940²/8 = 14583950;
    // SENSi = 63·1940²/32 = 7409587. TEMP2 = −46 (−0.46 °C),
    // P2 = (6465444·2900504332/2²¹ − 5498833553)/2¹⁵ = 105081.
    let cal = calibration(C_02BA);
    assert_eq!(
        compensate_first_order(Model::Bar02, &cal, 6_465_444, 7_500_000),
        RawMeasurement {
            temperature_centi_c: 60,
            pressure_pa: 105_333
        }
    );
    assert_eq!(
        compensate_raw(Model::Bar02, &cal, 6_465_444, 7_500_000),
        RawMeasurement {
            temperature_centi_c: -46,
            pressure_pa: 105_081
        }
    );
}

#[test]
fn bar30_second_order_below_minus_15_c() {
    // D2 = 5621376: dT = −1200000, TEMP = 2000 + ⌊−3740.3⌋ = −1741.
    // Ti = 3·dT²/2³³ = 502. (TEMP−2000)² = 3741² = 13995081,
    // (TEMP+1500)² = 241² = 58081: OFFi = 3·13995081/2 + 7·58081 = 21399188,
    // SENSi = 5·13995081/8 + 4·58081 = 8979249. OFF2 = 2151396734,
    // SENS2 = 1042023427 → P2 = 38110 (3811.0 mbar); TEMP2 = −2243.
    let raw = compensate_raw(Model::Bar30, &calibration(C_30BA), 4_958_179, 5_621_376);
    assert_eq!(
        raw,
        RawMeasurement {
            temperature_centi_c: -2243,
            pressure_pa: 381_100
        }
    );
}

#[test]
fn bar30_second_order_above_20_c() {
    // D2 = 7000000: dT = 178624, TEMP = 2556. Ti = 2·dT²/2³⁷ = 0,
    // OFFi = 556²/16 = 19321, SENSi = 0. P: 40293 first order, 40295 second.
    let cal = calibration(C_30BA);
    assert_eq!(
        compensate_first_order(Model::Bar30, &cal, 4_958_179, 7_000_000).pressure_pa,
        402_930
    );
    assert_eq!(
        compensate_raw(Model::Bar30, &cal, 4_958_179, 7_000_000),
        RawMeasurement {
            temperature_centi_c: 2556,
            pressure_pa: 402_950
        }
    );
}

#[test]
fn osr_commands_and_conversion_times() {
    // Datasheet: D1 0x40/42/44/46/48/4A, D2 0x50..0x5A; max conversion
    // 0.60/1.17/2.28/4.54/9.04/18.08 ms.
    let table = [
        (Osr::Osr256, 0x0, 600),
        (Osr::Osr512, 0x2, 1_170),
        (Osr::Osr1024, 0x4, 2_280),
        (Osr::Osr2048, 0x6, 4_540),
        (Osr::Osr4096, 0x8, 9_040),
        (Osr::Osr8192, 0xA, 18_080),
    ];
    for (osr, offset, us) in table {
        assert_eq!(osr.command_offset(), offset);
        assert_eq!(osr.max_conversion_us(), us);
    }
    // And on the bus, for the slowest one.
    let words = prom(C_02BA);
    let mut t = init_transactions(&words);
    t.extend([
        I2c::write(ADDR, vec![0x4A]),
        I2c::write_read(ADDR, vec![ADC_READ], adc_bytes(6_465_444)),
        I2c::write(ADDR, vec![0x5A]),
        I2c::write_read(ADDR, vec![ADC_READ], adc_bytes(8_077_636)),
    ]);
    let mut delay = CheckedDelay::new(&[
        Delay::delay_ms(RESET_MS),
        Delay::delay_us(18_080),
        Delay::delay_us(18_080),
    ]);
    let mut dev = Ms5837::new(I2cMock::new(&t), Model::Bar02, Osr::Osr8192);
    block_on(dev.init(&mut delay)).unwrap();
    assert_eq!(
        block_on(dev.read_adc(&mut delay)).unwrap(),
        (6_465_444, 8_077_636)
    );
    dev.destroy().done();
    delay.done();
}

// --- Driver on the bus -------------------------------------------------------

#[test]
fn init_then_read_bar30() {
    let words = prom(C_30BA);
    let mut t = init_transactions(&words);
    t.extend(read_transactions(4_958_179, 6_815_414));
    let mut delays = vec![Delay::delay_ms(RESET_MS)];
    delays.extend(read_delays());
    let mut delay = CheckedDelay::new(&delays);

    let mut dev = Ms5837::new(I2cMock::new(&t), Model::Bar30, Osr::Osr4096);
    let cal = block_on(dev.init(&mut delay)).unwrap();
    assert_eq!(cal.to_prom(), words);
    assert_eq!((cal.sens_t1, cal.tempsens), (34982, 26146));
    assert_eq!(dev.calibration(), Some(&cal));

    let m = block_on(dev.read(&mut delay)).unwrap();
    assert_eq!(m.pressure_kpa, 399.98_f32);
    assert_eq!(m.temperature_c, 19.81_f32);
    dev.destroy().done();
    delay.done();
}

#[test]
fn bad_prom_crc_is_reported_and_keeps_no_calibration() {
    let mut words = prom(C_30BA);
    let good = an520(&words);
    let bad = (good + 1) & 0xF;
    words[0] = (words[0] & 0x0FFF) | (u16::from(bad) << 12);
    let t = init_transactions(&words);
    let mut delay = CheckedDelay::new(&[Delay::delay_ms(RESET_MS)]);

    let mut dev = Ms5837::new(I2cMock::new(&t), Model::Bar30, Osr::Osr4096);
    assert_eq!(
        block_on(dev.init(&mut delay)),
        Err(Error::Crc {
            expected: bad,
            computed: good
        })
    );
    assert_eq!(dev.calibration(), None);
    // No bus traffic: reading without a calibration is refused up front.
    assert_eq!(block_on(dev.read(&mut delay)), Err(Error::NotInitialized));
    dev.destroy().done();
    delay.done();
}

#[test]
fn a_single_flipped_coefficient_bit_fails_the_crc() {
    let mut words = prom(C_02BA);
    words[4] ^= 0x0100;
    let t = init_transactions(&words);
    let mut delay = CheckedDelay::new(&[Delay::delay_ms(RESET_MS)]);
    let mut dev = Ms5837::new(I2cMock::new(&t), Model::Bar02, Osr::Osr4096);
    assert!(matches!(
        block_on(dev.init(&mut delay)),
        Err(Error::Crc { .. })
    ));
    dev.destroy().done();
    delay.done();
}

#[test]
fn nak_on_reset_is_a_bus_error() {
    let nak = ErrorKind::NoAcknowledge(NoAcknowledgeSource::Address);
    let t = [I2c::write(ADDR, vec![RESET]).with_error(nak)];
    let mut delay = CheckedDelay::new(&[]);
    let mut dev = Ms5837::new(I2cMock::new(&t), Model::Bar02, Osr::Osr4096);
    assert_eq!(block_on(dev.init(&mut delay)), Err(Error::Bus(nak)));
    dev.destroy().done();
    delay.done();
}

#[test]
fn nak_mid_prom_stops_init() {
    let nak = ErrorKind::NoAcknowledge(NoAcknowledgeSource::Data);
    let words = prom(C_02BA);
    let mut t = init_transactions(&words);
    t.truncate(4); // reset + words 0..=2
    t.push(I2c::write_read(ADDR, vec![0xA6], vec![0, 0]).with_error(nak));
    let mut delay = CheckedDelay::new(&[Delay::delay_ms(RESET_MS)]);
    let mut dev = Ms5837::new(I2cMock::new(&t), Model::Bar02, Osr::Osr4096);
    assert_eq!(block_on(dev.init(&mut delay)), Err(Error::Bus(nak)));
    assert_eq!(dev.calibration(), None);
    dev.destroy().done();
    delay.done();
}

#[test]
fn nak_during_conversion_is_a_bus_error() {
    let nak = ErrorKind::NoAcknowledge(NoAcknowledgeSource::Address);
    let words = prom(C_02BA);
    let mut t = init_transactions(&words);
    t.push(I2c::write(ADDR, vec![CONVERT_D1_OSR4096]));
    t.push(I2c::write_read(ADDR, vec![ADC_READ], vec![0, 0, 0]).with_error(nak));
    let mut delay = CheckedDelay::new(&[
        Delay::delay_ms(RESET_MS),
        Delay::delay_us(CONVERSION_OSR4096_US),
    ]);
    let mut dev = Ms5837::new(I2cMock::new(&t), Model::Bar02, Osr::Osr4096);
    block_on(dev.init(&mut delay)).unwrap();
    assert_eq!(block_on(dev.read(&mut delay)), Err(Error::Bus(nak)));
    dev.destroy().done();
    delay.done();
}

#[test]
fn adc_zero_means_not_ready() {
    let words = prom(C_02BA);
    let mut t = init_transactions(&words);
    t.push(I2c::write(ADDR, vec![CONVERT_D1_OSR4096]));
    t.push(I2c::write_read(ADDR, vec![ADC_READ], vec![0, 0, 0]));
    let mut delay = CheckedDelay::new(&[
        Delay::delay_ms(RESET_MS),
        Delay::delay_us(CONVERSION_OSR4096_US),
    ]);
    let mut dev = Ms5837::new(I2cMock::new(&t), Model::Bar02, Osr::Osr4096);
    block_on(dev.init(&mut delay)).unwrap();
    assert_eq!(block_on(dev.read(&mut delay)), Err(Error::AdcNotReady));
    dev.destroy().done();
    delay.done();
}

// --- Gauge zero ----------------------------------------------------------------

#[test]
fn capture_zero_averages_readings_in_pa() {
    // Two 02BA readings at TEMP = 2000: D1 = 6465444 → P = 110002 Pa, and
    // D1 = 6465544 → P = ((6465544·3039050829 >> 21) − 5764707214) >> 15
    // = 110007 Pa. Mean 110004.5 Pa = 110.0045 kPa.
    assert_eq!(
        compensate_raw(Model::Bar02, &calibration(C_02BA), 6_465_544, 8_077_636).pressure_pa,
        110_007
    );
    let words = prom(C_02BA);
    let mut t = init_transactions(&words);
    t.extend(read_transactions(6_465_444, 8_077_636));
    t.extend(read_transactions(6_465_544, 8_077_636));
    let mut delays = vec![Delay::delay_ms(RESET_MS)];
    delays.extend(read_delays());
    delays.extend(read_delays());
    let mut delay = CheckedDelay::new(&delays);
    let mut dev = Ms5837::new(I2cMock::new(&t), Model::Bar02, Osr::Osr4096);
    block_on(dev.init(&mut delay)).unwrap();
    let zero = block_on(dev.capture_zero(&mut delay, NonZeroU8::new(2).unwrap())).unwrap();
    assert_eq!(zero.zero_kpa(), 110.0045_f32);
    assert_eq!(zero.gauge_kpa(112.0), 112.0_f32 - 110.0045_f32);
    dev.destroy().done();
    delay.done();
}

#[test]
fn gauge_zero_from_samples() {
    let z = GaugeZero::from_samples(&[101.0, 102.0, 103.5]).unwrap();
    assert_eq!(z.zero_kpa(), 102.166_666_f32);
    assert_eq!(z.gauge_kpa(105.0), 105.0 - 102.166_666_f32);
    assert_eq!(GaugeZero::from_samples(&[]), None);
    assert_eq!(GaugeZero::from_samples(&[101.0, f32::NAN]), None);
    assert_eq!(GaugeZero::new(f32::INFINITY), None);
    assert_eq!(
        GaugeZero::new(101.325).map(|z| z.gauge_kpa(101.325)),
        Some(0.0)
    );
}
