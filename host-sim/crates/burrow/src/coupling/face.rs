//! The head's front face: a rigid disc closing the zone's front end, whose
//! sand pressure is read from its particle contacts.

use nalgebra::Vector3;

use dem::contact::{ContactGeometry, ContactModel, History};
use dem::{Particles, Sink};

/// A rigid disc touched by particles on the side its normal points to.
#[derive(Clone, Debug)]
pub struct FrontFace {
    /// Centre of the disc (m).
    pub centre_m: Vector3<f64>,
    /// Unit normal, pointing into the sand.
    pub normal: Vector3<f64>,
    /// Disc radius (m).
    pub radius_m: f64,
    /// Velocity of the face (m/s); the caller moves `centre_m`.
    pub velocity_m_s: Vector3<f64>,
    /// Particle–face contact law.
    pub model: ContactModel,
    /// Time step the tangential histories advance by (s): the DEM's.
    pub dt_s: f64,
    history: Vec<History>,
    normal_force_n: f64,
    contacts: usize,
}

impl FrontFace {
    /// A disc at `centre_m` with normal `normal` (normalised here; `None`
    /// when zero) and radius `radius_m` (m), contact law `model`, stepped
    /// with `dt_s` (s).
    pub fn new(
        centre_m: Vector3<f64>,
        normal: Vector3<f64>,
        radius_m: f64,
        model: ContactModel,
        dt_s: f64,
    ) -> Option<FrontFace> {
        let len = normal.norm();
        (len > 0.0 && len.is_finite() && radius_m > 0.0 && dt_s > 0.0).then(|| FrontFace {
            centre_m,
            normal: normal / len,
            radius_m,
            velocity_m_s: Vector3::zeros(),
            model,
            dt_s,
            history: Vec::new(),
            normal_force_n: 0.0,
            contacts: 0,
        })
    }

    /// Disc area (m²).
    pub fn area_m2(&self) -> f64 {
        std::f64::consts::PI * self.radius_m * self.radius_m
    }

    /// Normal force of the sand on the face at the last evaluation (N),
    /// positive pushing against the normal.
    pub fn normal_force_n(&self) -> f64 {
        self.normal_force_n
    }

    /// Mean sand pressure on the face (Pa): normal force / area.
    pub fn pressure_pa(&self) -> f64 {
        self.normal_force_n / self.area_m2()
    }

    /// Particles touching the face at the last evaluation.
    pub fn contacts(&self) -> usize {
        self.contacts
    }

    /// Adds the face's contact forces to `particles` and records the
    /// normal force.
    pub fn apply(&mut self, particles: &mut Particles) {
        let n = particles.len();
        if self.history.len() != n {
            self.history = vec![History::default(); n];
        }
        self.normal_force_n = 0.0;
        self.contacts = 0;
        for i in 0..n {
            let r = particles.radius_m[i];
            let rel = particles.position_m[i] - self.centre_m;
            let d = rel.dot(&self.normal);
            let radial = (rel - self.normal * d).norm();
            let overlap = r - d;
            // In front of the disc (centre not behind it) and over it.
            if !(overlap > 0.0 && d > 0.0 && radial <= self.radius_m) {
                self.history[i] = History::default();
                continue;
            }
            let g = ContactGeometry::sphere_on_surface(
                self.normal,
                overlap,
                r,
                particles.mass_kg[i],
                particles.velocity_m_s[i] - self.velocity_m_s,
                particles.angular_velocity_rad_s[i],
            );
            let cf = self.model.evaluate(&g, self.dt_s, &mut self.history[i]);
            // No adhesion: a grain leaving the face faster than its
            // overlap relaxes gets a damping force that pulls; the face
            // lets it go instead (LAMMPS' `limit_damping`), so p_h ≥ 0.
            let normal_n = cf.force_n.dot(&self.normal);
            if normal_n <= 0.0 {
                self.history[i] = History::default();
                continue;
            }
            particles.force_n[i] += cf.force_n;
            particles.torque_n_m[i] += cf.torque_per_radius_n * r + cf.rolling_torque_n_m;
            self.normal_force_n += normal_n;
            self.contacts += 1;
        }
    }
}

impl Sink for FrontFace {
    fn add_external_forces(&mut self, _time_s: f64, particles: &mut Particles) {
        self.apply(particles);
    }
}
