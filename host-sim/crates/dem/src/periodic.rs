//! Periodic boundaries, as LAMMPS' `boundary p`: along a periodic axis a
//! particle near one face touches the images of those near the other.
//!
//! No ghost copies: every pair is listed once, between the two particles
//! themselves, and its separation is the minimum image. So a pair's contact
//! history is carried across the boundary like any other (it is keyed by
//! the two particles), and the summation order that makes the forces the
//! same bits at any thread count is unchanged. Positions are wrapped back
//! into the box at each neighbour-list build; between builds a particle
//! may stand up to half the skin outside it.

use nalgebra::Vector3;

use super::DemError;

/// One periodic axis: positions along it repeat every `length_m` from
/// `lo_m`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PeriodicAxis {
    /// Lower face of the box along the axis (m).
    pub lo_m: f64,
    /// Period (m): the box's length along the axis. It must hold at least
    /// three neighbour cells (3 × (2 r_max + skin)), so that a pair meets
    /// through one image only.
    pub length_m: f64,
}

impl PeriodicAxis {
    /// The axis `lo_m .. lo_m + length_m` (m).
    pub fn new(lo_m: f64, length_m: f64) -> Result<PeriodicAxis, DemError> {
        if !(length_m > 0.0 && length_m.is_finite()) {
            return Err(DemError::param("periodic length_m", length_m));
        }
        if !lo_m.is_finite() {
            return Err(DemError::param("periodic lo_m", lo_m));
        }
        Ok(PeriodicAxis { lo_m, length_m })
    }

    /// `x` (m) brought into `lo_m .. lo_m + length_m`.
    #[inline]
    pub fn wrap(&self, x: f64) -> f64 {
        let w = self.lo_m + (x - self.lo_m).rem_euclid(self.length_m);
        // rem_euclid can round up to the period itself.
        if w >= self.lo_m + self.length_m {
            self.lo_m
        } else {
            w
        }
    }
}

/// The box's periods for the minimum-image separation: zero along axes
/// that are not periodic, so one branch-free formula serves every axis.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Images {
    length_m: [f64; 3],
    inverse_per_m: [f64; 3],
    any: bool,
}

impl Images {
    /// The images of `axes` (x, y, z; `None`: not periodic).
    pub fn new(axes: &[Option<PeriodicAxis>; 3]) -> Images {
        let length_m = axes.map(|a| a.map_or(0.0, |a| a.length_m));
        Images {
            length_m,
            inverse_per_m: length_m.map(|l| if l > 0.0 { 1.0 / l } else { 0.0 }),
            any: axes.iter().any(Option::is_some),
        }
    }

    /// Whether any axis is periodic.
    #[inline(always)]
    pub fn any(&self) -> bool {
        self.any
    }

    /// The shift (m) to add to a particle at separation `d` (m) from
    /// another so that it stands at its nearest image: −L·round(d/L) along
    /// each periodic axis, exactly 0 along the others and for pairs that
    /// do not straddle a face.
    #[inline(always)]
    pub fn shift(&self, d: [f64; 3]) -> [f64; 3] {
        std::array::from_fn(|a| -self.length_m[a] * (d[a] * self.inverse_per_m[a]).round())
    }

    /// The minimum-image separation `b − a` (m).
    #[inline(always)]
    pub fn separation(&self, a: &Vector3<f64>, b: &Vector3<f64>) -> Vector3<f64> {
        let d = b - a;
        if !self.any {
            return d;
        }
        let s = self.shift([d.x, d.y, d.z]);
        Vector3::new(d.x + s[0], d.y + s[1], d.z + s[2])
    }
}

/// Checks that every periodic axis of `axes` holds three neighbour cells
/// of width `cell_m` (m).
pub(crate) fn check_fits(axes: &[Option<PeriodicAxis>; 3], cell_m: f64) -> Result<(), DemError> {
    for a in axes.iter().flatten() {
        if a.length_m < 3.0 * cell_m {
            return Err(DemError::param(
                "periodic length_m (must be ≥ 3 × (2 r_max + skin))",
                a.length_m,
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_nearest_image_is_taken_along_periodic_axes_only() {
        let axes = [None, Some(PeriodicAxis::new(0.0, 0.03).unwrap()), None];
        let im = Images::new(&axes);
        let a = Vector3::new(0.01, 0.0005, 0.02);
        let b = Vector3::new(0.012, 0.0295, 0.021);
        let d = im.separation(&a, &b);
        assert!(
            (d - Vector3::new(0.002, -0.001, 0.001)).norm() < 1e-15,
            "{d}"
        );
        // Not across the face: exactly the plain difference.
        let c = Vector3::new(0.011, 0.0009, 0.02);
        assert_eq!(im.separation(&a, &c), c - a);
        assert_eq!(Images::default().separation(&a, &b), b - a);
        let y = axes[1].unwrap();
        assert!((y.wrap(0.031) - 0.001).abs() < 1e-15);
        assert!((y.wrap(-0.001) - 0.029).abs() < 1e-15);
        assert_eq!(y.wrap(0.0), 0.0);
        assert!((0.0..0.03).contains(&y.wrap(-1e-18)));
    }
}
