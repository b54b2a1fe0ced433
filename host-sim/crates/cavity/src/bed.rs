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
}

#[cfg(test)]
mod tests {
    use super::*;

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
