//! Gent (1996): W = −(μ·Jm/2)·ln(1 − (I1 − 3)/Jm), the limiting-chain law:
//! neo-Hookean (μ = 2·C10) at small strain, stiffening without bound as
//! I1 − 3 approaches Jm.

use serde::{Deserialize, Serialize};

use super::{Form, LawSpec, StrainEnergy};

/// Gent strain energy. Beyond the limit (I1 − 3 ≥ Jm) the energy and its
/// derivatives are +∞: no finite stress reaches that state.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Gent {
    /// Small-strain shear modulus μ (kPa).
    pub mu_kpa: f64,
    /// Limit Jm of I1 − 3 (dimensionless, > 0).
    pub jm: f64,
}

impl Gent {
    /// Registry row.
    pub const SPEC: LawSpec = LawSpec {
        name: "Gent",
        parameter_names: &["mu_kpa", "jm"],
        from_parameters: |p| match *p {
            [mu_kpa, jm] if jm > 0.0 && jm.is_finite() && mu_kpa.is_finite() => {
                Some(Box::new(Self { mu_kpa, jm }))
            }
            _ => None,
        },
        form: Form::Nonlinear {
            bounds: &[(-1e7, 1e7), (1e-3, 1e6)],
            linear_in: &[0],
            starts: || {
                [3.0, 10.0, 30.0, 100.0, 300.0, 1000.0]
                    .map(|jm| vec![jm])
                    .to_vec()
            },
            sign_pairs: &[],
        },
    };

    /// 1 − (I1 − 3)/Jm, or `None` at or beyond the limit.
    fn room(&self, i1: f64) -> Option<f64> {
        let r = 1.0 - (i1 - 3.0) / self.jm;
        (r > 0.0).then_some(r)
    }
}

impl StrainEnergy for Gent {
    fn name(&self) -> &'static str {
        Self::SPEC.name
    }
    fn parameters(&self) -> Vec<f64> {
        vec![self.mu_kpa, self.jm]
    }
    #[inline]
    fn energy_kpa(&self, i1: f64, _i2: f64) -> f64 {
        self.room(i1)
            .map_or(f64::INFINITY, |r| -0.5 * self.mu_kpa * self.jm * r.ln())
    }
    #[inline]
    fn dw_di1_kpa(&self, i1: f64, _i2: f64) -> f64 {
        self.room(i1)
            .map_or(f64::INFINITY, |r| 0.5 * self.mu_kpa / r)
    }
    #[inline]
    fn dw_di2_kpa(&self, _i1: f64, _i2: f64) -> f64 {
        0.0
    }
    #[inline]
    fn d2w_di1_di1_kpa(&self, i1: f64, _i2: f64) -> f64 {
        self.room(i1)
            .map_or(f64::INFINITY, |r| 0.5 * self.mu_kpa / (self.jm * r * r))
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
    use crate::NeoHookean;

    #[test]
    fn uniaxial_stress_is_the_textbook_formula_and_tends_to_neo_hookean() {
        // σ = μ·(λ² − 1/λ)/(1 − (λ² + 2/λ − 3)/Jm).
        let g = Gent {
            mu_kpa: 400.0,
            jm: 80.0,
        };
        for l in [0.5, 1.0, 2.0, 6.0] {
            let want = 400.0 * (l * l - 1.0 / l) / (1.0 - (l * l + 2.0 / l - 3.0) / 80.0);
            assert!((g.uniaxial_cauchy_kpa(l) - want).abs() < 1e-9 * want.abs().max(1.0));
        }
        assert_eq!(g.shear_modulus_kpa(), 400.0);
        // Jm → ∞ is neo-Hookean with C10 = μ/2.
        let wide = Gent {
            mu_kpa: 400.0,
            jm: 1e12,
        };
        let nh = NeoHookean { c10_kpa: 200.0 };
        let l = 3.0;
        assert!((wide.uniaxial_nominal_kpa(l) - nh.uniaxial_nominal_kpa(l)).abs() < 1e-6);
        // Beyond the limit: no finite stress.
        assert_eq!(g.dw_di1_kpa(84.0, 3.0), f64::INFINITY);
    }
}
