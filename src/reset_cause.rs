//! Why the last run ended, carried across a reset in RAM that the startup
//! code does not clear (the board's `.uninit` section).
//!
//! The panic and HardFault handlers write a [`ResetRecord`] just before
//! they reset the MCU; the next boot reads it once ([`ResetRecord::decode`])
//! and clears it, and reports the panic as a panic
//! ([`crate::controller::Fault::Panic`], latched) rather than as whatever
//! the reset flags would suggest. After a power-on the RAM holds noise: the
//! record carries a magic word and a check word, so noise decodes as "no
//! record" (a false positive needs 64 bits to match by chance).

/// What ended the last run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PanicKind {
    /// A Rust panic (the panic handler ran).
    Panic,
    /// A HardFault exception (bad memory access, undefined instruction…).
    HardFault,
}

/// The record as it lies in RAM: four words.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(C)]
pub struct ResetRecord {
    magic: u32,
    kind: u32,
    pc: u32,
    check: u32,
}

/// "URPN": marks a record written by a handler.
const MAGIC: u32 = 0x5552_504E;
/// Mixed into the check word so an all-equal pattern cannot pass.
const CHECK_SALT: u32 = 0xA5C3_3C5A;

impl ResetRecord {
    /// No record (what the boot writes back after reading one).
    pub const EMPTY: ResetRecord = ResetRecord {
        magic: 0,
        kind: 0,
        pc: 0,
        check: 0,
    };

    /// A record of `kind` at program counter `pc` (0 when unknown, as for a
    /// panic: its message and location go to the defmt log instead).
    pub const fn new(kind: PanicKind, pc: u32) -> ResetRecord {
        let kind = match kind {
            PanicKind::Panic => 1,
            PanicKind::HardFault => 2,
        };
        ResetRecord {
            magic: MAGIC,
            kind,
            pc,
            check: Self::check_of(kind, pc),
        }
    }

    const fn check_of(kind: u32, pc: u32) -> u32 {
        (MAGIC ^ kind ^ pc.rotate_left(7)) ^ CHECK_SALT
    }

    /// The record as the four words stored in RAM.
    pub const fn to_words(&self) -> [u32; 4] {
        [self.magic, self.kind, self.pc, self.check]
    }

    /// The record read back from four words of RAM (any bits: noise gives a
    /// record that [`ResetRecord::decode`]s to `None`).
    pub const fn from_words(w: [u32; 4]) -> ResetRecord {
        ResetRecord {
            magic: w[0],
            kind: w[1],
            pc: w[2],
            check: w[3],
        }
    }

    /// The kind and program counter of a valid record; `None` for noise,
    /// an empty record or a damaged one.
    pub fn decode(&self) -> Option<(PanicKind, u32)> {
        if self.magic != MAGIC || self.check != Self::check_of(self.kind, self.pc) {
            return None;
        }
        let kind = match self.kind {
            1 => PanicKind::Panic,
            2 => PanicKind::HardFault,
            _ => return None,
        };
        Some((kind, self.pc))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip() {
        for (kind, pc) in [(PanicKind::Panic, 0), (PanicKind::HardFault, 0x0800_1234)] {
            assert_eq!(ResetRecord::new(kind, pc).decode(), Some((kind, pc)));
        }
    }

    #[test]
    fn noise_and_damage_are_no_record() {
        assert_eq!(ResetRecord::EMPTY.decode(), None);
        let all = |w| ResetRecord {
            magic: w,
            kind: w,
            pc: w,
            check: w,
        };
        assert_eq!(all(0xFFFF_FFFF).decode(), None);
        assert_eq!(all(MAGIC).decode(), None);
        let good = ResetRecord::new(PanicKind::HardFault, 0x0800_1234);
        let mut bad = good;
        bad.pc ^= 1;
        assert_eq!(bad.decode(), None);
        let mut bad = good;
        bad.kind = 3;
        bad.check = ResetRecord::check_of(3, bad.pc);
        assert_eq!(bad.decode(), None);
        assert_eq!(ResetRecord::from_words(good.to_words()), good);
    }
}
