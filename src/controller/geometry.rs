//! Diameter of the expansion zone from the pumped volume.
//!
//! The skin is incompressible and the zone keeps its length `L`, so every
//! millilitre injected past rest widens the outer cylinder by the same
//! volume: `ΔV = π·L·(D² − D0²)/4`, hence `D = sqrt(D0² + 4·ΔV/(π·L))`.
//! D0 and L come from the table, so the geometry the firmware assumes is
//! the one the table was generated for.

use crate::table::Table;

/// Cubic millimetres per millilitre.
const MM3_PER_ML: f32 = 1000.0;

/// The expansion zone's rest geometry.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ExpansionZone {
    /// Outer diameter at rest, D0 (mm).
    pub initial_diameter_mm: f32,
    /// Length of the zone that expands radially, L (mm).
    pub expansion_length_mm: f32,
}

impl ExpansionZone {
    /// The geometry a table was generated for.
    pub fn of(table: &Table<'_>) -> Self {
        Self {
            initial_diameter_mm: table.initial_diameter_mm,
            expansion_length_mm: table.expansion_length_mm,
        }
    }

    /// Outer diameter (mm) after injecting `delta_volume_ml` past rest. A
    /// withdrawal past rest gives a smaller diameter, never below 0; NaN in,
    /// NaN out.
    pub fn diameter_mm(&self, delta_volume_ml: f32) -> f32 {
        let d0 = self.initial_diameter_mm;
        let area_mm2 =
            4.0 * delta_volume_ml * MM3_PER_ML / (core::f32::consts::PI * self.expansion_length_mm);
        let d2 = d0 * d0 + area_mm2;
        // `max` would turn NaN into 0; keep NaN visible.
        libm::sqrtf(if d2 < 0.0 { 0.0 } else { d2 })
    }

    /// Volume (mL) to inject past rest to reach outer diameter `diameter_mm`
    /// (negative below D0): the inverse of [`ExpansionZone::diameter_mm`].
    pub fn volume_ml(&self, diameter_mm: f32) -> f32 {
        let d0 = self.initial_diameter_mm;
        core::f32::consts::PI * self.expansion_length_mm * (diameter_mm * diameter_mm - d0 * d0)
            / 4.0
            / MM3_PER_ML
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const ZONE: ExpansionZone = ExpansionZone {
        initial_diameter_mm: 18.7,
        expansion_length_mm: 20.0,
    };

    #[test]
    fn paper_expansion_needs_4_3_ml() {
        // π·20·(25² − 18.7²)/4 mm³ = π·5·275.31 = 4324.55 mm³.
        let v = ZONE.volume_ml(25.0);
        assert!((v - 4.32455).abs() < 1e-4, "{v}");
        assert!((ZONE.diameter_mm(v) - 25.0).abs() < 1e-4);
        assert_eq!(ZONE.diameter_mm(0.0), 18.7);
    }

    #[test]
    fn withdrawal_and_garbage_do_not_panic() {
        assert_eq!(ZONE.diameter_mm(-100.0), 0.0);
        assert!(ZONE.diameter_mm(f32::NAN).is_nan());
        assert!(ZONE.diameter_mm(-1.0) < 18.7);
    }
}
