//! The pressure→diameter table the firmware compiles in.
//!
//! `host-sim tables` generates [`generated::TABLE`] from the physics (skin
//! model plus sand law) into `src/table/generated.rs`. The table holds the
//! internal pressure `p_i(D, h)` on the loading branch for a grid of outer
//! diameters `D` and sand depths `h`; the `h = 0` row is the skin alone
//! (free water), so `p_e(D, h) = p_i(D, h) - p_i(D, 0)`.
//!
//! A table carries a format version and a CRC-32 over every field, both
//! checked at boot by [`Table::verify`]: the controller refuses to start a
//! cycle on a table that fails it.

#[rustfmt::skip]
pub mod generated;
pub mod image;

/// Format version of the table layout and checksum rule; `host-sim tables`
/// writes the same number. Bump it whenever either changes.
pub const FORMAT_VERSION: u16 = 1;

/// Largest grid the firmware accepts, per axis (keeps lookups bounded).
pub const MAX_POINTS: usize = 64;

/// CRC-32 (ISO-HDLC, the zlib/PNG one) used for the table checksum.
pub const CHECKSUM_ALGORITHM: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);

/// A pressure→diameter table over depth. Borrowed slices keep it usable both
/// as a `const` in flash and as a table built at run time by `host-sim`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Table<'a> {
    /// Layout version, must equal [`FORMAT_VERSION`].
    pub format_version: u16,
    /// True while the table comes from a placeholder law rather than the
    /// project's physics; reported in telemetry so nobody mistakes it.
    pub placeholder: bool,
    /// Outer diameter of the expansion zone at rest, D0 (mm).
    pub initial_diameter_mm: f32,
    /// Length of the zone that expands radially (mm).
    pub expansion_length_mm: f32,
    /// Skin thickness at rest (mm).
    pub skin_thickness_mm: f32,
    /// Sand cover above the actuator axis for each row (mm), strictly
    /// increasing, first entry 0 (free water: skin alone).
    pub depths_mm: &'a [f32],
    /// Outer diameter for each column (mm), strictly increasing, first entry
    /// equal to `initial_diameter_mm`.
    pub diameters_mm: &'a [f32],
    /// Internal gauge pressure p_i (kPa), row-major `[depth][diameter]`,
    /// strictly increasing along each row.
    pub pressure_kpa: &'a [f32],
    /// CRC-32 of everything above, as computed by [`Table::compute_checksum`].
    pub checksum: u32,
}

/// Why a table was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum TableError {
    /// `format_version` differs from [`FORMAT_VERSION`].
    Version,
    /// Axis lengths inconsistent, too short (< 2) or too long.
    Shape,
    /// An axis is not strictly increasing, the first depth is not 0, or the
    /// first diameter is not D0.
    Axis,
    /// A value is NaN or infinite, or a geometry field is not positive.
    NotFinite,
    /// Pressure does not strictly increase with diameter in some row, so the
    /// inverse lookup would be ambiguous.
    NotMonotonic,
    /// The stored checksum does not match the contents.
    Checksum,
}

impl<'a> Table<'a> {
    /// CRC-32 over the version, flags, geometry, axis lengths and every value
    /// (little-endian IEEE-754 bytes), in field order.
    pub fn compute_checksum(&self) -> u32 {
        let mut digest = CHECKSUM_ALGORITHM.digest();
        digest.update(&self.format_version.to_le_bytes());
        digest.update(&[u8::from(self.placeholder)]);
        for v in [
            self.initial_diameter_mm,
            self.expansion_length_mm,
            self.skin_thickness_mm,
        ] {
            digest.update(&v.to_le_bytes());
        }
        for axis in [self.depths_mm, self.diameters_mm, self.pressure_kpa] {
            // Axis lengths are bounded by MAX_POINTS² so they fit in u32.
            digest.update(&(axis.len() as u32).to_le_bytes());
            for v in axis {
                digest.update(&v.to_le_bytes());
            }
        }
        digest.finalize()
    }

    /// Checks version, shape, axes, finiteness, monotonicity and checksum.
    pub fn verify(&self) -> Result<(), TableError> {
        if self.format_version != FORMAT_VERSION {
            return Err(TableError::Version);
        }
        let (nd, np) = (self.depths_mm.len(), self.diameters_mm.len());
        if !(2..=MAX_POINTS).contains(&nd)
            || !(2..=MAX_POINTS).contains(&np)
            || self.pressure_kpa.len() != nd * np
        {
            return Err(TableError::Shape);
        }
        let geometry = [
            self.initial_diameter_mm,
            self.expansion_length_mm,
            self.skin_thickness_mm,
        ];
        if geometry.iter().any(|v| !v.is_finite() || *v <= 0.0)
            || self
                .depths_mm
                .iter()
                .chain(self.diameters_mm)
                .chain(self.pressure_kpa)
                .any(|v| !v.is_finite())
        {
            return Err(TableError::NotFinite);
        }
        if !strictly_increasing(self.depths_mm)
            || !strictly_increasing(self.diameters_mm)
            || self.depths_mm[0] != 0.0
            || self.diameters_mm[0] != self.initial_diameter_mm
        {
            return Err(TableError::Axis);
        }
        if self
            .pressure_kpa
            .chunks_exact(np)
            .any(|row| !strictly_increasing(row))
        {
            return Err(TableError::NotMonotonic);
        }
        if self.compute_checksum() != self.checksum {
            return Err(TableError::Checksum);
        }
        Ok(())
    }

    /// Largest diameter in the table (mm).
    pub fn max_diameter_mm(&self) -> f32 {
        self.diameters_mm
            .last()
            .copied()
            .unwrap_or(self.initial_diameter_mm)
    }

    /// Internal pressure p_i (kPa) at outer diameter `diameter_mm` and sand
    /// depth `depth_mm`, bilinear, clamped to the grid. Assumes a verified
    /// table.
    pub fn pressure_kpa(&self, diameter_mm: f32, depth_mm: f32) -> f32 {
        let (j, wd) = bracket(self.diameters_mm, diameter_mm);
        let (i, wh) = bracket(self.depths_mm, depth_mm);
        let np = self.diameters_mm.len();
        let at = |row: usize, col: usize| self.pressure_kpa[row * np + col];
        let lo = lerp(at(i, j), at(i, j + 1), wd);
        let hi = lerp(at(i + 1, j), at(i + 1, j + 1), wd);
        lerp(lo, hi, wh)
    }

    /// Skin-only pressure (kPa) at `diameter_mm`: the free-water row.
    pub fn membrane_kpa(&self, diameter_mm: f32) -> f32 {
        self.pressure_kpa(diameter_mm, 0.0)
    }

    /// Outer diameter (mm) at which the loading branch reaches `pressure_kpa`
    /// at `depth_mm`: the inverse of [`Table::pressure_kpa`], clamped to the
    /// table's diameter range. Assumes a verified table (monotone rows).
    pub fn diameter_mm(&self, pressure_kpa: f32, depth_mm: f32) -> f32 {
        let (i, wh) = bracket(self.depths_mm, depth_mm);
        let np = self.diameters_mm.len();
        let row_at = |col: usize| {
            lerp(
                self.pressure_kpa[i * np + col],
                self.pressure_kpa[(i + 1) * np + col],
                wh,
            )
        };
        let first = row_at(0);
        if pressure_kpa <= first {
            return self.diameters_mm[0];
        }
        let mut prev = first;
        for col in 1..np {
            let p = row_at(col);
            if pressure_kpa <= p {
                let w = (pressure_kpa - prev) / (p - prev);
                return lerp(self.diameters_mm[col - 1], self.diameters_mm[col], w);
            }
            prev = p;
        }
        self.max_diameter_mm()
    }
}

fn strictly_increasing(values: &[f32]) -> bool {
    values.windows(2).all(|w| w[1] > w[0])
}

fn lerp(a: f32, b: f32, w: f32) -> f32 {
    a + (b - a) * w
}

/// Index `k` and weight `w` in [0, 1] such that `x ≈ axis[k] + w·(axis[k+1] - axis[k])`,
/// clamped at both ends. `axis` has at least two strictly increasing entries.
fn bracket(axis: &[f32], x: f32) -> (usize, f32) {
    let last = axis.len() - 2;
    let mut k = 0;
    while k < last && x > axis[k + 1] {
        k += 1;
    }
    let w = (x - axis[k]) / (axis[k + 1] - axis[k]);
    (k, w.clamp(0.0, 1.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    const DEPTHS: [f32; 2] = [0.0, 100.0];
    const DIAMETERS: [f32; 3] = [18.7, 20.0, 25.0];
    const PRESSURES: [f32; 6] = [0.0, 0.1, 0.3, 1.0, 5.0, 9.0];

    fn table() -> Table<'static> {
        let mut t = Table {
            format_version: FORMAT_VERSION,
            placeholder: true,
            initial_diameter_mm: 18.7,
            expansion_length_mm: 20.0,
            skin_thickness_mm: 1.75,
            depths_mm: &DEPTHS,
            diameters_mm: &DIAMETERS,
            pressure_kpa: &PRESSURES,
            checksum: 0,
        };
        t.checksum = t.compute_checksum();
        t
    }

    #[test]
    fn generated_table_verifies() {
        assert_eq!(generated::TABLE.verify(), Ok(()));
    }

    #[test]
    fn checksum_matches_reference_crc32() {
        // CRC-32/ISO-HDLC of "123456789" is the standard check value.
        assert_eq!(CHECKSUM_ALGORITHM.checksum(b"123456789"), 0xCBF4_3926);
    }

    #[test]
    fn any_single_value_change_is_caught() {
        let t = table();
        assert_eq!(t.verify(), Ok(()));
        let mut p = PRESSURES;
        p[4] = 5.01;
        let bad = Table {
            pressure_kpa: &p,
            ..t
        };
        assert_eq!(bad.verify(), Err(TableError::Checksum));
        let flag = Table {
            placeholder: false,
            ..t
        };
        assert_eq!(flag.verify(), Err(TableError::Checksum));
    }

    #[test]
    fn structural_errors_are_named() {
        let t = table();
        assert_eq!(
            Table {
                format_version: 2,
                ..t
            }
            .verify(),
            Err(TableError::Version)
        );
        assert_eq!(
            Table {
                pressure_kpa: &PRESSURES[..5],
                ..t
            }
            .verify(),
            Err(TableError::Shape)
        );
        let flat = [0.0, 0.1, 0.3, 1.0, 1.0, 9.0];
        assert_eq!(
            Table {
                pressure_kpa: &flat,
                ..t
            }
            .verify(),
            Err(TableError::NotMonotonic)
        );
        let nan = [0.0, 0.1, f32::NAN, 1.0, 5.0, 9.0];
        assert_eq!(
            Table {
                pressure_kpa: &nan,
                ..t
            }
            .verify(),
            Err(TableError::NotFinite)
        );
        let depths = [10.0, 100.0];
        assert_eq!(
            Table {
                depths_mm: &depths,
                ..t
            }
            .verify(),
            Err(TableError::Axis)
        );
    }

    #[test]
    fn lookups_interpolate_and_invert() {
        let t = table();
        assert!((t.pressure_kpa(20.0, 50.0) - 2.55).abs() < 1e-5);
        assert!((t.pressure_kpa(22.5, 100.0) - 7.0).abs() < 1e-5);
        // Clamped outside the grid.
        assert_eq!(t.pressure_kpa(30.0, 200.0), 9.0);
        assert_eq!(t.membrane_kpa(18.0), 0.0);
        for d in [18.7_f32, 19.3, 20.0, 21.1, 24.9] {
            for h in [0.0_f32, 37.0, 100.0] {
                let p = t.pressure_kpa(d, h);
                assert!((t.diameter_mm(p, h) - d).abs() < 1e-4, "d={d} h={h}");
            }
        }
        assert_eq!(t.diameter_mm(-1.0, 50.0), 18.7);
        assert_eq!(t.diameter_mm(100.0, 50.0), 25.0);
    }
}
