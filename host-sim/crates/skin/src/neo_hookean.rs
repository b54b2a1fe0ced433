//! Neo-Hookean: W = C10·(I1 − 3), μ = 2·C10.

use serde::{Deserialize, Serialize};

use super::{Form, LawSpec, StrainEnergy};

/// Neo-Hookean strain energy W = C10·(I1 − 3) (kPa).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct NeoHookean {
    /// C10 (kPa); the shear modulus is 2·C10.
    pub c10_kpa: f64,
}

impl NeoHookean {
    /// Registry row.
    pub const SPEC: LawSpec = LawSpec {
        name: "neo-Hookean",
        parameter_names: &["c10_kpa"],
        from_parameters: |p| match *p {
            [c10_kpa] => Some(Box::new(Self { c10_kpa })),
            _ => None,
        },
        form: Form::Linear,
    };
}

impl StrainEnergy for NeoHookean {
    // `#[inline]`: the FEM kernel calls these per element and point,
    // from another crate.
    fn name(&self) -> &'static str {
        Self::SPEC.name
    }
    fn parameters(&self) -> Vec<f64> {
        vec![self.c10_kpa]
    }
    #[inline]
    fn energy_kpa(&self, i1: f64, _i2: f64) -> f64 {
        self.c10_kpa * (i1 - 3.0)
    }
    #[inline]
    fn dw_di1_kpa(&self, _i1: f64, _i2: f64) -> f64 {
        self.c10_kpa
    }
    #[inline]
    fn dw_di2_kpa(&self, _i1: f64, _i2: f64) -> f64 {
        0.0
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
    fn uniaxial_stress_is_the_textbook_formula() {
        // σ = 2·C10·(λ² − 1/λ), written out independently.
        let m = NeoHookean { c10_kpa: 200.0 };
        for l in [0.5, 1.0, 2.0, 6.0] {
            let want = 2.0 * 200.0 * (l * l - 1.0 / l);
            assert!((m.uniaxial_cauchy_kpa(l) - want).abs() < 1e-9 * want.abs().max(1.0));
        }
        assert_eq!(m.shear_modulus_kpa(), 400.0);
    }
}
