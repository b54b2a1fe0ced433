//! The MS5837 calibration PROM: seven 16-bit words, checked by a 4-bit CRC.
//!
//! Pure functions of the PROM words, so they are unit- and fuzz-testable
//! without a bus.

use crc::{Algorithm, Crc, NoTable};

/// Number of PROM words the MS5837 holds (addresses 0xA0..=0xAC).
pub const PROM_WORDS: usize = 7;

/// The PROM check of TE application note AN520, expressed as a plain CRC.
///
/// AN520 runs a 16-bit register with feedback 0x3000 over the 16 bytes of
/// words 0..=7 (word 0's CRC nibble cleared, a zero word 7 appended) and
/// keeps the top nibble. Because 0x3000 = x¹²·(x⁴ + x + 1) and every byte
/// enters at the register's low end, that nibble equals the MSB-first CRC-4
/// with polynomial x⁴ + x + 1, init 0, no reflection and no final XOR over the
/// first 15 of those bytes (the 14 PROM bytes and word 7's zero high byte).
/// `tests/ms5837.rs` checks this against a literal transcription of AN520.
const AN520_CRC4: Algorithm<u8> = Algorithm {
    width: 4,
    poly: 0x3,
    init: 0x0,
    refin: false,
    refout: false,
    xorout: 0x0,
    check: 0xE,
    residue: 0x0,
};

/// Bit-by-bit engine: the check runs once per boot, a 256-byte table would
/// only cost flash.
const CRC4: Crc<u8, NoTable> = Crc::<u8, NoTable>::new(&AN520_CRC4);

/// The CRC-4 of a PROM image (0..=15), computed with word 0's CRC nibble
/// (bits 15..12) treated as zero, as the datasheet specifies.
pub fn crc4(prom: &[u16; PROM_WORDS]) -> u8 {
    let mut digest = CRC4.digest();
    for (i, word) in prom.iter().enumerate() {
        let word = if i == 0 { word & 0x0FFF } else { *word };
        digest.update(&word.to_be_bytes());
    }
    // High byte of the (virtual) zero word 7; its low byte is not part of the
    // equivalent CRC-4 (see `AN520_CRC4`).
    digest.update(&[0]);
    digest.finalize()
}

/// The CRC-4 stored in the PROM: the top 4 bits of word 0.
pub fn stored_crc4(prom: &[u16; PROM_WORDS]) -> u8 {
    // Shifting a u16 right by 12 leaves 4 bits: the cast cannot truncate.
    (prom[0] >> 12) as u8
}

/// A PROM whose stored CRC disagrees with the computed one.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CrcMismatch {
    /// CRC-4 stored in the PROM (word 0, bits 15..12).
    pub expected: u8,
    /// CRC-4 computed from the words read.
    pub computed: u8,
}

/// The factory calibration coefficients C1..C6 (datasheet names in the
/// field docs), plus PROM word 0.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Calibration {
    /// PROM word 0: CRC-4 (bits 15..12) and factory data (bits 11..0; bits
    /// 11..5 identify the sensor version).
    pub factory: u16,
    /// C1, SENS_T1: pressure sensitivity (raw counts).
    pub sens_t1: u16,
    /// C2, OFF_T1: pressure offset (raw counts).
    pub off_t1: u16,
    /// C3, TCS: temperature coefficient of pressure sensitivity.
    pub tcs: u16,
    /// C4, TCO: temperature coefficient of pressure offset.
    pub tco: u16,
    /// C5, T_REF: reference temperature (raw counts, compared with D2 / 2⁸).
    pub t_ref: u16,
    /// C6, TEMPSENS: temperature coefficient of the temperature.
    pub tempsens: u16,
}

impl Calibration {
    /// Builds the calibration from the seven PROM words (word 0 first) after
    /// checking their CRC-4.
    pub fn from_prom(prom: &[u16; PROM_WORDS]) -> Result<Self, CrcMismatch> {
        let expected = stored_crc4(prom);
        let computed = crc4(prom);
        if expected != computed {
            return Err(CrcMismatch { expected, computed });
        }
        let [factory, sens_t1, off_t1, tcs, tco, t_ref, tempsens] = *prom;
        Ok(Self {
            factory,
            sens_t1,
            off_t1,
            tcs,
            tco,
            t_ref,
            tempsens,
        })
    }

    /// The seven PROM words this calibration was read from (word 0 first).
    pub fn to_prom(&self) -> [u16; PROM_WORDS] {
        [
            self.factory,
            self.sens_t1,
            self.off_t1,
            self.tcs,
            self.tco,
            self.t_ref,
            self.tempsens,
        ]
    }
}
