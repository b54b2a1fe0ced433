//! The particles' state, one array per quantity (structure of arrays).

use nalgebra::Vector3;
use rayon::prelude::*;

use super::DemError;

/// Spheres as parallel arrays indexed by particle. Positions, velocities,
/// spins, forces and torques are what the solver advances; radius, mass
/// and their inverses are fixed at creation.
#[derive(Clone, Debug, Default)]
pub struct Particles {
    /// Centre positions (m).
    pub position_m: Vec<Vector3<f64>>,
    /// Velocities (m/s).
    pub velocity_m_s: Vec<Vector3<f64>>,
    /// Angular velocities (rad/s).
    pub angular_velocity_rad_s: Vec<Vector3<f64>>,
    /// Total force of the last force evaluation (N).
    pub force_n: Vec<Vector3<f64>>,
    /// Total torque of the last force evaluation (N·m).
    pub torque_n_m: Vec<Vector3<f64>>,
    /// Radii (m).
    pub radius_m: Vec<f64>,
    /// Masses (kg).
    pub mass_kg: Vec<f64>,
    /// 1 / mass (1/kg).
    pub inv_mass_per_kg: Vec<f64>,
    /// 1 / moment of inertia, 1 / (2/5 m r²) (1/(kg·m²)).
    pub inv_inertia_per_kg_m2: Vec<f64>,
}

/// A particle's position (m) and radius (m): what the pair pass's overlap
/// test reads, 32 bytes aligned, two to a cache line.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(32))]
pub(crate) struct Sphere(pub(crate) [f64; 4]);

impl Sphere {
    /// The sphere at `position_m` (m) of radius `radius_m` (m).
    #[inline(always)]
    pub(crate) fn new(position_m: &Vector3<f64>, radius_m: f64) -> Sphere {
        Sphere([position_m.x, position_m.y, position_m.z, radius_m])
    }

    /// Its centre (m).
    #[inline(always)]
    pub(crate) fn position_m(&self) -> Vector3<f64> {
        Vector3::new(self.0[0], self.0[1], self.0[2])
    }

    /// Its radius (m).
    #[inline(always)]
    pub(crate) fn radius_m(&self) -> f64 {
        self.0[3]
    }

    /// Whether this sphere and `other` overlap (the one test of the pair
    /// pass and of the contact count).
    #[inline(always)]
    pub(crate) fn overlaps(&self, other: &Sphere) -> bool {
        self.separation(other).2
    }

    /// This sphere's centre minus `other`'s (m), its square (m²), and
    /// whether the two overlap ([`Sphere::overlaps`]).
    #[inline(always)]
    pub(crate) fn separation(&self, other: &Sphere) -> (Vector3<f64>, f64, bool) {
        let (a, b) = (&self.0, &other.0);
        let sum = a[3] + b[3];
        let d = Vector3::new(a[0] - b[0], a[1] - b[1], a[2] - b[2]);
        let d2 = d.norm_squared();
        (d, d2, d2 < sum * sum)
    }

    /// As [`Sphere::overlaps`], `other` at its nearest image.
    #[inline(always)]
    pub(crate) fn overlaps_in(&self, other: &Sphere, images: &crate::Images) -> bool {
        if images.any() {
            self.overlaps_nearest(other, images)
        } else {
            self.overlaps(other)
        }
    }

    /// As [`Sphere::overlaps`], `other` at its nearest image along the
    /// periodic axes of `images` (which must have some).
    #[inline(always)]
    pub(crate) fn overlaps_nearest(&self, other: &Sphere, images: &crate::Images) -> bool {
        let (a, b) = (&self.0, &other.0);
        let sum = a[3] + b[3];
        let d = [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
        let s = images.shift(d);
        let d = Vector3::new(d[0] + s[0], d[1] + s[1], d[2] + s[2]);
        d.norm_squared() < sum * sum
    }
}

/// A particle's velocity (m/s) and mass (kg), then its angular velocity
/// (rad/s) and padding: what a touching pair reads besides [`Sphere`], one
/// cache line.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(64))]
pub(crate) struct Motion(pub(crate) [[f64; 4]; 2]);

impl Motion {
    /// Velocity (m/s).
    #[inline(always)]
    pub(crate) fn velocity_m_s(&self) -> Vector3<f64> {
        Vector3::new(self.0[0][0], self.0[0][1], self.0[0][2])
    }

    /// Mass (kg).
    #[inline(always)]
    pub(crate) fn mass_kg(&self) -> f64 {
        self.0[0][3]
    }

    /// Angular velocity (rad/s).
    #[inline(always)]
    pub(crate) fn spin_rad_s(&self) -> Vector3<f64> {
        Vector3::new(self.0[1][0], self.0[1][1], self.0[1][2])
    }
}

/// The particles' state packed for the pair pass: one aligned load per row
/// instead of five arrays, and the overlap test's data dense.
#[derive(Clone, Debug, Default)]
pub(crate) struct Packed {
    /// Position and radius of each particle.
    pub(crate) sphere: Vec<Sphere>,
    /// Velocity, mass and spin of each particle.
    pub(crate) motion: Vec<Motion>,
}

impl Packed {
    /// Sizes the arrays for `n` particles.
    pub(crate) fn resize(&mut self, n: usize) {
        self.sphere.resize(n, Sphere::default());
        self.motion.resize(n, Motion::default());
    }

    /// Writes the rows' positions, velocities and spins back into `p`
    /// (which must have as many particles).
    pub(crate) fn unpack_into(&self, p: &mut Particles) {
        (
            p.position_m.par_chunks_mut(PACK_CHUNK),
            p.velocity_m_s.par_chunks_mut(PACK_CHUNK),
            p.angular_velocity_rad_s.par_chunks_mut(PACK_CHUNK),
            self.sphere.par_chunks(PACK_CHUNK),
            self.motion.par_chunks(PACK_CHUNK),
        )
            .into_par_iter()
            .for_each(|(x, v, w, s, m)| {
                for k in 0..x.len() {
                    x[k] = s[k].position_m();
                    v[k] = m[k].velocity_m_s();
                    w[k] = m[k].spin_rad_s();
                }
            });
    }
}

/// Particle i's packed rows: at `x` (m) moving at `v` (m/s), spinning at
/// `w` (rad/s), of radius `r_m` (m) and mass `m_kg` (kg).
#[inline(always)]
pub(crate) fn pack_one(
    x: &Vector3<f64>,
    v: &Vector3<f64>,
    w: &Vector3<f64>,
    r_m: f64,
    m_kg: f64,
) -> (Sphere, Motion) {
    (
        Sphere::new(x, r_m),
        Motion([[v.x, v.y, v.z, m_kg], [w.x, w.y, w.z, 0.0]]),
    )
}

/// Particles per parallel task when packing.
const PACK_CHUNK: usize = 1024;

impl Particles {
    /// The state of every particle packed into `out` (resized to fit).
    pub(crate) fn pack_into(&self, out: &mut Packed) {
        out.resize(self.len());
        (
            out.sphere.par_chunks_mut(PACK_CHUNK),
            out.motion.par_chunks_mut(PACK_CHUNK),
        )
            .into_par_iter()
            .enumerate()
            .for_each(|(c, (s, m))| {
                for (k, (s, m)) in s.iter_mut().zip(m.iter_mut()).enumerate() {
                    let i = c * PACK_CHUNK + k;
                    (*s, *m) = pack_one(
                        &self.position_m[i],
                        &self.velocity_m_s[i],
                        &self.angular_velocity_rad_s[i],
                        self.radius_m[i],
                        self.mass_kg[i],
                    );
                }
            });
    }

    /// No particles.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds a solid sphere of radius `radius_m` (m) and density
    /// `density_kg_m3` (kg/m³) at `position_m`, moving at `velocity_m_s`;
    /// returns its index.
    pub fn push(
        &mut self,
        position_m: Vector3<f64>,
        velocity_m_s: Vector3<f64>,
        radius_m: f64,
        density_kg_m3: f64,
    ) -> Result<usize, DemError> {
        if !(radius_m > 0.0 && radius_m.is_finite()) {
            return Err(DemError::param("radius_m", radius_m));
        }
        if !(density_kg_m3 > 0.0 && density_kg_m3.is_finite()) {
            return Err(DemError::param("density_kg_m3", density_kg_m3));
        }
        if !position_m
            .iter()
            .chain(velocity_m_s.iter())
            .all(|v| v.is_finite())
        {
            return Err(DemError::NonFinite {
                particle: self.len(),
            });
        }
        if self.len() >= u32::MAX as usize {
            return Err(DemError::param("particle count", self.len() as f64));
        }
        let mass = density_kg_m3 * 4.0 / 3.0 * std::f64::consts::PI * radius_m.powi(3);
        self.position_m.push(position_m);
        self.velocity_m_s.push(velocity_m_s);
        self.angular_velocity_rad_s.push(Vector3::zeros());
        self.force_n.push(Vector3::zeros());
        self.torque_n_m.push(Vector3::zeros());
        self.radius_m.push(radius_m);
        self.mass_kg.push(mass);
        self.inv_mass_per_kg.push(1.0 / mass);
        self.inv_inertia_per_kg_m2
            .push(1.0 / (0.4 * mass * radius_m * radius_m));
        Ok(self.len() - 1)
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.position_m.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.position_m.is_empty()
    }

    /// Translational plus rotational kinetic energy (J).
    pub fn kinetic_energy_j(&self) -> f64 {
        (0..self.len())
            .map(|i| {
                0.5 * self.mass_kg[i] * self.velocity_m_s[i].norm_squared()
                    + 0.5 * self.angular_velocity_rad_s[i].norm_squared()
                        / self.inv_inertia_per_kg_m2[i]
            })
            .sum()
    }

    /// Total linear momentum (kg·m/s).
    pub fn momentum_kg_m_s(&self) -> Vector3<f64> {
        (0..self.len())
            .map(|i| self.velocity_m_s[i] * self.mass_kg[i])
            .sum()
    }

    /// Largest radius (m); 0 when empty.
    pub fn max_radius_m(&self) -> f64 {
        self.radius_m.iter().copied().fold(0.0, f64::max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sphere_mass_and_inertia() {
        let mut p = Particles::new();
        p.push(Vector3::zeros(), Vector3::zeros(), 1e-3, 2920.0)
            .unwrap();
        let m = 2920.0 * 4.0 / 3.0 * std::f64::consts::PI * 1e-9;
        assert!((p.mass_kg[0] - m).abs() < 1e-18);
        assert!((1.0 / p.inv_inertia_per_kg_m2[0] - 0.4 * m * 1e-6).abs() < 1e-24);
        assert!(p
            .push(Vector3::zeros(), Vector3::zeros(), -1.0, 1.0)
            .is_err());
    }
}
