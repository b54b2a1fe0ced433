//! The project's p_i(D, h): the skin tube's own pressure plus the sand's,
//! p_i = p_membrane(D) + p_e(D, h) (exact for an incompressible wall; see
//! [`crate::skin::membrane`]). This is what the firmware tables sample.

use anyhow::Result;

use crate::sand::{ParametricSand, SandLaw};
use crate::skin::membrane::{Ends, InflationState, Tube};
use crate::skin::Yeoh;
use crate::tables::PressureModel;

/// Skin tube plus sand law.
#[derive(Clone, Debug)]
pub struct SkinSandModel {
    /// The skin tube of the expansion zone.
    pub tube: Tube<Yeoh>,
    /// The sand around it.
    pub sand: ParametricSand,
}

impl SkinSandModel {
    /// The default ([`TubeGeometry::PAPER`](crate::skin::membrane::TubeGeometry::PAPER)): the paper's zone (D0 18.7 mm, 1.75 mm skin, 20 mm) of
    /// the default Yeoh skin with closed ends (the zone is part of a
    /// closed, pressurised body, so its wall carries the pressure on the
    /// cross-section), in the balloon-calibrated sand.
    pub fn paper_default() -> Self {
        Self {
            tube: Tube::paper(crate::skin::default_skin(), Ends::Closed),
            sand: ParametricSand::calibrated_to_balloon(),
        }
    }

    /// The skin's pressure p_membrane (kPa) at outer diameter `diameter_mm`.
    pub fn membrane_kpa(&self, diameter_mm: f64) -> Result<f64> {
        Ok(self.tube.pressure_kpa(diameter_mm)?)
    }

    /// The skin's full state (stretches, von Mises) at `diameter_mm`.
    pub fn skin_state(&self, diameter_mm: f64) -> Result<InflationState> {
        Ok(self.tube.state(diameter_mm)?)
    }
}

impl PressureModel for SkinSandModel {
    fn internal_pressure_kpa(&self, diameter_mm: f64, depth_mm: f64) -> f64 {
        // NaN for a diameter the tube cannot reach; the table generator's
        // verification refuses non-finite values.
        self.tube.pressure_kpa(diameter_mm).unwrap_or(f64::NAN)
            + self.sand.loading_pressure_kpa(diameter_mm, depth_mm)
    }

    fn provenance(&self) -> String {
        let y = &self.tube.skin;
        let g = &self.tube.geometry;
        let s = &self.sand.params;
        format!(
            "host-sim skin + sand (issue 3): Yeoh C10={:.4} C20={:.5} C30={:.6} kPa \
             (fit to data/skin/unicinctus_circumferential.csv), {} thick tube \
             D0={} mm wall={} mm; parametric sand K0={:.3} N={:.3} dDc={:.3} mm, \
             gamma'={:.5} kPa/mm (N fit to the paper's balloon table)",
            y.c10_kpa,
            y.c20_kpa,
            y.c30_kpa,
            self.tube.ends.label(),
            g.outer_diameter_mm,
            g.wall_thickness_mm,
            s.at_rest_coefficient,
            s.limit_coefficient,
            s.characteristic_diameter_increase_mm,
            s.buoyant_unit_weight_kpa_per_mm(),
        )
    }

    fn is_placeholder(&self) -> bool {
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn internal_pressure_is_membrane_plus_sand() {
        let m = SkinSandModel::paper_default();
        for (d, h) in [(18.7, 0.0), (21.0, 40.0), (25.0, 100.0)] {
            let want = m.membrane_kpa(d).unwrap() + m.sand.loading_pressure_kpa(d, h);
            assert_eq!(m.internal_pressure_kpa(d, h), want);
        }
        // Free water at rest reads zero (the sensor's zero).
        assert!(m.internal_pressure_kpa(18.7, 0.0).abs() < 1e-12);
        // A diameter that closes the bore is NaN, not a panic.
        assert!(m.internal_pressure_kpa(5.0, 0.0).is_nan());
        assert!(!m.is_placeholder());
    }
}
