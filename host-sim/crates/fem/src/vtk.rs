//! The skin as a legacy-format VTK file (ParaView reads it, and a
//! `.vtk.series` index of such files as a time series): node positions and
//! displacements, the elements (mid-surface triangles, or a solid wall's
//! hexahedra), and per element the von Mises stress and the current wall
//! thickness (a solid: the volume ratio).

use super::bending::von_mises_3d_pa;
use super::solid::{HexState, Solid};
use super::{FemError, Skin};
use crate::StrainEnergy;
use std::fmt::Write as _;

/// The skin's current state as legacy ASCII VTK (SI units): polydata of
/// the mid-surface triangles, or for a solid wall an unstructured grid of
/// its hexahedra.
pub fn to_vtk<S: StrainEnergy>(skin: &Skin<S>) -> Result<String, FemError> {
    if let Some(solid) = &skin.solid {
        return Ok(solid_to_vtk(skin, solid));
    }
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
    write_displacements(&mut s, skin);
    Ok(s)
}

/// The solid wall: hexahedra (VTK cell type 12) with each one's centre
/// von Mises stress and volume ratio J̄, as cell data.
fn solid_to_vtk<S: StrainEnergy>(skin: &Skin<S>, solid: &Solid) -> String {
    let n = skin.node_count();
    let m = solid.hexes.len();
    let states: Vec<Option<HexState>> = (0..m)
        .map(|k| solid.state(&skin.law, k, &skin.position_m).ok())
        .collect();
    let mut s = String::new();
    let _ = writeln!(s, "# vtk DataFile Version 3.0");
    let _ = writeln!(s, "urechis skin (solid), t = {} s", skin.time_s);
    let _ = writeln!(s, "ASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS {n} double");
    for x in &skin.position_m {
        let _ = writeln!(s, "{:e} {:e} {:e}", x.x, x.y, x.z);
    }
    let _ = writeln!(s, "CELLS {m} {}", 9 * m);
    for hex in &solid.hexes {
        let ids: Vec<String> = hex.nodes.iter().map(|a| a.to_string()).collect();
        let _ = writeln!(s, "8 {}", ids.join(" "));
    }
    let _ = writeln!(s, "CELL_TYPES {m}");
    for _ in 0..m {
        let _ = writeln!(s, "12");
    }
    let _ = writeln!(s, "CELL_DATA {m}");
    // A collapsed element (the run stops on it anyway) is written as NaN.
    type Column = (&'static str, fn(&HexState) -> f64);
    let columns: [Column; 2] = [
        ("von_mises_pa", |h| von_mises_3d_pa(&h.cauchy_pa)),
        ("volume_ratio", |h| h.volume_ratio),
    ];
    for (name, value) in columns {
        let _ = writeln!(s, "SCALARS {name} double 1\nLOOKUP_TABLE default");
        for st in &states {
            let _ = writeln!(s, "{:e}", st.as_ref().map_or(f64::NAN, value));
        }
    }
    write_displacements(&mut s, skin);
    s
}

/// Point data: each node's displacement from rest.
fn write_displacements<S: StrainEnergy>(s: &mut String, skin: &Skin<S>) {
    let _ = writeln!(
        s,
        "POINT_DATA {}\nVECTORS displacement_m double",
        skin.node_count()
    );
    for (x, x0) in skin.position_m.iter().zip(&skin.rest_m) {
        let u = x - x0;
        let _ = writeln!(s, "{:e} {:e} {:e}", u.x, u.y, u.z);
    }
}
