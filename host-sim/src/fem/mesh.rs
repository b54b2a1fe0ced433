//! The structured triangle mesh of the skin tube's mid-surface.

use nalgebra::Vector3;

use super::FemError;

/// A tube mid-surface along +z from z = 0 to z = `length_m`, centred on
/// the z axis.
#[derive(Clone, Debug, PartialEq)]
pub struct TubeMesh {
    /// Rest node positions (m); node (ring j, around i) is j·around + i.
    pub rest_m: Vec<Vector3<f64>>,
    /// Triangles (node indices, outward normal by the right-hand rule).
    pub triangles: Vec<[usize; 3]>,
    /// Nodes around the circumference.
    pub around: usize,
    /// Element rows along the axis (rings − 1).
    pub along: usize,
    /// Rest mid-surface radius (m).
    pub radius_m: f64,
    /// Rest length (m).
    pub length_m: f64,
}

impl TubeMesh {
    /// A tube of mid-surface radius `radius_m` and length `length_m` (m),
    /// `around` (≥ 3) nodes round each ring and `along` (≥ 1) rows of
    /// quads, each split into two triangles with alternating diagonals (no
    /// preferred direction).
    pub fn tube(
        radius_m: f64,
        length_m: f64,
        around: usize,
        along: usize,
    ) -> Result<TubeMesh, FemError> {
        if !(radius_m > 0.0 && radius_m.is_finite()) {
            return Err(FemError::param("radius_m", radius_m));
        }
        if !(length_m > 0.0 && length_m.is_finite()) {
            return Err(FemError::param("length_m", length_m));
        }
        if around < 3 {
            return Err(FemError::param("around", around as f64));
        }
        if along < 1 {
            return Err(FemError::param("along", along as f64));
        }
        let mut rest_m = Vec::with_capacity(around * (along + 1));
        for j in 0..=along {
            let z = length_m * j as f64 / along as f64;
            for i in 0..around {
                let t = std::f64::consts::TAU * i as f64 / around as f64;
                rest_m.push(Vector3::new(radius_m * t.cos(), radius_m * t.sin(), z));
            }
        }
        let id = |i: usize, j: usize| j * around + i % around;
        let mut triangles = Vec::with_capacity(2 * around * along);
        for j in 0..along {
            for i in 0..around {
                let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
                if (i + j) % 2 == 0 {
                    triangles.push([a, b, c]);
                    triangles.push([a, c, d]);
                } else {
                    triangles.push([a, b, d]);
                    triangles.push([b, c, d]);
                }
            }
        }
        Ok(TubeMesh {
            rest_m,
            triangles,
            around,
            along,
            radius_m,
            length_m,
        })
    }

    /// Node indices of ring `j` (0 = the z = 0 end).
    pub fn ring(&self, j: usize) -> std::ops::Range<usize> {
        j * self.around..(j + 1) * self.around
    }

    /// The ring nearest mid-length.
    pub fn middle_ring(&self) -> usize {
        self.along.div_ceil(2)
    }
}
