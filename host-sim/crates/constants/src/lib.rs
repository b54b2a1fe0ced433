//! The physical constants every host-sim model shares, defined once. The
//! kernels (dem, fem) take them as inputs and define none.

/// Gravitational acceleration (m/s²). 9.81, not standard gravity's
/// 9.80665: the FEM–DEM solver's stored results and the DEM benchmark's
/// LIGGGHTS input were computed with 9.81, and the 0.035 % between the two
/// is far inside any rig's other uncertainties.
pub const GRAVITY_M_S2: f64 = 9.81;

/// Density of sea water (kg/m³), the worm's habitat and the paper's
/// set-up: the default fluid of a rig and of the solver's scenario.
pub const SEAWATER_DENSITY_KG_M3: f64 = 1025.0;

/// Standard atmosphere (kPa): the absolute pressure at the water surface.
pub const ATMOSPHERE_KPA: f64 = 101.325;
