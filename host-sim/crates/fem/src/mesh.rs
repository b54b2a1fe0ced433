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
    /// Rest axial position of each ring (m), ascending from 0 to
    /// `length_m`.
    pub ring_z_m: Vec<f64>,
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
        if along < 1 {
            return Err(FemError::param("along", along as f64));
        }
        let rings = (0..=along)
            .map(|j| length_m * j as f64 / along as f64)
            .collect();
        Self::with_rings(radius_m, length_m, around, rings)
    }

    /// Growth of the row length from one row to the next in
    /// [`TubeMesh::graded`].
    pub const GRADING_RATIO: f64 = 1.25;

    /// A tube like [`TubeMesh::tube`] whose rows are `end_row_m` long at
    /// both ends and grow by [`TubeMesh::GRADING_RATIO`] per row towards
    /// the middle, up to `max_row_m` (m): fine where the skin bends at the
    /// clamped ends, coarse where it does not. Symmetric about mid-length,
    /// with a ring there.
    pub fn graded(
        radius_m: f64,
        length_m: f64,
        around: usize,
        end_row_m: f64,
        max_row_m: f64,
    ) -> Result<TubeMesh, FemError> {
        if !(end_row_m > 0.0 && end_row_m.is_finite()) {
            return Err(FemError::param("end_row_m", end_row_m));
        }
        if !(max_row_m >= end_row_m && max_row_m.is_finite()) {
            return Err(FemError::param("max_row_m", max_row_m));
        }
        if !(length_m > 0.0 && length_m.is_finite()) {
            return Err(FemError::param("length_m", length_m));
        }
        // Rows of the half from an end to the middle, then scaled to fit.
        let half = 0.5 * length_m;
        let mut rows = Vec::new();
        let (mut h, mut sum) = (end_row_m, 0.0);
        while sum + 0.5 * h < half {
            rows.push(h);
            sum += h;
            h = (h * Self::GRADING_RATIO).min(max_row_m);
        }
        if rows.is_empty() {
            rows.push(half);
            sum = half;
        }
        let scale = half / sum;
        let mut rings = vec![0.0];
        for h in rows.iter().chain(rows.iter().rev()) {
            let z = rings.last().copied().unwrap_or(0.0) + h * scale;
            rings.push(z);
        }
        // The last ring exactly at the end.
        if let Some(z) = rings.last_mut() {
            *z = length_m;
        }
        Self::with_rings(radius_m, length_m, around, rings)
    }

    /// A tube with rings at rest positions `ring_z_m` (m), ascending from
    /// 0 to `length_m`.
    pub fn with_rings(
        radius_m: f64,
        length_m: f64,
        around: usize,
        ring_z_m: Vec<f64>,
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
        let along = ring_z_m.len().saturating_sub(1);
        if along < 1 {
            return Err(FemError::param("along", along as f64));
        }
        // Strictly ascending and finite (a NaN fails the comparison).
        if let Some(w) = ring_z_m
            .windows(2)
            .find(|w| w[1].partial_cmp(&w[0]) != Some(std::cmp::Ordering::Greater))
        {
            return Err(FemError::param("ring_z_m", w[1]));
        }
        let mut rest_m = Vec::with_capacity(around * (along + 1));
        for &z in &ring_z_m {
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
            ring_z_m,
        })
    }

    /// Rest length of row j, between rings j and j + 1 (m).
    pub fn row_m(&self, j: usize) -> f64 {
        self.ring_z_m[j + 1] - self.ring_z_m[j]
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
