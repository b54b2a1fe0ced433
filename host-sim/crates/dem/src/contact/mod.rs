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
//! implementing the family trait; the sand's usual combination is also a
//! type of its own ([`HertzMindlin`]), for which the pair pass is compiled
//! without any `match`. Both go through one composition of the laws.
//!
//! Every law is written once, generic over its number type ([`Real`]):
//! `f64` for one contact, or [`Lanes`] for four contacts at once (SIMD over
//! contacts, as rapier's solver), which is how the particle pairs are
//! evaluated. Branches are lane selects, and both instances run the same
//! IEEE operations in the same order, so a pair gets bit for bit the same
//! force in either ([`lanes`]).

pub mod damping;
pub mod lanes;
pub mod normal;
pub mod rolling;
pub mod tangential;

use nalgebra::Vector3;

pub use damping::{Damping, DampingLaw, NoDamping, ViscoelasticDamping};
pub use lanes::{Lanes, Real, LANE_COUNT};
pub use normal::{Hertz, Normal, NormalLaw, NormalOutput};
pub use rolling::{ConstantTorque, NoRolling, Rolling, RollingLaw};
pub use tangential::{Mindlin, NoTangential, Tangential, TangentialLaw};

use super::DemError;

/// Number of history values stored per contact (the largest any law needs:
/// the Mindlin tangential displacement, 3 components in m).
pub const HISTORY_LEN: usize = 3;

/// Per-contact history (see [`HISTORY_LEN`]); zero when a contact opens.
pub type History = [f64; HISTORY_LEN];

/// The geometry and kinematics of one contact (of [`LANE_COUNT`] contacts
/// for `T = Lanes`), computed once by the caller and read by every law. "i"
/// is the particle the forces are for; "j" is the other particle or the wall.
#[derive(Clone, Copy, Debug)]
pub struct ContactGeometry<T = f64> {
    /// Unit normal pointing from j (or the wall) to i.
    pub normal: Vector3<T>,
    /// Overlap δ = R_i + R_j − distance (m); > 0 in contact.
    pub overlap_m: T,
    /// Effective radius R* = R_i R_j / (R_i + R_j) (m); R_i for a wall.
    pub radius_eff_m: T,
    /// Effective mass m* = m_i m_j / (m_i + m_j) (kg); m_i for a wall.
    pub mass_eff_kg: T,
    /// Normal relative velocity (v_i − v_j)·n (m/s); negative while approaching.
    pub normal_velocity_m_s: T,
    /// Tangential relative velocity of the two contact points (m/s), ⟂ n.
    pub tangential_velocity_m_s: Vector3<T>,
    /// Relative angular velocity ω_i − ω_j (rad/s).
    pub relative_spin_rad_s: Vector3<T>,
}

impl<T: Real> Default for ContactGeometry<T> {
    /// No contact: everything zero (a placeholder, not a valid normal).
    fn default() -> Self {
        let zero = T::splat(0.0);
        ContactGeometry {
            normal: Vector3::repeat(zero),
            overlap_m: zero,
            radius_eff_m: zero,
            mass_eff_kg: zero,
            normal_velocity_m_s: zero,
            tangential_velocity_m_s: Vector3::repeat(zero),
            relative_spin_rad_s: Vector3::repeat(zero),
        }
    }
}

/// What one contact exerts, from i's point of view.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactForce<T = f64> {
    /// Force on i (N); j receives the opposite.
    pub force_n: Vector3<T>,
    /// −n × F_t (N): the torque on i is R_i times this, and on j R_j times
    /// this (same sign: both contact points are dragged the same way).
    pub torque_per_radius_n: Vector3<T>,
    /// Rolling-resistance torque on i (N·m); j receives the opposite.
    pub rolling_torque_n_m: Vector3<T>,
}

impl<T: Real> Default for ContactForce<T> {
    fn default() -> Self {
        let zero = Vector3::repeat(T::splat(0.0));
        ContactForce {
            force_n: zero,
            torque_per_radius_n: zero,
            rolling_torque_n_m: zero,
        }
    }
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

    /// Forces of one contact with overlap > 0 (or of four, `T = Lanes`);
    /// updates `history` (the tangential spring) over the step `dt_s` (s).
    #[inline(always)]
    pub fn evaluate<T: Real>(
        &self,
        g: &ContactGeometry<T>,
        dt_s: f64,
        history: &mut [T; HISTORY_LEN],
    ) -> ContactForce<T> {
        let laws = (&self.normal, &self.damping, &self.tangential, &self.rolling);
        compose(laws, g, dt_s, history)
    }
}

/// The one composition of the four families, in LAMMPS' order, for any
/// laws: those a [`ContactModel`] chooses at run time, or laws fixed at
/// compile time ([`HertzMindlin`]).
#[inline(always)]
fn compose<T: Real>(
    (normal, damping, tangential, rolling): (
        &impl NormalLaw,
        &impl DampingLaw,
        &impl TangentialLaw,
        &impl RollingLaw,
    ),
    g: &ContactGeometry<T>,
    dt_s: f64,
    history: &mut [T; HISTORY_LEN],
) -> ContactForce<T> {
    let elastic = normal.force(g);
    let gamma_n = damping.coefficient_n_s_per_m(g, &elastic);
    let fn_total = elastic.force_n - gamma_n * g.normal_velocity_m_s;
    // Fncrit as LAMMPS' Hertz: |elastic + damping|.
    let fncrit = fn_total.simd_abs();
    let ft = tangential.force(g, &elastic, gamma_n, fncrit, dt_s, history);
    ContactForce {
        force_n: g.normal * fn_total + ft,
        torque_per_radius_n: -g.normal.cross(&ft),
        rolling_torque_n_m: rolling.torque(g, fncrit),
    }
}

/// A contact law as the pair pass calls it. The pass is compiled for each
/// implementation: for any [`ContactModel`], and for [`HertzMindlin`],
/// whose laws are known at compile time, so that the families' `match`es
/// and the rolling torque leave its loop.
pub trait PairLaw: Copy + Sync {
    /// Whether the law can exert a rolling torque (else its
    /// `rolling_torque_n_m` is always zero and need not be added).
    const ROLLS: bool;

    /// As [`ContactModel::evaluate`].
    fn evaluate<T: Real>(
        &self,
        g: &ContactGeometry<T>,
        dt_s: f64,
        history: &mut [T; HISTORY_LEN],
    ) -> ContactForce<T>;
}

impl PairLaw for ContactModel {
    const ROLLS: bool = true;

    #[inline(always)]
    fn evaluate<T: Real>(
        &self,
        g: &ContactGeometry<T>,
        dt_s: f64,
        history: &mut [T; HISTORY_LEN],
    ) -> ContactForce<T> {
        ContactModel::evaluate(self, g, dt_s, history)
    }
}

/// Hertz normal, viscoelastic damping, Mindlin tangential, no rolling
/// resistance: [`ContactModel::hertz_mindlin`] with `rolling_friction` 0,
/// the sand's usual law, its laws fixed at compile time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HertzMindlin {
    normal: Hertz,
    damping: ViscoelasticDamping,
    tangential: Mindlin,
}

impl HertzMindlin {
    /// `model`'s laws, if they are these.
    pub fn of(model: &ContactModel) -> Option<Self> {
        match *model {
            ContactModel {
                normal: Normal::Hertz(normal),
                damping: Damping::Viscoelastic(damping),
                tangential: Tangential::Mindlin(tangential),
                rolling: Rolling::None(_),
            } => Some(HertzMindlin {
                normal,
                damping,
                tangential,
            }),
            _ => None,
        }
    }
}

impl PairLaw for HertzMindlin {
    const ROLLS: bool = false;

    #[inline(always)]
    fn evaluate<T: Real>(
        &self,
        g: &ContactGeometry<T>,
        dt_s: f64,
        history: &mut [T; HISTORY_LEN],
    ) -> ContactForce<T> {
        let laws = (&self.normal, &self.damping, &self.tangential, &NoRolling);
        compose(laws, g, dt_s, history)
    }
}

impl<T: Real> ContactGeometry<T> {
    /// Two spheres i and j, positions `x` (m), velocities `v` (m/s), spins
    /// `w` (rad/s), radii `r` (m) and masses `m` (kg), i's first; the
    /// caller checks that they overlap.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub fn spheres(
        x: [&Vector3<T>; 2],
        v: [&Vector3<T>; 2],
        w: [&Vector3<T>; 2],
        r: [T; 2],
        m: [T; 2],
    ) -> Self {
        let dx = x[0] - x[1];
        let d2 = dx.dot(&dx);
        Self::spheres_apart(dx, d2, v, w, r, m)
    }

    /// As [`ContactGeometry::spheres`], given i's position minus j's `dx`
    /// (m) and its square `d2` (m²) in place of the positions.
    #[inline(always)]
    pub fn spheres_apart(
        dx: Vector3<T>,
        d2: T,
        v: [&Vector3<T>; 2],
        w: [&Vector3<T>; 2],
        r: [T; 2],
        m: [T; 2],
    ) -> Self {
        let sum = r[0] + r[1];
        let d = d2.simd_sqrt();
        let n = dx / d;
        let vr = v[0] - v[1];
        let vn = vr.dot(&n);
        // Contact-point velocities: v_i − R_i ω_i × n minus v_j + R_j ω_j × n.
        let spin = w[0] * r[0] + w[1] * r[1];
        let vt = vr - n * vn - spin.cross(&n);
        ContactGeometry {
            normal: n,
            overlap_m: sum - d,
            radius_eff_m: r[0] * r[1] / sum,
            mass_eff_kg: m[0] * m[1] / (m[0] + m[1]),
            normal_velocity_m_s: vn,
            tangential_velocity_m_s: vt,
            relative_spin_rad_s: w[0] - w[1],
        }
    }
}

impl ContactGeometry {
    /// A sphere of radius `radius_m` (m), spin `spin_rad_s` (rad/s) and
    /// (effective) mass `mass_eff_kg` (kg) pressed `overlap_m` (m) into a
    /// surface (a wall, the skin, the head's face) whose outward `normal`
    /// points at the sphere; `relative_velocity_m_s` (m/s) is the sphere's
    /// velocity minus the surface's. The surface does not spin.
    #[inline(always)]
    pub fn sphere_on_surface(
        normal: Vector3<f64>,
        overlap_m: f64,
        radius_m: f64,
        mass_eff_kg: f64,
        relative_velocity_m_s: Vector3<f64>,
        spin_rad_s: Vector3<f64>,
    ) -> Self {
        let vr = relative_velocity_m_s;
        let vn = vr.dot(&normal);
        // Contact-point velocity: v − R ω × n (the surface point moves
        // with the surface).
        ContactGeometry {
            normal,
            overlap_m,
            radius_eff_m: radius_m,
            mass_eff_kg,
            normal_velocity_m_s: vn,
            tangential_velocity_m_s: vr - normal * vn - (spin_rad_s * radius_m).cross(&normal),
            relative_spin_rad_s: spin_rad_s,
        }
    }
}

impl ContactGeometry<Lanes> {
    /// [`LANE_COUNT`] contacts' geometries as one, contact l in lane l.
    #[inline(always)]
    pub fn gather(g: &[ContactGeometry; LANE_COUNT]) -> Self {
        let lanes = |f: fn(&ContactGeometry) -> f64| Lanes(std::array::from_fn(|l| f(&g[l])));
        let vec3 = |f: fn(&ContactGeometry) -> Vector3<f64>| {
            Vector3::new(
                Lanes(std::array::from_fn(|l| f(&g[l]).x)),
                Lanes(std::array::from_fn(|l| f(&g[l]).y)),
                Lanes(std::array::from_fn(|l| f(&g[l]).z)),
            )
        };
        ContactGeometry {
            normal: vec3(|g| g.normal),
            overlap_m: lanes(|g| g.overlap_m),
            radius_eff_m: lanes(|g| g.radius_eff_m),
            mass_eff_kg: lanes(|g| g.mass_eff_kg),
            normal_velocity_m_s: lanes(|g| g.normal_velocity_m_s),
            tangential_velocity_m_s: vec3(|g| g.tangential_velocity_m_s),
            relative_spin_rad_s: vec3(|g| g.relative_spin_rad_s),
        }
    }
}

impl ContactForce<Lanes> {
    /// What the contact in lane `l` exerts.
    #[inline(always)]
    pub fn lane(&self, l: usize) -> ContactForce {
        let of = |v: &Vector3<Lanes>| Vector3::new(v.x.0[l], v.y.0[l], v.z.0[l]);
        ContactForce {
            force_n: of(&self.force_n),
            torque_per_radius_n: of(&self.torque_per_radius_n),
            rolling_torque_n_m: of(&self.rolling_torque_n_m),
        }
    }
}

/// `a` where `cond` holds and `b` elsewhere, per lane.
#[inline(always)]
pub(crate) fn select3<T: Real>(cond: T::Mask, a: Vector3<T>, b: Vector3<T>) -> Vector3<T> {
    Vector3::new(
        a.x.select(cond, b.x),
        a.y.select(cond, b.y),
        a.z.select(cond, b.z),
    )
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

    /// Four contacts through `Lanes` give the bits each gives alone
    /// through `f64`: sticking and sliding, rolling or not, opening or
    /// carrying a history.
    #[test]
    fn lanes_give_the_bits_of_one_contact_at_a_time() {
        let sand = Material {
            youngs_modulus_pa: 1.0e7,
            poisson_ratio: 0.3,
            density_kg_m3: 2920.0,
        };
        let spec = ContactSpec {
            rolling_friction: 0.2,
            ..ContactSpec::default()
        };
        let model = ContactModel::hertz_mindlin(&sand, &sand, &spec).unwrap();
        let mut seed = 7u64;
        let mut u = move || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        fn v3(u: &mut impl FnMut() -> f64, s: f64) -> Vector3<f64> {
            Vector3::new(u() * s, u() * s, u() * s)
        }
        let (mut slid, mut stuck) = (0, 0);
        for _ in 0..200 {
            let one: [(ContactGeometry, History); LANE_COUNT] = std::array::from_fn(|_| {
                let normal = v3(&mut u, 1.0).normalize();
                let g = ContactGeometry {
                    normal,
                    overlap_m: (u() + 0.5) * 2e-5,
                    radius_eff_m: 5e-4 + u() * 1e-4,
                    mass_eff_kg: 6e-6 + u() * 1e-6,
                    normal_velocity_m_s: u() * 0.02,
                    tangential_velocity_m_s: {
                        let v = v3(&mut u, 0.01);
                        v - normal * v.dot(&normal)
                    },
                    relative_spin_rad_s: {
                        let spin = if u() > 0.0 { 50.0 } else { 0.0 };
                        v3(&mut u, spin)
                    },
                };
                (g, [u() * 2e-6, u() * 2e-6, u() * 2e-6])
            });
            let g4 = ContactGeometry::<Lanes>::gather(&one.map(|(g, _)| g));
            let mut h4: [Lanes; HISTORY_LEN] =
                std::array::from_fn(|c| Lanes(one.map(|(_, h)| h[c])));
            let f4 = model.evaluate(&g4, 1.5e-5, &mut h4);
            for (l, (g, h)) in one.iter().enumerate() {
                let mut h = *h;
                let f = model.evaluate(g, 1.5e-5, &mut h);
                let bits = |v: Vector3<f64>| v.map(f64::to_bits);
                let fl = f4.lane(l);
                assert_eq!(bits(f.force_n), bits(fl.force_n));
                assert_eq!(bits(f.torque_per_radius_n), bits(fl.torque_per_radius_n));
                assert_eq!(bits(f.rolling_torque_n_m), bits(fl.rolling_torque_n_m));
                assert_eq!(h.map(f64::to_bits), h4.map(|c| c.0[l].to_bits()));
                let ft = f.force_n - g.normal * f.force_n.dot(&g.normal);
                let fncrit = (f.force_n.dot(&g.normal)).abs();
                if (ft.norm() - 0.25 * fncrit).abs() < 1e-12 * fncrit.max(1e-30) {
                    slid += 1;
                } else {
                    stuck += 1;
                }
            }
        }
        // Both branches of the Coulomb cap were exercised.
        assert!(slid > 50 && stuck > 50, "slid {slid}, stuck {stuck}");
    }

    #[test]
    fn the_fixed_law_stands_for_the_usual_model_only() {
        let sand = Material {
            youngs_modulus_pa: 1.0e7,
            poisson_ratio: 0.3,
            density_kg_m3: 2920.0,
        };
        let usual = ContactModel::hertz_mindlin(&sand, &sand, &ContactSpec::default()).unwrap();
        assert!(HertzMindlin::of(&usual).is_some());
        let spec = ContactSpec {
            rolling_friction: 0.2,
            ..ContactSpec::default()
        };
        let rolling = ContactModel::hertz_mindlin(&sand, &sand, &spec).unwrap();
        assert!(HertzMindlin::of(&rolling).is_none());
        let undamped = ContactModel {
            damping: Damping::None(NoDamping),
            ..usual
        };
        assert!(HertzMindlin::of(&undamped).is_none());
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
