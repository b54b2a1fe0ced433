//! # Element tests of the DEM sand
//!
//! The solver's sand in bulk, measured as a laboratory measures a sand:
//! a sample of the scenario's grains in a cell of six frictionless walls,
//! no gravity, consolidated isotropically ([`procedure::consolidate`]), then
//! sheared in drained triaxial compression ([`procedure::triaxial`]: the peak
//! and critical-state friction angles and the dilatancy angle) or loaded
//! in one-dimensional compression ([`procedure::oedometer`]: K0), at the
//! stresses of the burrowing problem (0.5–10 kPa) and quasi-statically
//! (inertial number [`procedure::INERTIAL_NUMBER`]).

pub mod cell;
pub mod procedure;
pub mod study;

pub use cell::{Axis, Cell, Grains};
