//! A settled bed as `shared/cavity` gives it: `id,x,y,z,radius` in m, one
//! sphere per row.

use std::path::Path;

use anyhow::{Context, Result};
use datafile::Table;
use nalgebra::Vector3;

/// The spheres of a bed.
#[derive(Clone, Debug, PartialEq)]
pub struct Bed {
    /// Centres (m).
    pub position_m: Vec<Vector3<f64>>,
    /// Radii (m).
    pub radius_m: Vec<f64>,
}

impl Bed {
    /// Reads a bed file; an error names the file, the line and the column
    /// of the first bad value (a radius that is not positive, a centre that
    /// is not finite).
    pub fn read(path: &Path) -> Result<Bed> {
        let bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
        Bed::parse(&path.display().to_string(), &bytes)
    }

    /// Parses the text of a bed file named `file` (for errors).
    pub fn parse(file: &str, bytes: &[u8]) -> Result<Bed> {
        let mut table = Table::parse(file, bytes)?;
        let (x, y, z, r) = (
            table.require("x")?,
            table.require("y")?,
            table.require("z")?,
            table.require("radius")?,
        );
        let mut bed = Bed {
            position_m: Vec::new(),
            radius_m: Vec::new(),
        };
        for row in table.rows() {
            let row = row?;
            let radius = row.number(r)?;
            if radius <= 0.0 {
                return Err(row
                    .error_in(r, format!("radius {radius} m is not positive"))
                    .into());
            }
            bed.position_m
                .push(Vector3::new(row.number(x)?, row.number(y)?, row.number(z)?));
            bed.radius_m.push(radius);
        }
        anyhow::ensure!(!bed.radius_m.is_empty(), "{file}: no spheres");
        Ok(bed)
    }

    /// Number of spheres.
    pub fn len(&self) -> usize {
        self.radius_m.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.radius_m.is_empty()
    }

    /// Solid fraction and contacts per sphere of the spheres whose centres
    /// lie in the box `lo`..`hi` (m), the bed periodic along y with period
    /// `period_y_m` (centres' y taken modulo the period): a contact is a
    /// pair closer than the sum of its radii (a settled bed's overlaps are
    /// its contacts). The solid fraction counts those spheres' whole
    /// volume over the box's.
    pub fn packing(&self, lo: Vector3<f64>, hi: Vector3<f64>, period_y_m: f64) -> Packing {
        let inside: Vec<usize> = (0..self.len())
            .filter(|&i| {
                let mut p = self.position_m[i];
                p.y = p.y.rem_euclid(period_y_m);
                (0..3).all(|k| p[k] >= lo[k] && p[k] < hi[k])
            })
            .collect();
        let volume: f64 = inside
            .iter()
            .map(|&i| 4.0 / 3.0 * std::f64::consts::PI * self.radius_m[i].powi(3))
            .sum();
        let box_volume = (hi - lo).iter().product::<f64>();
        // Cells of the largest diameter: contacts are in neighbouring cells.
        let cell = 2.0 * self.radius_m.iter().cloned().fold(0.0, f64::max);
        // Along y a whole number of cells fills the period, each at least
        // `cell` long.
        let cells_y = (period_y_m / cell).floor().max(1.0) as i64;
        let cell_y = period_y_m / cells_y as f64;
        let key = |p: &Vector3<f64>| {
            [
                (p.x / cell).floor() as i64,
                ((p.y.rem_euclid(period_y_m) / cell_y).floor() as i64).min(cells_y - 1),
                (p.z / cell).floor() as i64,
            ]
        };
        let mut grid: std::collections::HashMap<[i64; 3], Vec<usize>> =
            std::collections::HashMap::new();
        for (i, p) in self.position_m.iter().enumerate() {
            grid.entry(key(p)).or_default().push(i);
        }
        let mut contacts = 0usize;
        for &i in &inside {
            let p = self.position_m[i];
            let [cx, cy, cz] = key(&p);
            let mut seen = Vec::new();
            for dx in -1..=1 {
                for dy in -1..=1 {
                    for dz in -1..=1 {
                        let y = (cy + dy).rem_euclid(cells_y);
                        let Some(list) = grid.get(&[cx + dx, y, cz + dz]) else {
                            continue;
                        };
                        for &j in list {
                            if j == i || seen.contains(&j) {
                                continue;
                            }
                            let mut d = self.position_m[j] - p;
                            d.y -= period_y_m * (d.y / period_y_m).round();
                            if d.norm() < self.radius_m[i] + self.radius_m[j] {
                                seen.push(j);
                            }
                        }
                    }
                }
            }
            contacts += seen.len();
        }
        Packing {
            spheres: inside.len(),
            solid_fraction: volume / box_volume,
            coordination: contacts as f64 / inside.len().max(1) as f64,
        }
    }
}

/// What [`Bed::packing`] measures.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Packing {
    /// Spheres counted.
    pub spheres: usize,
    /// Solid volume over the box's volume (−).
    pub solid_fraction: f64,
    /// Contacts per sphere (−).
    pub coordination: f64,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_simple_cubic_lattice_has_six_contacts_and_its_solid_fraction() {
        // Spheres of radius 1 mm on a 1.999 mm cubic lattice, periodic
        // along y over 10 cells: every inner sphere touches 6.
        let (pitch, r) = (1.999e-3, 1.0e-3);
        let mut bed = Bed {
            position_m: Vec::new(),
            radius_m: Vec::new(),
        };
        for i in 0..10 {
            for j in 0..10 {
                for k in 0..10 {
                    bed.position_m
                        .push(Vector3::new(i as f64, j as f64, k as f64) * pitch);
                    bed.radius_m.push(r);
                }
            }
        }
        let lo = Vector3::new(2.5, 0.0, 2.5) * pitch;
        let hi = Vector3::new(7.5, 10.0, 7.5) * pitch;
        let p = bed.packing(lo, hi, 10.0 * pitch);
        assert_eq!(p.spheres, 250);
        // Ten layers along y in a box of ten pitches: the lattice's own
        // solid fraction.
        assert!((p.coordination - 6.0).abs() < 1e-12, "{}", p.coordination);
        let want = 4.0 / 3.0 * std::f64::consts::PI * r.powi(3) / pitch.powi(3);
        assert!((p.solid_fraction / want - 1.0).abs() < 1e-9);
    }

    #[test]
    fn a_bed_is_read_and_bad_values_are_named_by_line_and_column() {
        let ok = "id,x,y,z,radius\n1,0.01,0.002,0.001,0.001\n2,0.012,0.002,0.001,9.5e-4\n";
        let bed = Bed::parse("bed.csv", ok.as_bytes()).unwrap();
        assert_eq!(bed.len(), 2);
        assert_eq!(bed.radius_m[1], 9.5e-4);
        let bad = "id,x,y,z,radius\n1,0.01,0.002,0.001,0.001\n2,0.012,nan,0.001,0.001\n";
        let e = Bed::parse("bed.csv", bad.as_bytes())
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("bed.csv") && e.contains('3') && e.contains('y'),
            "{e}"
        );
        let neg = "id,x,y,z,radius\n1,0.01,0.002,0.001,-0.001\n";
        let e = Bed::parse("bed.csv", neg.as_bytes())
            .unwrap_err()
            .to_string();
        assert!(e.contains("radius") && e.contains("not positive"), "{e}");
        let missing = "id,x,y,radius\n1,0.01,0.002,0.001\n";
        let e = Bed::parse("bed.csv", missing.as_bytes())
            .unwrap_err()
            .to_string();
        assert!(e.contains('z'), "{e}");
    }
}
