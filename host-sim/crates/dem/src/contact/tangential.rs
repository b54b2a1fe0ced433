//! Tangential laws: friction at the contact.

use nalgebra::Vector3;

use super::{select3, ContactGeometry, NormalOutput, Real, HISTORY_LEN};
use crate::DemError;

/// A tangential law.
pub trait TangentialLaw {
    /// History values it uses per contact.
    fn history_len(&self) -> usize;

    /// Tangential force on i (N), given the normal output, the normal
    /// dashpot γ_n (N·s/m), the Coulomb limit force `fncrit_n` (N) and the
    /// step `dt_s` (s); updates `history`.
    #[allow(clippy::too_many_arguments)]
    fn force<T: Real>(
        &self,
        g: &ContactGeometry<T>,
        normal: &NormalOutput<T>,
        gamma_n: T,
        fncrit_n: T,
        dt_s: f64,
        history: &mut [T; HISTORY_LEN],
    ) -> Vector3<T>;
}

/// Frictionless contacts.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct NoTangential;

impl TangentialLaw for NoTangential {
    fn history_len(&self) -> usize {
        0
    }

    #[inline(always)]
    fn force<T: Real>(
        &self,
        _g: &ContactGeometry<T>,
        _normal: &NormalOutput<T>,
        _gamma_n: T,
        _fncrit_n: T,
        _dt_s: f64,
        _history: &mut [T; HISTORY_LEN],
    ) -> Vector3<T> {
        Vector3::repeat(T::splat(0.0))
    }
}

/// Mindlin (no-slip) tangential spring with history and a Coulomb cap, as
/// LIGGGHTS' `tangential history`: the history ξ (m) is the accumulated
/// tangential displacement, projected each step onto the current tangent
/// plane; k_t = 8 G* a; F_t = −k_t ξ − γ_t v_t, limited to μ F_ncrit, and
/// when it slides ξ is set back so that the spring holds the capped force.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mindlin {
    /// Effective shear modulus G* (Pa).
    pub effective_shear_modulus_pa: f64,
    /// Coulomb friction coefficient μ (−).
    pub friction: f64,
    /// γ_t / γ_n (−); √(4G*/E*) reproduces LIGGGHTS' γ_t = 2√(5/6)β√(S_t m*).
    pub damping_scale: f64,
}

impl Mindlin {
    /// Mindlin with G* (Pa, > 0), μ (≥ 0) and γ_t/γ_n (≥ 0).
    pub fn new(
        effective_shear_modulus_pa: f64,
        friction: f64,
        damping_scale: f64,
    ) -> Result<Self, DemError> {
        if !(effective_shear_modulus_pa > 0.0 && effective_shear_modulus_pa.is_finite()) {
            return Err(DemError::param(
                "effective_shear_modulus_pa",
                effective_shear_modulus_pa,
            ));
        }
        if !(friction >= 0.0 && friction.is_finite()) {
            return Err(DemError::param("friction", friction));
        }
        if !(damping_scale >= 0.0 && damping_scale.is_finite()) {
            return Err(DemError::param("damping_scale", damping_scale));
        }
        Ok(Self {
            effective_shear_modulus_pa,
            friction,
            damping_scale,
        })
    }
}

impl TangentialLaw for Mindlin {
    fn history_len(&self) -> usize {
        3
    }

    #[inline(always)]
    fn force<T: Real>(
        &self,
        g: &ContactGeometry<T>,
        normal: &NormalOutput<T>,
        gamma_n: T,
        fncrit_n: T,
        dt_s: f64,
        history: &mut [T; HISTORY_LEN],
    ) -> Vector3<T> {
        let n = &g.normal;
        let vt = &g.tangential_velocity_m_s;
        let mut xi = Vector3::new(history[0], history[1], history[2]);
        // Keep the spring in the tangent plane as the contact rotates.
        xi -= n * xi.dot(n);
        xi += vt * T::splat(dt_s);
        let kt = T::splat(8.0 * self.effective_shear_modulus_pa) * normal.contact_radius_m;
        let gamma_t = T::splat(self.damping_scale) * gamma_n;
        let mut ft = xi * -kt - vt * gamma_t;
        let limit = T::splat(self.friction) * fncrit_n;
        let ft2 = ft.dot(&ft);
        let slides = ft2.simd_gt(limit * limit);
        if T::any(slides) {
            let capped = ft * (limit / ft2.simd_sqrt());
            // The spring set back to hold the capped force.
            let zero = Vector3::repeat(T::splat(0.0));
            let stiff = kt.simd_gt(T::splat(0.0));
            let held = select3(stiff, -(capped + vt * gamma_t) / kt, zero);
            xi = select3(slides, held, xi);
            ft = select3(slides, capped, ft);
        }
        history[0] = xi.x;
        history[1] = xi.y;
        history[2] = xi.z;
        ft
    }
}

/// The tangential family (enum dispatch for the hot loop).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Tangential {
    /// [`NoTangential`].
    None(NoTangential),
    /// [`Mindlin`].
    Mindlin(Mindlin),
}

impl TangentialLaw for Tangential {
    fn history_len(&self) -> usize {
        match self {
            Tangential::None(l) => l.history_len(),
            Tangential::Mindlin(l) => l.history_len(),
        }
    }

    #[inline(always)]
    fn force<T: Real>(
        &self,
        g: &ContactGeometry<T>,
        normal: &NormalOutput<T>,
        gamma_n: T,
        fncrit_n: T,
        dt_s: f64,
        history: &mut [T; HISTORY_LEN],
    ) -> Vector3<T> {
        match self {
            Tangential::None(l) => l.force(g, normal, gamma_n, fncrit_n, dt_s, history),
            Tangential::Mindlin(l) => l.force(g, normal, gamma_n, fncrit_n, dt_s, history),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn geom(vt: Vector3<f64>) -> ContactGeometry {
        ContactGeometry {
            normal: Vector3::z(),
            overlap_m: 1e-5,
            radius_eff_m: 1e-3,
            mass_eff_kg: 1e-5,
            normal_velocity_m_s: 0.0,
            tangential_velocity_m_s: vt,
            relative_spin_rad_s: Vector3::zeros(),
        }
    }

    #[test]
    fn sticks_below_and_slides_at_the_coulomb_limit() {
        let m = Mindlin::new(1.0e6, 0.25, 0.0).unwrap();
        let normal = NormalOutput {
            force_n: 1.0,
            stiffness_n_per_m: 0.0,
            contact_radius_m: 1e-4,
        };
        let mut h = [0.0; 3];
        // One small step: elastic, F = −k_t v dt.
        let f = m.force(&geom(Vector3::x() * 1e-3), &normal, 0.0, 1.0, 1e-3, &mut h);
        let kt = 8.0 * 1.0e6 * 1e-4;
        assert!((f.x + kt * 1e-6).abs() < 1e-12);
        // A large displacement: capped at μ F_n, spring holds the cap.
        let f = m.force(&geom(Vector3::x()), &normal, 0.0, 1.0, 1.0, &mut h);
        assert!((f.norm() - 0.25).abs() < 1e-12);
        assert!((h[0] * kt - 0.25).abs() < 1e-12);
    }
}
