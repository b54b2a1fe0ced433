//! The rest geometry of a tube, in the millimetres its users measure.

use serde::Serialize;

/// Rest geometry of the expansion zone's skin tube.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct TubeGeometry {
    /// Outer diameter at rest, D0 (mm).
    pub outer_diameter_mm: f64,
    /// Wall (skin) thickness at rest (mm).
    pub wall_thickness_mm: f64,
    /// Length of the expansion zone at rest (mm); only used for volumes.
    pub length_mm: f64,
}

impl TubeGeometry {
    /// The paper's actuator: D0 = 18.7 mm, 1.75 mm skin, 20 mm zone.
    pub const PAPER: Self = Self {
        outer_diameter_mm: 18.7,
        wall_thickness_mm: 1.75,
        length_mm: 20.0,
    };

    /// Outer radius at rest, Ro (mm).
    pub fn outer_radius_mm(&self) -> f64 {
        0.5 * self.outer_diameter_mm
    }

    /// Inner radius at rest, Ri (mm).
    pub fn inner_radius_mm(&self) -> f64 {
        0.5 * self.outer_diameter_mm - self.wall_thickness_mm
    }
}
