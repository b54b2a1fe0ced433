//! Yeoh (three-term reduced polynomial):
//! W = C10·(I1 − 3) + C20·(I1 − 3)² + C30·(I1 − 3)³, μ = 2·C10.

use serde::{Deserialize, Serialize};

use super::{Form, LawSpec, StrainEnergy};

/// Three-term Yeoh strain energy (kPa). Depends on I1 only.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Yeoh {
    /// C10 (kPa); the small-strain shear modulus is 2·C10.
    pub c10_kpa: f64,
    /// C20 (kPa); often negative in fits (softening at moderate strain).
    pub c20_kpa: f64,
    /// C30 (kPa); the large-strain stiffening.
    pub c30_kpa: f64,
}

impl Yeoh {
    /// Registry row.
    pub const SPEC: LawSpec = LawSpec {
        name: "Yeoh",
        parameter_names: &["c10_kpa", "c20_kpa", "c30_kpa"],
        from_parameters: |p| match *p {
            [c10_kpa, c20_kpa, c30_kpa] => Some(Box::new(Self {
                c10_kpa,
                c20_kpa,
                c30_kpa,
            })),
            _ => None,
        },
        form: Form::Linear,
    };
}

impl StrainEnergy for Yeoh {
    // `#[inline]`: the FEM kernel calls these per element and point,
    // from another crate.
    fn name(&self) -> &'static str {
        Self::SPEC.name
    }
    fn parameters(&self) -> Vec<f64> {
        vec![self.c10_kpa, self.c20_kpa, self.c30_kpa]
    }
    #[inline]
    fn energy_kpa(&self, i1: f64, _i2: f64) -> f64 {
        let x = i1 - 3.0;
        x * (self.c10_kpa + x * (self.c20_kpa + x * self.c30_kpa))
    }
    #[inline]
    fn dw_di1_kpa(&self, i1: f64, _i2: f64) -> f64 {
        let x = i1 - 3.0;
        self.c10_kpa + x * (2.0 * self.c20_kpa + 3.0 * x * self.c30_kpa)
    }
    #[inline]
    fn dw_di2_kpa(&self, _i1: f64, _i2: f64) -> f64 {
        0.0
    }
    #[inline]
    fn d2w_di1_di1_kpa(&self, i1: f64, _i2: f64) -> f64 {
        2.0 * self.c20_kpa + 6.0 * (i1 - 3.0) * self.c30_kpa
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
    fn uniaxial_stress_is_the_papers_formula() {
        // σ = 2(λ² − 1/λ)[C10 + 2·C20(I1 − 3) + 3·C30(I1 − 3)²], I1 = λ² + 2/λ.
        let (c10, c20, c30) = (30.0, -1.5, 0.2);
        let m = Yeoh {
            c10_kpa: c10,
            c20_kpa: c20,
            c30_kpa: c30,
        };
        for l in [0.5, 1.0, 2.0, 4.6] {
            let x = l * l + 2.0 / l - 3.0;
            let want = 2.0 * (l * l - 1.0 / l) * (c10 + 2.0 * c20 * x + 3.0 * c30 * x * x);
            assert!((m.uniaxial_cauchy_kpa(l) - want).abs() < 1e-9 * want.abs().max(1.0));
        }
    }
}
