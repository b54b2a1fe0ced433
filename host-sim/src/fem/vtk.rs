//! The skin as a legacy-format VTK polydata file (ParaView reads it, and a
//! `.vtk.series` index of such files as a time series): node positions and
//! displacements, triangles, and per element the von Mises stress and the
//! current wall thickness.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::Context;

use super::{FemError, Skin};
use crate::skin::StrainEnergy;

/// The skin's current state as legacy ASCII VTK polydata (SI units).
pub fn to_vtk<S: StrainEnergy>(skin: &Skin<S>) -> Result<String, FemError> {
    let von_mises = skin.von_mises_pa()?;
    let thickness = (0..skin.elements.len())
        .map(|k| Ok(skin.spec.thickness_m * skin.strain(k)?.thickness_stretch()))
        .collect::<Result<Vec<f64>, FemError>>()?;
    let (n, m) = (skin.node_count(), skin.elements.len());
    let mut s = String::new();
    // Writing to a String cannot fail; the results are ignored for that reason.
    let _ = writeln!(s, "# vtk DataFile Version 3.0");
    let _ = writeln!(s, "urechis skin, t = {} s", skin.time_s);
    let _ = writeln!(s, "ASCII\nDATASET POLYDATA\nPOINTS {n} double");
    for x in &skin.position_m {
        let _ = writeln!(s, "{:e} {:e} {:e}", x.x, x.y, x.z);
    }
    let _ = writeln!(s, "POLYGONS {m} {}", 4 * m);
    for tri in &skin.elements {
        let [a, b, c] = tri.nodes;
        let _ = writeln!(s, "3 {a} {b} {c}");
    }
    let _ = writeln!(s, "CELL_DATA {m}");
    for (name, values) in [("von_mises_pa", &von_mises), ("thickness_m", &thickness)] {
        let _ = writeln!(s, "SCALARS {name} double 1\nLOOKUP_TABLE default");
        for v in values {
            let _ = writeln!(s, "{v:e}");
        }
    }
    let _ = writeln!(s, "POINT_DATA {n}\nVECTORS displacement_m double");
    for (x, x0) in skin.position_m.iter().zip(&skin.mesh.rest_m) {
        let u = x - x0;
        let _ = writeln!(s, "{:e} {:e} {:e}", u.x, u.y, u.z);
    }
    Ok(s)
}

/// Writes [`to_vtk`] to `path` atomically.
pub fn write_vtk<S: StrainEnergy>(skin: &Skin<S>, path: &Path) -> anyhow::Result<()> {
    let text = to_vtk(skin).with_context(|| format!("skin state for {}", path.display()))?;
    crate::files::write_atomic(path, text.as_bytes())
}
