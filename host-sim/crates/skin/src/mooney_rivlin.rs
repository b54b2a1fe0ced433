//! Two-term Mooney–Rivlin: W = C10·(I1 − 3) + C01·(I2 − 3), μ = 2(C10 + C01).

use serde::{Deserialize, Serialize};

use super::{Form, LawSpec, StrainEnergy};

/// Two-term Mooney–Rivlin strain energy (kPa).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct MooneyRivlin {
    /// C10 (kPa).
    pub c10_kpa: f64,
    /// C01 (kPa); fits to stiffening data often make it negative, which is
    /// what costs this law its Drucker stability.
    pub c01_kpa: f64,
}

impl MooneyRivlin {
    /// Registry row.
    pub const SPEC: LawSpec = LawSpec {
        name: "Mooney-Rivlin",
        parameter_names: &["c10_kpa", "c01_kpa"],
        from_parameters: |p| match *p {
            [c10_kpa, c01_kpa] => Some(Box::new(Self { c10_kpa, c01_kpa })),
            _ => None,
        },
        form: Form::Linear,
    };
}

impl StrainEnergy for MooneyRivlin {
    // `#[inline]`: the FEM kernel calls these per element and point,
    // from another crate.
    fn name(&self) -> &'static str {
        Self::SPEC.name
    }
    fn parameters(&self) -> Vec<f64> {
        vec![self.c10_kpa, self.c01_kpa]
    }
    #[inline]
    fn energy_kpa(&self, i1: f64, i2: f64) -> f64 {
        self.c10_kpa * (i1 - 3.0) + self.c01_kpa * (i2 - 3.0)
    }
    #[inline]
    fn dw_di1_kpa(&self, _i1: f64, _i2: f64) -> f64 {
        self.c10_kpa
    }
    #[inline]
    fn dw_di2_kpa(&self, _i1: f64, _i2: f64) -> f64 {
        self.c01_kpa
    }
    #[inline]
    fn d2w_di1_di1_kpa(&self, _i1: f64, _i2: f64) -> f64 {
        0.0
    }
    #[inline]
    fn d2w_di1_di2_kpa(&self, _i1: f64, _i2: f64) -> f64 {
        0.0
    }
    #[inline]
    fn d2w_di2_di2_kpa(&self, _i1: f64, _i2: f64) -> f64 {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uniaxial_stress_and_drucker_slope_are_the_textbook_formulas() {
        // σ = 2(λ² − 1/λ)(C10 + C01/λ); dσ/dλ written out by hand.
        let (c10, c01) = (150.0, -60.0);
        let m = MooneyRivlin {
            c10_kpa: c10,
            c01_kpa: c01,
        };
        for l in [0.5, 1.0, 1.7, 5.0] {
            let s = 2.0 * (l * l - 1.0 / l) * (c10 + c01 / l);
            let ds = 2.0 * (2.0 * l + 1.0 / (l * l)) * (c10 + c01 / l)
                - 2.0 * (l * l - 1.0 / l) * c01 / (l * l);
            assert!((m.uniaxial_cauchy_kpa(l) - s).abs() < 1e-9 * s.abs().max(1.0));
            assert!((m.uniaxial_cauchy_slope_kpa(l) - ds).abs() < 1e-9 * ds.abs().max(1.0));
        }
    }
}
