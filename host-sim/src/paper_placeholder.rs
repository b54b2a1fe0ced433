//! PLACEHOLDER physics for the firmware table, built only from the paper's
//! summary numbers (`shared/reference/paper-figures.md`), until the skin
//! model and the sand law of issue 3 replace it.
//!
//! - Skin: a thin-walled neo-Hookean tube in plane strain,
//!   p_m = (μ t0 / R0)(1 − λ⁻⁴) with λ = D / D0, scaled so that
//!   p_m(25 mm) = 4.06 − 3.86 = 0.20 kPa (the paper's simulated p_i at 4 cm
//!   minus the measured p_e at 4 cm).
//! - Sand: p_e rises from the at-rest K0·σ'v to the balloon experiment's
//!   k·h (k = 0.96 kPa/cm, least squares through the origin of its table),
//!   exponentially over 1.2 mm of diameter increase, so most of the rise is
//!   over by D ≈ 22 mm as in the paper's Figure 3b.

use crate::tables::PressureModel;

/// Stand-in p_i(D, h) from the paper's figures; see the module docs.
#[derive(Clone, Copy, Debug)]
pub struct PaperPlaceholder {
    /// D0 (mm).
    pub initial_diameter_mm: f64,
    /// μ·t0/R0 (kPa): the skin's pressure scale.
    pub skin_scale_kpa: f64,
    /// Plateau of p_e per mm of depth (kPa/mm).
    pub plateau_kpa_per_mm: f64,
    /// At-rest p_e per mm of depth (kPa/mm): K0·γ'.
    pub at_rest_kpa_per_mm: f64,
    /// Characteristic diameter increase of the p_e rise (mm).
    pub rise_mm: f64,
}

impl Default for PaperPlaceholder {
    fn default() -> Self {
        let d0 = 18.7;
        let lambda_final: f64 = 25.0 / d0;
        // Buoyant unit weight of the sand: (ρs − ρw)(1 − n) g with n = 0.4.
        let gamma_buoyant_kpa_per_mm = (2920.0 - 1025.0) * 0.6 * 9.81 * 1e-6;
        let k0 = 1.0 - (0.25_f64).atan().sin();
        Self {
            initial_diameter_mm: d0,
            skin_scale_kpa: 0.20 / (1.0 - lambda_final.powi(-4)),
            plateau_kpa_per_mm: 0.096,
            at_rest_kpa_per_mm: k0 * gamma_buoyant_kpa_per_mm,
            rise_mm: 1.2,
        }
    }
}

impl PressureModel for PaperPlaceholder {
    fn internal_pressure_kpa(&self, diameter_mm: f64, depth_mm: f64) -> f64 {
        let lambda = diameter_mm / self.initial_diameter_mm;
        let membrane = self.skin_scale_kpa * (1.0 - lambda.powi(-4));
        let rise = 1.0 - (-(diameter_mm - self.initial_diameter_mm) / self.rise_mm).exp();
        let at_rest = self.at_rest_kpa_per_mm * depth_mm;
        let sand = at_rest + (self.plateau_kpa_per_mm * depth_mm - at_rest) * rise;
        membrane + sand
    }

    fn provenance(&self) -> String {
        "paper summary figures (thin-wall neo-Hookean skin scaled to 0.20 kPa at 25 mm; \
         p_e from K0*sigma'v to 0.96 kPa/cm over 1.2 mm)"
            .into()
    }

    fn is_placeholder(&self) -> bool {
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reproduces_the_paper_numbers_it_was_built_from() {
        let m = PaperPlaceholder::default();
        // p_i at 4 cm and 25 mm: the paper's 4.06 kPa.
        let p = m.internal_pressure_kpa(25.0, 40.0);
        assert!((p - 4.06).abs() < 0.05, "p_i(25 mm, 4 cm) = {p}");
        // p_e plateau at 10 cm: k·h = 9.6 kPa against the measured 9.07 ± 2.42.
        let pe = m.internal_pressure_kpa(25.0, 100.0) - m.internal_pressure_kpa(25.0, 0.0);
        assert!((pe - 9.07).abs() < 2.42, "p_e(25 mm, 10 cm) = {pe}");
        // Free water at rest reads zero (the sensor's zero).
        assert!(m.internal_pressure_kpa(18.7, 0.0).abs() < 1e-12);
    }
}
