//! Contact laws between two spheres, or a sphere and a wall, composed like
//! LAMMPS' `GranularModel`: one law per family (normal, damping, tangential,
//! rolling), each family a trait with a `None` law, evaluated in a fixed
//! order in which the laws talk to each other only through the normal
//! output and the critical normal force `Fncrit` passed explicitly.
//!
//! Order in [`ContactModel::evaluate`]: geometry (given) → normal elastic force
//! → damping coefficient → total normal force → `Fncrit` → tangential force
//! (Coulomb cap from `Fncrit`, history) → rolling torque.
//!
//! Each family is an enum over its laws, so the hot loop dispatches with a
//! `match` (no virtual calls), while every law is its own struct
//! implementing the family trait.

pub mod damping;
pub mod normal;
pub mod rolling;
pub mod tangential;

use nalgebra::Vector3;

pub use damping::{Damping, DampingLaw, NoDamping, ViscoelasticDamping};
pub use normal::{Hertz, Normal, NormalLaw, NormalOutput};
pub use rolling::{ConstantTorque, NoRolling, Rolling, RollingLaw};
pub use tangential::{Mindlin, NoTangential, Tangential, TangentialLaw};

use super::DemError;

/// Number of history values stored per contact (the largest any law needs:
/// the Mindlin tangential displacement, 3 components in m).
pub const HISTORY_LEN: usize = 3;

/// Per-contact history (see [`HISTORY_LEN`]); zero when a contact opens.
pub type History = [f64; HISTORY_LEN];

/// The geometry and kinematics of one contact, computed once by the caller
/// and read by every law. "i" is the particle the forces are for; "j" is
/// the other particle or the wall.
#[derive(Clone, Copy, Debug)]
pub struct ContactGeometry {
    /// Unit normal pointing from j (or the wall) to i.
    pub normal: Vector3<f64>,
    /// Overlap δ = R_i + R_j − distance (m); > 0 in contact.
    pub overlap_m: f64,
    /// Effective radius R* = R_i R_j / (R_i + R_j) (m); R_i for a wall.
    pub radius_eff_m: f64,
    /// Effective mass m* = m_i m_j / (m_i + m_j) (kg); m_i for a wall.
    pub mass_eff_kg: f64,
    /// Normal relative velocity (v_i − v_j)·n (m/s); negative while approaching.
    pub normal_velocity_m_s: f64,
    /// Tangential relative velocity of the two contact points (m/s), ⟂ n.
    pub tangential_velocity_m_s: Vector3<f64>,
    /// Relative angular velocity ω_i − ω_j (rad/s).
    pub relative_spin_rad_s: Vector3<f64>,
}

/// What one contact exerts, from i's point of view.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ContactForce {
    /// Force on i (N); j receives the opposite.
    pub force_n: Vector3<f64>,
    /// −n × F_t (N): the torque on i is R_i times this, and on j R_j times
    /// this (same sign: both contact points are dragged the same way).
    pub torque_per_radius_n: Vector3<f64>,
    /// Rolling-resistance torque on i (N·m); j receives the opposite.
    pub rolling_torque_n_m: Vector3<f64>,
}

/// Young's modulus, Poisson's ratio and density of one material.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    /// Young's modulus E (Pa).
    pub youngs_modulus_pa: f64,
    /// Poisson's ratio ν (−), in [0, 0.5).
    pub poisson_ratio: f64,
    /// Density (kg/m³); unused for walls.
    pub density_kg_m3: f64,
}

impl Material {
    /// Effective contact modulus of two materials (Pa):
    /// 1/E* = (1 − ν₁²)/E₁ + (1 − ν₂²)/E₂.
    pub fn effective_modulus_pa(&self, other: &Material) -> f64 {
        1.0 / ((1.0 - self.poisson_ratio.powi(2)) / self.youngs_modulus_pa
            + (1.0 - other.poisson_ratio.powi(2)) / other.youngs_modulus_pa)
    }

    /// Effective shear modulus of two materials (Pa), Mindlin's:
    /// 1/G* = 2(2 − ν₁)(1 + ν₁)/E₁ + 2(2 − ν₂)(1 + ν₂)/E₂.
    pub fn effective_shear_modulus_pa(&self, other: &Material) -> f64 {
        let term = |m: &Material| {
            2.0 * (2.0 - m.poisson_ratio) * (1.0 + m.poisson_ratio) / m.youngs_modulus_pa
        };
        1.0 / (term(self) + term(other))
    }

    fn validate(&self) -> Result<(), DemError> {
        if !(self.youngs_modulus_pa > 0.0 && self.youngs_modulus_pa.is_finite()) {
            return Err(DemError::param("youngs_modulus_pa", self.youngs_modulus_pa));
        }
        if !(0.0..0.5).contains(&self.poisson_ratio) {
            return Err(DemError::param("poisson_ratio", self.poisson_ratio));
        }
        if !(self.density_kg_m3 >= 0.0 && self.density_kg_m3.is_finite()) {
            return Err(DemError::param("density_kg_m3", self.density_kg_m3));
        }
        Ok(())
    }
}

/// The usual contact: Hertz normal, restitution-based viscoelastic damping,
/// Mindlin tangential with history and Coulomb cap, optional rolling
/// resistance. Fields give units and defaults.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactSpec {
    /// Normal restitution coefficient e (−), in (0, 1]. Default 0.5.
    pub restitution: f64,
    /// Coulomb friction coefficient μ (−). Default 0.25 (the paper's sand).
    pub friction: f64,
    /// Constant-torque rolling-resistance coefficient μ_r (−); 0 = no
    /// rolling resistance. Default 0.
    pub rolling_friction: f64,
}

impl Default for ContactSpec {
    fn default() -> Self {
        Self {
            restitution: 0.5,
            friction: 0.25,
            rolling_friction: 0.0,
        }
    }
}

/// One law per family, evaluated in LAMMPS' order.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactModel {
    /// Normal elastic law.
    pub normal: Normal,
    /// Normal (and, scaled, tangential) damping.
    pub damping: Damping,
    /// Tangential law (friction).
    pub tangential: Tangential,
    /// Rolling resistance.
    pub rolling: Rolling,
}

impl ContactModel {
    /// Hertz–Mindlin with history between materials `a` and `b` (a wall's
    /// material for particle–wall contacts), configured by `spec`. The
    /// tangential damping is the normal one scaled by √(4G*/E*), as in
    /// LIGGGHTS (γ_t = 2√(5/6) β √(S_t m*)).
    pub fn hertz_mindlin(
        a: &Material,
        b: &Material,
        spec: &ContactSpec,
    ) -> Result<ContactModel, DemError> {
        a.validate()?;
        b.validate()?;
        let e_star = a.effective_modulus_pa(b);
        let g_star = a.effective_shear_modulus_pa(b);
        let damping = ViscoelasticDamping::from_restitution(spec.restitution)?;
        let tangential = Mindlin::new(g_star, spec.friction, (4.0 * g_star / e_star).sqrt())?;
        let rolling = if spec.rolling_friction == 0.0 {
            Rolling::None(NoRolling)
        } else {
            Rolling::ConstantTorque(ConstantTorque::new(spec.rolling_friction)?)
        };
        Ok(ContactModel {
            normal: Normal::Hertz(Hertz::new(e_star)?),
            damping: Damping::Viscoelastic(damping),
            tangential: Tangential::Mindlin(tangential),
            rolling,
        })
    }

    /// History values this model uses per contact (≤ [`HISTORY_LEN`]).
    pub fn history_len(&self) -> usize {
        self.tangential.history_len()
    }

    /// Forces of one contact with overlap > 0; updates `history` (the
    /// tangential spring) over the step `dt_s` (s).
    #[inline]
    pub fn evaluate(&self, g: &ContactGeometry, dt_s: f64, history: &mut History) -> ContactForce {
        let normal = self.normal.force(g);
        let gamma_n = self.damping.coefficient_n_s_per_m(g, &normal);
        let fn_total = normal.force_n - gamma_n * g.normal_velocity_m_s;
        // Fncrit as LAMMPS' Hertz: |elastic + damping|.
        let fncrit = fn_total.abs();
        let ft = self
            .tangential
            .force(g, &normal, gamma_n, fncrit, dt_s, history);
        let rolling = self.rolling.torque(g, fncrit);
        ContactForce {
            force_n: g.normal * fn_total + ft,
            torque_per_radius_n: -g.normal.cross(&ft),
            rolling_torque_n_m: rolling,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn effective_moduli_of_identical_materials() {
        let m = Material {
            youngs_modulus_pa: 1.0e7,
            poisson_ratio: 0.3,
            density_kg_m3: 2920.0,
        };
        // E* = E / (2(1 − ν²)), G* = E / (4(2 − ν)(1 + ν)).
        assert!((m.effective_modulus_pa(&m) - 1.0e7 / (2.0 * 0.91)).abs() < 1e-6);
        assert!((m.effective_shear_modulus_pa(&m) - 1.0e7 / (4.0 * 1.7 * 1.3)).abs() < 1e-6);
    }

    #[test]
    fn rejects_bad_materials() {
        let bad = Material {
            youngs_modulus_pa: -1.0,
            poisson_ratio: 0.3,
            density_kg_m3: 1.0,
        };
        assert!(ContactModel::hertz_mindlin(&bad, &bad, &ContactSpec::default()).is_err());
    }
}
