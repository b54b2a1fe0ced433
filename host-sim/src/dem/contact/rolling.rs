//! Rolling-resistance laws: a torque opposing the relative rolling of the
//! two surfaces.

use nalgebra::Vector3;

use super::ContactGeometry;
use crate::dem::DemError;

/// A rolling-resistance law.
pub trait RollingLaw {
    /// Torque on i (N·m), given the Coulomb limit force `fncrit_n` (N).
    fn torque(&self, g: &ContactGeometry, fncrit_n: f64) -> Vector3<f64>;
}

/// No rolling resistance.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct NoRolling;

impl RollingLaw for NoRolling {
    #[inline]
    fn torque(&self, _g: &ContactGeometry, _fncrit_n: f64) -> Vector3<f64> {
        Vector3::zeros()
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
    #[inline]
    fn torque(&self, g: &ContactGeometry, fncrit_n: f64) -> Vector3<f64> {
        let w = g.relative_spin_rad_s - g.normal * g.relative_spin_rad_s.dot(&g.normal);
        let s = w.norm();
        if s <= self.rest_spin_rad_s {
            return Vector3::zeros();
        }
        w * (-self.rolling_friction * g.radius_eff_m * fncrit_n / s)
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
    #[inline]
    fn torque(&self, g: &ContactGeometry, fncrit_n: f64) -> Vector3<f64> {
        match self {
            Rolling::None(l) => l.torque(g, fncrit_n),
            Rolling::ConstantTorque(l) => l.torque(g, fncrit_n),
        }
    }
}
