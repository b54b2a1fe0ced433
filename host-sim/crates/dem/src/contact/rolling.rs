//! Rolling-resistance laws: a torque opposing the relative rolling of the
//! two surfaces.

use nalgebra::Vector3;

use super::{select3, ContactGeometry, Real};
use crate::DemError;

/// A rolling-resistance law.
pub trait RollingLaw {
    /// Torque on i (N·m), given the Coulomb limit force `fncrit_n` (N).
    fn torque<T: Real>(&self, g: &ContactGeometry<T>, fncrit_n: T) -> Vector3<T>;
}

/// No rolling resistance.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct NoRolling;

impl RollingLaw for NoRolling {
    #[inline(always)]
    fn torque<T: Real>(&self, _g: &ContactGeometry<T>, _fncrit_n: T) -> Vector3<T> {
        // Built in place: `Vector3::repeat` left the pass's AVX2 copy a
        // chain of unaligned stack copies per batch.
        let zero = T::splat(0.0);
        Vector3::new(zero, zero, zero)
    }
}

/// Constant directional torque (Zhou et al. 1999, "model A" of Ai et al.
/// 2011): M_r = −μ_r R* F_ncrit ω_r/|ω_r|, with ω_r the relative spin
/// without its twisting part. No history; it chatters around ω_r = 0, so
/// below [`ConstantTorque::rest_spin_rad_s`] it is switched off.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConstantTorque {
    /// Rolling-friction coefficient μ_r (−).
    pub rolling_friction: f64,
    /// Relative spin (rad/s) under which no torque acts. Default 1e-9.
    pub rest_spin_rad_s: f64,
}

impl ConstantTorque {
    /// Constant torque with coefficient μ_r (≥ 0).
    pub fn new(rolling_friction: f64) -> Result<Self, DemError> {
        if !(rolling_friction >= 0.0 && rolling_friction.is_finite()) {
            return Err(DemError::param("rolling_friction", rolling_friction));
        }
        Ok(Self {
            rolling_friction,
            rest_spin_rad_s: 1e-9,
        })
    }
}

impl RollingLaw for ConstantTorque {
    #[inline(always)]
    fn torque<T: Real>(&self, g: &ContactGeometry<T>, fncrit_n: T) -> Vector3<T> {
        let w = g.relative_spin_rad_s - g.normal * g.relative_spin_rad_s.dot(&g.normal);
        let s = w.dot(&w).simd_sqrt();
        let rolling = s.simd_gt(T::splat(self.rest_spin_rad_s));
        if !T::any(rolling) {
            return Vector3::repeat(T::splat(0.0));
        }
        let torque = w * (T::splat(-self.rolling_friction) * g.radius_eff_m * fncrit_n / s);
        select3(rolling, torque, Vector3::repeat(T::splat(0.0)))
    }
}

/// The rolling family (enum dispatch for the hot loop).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Rolling {
    /// [`NoRolling`].
    None(NoRolling),
    /// [`ConstantTorque`].
    ConstantTorque(ConstantTorque),
}

impl RollingLaw for Rolling {
    #[inline(always)]
    fn torque<T: Real>(&self, g: &ContactGeometry<T>, fncrit_n: T) -> Vector3<T> {
        match self {
            Rolling::None(l) => l.torque(g, fncrit_n),
            Rolling::ConstantTorque(l) => l.torque(g, fncrit_n),
        }
    }
}
