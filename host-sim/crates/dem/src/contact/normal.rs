//! Normal elastic laws: the repulsive force as a function of the overlap.

use super::{ContactGeometry, Real};
use crate::DemError;

/// What a normal law gives the laws after it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NormalOutput<T = f64> {
    /// Elastic normal force (N), ≥ 0 = repulsive.
    pub force_n: T,
    /// Tangent stiffness S_n = dF/dδ (N/m), used by the damping law.
    pub stiffness_n_per_m: T,
    /// Contact radius a (m), used by the tangential law.
    pub contact_radius_m: T,
}

impl<T: Real> NormalOutput<T> {
    /// No force, no stiffness.
    pub fn zero() -> Self {
        let z = T::splat(0.0);
        NormalOutput {
            force_n: z,
            stiffness_n_per_m: z,
            contact_radius_m: z,
        }
    }
}

/// A normal elastic law.
pub trait NormalLaw {
    /// The elastic force of a contact with overlap > 0.
    fn force<T: Real>(&self, g: &ContactGeometry<T>) -> NormalOutput<T>;
}

/// No normal force (contacts pass through each other).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct NoNormal;

impl NormalLaw for NoNormal {
    #[inline(always)]
    fn force<T: Real>(&self, _g: &ContactGeometry<T>) -> NormalOutput<T> {
        NormalOutput::zero()
    }
}

/// Hertz: F = (4/3) E* √R* δ^{3/2}, a = √(R* δ), S_n = 2 E* a.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hertz {
    /// Effective modulus E* (Pa).
    pub effective_modulus_pa: f64,
}

impl Hertz {
    /// Hertz with effective modulus `effective_modulus_pa` (Pa, > 0).
    pub fn new(effective_modulus_pa: f64) -> Result<Self, DemError> {
        if !(effective_modulus_pa > 0.0 && effective_modulus_pa.is_finite()) {
            return Err(DemError::param(
                "effective_modulus_pa",
                effective_modulus_pa,
            ));
        }
        Ok(Self {
            effective_modulus_pa,
        })
    }
}

impl NormalLaw for Hertz {
    #[inline(always)]
    fn force<T: Real>(&self, g: &ContactGeometry<T>) -> NormalOutput<T> {
        let a = (g.radius_eff_m * g.overlap_m).simd_sqrt();
        NormalOutput {
            force_n: T::splat((4.0 / 3.0) * self.effective_modulus_pa) * a * g.overlap_m,
            stiffness_n_per_m: T::splat(2.0 * self.effective_modulus_pa) * a,
            contact_radius_m: a,
        }
    }
}

/// The normal family (enum dispatch for the hot loop).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Normal {
    /// [`NoNormal`].
    None(NoNormal),
    /// [`Hertz`].
    Hertz(Hertz),
}

impl NormalLaw for Normal {
    #[inline(always)]
    fn force<T: Real>(&self, g: &ContactGeometry<T>) -> NormalOutput<T> {
        match self {
            Normal::None(l) => l.force(g),
            Normal::Hertz(l) => l.force(g),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    #[test]
    fn hertz_force_is_the_derivative_of_its_energy() {
        let h = Hertz::new(5.0e6).unwrap();
        let geom = |d: f64| ContactGeometry {
            normal: Vector3::z(),
            overlap_m: d,
            radius_eff_m: 5e-4,
            mass_eff_kg: 1.0,
            normal_velocity_m_s: 0.0,
            tangential_velocity_m_s: Vector3::zeros(),
            relative_spin_rad_s: Vector3::zeros(),
        };
        // S_n = dF/dδ by central differences.
        let d = 1e-5;
        let fd =
            (h.force(&geom(d * 1.001)).force_n - h.force(&geom(d * 0.999)).force_n) / (0.002 * d);
        let s = h.force(&geom(d)).stiffness_n_per_m;
        assert!((fd - s).abs() < 1e-5 * s, "{fd} vs {s}");
    }
}
