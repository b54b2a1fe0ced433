//! Fixed (or translating) rigid walls: planes and infinite cylinders,
//! touched from either side.

use nalgebra::Vector3;

use super::contact::{ContactModel, ContactSpec, Material};
use super::DemError;

/// Which side of a cylinder the particles are on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CylinderSide {
    /// Particles inside (a pipe or container).
    Inside,
    /// Particles outside (a rod or a probe).
    Outside,
}

/// The geometry of a wall.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum WallShape {
    /// Infinite plane; particles live on the side `normal` points to.
    Plane {
        /// A point of the plane (m).
        point_m: Vector3<f64>,
        /// Unit normal towards the particles.
        normal: Vector3<f64>,
    },
    /// Infinite circular cylinder.
    Cylinder {
        /// A point of the axis (m).
        axis_point_m: Vector3<f64>,
        /// Unit axis direction.
        axis: Vector3<f64>,
        /// Radius (m).
        radius_m: f64,
        /// Which side the particles are on.
        side: CylinderSide,
    },
}

impl WallShape {
    /// The farthest any point of the surface moved from `earlier` to this
    /// shape (m), or `None` when the two are not the same surface moved
    /// along its normal (another normal, axis or side): how far a particle
    /// could have come closer to the wall through the wall's own motion.
    pub fn shift_from(&self, earlier: &WallShape) -> Option<f64> {
        match (*self, *earlier) {
            (
                WallShape::Plane { point_m, normal },
                WallShape::Plane {
                    point_m: p0,
                    normal: n0,
                },
            ) if normal == n0 => Some((point_m - p0).dot(&normal).abs()),
            (
                WallShape::Cylinder {
                    axis_point_m,
                    axis,
                    radius_m,
                    side,
                },
                WallShape::Cylinder {
                    axis_point_m: a0,
                    axis: ax0,
                    radius_m: r0,
                    side: s0,
                },
            ) if axis == ax0 && side == s0 => {
                let moved = axis_point_m - a0;
                let across = (moved - axis * moved.dot(&axis)).norm();
                Some(across + (radius_m - r0).abs())
            }
            _ => None,
        }
    }
}

/// A rigid wall with its contact law.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Wall {
    /// Geometry.
    pub shape: WallShape,
    /// Translational velocity of the wall surface (m/s); its position is not
    /// advanced by the solver (the caller moves `shape`). Default zero.
    pub velocity_m_s: Vector3<f64>,
    /// Speed of the surface along its normal, towards the particles (m/s):
    /// a cylinder's dR/dt with the particles outside, −dR/dt with them
    /// inside. It enters the contact's relative velocity (damping,
    /// tangential spring), as the surface's own motion does; the caller
    /// changes the radius. Default zero.
    pub normal_velocity_m_s: f64,
    /// Particle–wall contact law (built from the particle and wall materials).
    pub model: ContactModel,
}

impl Wall {
    /// A plane wall through `point_m` with unit-normalised `normal` towards
    /// the particles, Hertz–Mindlin between `particle` and `wall` materials.
    pub fn plane(
        point_m: Vector3<f64>,
        normal: Vector3<f64>,
        particle: &Material,
        wall: &Material,
        spec: &ContactSpec,
    ) -> Result<Wall, DemError> {
        let len = normal.norm();
        if !(len > 0.0 && len.is_finite()) {
            return Err(DemError::param("wall normal length", len));
        }
        Ok(Wall {
            shape: WallShape::Plane {
                point_m,
                normal: normal / len,
            },
            velocity_m_s: Vector3::zeros(),
            normal_velocity_m_s: 0.0,
            model: ContactModel::hertz_mindlin(particle, wall, spec)?,
        })
    }

    /// A cylinder wall of radius `radius_m` (m) around the axis through
    /// `axis_point_m` along `axis`, particles on `side`.
    pub fn cylinder(
        axis_point_m: Vector3<f64>,
        axis: Vector3<f64>,
        radius_m: f64,
        side: CylinderSide,
        particle: &Material,
        wall: &Material,
        spec: &ContactSpec,
    ) -> Result<Wall, DemError> {
        let len = axis.norm();
        if !(len > 0.0 && len.is_finite()) {
            return Err(DemError::param("cylinder axis length", len));
        }
        if !(radius_m > 0.0 && radius_m.is_finite()) {
            return Err(DemError::param("cylinder radius_m", radius_m));
        }
        Ok(Wall {
            shape: WallShape::Cylinder {
                axis_point_m,
                axis: axis / len,
                radius_m,
                side,
            },
            velocity_m_s: Vector3::zeros(),
            normal_velocity_m_s: 0.0,
            model: ContactModel::hertz_mindlin(particle, wall, spec)?,
        })
    }

    /// Unit normal from the wall to the sphere of radius `r` (m) at `x`
    /// and the overlap (m), if it touches.
    #[inline]
    pub fn touch(&self, x: &Vector3<f64>, r: f64) -> Option<(Vector3<f64>, f64)> {
        self.normal_and_overlap(x, r)
            .filter(|&(_, overlap)| overlap > 0.0)
    }

    /// Gap between the wall and the surface of the sphere of radius `r`
    /// (m) at `x` (m); negative while they overlap, +∞ on a cylinder's
    /// axis (no contact is representable there).
    pub fn clearance_m(&self, x: &Vector3<f64>, r: f64) -> f64 {
        self.normal_and_overlap(x, r)
            .map_or(f64::INFINITY, |(_, overlap)| -overlap)
    }

    /// Normal from the wall to the sphere and the signed overlap (m);
    /// `None` on a cylinder's axis, where the direction is undefined.
    #[inline]
    fn normal_and_overlap(&self, x: &Vector3<f64>, r: f64) -> Option<(Vector3<f64>, f64)> {
        match self.shape {
            WallShape::Plane { point_m, normal } => Some((normal, r - (x - point_m).dot(&normal))),
            WallShape::Cylinder {
                axis_point_m,
                axis,
                radius_m,
                side,
            } => {
                let rel = x - axis_point_m;
                let radial = rel - axis * rel.dot(&axis);
                let rho = radial.norm();
                if rho == 0.0 {
                    // On the axis the direction is undefined; an inside
                    // particle there is far from the wall, an outside one
                    // would be buried in the rod (not representable).
                    return None;
                }
                let out = radial / rho;
                Some(match side {
                    CylinderSide::Inside => (-out, r - (radius_m - rho)),
                    CylinderSide::Outside => (out, r - (rho - radius_m)),
                })
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mat() -> Material {
        Material {
            youngs_modulus_pa: 1e7,
            poisson_ratio: 0.3,
            density_kg_m3: 2920.0,
        }
    }

    #[test]
    fn cylinder_sides() {
        let spec = ContactSpec::default();
        let inside = Wall::cylinder(
            Vector3::zeros(),
            Vector3::z() * 2.0,
            0.01,
            CylinderSide::Inside,
            &mat(),
            &mat(),
            &spec,
        )
        .unwrap();
        let (n, d) = inside
            .touch(&Vector3::new(0.0095, 0.0, 5.0), 0.001)
            .unwrap();
        assert!((d - 0.0005).abs() < 1e-12 && (n + Vector3::x()).norm() < 1e-12);
        assert!(inside
            .touch(&Vector3::new(0.008, 0.0, 0.0), 0.001)
            .is_none());
        let outside = Wall {
            shape: WallShape::Cylinder {
                axis_point_m: Vector3::zeros(),
                axis: Vector3::z(),
                radius_m: 0.01,
                side: CylinderSide::Outside,
            },
            ..inside
        };
        let (n, d) = outside
            .touch(&Vector3::new(0.0, 0.0105, 0.0), 0.001)
            .unwrap();
        assert!((d - 0.0005).abs() < 1e-12 && (n - Vector3::y()).norm() < 1e-12);
    }

    #[test]
    fn a_shift_is_the_surfaces_largest_move_along_its_normal() {
        let plane = |p: [f64; 3], n: Vector3<f64>| WallShape::Plane {
            point_m: Vector3::from(p),
            normal: n,
        };
        let z = Vector3::z();
        // Along the normal counts, within the plane does not.
        let s = plane([0.3, -0.2, 0.004], z).shift_from(&plane([0.0, 0.0, 0.001], z));
        assert!((s.unwrap() - 0.003).abs() < 1e-15);
        // Another normal (or a plane become a cylinder) is another surface.
        assert_eq!(
            plane([0.0; 3], Vector3::x()).shift_from(&plane([0.0; 3], z)),
            None
        );
        let rod = |c: [f64; 3], r: f64| WallShape::Cylinder {
            axis_point_m: Vector3::from(c),
            axis: Vector3::y(),
            radius_m: r,
            side: CylinderSide::Outside,
        };
        assert_eq!(rod([0.0; 3], 0.01).shift_from(&plane([0.0; 3], z)), None);
        // A rod grown by 0.5 mm whose axis moved 0.3 mm across and 5 mm along.
        let s = rod([0.0003, 0.005, 0.0], 0.0105).shift_from(&rod([0.0; 3], 0.01));
        assert!((s.unwrap() - 0.0008).abs() < 1e-15);
    }
}
