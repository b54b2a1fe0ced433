//! The constitutive interface the FEM skin needs: an incompressible,
//! isotropic hyperelastic law given by W(I1, I2) and its derivatives. The
//! laws themselves (and their fits) live in the skin crate.
//!
//! Laws written in principal stretches (Ogden) implement the same
//! interface: W(I1, I2) is a smooth function of the invariants for any
//! smooth symmetric function of the stretches, and such a law overrides
//! the principal-stretch views below ([`StrainEnergy::extra_stress_kpa`],
//! the uniaxial slope, the shear modulus) with its own closed forms.

/// An incompressible, isotropic strain-energy density W(I1, I2) (kPa, i.e.
/// kJ/m³), I1 and I2 the invariants of the right Cauchy–Green tensor.
///
/// Implementors give W and its derivatives; every stress below is derived
/// here, once, from the incompressible constitutive law
/// σ = −p·1 + 2·W1·B − 2·W2·B⁻¹ (W1 = ∂W/∂I1, W2 = ∂W/∂I2).
pub trait StrainEnergy: std::fmt::Debug + Send + Sync {
    /// Name of the law, as in the skin crate's law registry.
    fn name(&self) -> &'static str;
    /// Coefficients in the law's own order, units as in the registry's
    /// parameter names (moduli in kPa, exponents and limits dimensionless).
    fn parameters(&self) -> Vec<f64>;
    /// W (kPa) at the invariants `i1`, `i2`.
    fn energy_kpa(&self, i1: f64, i2: f64) -> f64;
    /// ∂W/∂I1 (kPa).
    fn dw_di1_kpa(&self, i1: f64, i2: f64) -> f64;
    /// ∂W/∂I2 (kPa).
    fn dw_di2_kpa(&self, i1: f64, i2: f64) -> f64;
    /// ∂²W/∂I1² (kPa).
    fn d2w_di1_di1_kpa(&self, i1: f64, i2: f64) -> f64;
    /// ∂²W/∂I1∂I2 (kPa).
    fn d2w_di1_di2_kpa(&self, i1: f64, i2: f64) -> f64;
    /// ∂²W/∂I2² (kPa).
    fn d2w_di2_di2_kpa(&self, i1: f64, i2: f64) -> f64;

    /// Small-strain shear modulus μ = 2(W1 + W2) at the undeformed state (kPa).
    fn shear_modulus_kpa(&self) -> f64 {
        2.0 * (self.dw_di1_kpa(3.0, 3.0) + self.dw_di2_kpa(3.0, 3.0))
    }

    /// Principal Cauchy stresses (kPa) up to the common pressure:
    /// t_i = λi·∂W/∂λi = 2·W1·λi² − 2·W2·λi⁻², for principal stretches
    /// `stretches` (their product must be 1). The true stress is
    /// σ_i = t_i − p; only differences t_i − t_j are meaningful. Every
    /// homogeneous-test stress below and the tube inflation derive from
    /// this one; a principal-stretch law overrides it with λi·∂W/∂λi.
    fn extra_stress_kpa(&self, stretches: [f64; 3]) -> [f64; 3] {
        let [a, b, c] = stretches.map(|l| l * l);
        let (i1, i2) = (a + b + c, a * b + b * c + c * a);
        let (w1, w2) = (self.dw_di1_kpa(i1, i2), self.dw_di2_kpa(i1, i2));
        [a, b, c].map(|l2| 2.0 * w1 * l2 - 2.0 * w2 / l2)
    }

    /// Uniaxial tension/compression at stretch λ = 1 + ε: Cauchy (true)
    /// stress σ (kPa), with λ2 = λ3 = λ^(-1/2) and σ2 = σ3 = 0.
    fn uniaxial_cauchy_kpa(&self, stretch: f64) -> f64 {
        let lt = stretch.powf(-0.5);
        let [t1, t2, _] = self.extra_stress_kpa([stretch, lt, lt]);
        t1 - t2
    }

    /// Uniaxial nominal (engineering, first Piola–Kirchhoff) stress P = σ/λ
    /// (kPa): 2(λ − λ⁻²)(W1 + W2/λ).
    fn uniaxial_nominal_kpa(&self, stretch: f64) -> f64 {
        self.uniaxial_cauchy_kpa(stretch) / stretch
    }

    /// Uniaxial tangent of the nominal stress, dP/dλ = dP/dε (kPa).
    fn uniaxial_nominal_slope_kpa(&self, stretch: f64) -> f64 {
        let l = stretch;
        let (i1, i2) = (l * l + 2.0 / l, 2.0 * l + 1.0 / (l * l));
        let (di1, di2) = (2.0 * l - 2.0 / (l * l), 2.0 - 2.0 / (l * l * l));
        let (w1, w2) = (self.dw_di1_kpa(i1, i2), self.dw_di2_kpa(i1, i2));
        let w11 = self.d2w_di1_di1_kpa(i1, i2);
        let w12 = self.d2w_di1_di2_kpa(i1, i2);
        let w22 = self.d2w_di2_di2_kpa(i1, i2);
        let g = w1 + w2 / l;
        let dg = w11 * di1 + w12 * di2 + (w12 * di1 + w22 * di2) / l - w2 / (l * l);
        2.0 * (1.0 + 2.0 / (l * l * l)) * g + 2.0 * (l - 1.0 / (l * l)) * dg
    }

    /// Uniaxial tangent of the Cauchy stress, dσ/dλ = dσ/dε (kPa). Drucker
    /// stability in uniaxial loading (dσ : dε > 0 with logarithmic strain
    /// increments) is exactly this slope being positive.
    fn uniaxial_cauchy_slope_kpa(&self, stretch: f64) -> f64 {
        self.uniaxial_nominal_kpa(stretch) + stretch * self.uniaxial_nominal_slope_kpa(stretch)
    }

    /// Equibiaxial tension: nominal stress (kPa) in each loaded direction at
    /// in-plane stretch λ (λ3 = λ⁻²): 2(λ − λ⁻⁵)(W1 + λ²·W2).
    fn equibiaxial_nominal_kpa(&self, stretch: f64) -> f64 {
        let [t1, _, t3] = self.extra_stress_kpa([stretch, stretch, stretch.powi(-2)]);
        (t1 - t3) / stretch
    }

    /// Planar (pure shear) tension: nominal stress (kPa) along the loaded
    /// direction at stretch λ (λ2 = 1, λ3 = 1/λ): 2(λ − λ⁻³)(W1 + W2).
    fn planar_nominal_kpa(&self, stretch: f64) -> f64 {
        let [t1, _, t3] = self.extra_stress_kpa([stretch, 1.0, 1.0 / stretch]);
        (t1 - t3) / stretch
    }

    /// Runs `v` on this law as its own concrete type. A law chosen at run
    /// time (a wrapper holding one of several laws) overrides it to hand
    /// over the law it holds, so an element loop dispatches once, not at
    /// every quadrature point.
    fn visit<V: LawVisitor>(&self, v: V) -> V::Output
    where
        Self: Sized,
    {
        v.visit(self)
    }
}

/// Work over a law of any concrete type ([`StrainEnergy::visit`]): the
/// element loops, compiled for the law they are handed.
pub trait LawVisitor {
    /// What the work returns.
    type Output;
    /// Does the work with `law`.
    fn visit<L: StrainEnergy + ?Sized>(self, law: &L) -> Self::Output;
}

/// A boxed law is a law: every method forwards, the overridden views
/// included, so a law chosen at run time (a fit's result) drives the tube
/// and the FEM skin exactly as its concrete type would.
impl<T: StrainEnergy + ?Sized> StrainEnergy for Box<T> {
    fn name(&self) -> &'static str {
        (**self).name()
    }
    fn parameters(&self) -> Vec<f64> {
        (**self).parameters()
    }
    fn energy_kpa(&self, i1: f64, i2: f64) -> f64 {
        (**self).energy_kpa(i1, i2)
    }
    fn dw_di1_kpa(&self, i1: f64, i2: f64) -> f64 {
        (**self).dw_di1_kpa(i1, i2)
    }
    fn dw_di2_kpa(&self, i1: f64, i2: f64) -> f64 {
        (**self).dw_di2_kpa(i1, i2)
    }
    fn d2w_di1_di1_kpa(&self, i1: f64, i2: f64) -> f64 {
        (**self).d2w_di1_di1_kpa(i1, i2)
    }
    fn d2w_di1_di2_kpa(&self, i1: f64, i2: f64) -> f64 {
        (**self).d2w_di1_di2_kpa(i1, i2)
    }
    fn d2w_di2_di2_kpa(&self, i1: f64, i2: f64) -> f64 {
        (**self).d2w_di2_di2_kpa(i1, i2)
    }
    fn shear_modulus_kpa(&self) -> f64 {
        (**self).shear_modulus_kpa()
    }
    fn extra_stress_kpa(&self, stretches: [f64; 3]) -> [f64; 3] {
        (**self).extra_stress_kpa(stretches)
    }
    fn uniaxial_cauchy_kpa(&self, stretch: f64) -> f64 {
        (**self).uniaxial_cauchy_kpa(stretch)
    }
    fn uniaxial_nominal_kpa(&self, stretch: f64) -> f64 {
        (**self).uniaxial_nominal_kpa(stretch)
    }
    fn uniaxial_nominal_slope_kpa(&self, stretch: f64) -> f64 {
        (**self).uniaxial_nominal_slope_kpa(stretch)
    }
    fn uniaxial_cauchy_slope_kpa(&self, stretch: f64) -> f64 {
        (**self).uniaxial_cauchy_slope_kpa(stretch)
    }
    fn equibiaxial_nominal_kpa(&self, stretch: f64) -> f64 {
        (**self).equibiaxial_nominal_kpa(stretch)
    }
    fn planar_nominal_kpa(&self, stretch: f64) -> f64 {
        (**self).planar_nominal_kpa(stretch)
    }
}
