//! The paper's expansion scenario as a bed: the zone's skin (axis along z,
//! from z = 0 to its length, centred at x = y = 0), coarse-grained sand
//! round it in a box of the paper's 40 mm width, gravity along −y, the
//! grains submerged; the rigid head ([`Ends::Head`]) closing the zone at
//! z = L, sliding along the axis (drawn back as the zone swells,
//! [`HeadSupport`]), its front face ([`FrontFace`]) against the sand ahead. By default the sand column reaches the surface
//! (h above the axis); [`ScenarioSpec::with_surcharge`] swaps its top for
//! a surcharge layer of heavy grains, cheaper but without the overburden's
//! shear strength.
//!
//! The bed is deposited dense: frictionless for the first half of the
//! settling, then with the paper's μ = 0.25 (the bed then settles at a
//! solid fraction ≈ 0.56, and the final p_e no longer depends on the grain
//! radius: see the crate README).
//!
//! Walls: the floor, the z = 0 plane (the body behind the zone) and the far
//! z end are frictionless (artificial cuts of a larger bed); the two x
//! walls are the box's, with the grains' friction.
//!
//! [`ScenarioSpec::with_rig`] puts a user's set-up (an experiment folder's
//! `rig.toml`) in place of the paper's: the actuator's tube and skin, the
//! grains' density and friction, the fluid's density and the box width.

use std::num::NonZeroUsize;

use constants::{GRAVITY_M_S2, SEAWATER_DENSITY_KG_M3};

use anyhow::{ensure, Context, Result};
use nalgebra::Vector3;
use rand::{RngExt, SeedableRng};

use crate::coupling::{Coupling, FrontFace, HeadDraw};
use dem::{ContactModel, ContactSpec, Material, Params, Particles, State, Wall};
use fem::{Ends, FemError, Skin, SkinKind, SkinSpec, VolumeControl};
use rig::Rig;
use sand::{BalloonPoint, BALLOON_FINAL_DIAMETER_MM, BALLOON_TABLE};
use skin::membrane::TubeGeometry;
use skin::{default_skin, SkinLaw, StrainEnergy};

/// Most hexahedra through a solid skin's wall ([`ScenarioSpec::with_solid`]):
/// at 8 each is 0.22 mm thick and the skin's step falls well below the
/// DEM's.
pub const MAX_SKIN_LAYERS: usize = 8;

/// Lattice rows of a surcharge layer ([`ScenarioSpec::with_surcharge`]).
pub const SURCHARGE_ROWS: NonZeroUsize = NonZeroUsize::new(2).expect("two rows");

/// Grain radius of the default coarse-grained sand (m): 1.5 mm, about 4
/// of the paper's 0.36 mm grains across; the final Δp_i changed by 2.1 %
/// from 1.0 mm (the crate README).
pub const DEFAULT_GRAIN_RADIUS_M: f64 = 1.5e-3;
/// Grain density of the paper's sand (kg/m³).
pub const GRAIN_DENSITY_KG_M3: f64 = 2920.0;
/// Default Young's modulus of the coarse grains during the advance and the
/// expansion (Pa). Stiff enough that the face load is converged: at 1e7 Pa
/// (Hertz overlaps ≈ 2.5 % of r at 100 mm) the advance loaded the face 3×
/// less at depth and its drop fell short of the paper's (the crate README).
pub const GRAIN_MODULUS_PA: f64 = 1.0e8;
/// Default Young's modulus of the grains while the bed settles (Pa): the
/// DEM benchmark's soft grains, for a √10 longer step.
pub const DEPOSITION_MODULUS_PA: f64 = 1.0e7;
/// How long the stiffened bed relaxes, with the settling drag, before the
/// advance (s): a few drag times.
pub const RELAX_S: f64 = 0.03;
/// Inter-grain friction of the paper.
pub const FRICTION: f64 = 0.25;
/// Rolling resistance of the coarse spheres (−): a typical value for
/// natural sand's angular grains (0.1–0.3 in the DEM literature), not
/// fitted; alone it raised the final contact p_e at 40 mm by 2–7 % over
/// μ_r = 0, by 33 % together with the dense deposition.
pub const ROLLING_FRICTION: f64 = 0.2;
/// The one calibrated number: the skin's stiffness relative to the
/// project's default skin law (synthetic, the paper's coefficients are not
/// published), fitted so that the final p_i at h = 40 mm is the paper's
/// FEM–DEM 4.06 kPa (full runs, seed 1: 3.88 kPa at 2.3, 4.24 at 2.7;
/// linear between them). See the crate README.
pub const SKIN_STIFFNESS_SCALE: f64 = 2.5;
/// The paper's expansion: 18.7 → 25 mm outer diameter, a stretch of
/// 25/18.7 that a rig's actuator gets by default.
pub const PAPER_FINAL_DIAMETER_M: f64 = 25e-3;
/// Length of the skin's end rows (m): where the zone leaves the body and
/// the head the skin bends over ≈ 1 mm; rows of 0.35 mm give the end
/// curvature within ≈ 5 % of a uniform 0.125 mm mesh (free inflation to
/// 25 mm) at a stable step still about the DEM's.
pub const SKIN_END_ROW_M: f64 = 0.35e-3;
/// Wall thickness over outer radius below which a rig's skin is the
/// membrane ([`ScenarioSpec::with_rig`]): mid-surface theory is then within
/// about T/2R of the solid's, and hexahedra a tenth of the radius thin
/// would cut the skin's step well under the DEM's. The paper's wall is
/// 0.19.
pub const THIN_WALL_RATIO: f64 = 0.1;
/// Hexahedra through the wall of the scenario's skin ([`ScenarioSpec::paper`]):
/// a third layer moved the peak stress by 3 % (the crate README).
pub const SOLID_LAYERS: NonZeroUsize = NonZeroUsize::new(2).expect("two layers");
/// The membrane's mesh ([`ScenarioSpec::with_membrane`]): 24 round, 6 along.
pub const MEMBRANE_MESH: (usize, usize) = (24, 6);
/// The shell's mesh ([`ScenarioSpec::with_shell`]): 24 nodes round, rows
/// growing from [`SKIN_END_ROW_M`] to a 13th of the zone (20 rows for the
/// paper's 20 mm).
pub const SHELL_MESH: (usize, usize) = (24, 13);
/// Where the paper reads its head-pressure drop as done: D ≈ 22 mm of its
/// 18.7 → 25 mm expansion (m); other expansions use the same fraction
/// ([`ScenarioSpec::face_drop_from_m`]).
pub const PAPER_FACE_DROP_FROM_M: f64 = 22e-3;
/// The advance before the expansion (m): the paper's 1 mm per burrowing
/// cycle, so the expansion starts, as in a burrow, with the sand ahead
/// loaded by the head's last advance (the paper's drop to 25 Pa by 97 %
/// implies a face pressure of about 0.9 kPa before it, ≈ 2 σ'v at 4 cm;
/// the settled bed at rest gives ≈ 0.25 σ'v).
pub const PAPER_ADVANCE_M: f64 = 1e-3;
/// Sand beside the expanded zone when the rig names no box (a wide tank):
/// the box is this many final diameters wide, with frictionless sides
/// standing for the sand beyond (the paper's box is 1.6 of them).
pub const WIDE_TANK_DIAMETERS: f64 = 3.0;
/// Penalty bulk modulus of the zone's fluid (Pa): ≫ the few kPa reached.
pub const FLUID_BULK_MODULUS_PA: f64 = 1e6;

/// What the body does with the head while the zone swells.
///
/// The paper's head recedes as the zone swells, little at first, more as
/// D grows (its Figure 5), "pulled" by the skin. A free head on this solid
/// wall does not: the sand holds the zone's lower side straight, the
/// wall there props the head, and the zone lengthens under p_i, so the
/// head comes forward and the face reloads (the crate README).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum HeadSupport {
    /// Drawn back in step with the swelling, as the chord of a meridian
    /// that keeps its length ([`crate::coupling::HeadDraw::meridian`]):
    /// the longitudinal muscles (or an actuator's inextensible fibres)
    /// keep the zone's skin from lengthening. For the paper's zone, D_r
    /// reaches 1.2 mm at 25 mm. The default.
    Drawn,
    /// Drawn back by this much (m) by the final diameter, with the same
    /// square law ([`crate::coupling::HeadDraw`]).
    DrawnBy(f64),
    /// Free: moved only by the skin and the sand on its face (the fluid's
    /// push on the cap taken by the body, [`fem::Ends::Head`]).
    Free,
    /// Held where the advance left it (a head on a rigid body, D_r = 0).
    Held,
}

impl std::str::FromStr for HeadSupport {
    type Err = String;

    /// `drawn`, `free`, `held`, or a distance in mm (drawn back that far).
    fn from_str(s: &str) -> Result<HeadSupport, String> {
        match s {
            "drawn" => Ok(HeadSupport::Drawn),
            "free" => Ok(HeadSupport::Free),
            "held" => Ok(HeadSupport::Held),
            mm => match mm.parse::<f64>() {
                Ok(v) if v >= 0.0 && v.is_finite() => Ok(HeadSupport::DrawnBy(v * 1e-3)),
                _ => Err(format!(
                    "head support {s:?}: expected drawn, free, held or a distance in mm ≥ 0"
                )),
            },
        }
    }
}

impl std::fmt::Display for HeadSupport {
    /// As `from_str` reads it (`--head`).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            HeadSupport::Drawn => write!(f, "drawn"),
            HeadSupport::DrawnBy(m) => write!(f, "{}", m * 1e3),
            HeadSupport::Free => write!(f, "free"),
            HeadSupport::Held => write!(f, "held"),
        }
    }
}

/// Everything that sets up one scenario run.
/// What lies above the zone's axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Overburden {
    /// Sand up to the surface.
    Sand,
    /// Sand up to `slab_top_m` above the axis, and above it `rows` lattice
    /// rows of heavy grains carrying the rest of the overburden's weight.
    Surcharge {
        /// Top of the sand slab above the axis (m).
        slab_top_m: f64,
        /// Lattice rows of the surcharge layer.
        rows: NonZeroUsize,
    },
}

#[derive(Clone, Debug, PartialEq)]
pub struct ScenarioSpec {
    /// Depth of the zone's axis below the sand surface h (m).
    pub depth_m: f64,
    /// Grain radius of the coarse-grained sand (m).
    pub grain_radius_m: f64,
    /// Box width across the axis (m): the paper's 40 mm.
    pub box_width_m: f64,
    /// Sand ahead of the front face along the axis (m).
    pub ahead_m: f64,
    /// Floor below the axis (m).
    pub below_m: f64,
    /// What lies above the axis: sand to the surface, or sand to a slab
    /// top with a surcharge layer standing for the rest.
    pub overburden: Overburden,
    /// Solid fraction of the settled bed (for the grain count and the
    /// buoyant unit weight γ' = φ (ρ_s − ρ_w) g): 0.56, what the
    /// dense-deposited bed settles at (its surface then lands within
    /// about a grain of h).
    pub packing: f64,
    /// Settling time before the expansion (s).
    pub settle_s: f64,
    /// Target duration of the expansion (s): sets the injection rate.
    pub expansion_s: f64,
    /// Final outer diameter at mid-length (m).
    pub final_diameter_m: f64,
    /// Skin mesh: nodes round, and rows along (with
    /// [`ScenarioSpec::skin_end_row_m`], the number of the longest rows
    /// that would fill the zone).
    pub skin_mesh: (usize, usize),
    /// Length of the skin's rows at the clamped ends (m), growing towards
    /// the middle ([`fem::mesh::TubeMesh::graded`]): the skin bends over
    /// about a millimetre there; `None`: rows of equal length.
    pub skin_end_row_m: Option<f64>,
    /// How the skin's wall is modelled: the mid-surface membrane
    /// ([`ScenarioSpec::with_membrane`]), a shell ([`fem::bending`],
    /// [`ScenarioSpec::with_shell`]) or a solid wall of hexahedra
    /// ([`fem::solid`], [`ScenarioSpec::with_solid`]).
    pub skin_kind: SkinKind,
    /// Scale a solid wall's mass so that it takes one step per DEM step
    /// while the bed settles ([`crate::coupling::Coupling::mass_scaling`]),
    /// where nothing is measured and the long settling step would take it
    /// three; the advance and the expansion run at its own mass. Default
    /// true; no effect on a membrane or shell, whose steps are longer.
    pub skin_mass_scaling: bool,
    /// Keep the zone round ([`fem::Skin::round_rings`]): the sand's
    /// answer to a round expansion, whatever shape the skin would take
    /// (off by default; for studies, the crate README).
    pub round_zone: bool,
    /// VTK frames over the expansion (≥ 1).
    pub frames: usize,
    /// Samples over the expansion (about).
    pub samples: usize,
    /// Lattice jitter seed.
    pub seed: u64,
    /// Rolling-resistance coefficient μ_r of the grains' contacts (−).
    pub rolling_friction: f64,
    /// Factor on the shared skin law's coefficients (−), see
    /// [`ScenarioSpec::skin_law`].
    pub skin_stiffness_scale: f64,
    /// Friction of the grains on the box's side walls (−).
    pub wall_friction: f64,
    /// Friction of the grains on the skin (−).
    pub skin_friction: f64,
    /// Inter-grain friction while the bed is deposited, the first half of
    /// settling (−); the paper's μ after that. Below μ it packs denser.
    pub deposition_friction: f64,
    /// The skin tube at rest (outer diameter D0, thickness, zone length).
    pub tube: TubeGeometry,
    /// The skin's measured law (rig.toml's Yeoh `[skin]`, or any law
    /// from `--skin-fit`); `None`: the project's default skin (see
    /// [`ScenarioSpec::skin_law`]). Its `Debug` is the law's own, so a
    /// Yeoh law keys a case record as it always has.
    pub skin_coefficients: Option<SkinLaw>,
    /// Grain material density ρ_s (kg/m³).
    pub grain_density_kg_m3: f64,
    /// Density of the water in the pores ρ_w (kg/m³): buoyancy.
    pub water_density_kg_m3: f64,
    /// Inter-grain Coulomb friction μ (−).
    pub friction: f64,
    /// Where the set-up comes from, for the summary (e.g. the rig's path).
    pub setup: String,
    /// Radius of finer grains filling a block in front of the head (m), so
    /// the face carries more than a dozen grains; `None`: one size. The
    /// block spans the face plus two coarse grains each side and reaches
    /// one face radius ahead ([`ScenarioSpec::face_block_m`]). The time step
    /// follows the finest grains.
    pub face_grain_radius_m: Option<f64>,
    /// How far the actuator (head and zone together, the skin unstrained)
    /// advances into the settled sand before the expansion (m), as the
    /// advance that ends each burrowing cycle; 0: expand from the settled
    /// state. Default [`PAPER_ADVANCE_M`].
    pub advance_m: f64,
    /// Duration of that advance (s).
    pub advance_s: f64,
    /// Pause after the advance (s): the body stops and holds the head
    /// where it is before the zone inflates. Default 0.
    pub advance_hold_s: f64,
    /// What moves the head along the axis through the expansion, after
    /// the advance (and its pause). Default [`HeadSupport::Drawn`].
    pub head: HeadSupport,
    /// Young's modulus of the grains during the advance and the expansion
    /// (Pa); the time step scales as the Rayleigh time, ∝ 1/√E. Default
    /// [`GRAIN_MODULUS_PA`].
    pub grain_modulus_pa: f64,
    /// Young's modulus of the grains while the bed settles (Pa): softer
    /// for a longer step where nothing is measured; the bed is then
    /// stiffened to `grain_modulus_pa` and relaxed for [`RELAX_S`]. Equal
    /// to it: one modulus throughout. Default [`DEPOSITION_MODULUS_PA`].
    pub deposition_modulus_pa: f64,
    /// The run stands for the paper's balloon experiment
    /// ([`ScenarioSpec::as_balloon`]), not a burrowing cycle: its summary
    /// compares p_i and Δp_i with the balloon's measured pressures.
    pub balloon: bool,
}

impl ScenarioSpec {
    /// The full case at depth `depth_m` (m) with grains of radius
    /// `grain_radius_m` (m), the skin a solid wall [`SOLID_LAYERS`]
    /// hexahedra thick ([`ScenarioSpec::with_solid`]; the paper's element
    /// family and its peak stress; [`ScenarioSpec::with_membrane`] for the
    /// mid-surface membrane of the earlier results, 2.5× cheaper).
    pub fn paper(depth_m: f64, grain_radius_m: f64) -> ScenarioSpec {
        let below_m = 20e-3;
        ScenarioSpec {
            depth_m,
            grain_radius_m,
            box_width_m: 40e-3,
            ahead_m: 15e-3,
            below_m,
            overburden: Overburden::Sand,
            packing: 0.56,
            settle_s: Self::column_settle_s(below_m + depth_m),
            expansion_s: 0.3,
            final_diameter_m: PAPER_FINAL_DIAMETER_M,
            skin_mesh: MEMBRANE_MESH,
            skin_end_row_m: None,
            skin_kind: SkinKind::Membrane,
            skin_mass_scaling: true,
            round_zone: false,
            frames: 10,
            samples: 200,
            seed: 1,
            rolling_friction: ROLLING_FRICTION,
            skin_stiffness_scale: SKIN_STIFFNESS_SCALE,
            wall_friction: FRICTION,
            skin_friction: FRICTION,
            deposition_friction: 0.0,
            tube: TubeGeometry::PAPER,
            skin_coefficients: None,
            grain_density_kg_m3: GRAIN_DENSITY_KG_M3,
            water_density_kg_m3: SEAWATER_DENSITY_KG_M3,
            friction: FRICTION,
            setup: "the paper's set-up".to_string(),
            face_grain_radius_m: None,
            advance_m: PAPER_ADVANCE_M,
            advance_s: 0.05,
            advance_hold_s: 0.0,
            head: HeadSupport::Drawn,
            grain_modulus_pa: GRAIN_MODULUS_PA,
            deposition_modulus_pa: DEPOSITION_MODULUS_PA,
            balloon: false,
        }
        .with_solid(SOLID_LAYERS)
    }

    /// This case with the set-up of `rig` (read from `rig_file`, named in
    /// errors) instead of the paper's: the actuator's tube; its skin's
    /// law when known ([`Rig::skin_known`]: `[skin]` or `--skin-fit`; used
    /// as measured, with no stiffness scale), else the default skin with the paper's
    /// calibrated scale; the grains' density and friction (`[sand]`,
    /// required); the pore water's density; the box width (`[container]`;
    /// absent: a wide tank, [`WIDE_TANK_DIAMETERS`] final diameters with
    /// frictionless sides). The zone expands to `final_diameter_m` (m),
    /// by default by the paper's stretch 25/18.7. The floor sits the
    /// paper's 7.5 mm of sand below the expanded zone, the far end the
    /// paper's 15 mm (or 0.8 D0 for larger heads) ahead of the face.
    ///
    /// Returns notes on what the rig says that the solver does not take
    /// as given (the real grain radius, the porosity, the water above the
    /// sand, the box length).
    pub fn with_rig(
        self,
        rig: &Rig,
        rig_file: &str,
        final_diameter_m: Option<f64>,
    ) -> Result<(ScenarioSpec, Vec<String>)> {
        let sand = rig.sand.as_ref().with_context(|| {
            format!("{rig_file}: [sand] is required to simulate the actuator in sand")
        })?;
        let a = &rig.actuator;
        let tube = a.tube();
        let d0 = tube.outer_diameter_mm * 1e-3;
        let final_diameter_m = final_diameter_m.unwrap_or(
            d0 * PAPER_FINAL_DIAMETER_M / (TubeGeometry::PAPER.outer_diameter_mm * 1e-3),
        );
        ensure!(
            final_diameter_m > d0 && final_diameter_m.is_finite(),
            "{rig_file}: [actuator] initial_diameter_mm = {} mm: the final diameter {:.2} mm must exceed it",
            a.initial_diameter_mm,
            final_diameter_m * 1e3
        );
        let skin_coefficients = rig.skin_known().then(|| rig.skin_law());
        let (box_width_m, wall_friction) = match rig.container.as_ref().and_then(|c| c.width_mm) {
            Some(width_mm) => (width_mm * 1e-3, sand.friction),
            // No box, or a tank with no width given: a wide tank.
            None => (WIDE_TANK_DIAMETERS * final_diameter_m, 0.0),
        };
        let below_m = 0.5 * final_diameter_m + 7.5e-3;
        let mut notes = vec![format!(
            "{rig_file}: [sand] grain_radius_mm = {} mm: the DEM grains are {:.2} mm (coarse-grained)",
            sand.grain_radius_mm,
            self.grain_radius_m * 1e3
        )];
        notes.push(format!(
            "{rig_file}: [sand] porosity = {}: the deposited spheres settle at their own solid fraction (about {:.2}); the bed is filled for that",
            sand.porosity, self.packing
        ));
        notes.push(format!(
            "{rig_file}: [fluid] water_above_sand_mm = {} mm: hydrostatic, it changes no effective stress",
            rig.fluid.water_above_sand_mm
        ));
        match (&rig.skin_fit, &skin_coefficients) {
            (_, None) => notes.push(format!(
                "{rig_file}: no [skin]: the default skin × {} (the stiffness calibrated on the paper's case)",
                self.skin_stiffness_scale
            )),
            (Some(fit), Some(law)) => notes.push(format!(
                "the skin is {}, {}, used as measured (scale 1)",
                fit.source,
                law.describe()
            )),
            (None, Some(_)) => {}
        }
        notes.push(match &rig.container {
            None => format!(
                "{rig_file}: no [container] (a wide tank): the box is {WIDE_TANK_DIAMETERS} final diameters ({:.1} mm) wide with frictionless sides",
                box_width_m * 1e3
            ),
            Some(c) => format!(
                "{rig_file}: [container] length_mm = {} mm: the simulated slab is the zone plus the sand ahead of the head",
                c.length_mm
            ),
        });
        let spec = ScenarioSpec {
            box_width_m,
            ahead_m: self.ahead_m.max(0.8 * d0),
            below_m,
            settle_s: Self::column_settle_s(below_m + self.above_m()),
            final_diameter_m,
            wall_friction,
            skin_friction: sand.friction,
            skin_stiffness_scale: if skin_coefficients.is_some() {
                1.0
            } else {
                self.skin_stiffness_scale
            },
            tube,
            skin_coefficients,
            grain_density_kg_m3: sand.grain_density_kg_m3,
            water_density_kg_m3: rig.fluid.density_kg_m3,
            friction: sand.friction,
            setup: format!("rig {rig_file}"),
            ..self
        };
        let thin = tube.wall_thickness_mm / (0.5 * tube.outer_diameter_mm);
        let spec = if spec.skin_kind.layers() > 0 && thin < THIN_WALL_RATIO {
            notes.push(format!(
                "{rig_file}: [actuator] skin_thickness_mm = {} mm is {:.3} of the outer radius, under {THIN_WALL_RATIO}: the skin is the membrane (a thin wall; --solid-skin LAYERS for the solid)",
                a.skin_thickness_mm, thin
            ));
            spec.with_membrane()
        } else {
            spec
        };
        spec.validate()
            .with_context(|| format!("{rig_file}: the set-up cannot be simulated"))?;
        Ok((spec, notes))
    }

    /// Default DEM grain radius for `rig` (m): the coarse-grained
    /// [`DEFAULT_GRAIN_RADIUS_M`], or the real grains when they are coarser.
    pub fn grain_radius_for(rig: &Rig) -> f64 {
        rig.sand.as_ref().map_or(DEFAULT_GRAIN_RADIUS_M, |s| {
            DEFAULT_GRAIN_RADIUS_M.max(s.grain_radius_mm * 1e-3)
        })
    }

    /// D from which the head-pressure drop is read as done (m): the
    /// paper's 22 mm of 18.7 → 25 mm, as the same fraction of this
    /// case's expansion.
    pub fn face_drop_from_m(&self) -> f64 {
        let paper_d0 = TubeGeometry::PAPER.outer_diameter_mm * 1e-3;
        let f = (PAPER_FACE_DROP_FROM_M - paper_d0) / (PAPER_FINAL_DIAMETER_M - paper_d0);
        let d0 = self.tube.outer_diameter_mm * 1e-3;
        d0 + f * (self.final_diameter_m - d0)
    }

    /// A shorter run of the same case (expansion 0.15 s).
    pub fn quick(depth_m: f64, grain_radius_m: f64) -> ScenarioSpec {
        ScenarioSpec {
            expansion_s: 0.15,
            frames: 5,
            samples: 100,
            ..ScenarioSpec::paper(depth_m, grain_radius_m)
        }
    }

    /// This case as the paper's balloon experiment instead of a burrowing
    /// cycle: no advance (the balloon is buried, then inflated where it
    /// lies) and both ends of the zone held (the bulge forms in a 30 cm
    /// latex tube whose uninflated parts lie in the sand either side). The
    /// sand, the box, the depth and the zone's 9.8 mL stay the case's; the
    /// skin's stiffness is matched to the balloon's own pressure
    /// separately ([`crate::balloon`]).
    pub fn as_balloon(self) -> ScenarioSpec {
        ScenarioSpec {
            advance_m: 0.0,
            advance_hold_s: 0.0,
            head: HeadSupport::Held,
            setup: format!("{}, as the balloon experiment", self.setup),
            balloon: true,
            ..self
        }
    }

    /// The same case with the overburden above `above_m` (m over the axis)
    /// as a surcharge layer of `rows` heavy lattice rows instead of sand:
    /// cheaper, but the layer has the overburden's weight, not its shear
    /// strength (measured: p_e at 40 mm 0.81 kPa under a surcharge above
    /// 20 mm, 0.92 kPa with the sand column, same grains).
    pub fn with_surcharge(self, above_m: f64, rows: NonZeroUsize) -> ScenarioSpec {
        ScenarioSpec {
            overburden: Overburden::Surcharge {
                slab_top_m: above_m,
                rows,
            },
            settle_s: Self::column_settle_s(self.below_m + above_m),
            ..self
        }
    }

    /// Settling time for a bed `height_m` (m) tall (s): the lattice
    /// (pitch 2.1 r, solid fraction 0.45) packs to ≈ 0.6, a quarter of its
    /// height, falling at ≈ 0.13 m/s under the settling drag, then rests.
    pub fn column_settle_s(height_m: f64) -> f64 {
        0.15 + 2.5 * height_m
    }

    /// Nominal top of the simulated slab above the axis (m): the depth
    /// (sand to the surface), or lower under a surcharge layer.
    pub fn above_m(&self) -> f64 {
        match self.overburden {
            Overburden::Sand => self.depth_m,
            Overburden::Surcharge { slab_top_m, .. } => slab_top_m,
        }
    }

    /// Lattice rows of heavy grains carrying the surcharge (0: none).
    pub fn surcharge_rows(&self) -> usize {
        match self.overburden {
            Overburden::Sand => 0,
            Overburden::Surcharge { rows, .. } => rows.get(),
        }
    }

    /// The skin's law: the measured law, else the project's default Yeoh
    /// skin, with W times [`ScenarioSpec::skin_stiffness_scale`] (every
    /// modulus scaled, [`SkinLaw::scaled`]); an error for a scale that
    /// leaves the law's domain.
    pub fn skin_law(&self) -> Result<SkinLaw, FemError> {
        let k = self.skin_stiffness_scale;
        self.skin_coefficients
            .clone()
            .unwrap_or_else(|| default_skin().into())
            .scaled(k)
            .ok_or(FemError::Param {
                name: "skin_stiffness_scale",
                value: k,
            })
    }

    /// This case with the skin `law` (a law from `--skin-fit`), used as
    /// measured: the stiffness scale is 1.
    pub fn with_skin_law(self, law: SkinLaw) -> ScenarioSpec {
        ScenarioSpec {
            skin_coefficients: Some(law),
            skin_stiffness_scale: 1.0,
            ..self
        }
    }

    /// This case with the skin as a shell that resists bending, its rows
    /// [`SKIN_END_ROW_M`] long at the clamped ends and growing to 1/13 of
    /// the zone in the middle ([`SHELL_MESH`]), to resolve where it bends
    /// leaving the body and the head. About twice the cost of a case. Not
    /// offered on the command line: in the paper's case the skin folds over
    /// the body's edge with surface strains of 1–2, far past what linear
    /// thin-shell bending describes, and at 100 mm the run breaks down
    /// (the crate README).
    pub fn with_shell(self) -> ScenarioSpec {
        ScenarioSpec {
            skin_kind: SkinKind::Shell,
            skin_end_row_m: Some(SKIN_END_ROW_M),
            skin_mesh: SHELL_MESH,
            ..self
        }
    }

    /// This case with the skin as the mid-surface membrane on the uniform
    /// [`MEMBRANE_MESH`]: no bending, about 40 % of the solid wall's
    /// cost; the crate README's membrane results were run with it.
    pub fn with_membrane(self) -> ScenarioSpec {
        ScenarioSpec {
            skin_kind: SkinKind::Membrane,
            skin_end_row_m: None,
            skin_mesh: MEMBRANE_MESH,
            ..self
        }
    }

    /// This case with the skin as a solid wall, `layers` hexahedra thick
    /// ([`fem::solid`], the paper's own element family), its rows
    /// graded as the shell's ([`SHELL_MESH`], [`SKIN_END_ROW_M`] at the
    /// clamped ends) so the fold where it leaves the body is resolved.
    pub fn with_solid(self, layers: NonZeroUsize) -> ScenarioSpec {
        ScenarioSpec {
            skin_kind: SkinKind::Solid { layers },
            skin_end_row_m: Some(SKIN_END_ROW_M),
            skin_mesh: SHELL_MESH,
            ..self
        }
    }

    /// The zone's skin of this case ([`ScenarioSpec::skin_law`] on
    /// [`ScenarioSpec::tube`], [`ScenarioSpec::skin_mesh`]) held by `ends`,
    /// at rest.
    pub fn skin(&self, ends: Ends) -> Result<Skin<SkinLaw>, FemError> {
        let (around, along) = self.skin_mesh;
        let spec = SkinSpec {
            end_row_m: self.skin_end_row_m,
            kind: self.skin_kind,
            ..SkinSpec::from_tube(&self.tube, around, along)
        };
        let mut skin = Skin::new(self.skin_law()?, &spec, ends)?;
        skin.round_rings = self.round_zone;
        // The solid wall's element loop follows the DEM's instruction set.
        if let Some(solid) = &mut skin.solid {
            solid.avx2 = dem::simd() == dem::Simd::Avx2;
        }
        Ok(skin)
    }

    /// Buoyant unit weight of the sand γ' = φ (ρ_s − ρ_w) g (N/m³).
    pub fn buoyant_unit_weight_n_m3(&self) -> f64 {
        self.packing * (self.grain_density_kg_m3 - self.water_density_kg_m3) * GRAVITY_M_S2
    }

    /// Vertical effective stress the surcharge layer applies on the slab
    /// top: γ'·(h − slab top) (Pa).
    pub fn surcharge_pa(&self) -> f64 {
        self.buoyant_unit_weight_n_m3() * (self.depth_m - self.above_m())
    }

    /// Vertical effective stress at the axis, γ'·h (Pa).
    pub fn vertical_stress_at_axis_pa(&self) -> f64 {
        self.buoyant_unit_weight_n_m3() * self.depth_m
    }

    /// Slab length along the axis: the zone plus the sand ahead (m).
    pub fn slab_length_m(&self) -> f64 {
        self.zone_length_m() + self.ahead_m
    }

    /// Length of the expansion zone along the axis (m).
    pub fn zone_length_m(&self) -> f64 {
        SkinSpec::from_tube(&self.tube, 3, 1).length_m
    }

    /// The head's draw through an expansion from `start_diameter_m` (m) of
    /// a zone `length_m` (m) long, to this case's final diameter; `None`
    /// unless [`ScenarioSpec::head`] draws it.
    pub fn head_draw(&self, start_diameter_m: f64, length_m: f64) -> Option<HeadDraw> {
        let meridian = HeadDraw::meridian(start_diameter_m, self.final_diameter_m, length_m);
        match self.head {
            HeadSupport::Drawn => Some(meridian),
            HeadSupport::DrawnBy(m) => Some(HeadDraw {
                final_receding_m: m,
                ..meridian
            }),
            HeadSupport::Free | HeadSupport::Held => None,
        }
    }

    /// The head's draw through this case's expansion ([`ScenarioSpec::head_draw`]
    /// from the zone's rest outer diameter D0 over its length): one law of
    /// D for the run ([`crate::run::inflate`]) and for the free-skin
    /// reference subtracted from it ([`crate::FreeCurve`]), so that both
    /// draw the head back by the same D_r at the same D. `None` unless
    /// [`ScenarioSpec::head`] draws it.
    pub fn expansion_head_draw(&self) -> Option<HeadDraw> {
        self.head_draw(self.tube.outer_diameter_mm * 1e-3, self.zone_length_m())
    }

    /// This case with the box's floor `below_m` (m) below the axis, the
    /// settling time following the deeper or shallower column.
    pub fn with_floor_below(self, below_m: f64) -> ScenarioSpec {
        ScenarioSpec {
            below_m,
            settle_s: Self::column_settle_s(below_m + self.above_m()),
            ..self
        }
    }

    /// The smallest grain radius (m): the face block's, else the sand's.
    pub fn min_grain_radius_m(&self) -> f64 {
        self.face_grain_radius_m
            .map_or(self.grain_radius_m, |f| f.min(self.grain_radius_m))
    }

    /// The block of finer grains in front of the head, when there is one:
    /// its corners (m), x and y within the face radius `face_radius_m` plus
    /// two coarse grains, z from the face at `zone_m` one face radius
    /// ahead (at most to the far end).
    pub fn face_block_m(
        &self,
        zone_m: f64,
        face_radius_m: f64,
    ) -> Option<(Vector3<f64>, Vector3<f64>)> {
        let rf = self.face_grain_radius_m?;
        let half = face_radius_m + 2.0 * self.grain_radius_m;
        // Inside the box's sides and floor.
        let half_x = half.min(0.5 * self.box_width_m - rf);
        let low_y = (-half).max(-self.below_m + rf);
        let front = zone_m + 1.1 * rf;
        let back = (zone_m + face_radius_m).min(zone_m + self.ahead_m - rf);
        Some((
            Vector3::new(-half_x, low_y, front),
            Vector3::new(half_x, half, back),
        ))
    }

    /// The paper's balloon experiment at this case's depth (its p_e, the
    /// like of Δp_i, ± SD), for the paper's actuator expanded to the
    /// paper's 25 mm in the paper's sand and water at one of the
    /// experiment's depths; `None` otherwise.
    pub fn balloon_point(&self) -> Option<BalloonPoint> {
        let paper = self.tube == TubeGeometry::PAPER
            && (self.final_diameter_m * 1e3 - BALLOON_FINAL_DIAMETER_MM).abs() < 1e-9
            && self.grain_density_kg_m3 == GRAIN_DENSITY_KG_M3
            && self.water_density_kg_m3 == SEAWATER_DENSITY_KG_M3
            && self.friction == FRICTION;
        let h_mm = self.depth_m * 1e3;
        BALLOON_TABLE
            .iter()
            .find(|b| paper && (b.depth_mm - h_mm).abs() < 1e-6)
            .copied()
    }

    /// DEM time step of the advance and the expansion (s): the throughput
    /// benchmark's 1.5e-5 s for 1 mm grains of 2920 kg/m³ and 1e7 Pa,
    /// scaled as the Rayleigh time, ∝ r √(ρ/E), for the finest grains.
    pub fn dt_s(&self) -> f64 {
        self.dt_at_s(self.grain_modulus_pa)
    }

    /// The grains as the expansion meets them: their material (at
    /// [`ScenarioSpec::grain_modulus_pa`]), their contact law with one
    /// another (friction, rolling resistance, restitution) and the time
    /// step of the expansion (s). The element tests of the sand take them
    /// from here.
    pub fn grains(&self) -> (Material, ContactSpec, f64) {
        let laws = Laws::of(self, self.grain_modulus_pa);
        (laws.mat, laws.rough, laws.dt_s)
    }

    /// DEM time step while the bed settles (s), as [`ScenarioSpec::dt_s`]
    /// for the deposition modulus.
    pub fn settle_dt_s(&self) -> f64 {
        self.dt_at_s(self.deposition_modulus_pa)
    }

    fn dt_at_s(&self, modulus_pa: f64) -> f64 {
        1.5e-5 * self.min_grain_radius_m() / 1e-3
            * (self.grain_density_kg_m3 / GRAIN_DENSITY_KG_M3).sqrt()
            * (DEPOSITION_MODULUS_PA / modulus_pa).sqrt()
    }

    /// The grains' material at Young's modulus `modulus_pa` (Pa): ν = 0.3,
    /// this case's grain density.
    fn sand_at(&self, modulus_pa: f64) -> Material {
        Material {
            youngs_modulus_pa: modulus_pa,
            poisson_ratio: 0.3,
            density_kg_m3: self.grain_density_kg_m3,
        }
    }

    fn validate(&self) -> Result<()> {
        let pos = |v: f64| v > 0.0 && v.is_finite();
        ensure!(pos(self.grain_radius_m), "grain radius must be positive");
        ensure!(
            self.skin_kind.layers() <= MAX_SKIN_LAYERS,
            "a solid skin of {} layers: at most {MAX_SKIN_LAYERS} (the explicit step shrinks with the layer's thickness)",
            self.skin_kind.layers()
        );
        ensure!(
            pos(self.grain_modulus_pa) && pos(self.deposition_modulus_pa),
            "grain modulus {} Pa and deposition modulus {} Pa must be positive",
            self.grain_modulus_pa,
            self.deposition_modulus_pa
        );
        if let Some(rf) = self.face_grain_radius_m {
            ensure!(
                pos(rf) && rf < self.grain_radius_m && rf >= 0.2 * self.grain_radius_m,
                "face grain radius {} mm must lie between a fifth of the grain radius {} mm and it",
                rf * 1e3,
                self.grain_radius_m * 1e3
            );
        }
        ensure!(
            pos(self.depth_m),
            "depth {} mm must be positive (the zone's axis below the sand surface)",
            self.depth_m * 1e3
        );
        ensure!(
            self.depth_m >= self.above_m() && self.above_m() > 0.0,
            "depth {} mm must be at or below the slab top at {} mm above the axis",
            self.depth_m * 1e3,
            self.above_m() * 1e3
        );
        ensure!(
            self.depth_m >= 0.5 * self.final_diameter_m + 2.0 * self.grain_radius_m,
            "depth {} mm leaves the expanded zone (radius {} mm) under less than a grain of sand",
            self.depth_m * 1e3,
            0.5 * self.final_diameter_m * 1e3
        );
        let gap_below = self.below_m - 0.5 * self.final_diameter_m;
        ensure!(
            self.grain_radius_m <= 0.4 * gap_below,
            "grain radius {} mm too coarse for the {:.1} mm gap below the zone",
            self.grain_radius_m * 1e3,
            gap_below * 1e3
        );
        let gap_side = 0.5 * (self.box_width_m - self.final_diameter_m);
        ensure!(
            gap_side >= 2.0 * self.grain_radius_m,
            "box width {:.1} mm leaves less than a grain ({:.2} mm) beside the expanded zone ({:.2} mm)",
            self.box_width_m * 1e3,
            2.0 * self.grain_radius_m * 1e3,
            self.final_diameter_m * 1e3
        );
        let d0 = self.tube.outer_diameter_mm * 1e-3;
        ensure!(
            self.final_diameter_m > d0 && self.final_diameter_m.is_finite(),
            "final diameter {:.2} mm must exceed the rest diameter {:.2} mm",
            self.final_diameter_m * 1e3,
            d0 * 1e3
        );
        ensure!(
            pos(self.grain_density_kg_m3)
                && self.water_density_kg_m3 >= 0.0
                && self.water_density_kg_m3 < self.grain_density_kg_m3,
            "grain density {} kg/m³ must be positive and exceed the water's {} kg/m³ (grains that float cannot settle)",
            self.grain_density_kg_m3,
            self.water_density_kg_m3
        );
        ensure!(
            [self.friction, self.wall_friction, self.skin_friction]
                .iter()
                .all(|m| (0.0..=2.0).contains(m)),
            "friction {}, wall friction {} and skin friction {} must lie in 0..=2",
            self.friction,
            self.wall_friction,
            self.skin_friction
        );
        ensure!(
            pos(self.settle_s) && pos(self.expansion_s) && self.frames >= 1 && self.samples >= 1,
            "settle/expansion times, frames and samples must be positive"
        );
        ensure!(
            self.advance_m >= 0.0
                && self.advance_m <= 0.5 * self.ahead_m
                && pos(self.advance_s),
            "advance {} mm must lie between 0 and half the sand ahead ({} mm), over a positive time",
            self.advance_m * 1e3,
            0.5 * self.ahead_m * 1e3
        );
        ensure!(
            self.advance_hold_s >= 0.0 && self.advance_hold_s.is_finite(),
            "the pause after the advance ({} s) must be 0 or positive",
            self.advance_hold_s
        );
        ensure!(
            pos(self.skin_stiffness_scale),
            "skin stiffness scale {} must be positive",
            self.skin_stiffness_scale
        );
        ensure!(
            (0.0..=1.0).contains(&self.rolling_friction)
                && (0.0..=1.0).contains(&self.deposition_friction),
            "rolling friction {} and deposition friction {} must lie in 0..=1",
            self.rolling_friction,
            self.deposition_friction
        );
        Ok(())
    }
}

/// The skin of law `law` as a contact material: E = 3μ, nearly
/// incompressible, tissue density.
pub fn skin_material(law: &dyn StrainEnergy) -> Material {
    Material {
        youngs_modulus_pa: 3.0 * law.shear_modulus_kpa() * 1e3,
        poisson_ratio: 0.49,
        density_kg_m3: SkinSpec::TISSUE_DENSITY_KG_M3,
    }
}

/// The grains' contact law while the bed settles (the deposition
/// modulus) with inter-grain friction `friction` and the rolling
/// resistance of `spec`.
pub fn grain_contacts(spec: &ScenarioSpec, friction: f64) -> Result<ContactModel> {
    let laws = Laws::of(spec, spec.deposition_modulus_pa);
    laws.grains(&ContactSpec {
        friction,
        ..laws.rough
    })
}

/// Wall indices in [`Params::walls`].
pub mod wall {
    /// The floor (y = −below).
    pub const FLOOR: usize = 0;
    /// The box side at x = −w/2.
    pub const SIDE_NEG_X: usize = 1;
    /// The box side at x = +w/2.
    pub const SIDE_POS_X: usize = 2;
    /// The body's plane behind the zone (z = 0).
    pub const BACK: usize = 3;
    /// The far end ahead of the front face.
    pub const FAR: usize = 4;
}

/// A built scenario, ready to settle.
#[derive(Debug)]
pub struct Bed {
    /// What it was built from.
    pub spec: ScenarioSpec,
    /// DEM parameters (walls as in [`wall`]).
    pub params: Params,
    /// Particles and time.
    pub state: State,
    /// The skin, its contact law and the front face.
    pub coupling: Coupling<SkinLaw>,
    /// Grains of the slab (the first ones in `state.particles`).
    pub slab_grains: usize,
    /// Heavy surcharge grains (the last ones).
    pub surcharge_grains: usize,
    /// Area the surcharge acts on: box width × slab length (m²).
    pub top_area_m2: f64,
}

impl Bed {
    /// Sum of the grains' buoyant weights (N), the surcharge's included.
    pub fn buoyant_weight_n(&self) -> f64 {
        let g = self.params.gravity_m_s2.norm() * self.params.buoyancy_factor();
        self.state.particles.mass_kg.iter().sum::<f64>() * g
    }
}

/// The grains of `spec` at Young's modulus `modulus_pa` (Pa): their
/// material, contact settings and time step; one definition for the bed as
/// built and as stiffened.
struct Laws {
    dt_s: f64,
    mat: Material,
    /// Grain–grain and grain–face: the sand's friction.
    rough: ContactSpec,
    /// Grain–skin.
    on_skin: ContactSpec,
    /// Grain–wall, in [`wall`] order: smooth floor, back and far end, the
    /// sides at the wall friction.
    walls: [ContactSpec; 5],
}

impl Laws {
    fn of(spec: &ScenarioSpec, modulus_pa: f64) -> Laws {
        let rough = ContactSpec {
            friction: spec.friction,
            rolling_friction: spec.rolling_friction,
            ..ContactSpec::default()
        };
        let smooth = ContactSpec {
            friction: 0.0,
            ..rough
        };
        let side = ContactSpec {
            friction: spec.wall_friction,
            ..rough
        };
        Laws {
            dt_s: spec.dt_at_s(modulus_pa),
            mat: spec.sand_at(modulus_pa),
            on_skin: ContactSpec {
                friction: spec.skin_friction,
                ..rough
            },
            rough,
            walls: [smooth, side, side, smooth, smooth],
        }
    }

    /// Grain–grain (and grain–face) contacts.
    fn grains(&self, s: &ContactSpec) -> Result<ContactModel> {
        Ok(ContactModel::hertz_mindlin(&self.mat, &self.mat, s)?)
    }

    /// Grain–skin contacts for the skin of `law`.
    fn skin(&self, law: &dyn StrainEnergy) -> Result<ContactModel> {
        Ok(ContactModel::hertz_mindlin(
            &self.mat,
            &skin_material(law),
            &self.on_skin,
        )?)
    }
}

impl Bed {
    /// Gives the grains Young's modulus `modulus_pa` (Pa): every contact
    /// law (grains, walls, skin, face) and the time step; the contact
    /// histories (tangential displacements) are kept.
    pub fn set_grain_modulus(&mut self, modulus_pa: f64) -> Result<()> {
        ensure!(
            modulus_pa > 0.0 && modulus_pa.is_finite(),
            "grain modulus {modulus_pa} Pa must be positive"
        );
        let laws = Laws::of(&self.spec, modulus_pa);
        ensure!(
            self.params.walls.len() == laws.walls.len(),
            "the bed has {} walls, not the scenario's {}",
            self.params.walls.len(),
            laws.walls.len()
        );
        self.params.dt_s = laws.dt_s;
        self.params.pair_model = laws.grains(&laws.rough)?;
        for (w, s) in self.params.walls.iter_mut().zip(&laws.walls) {
            w.model = laws.grains(s)?;
        }
        self.coupling.model = laws.skin(&self.spec.skin_law()?)?;
        self.coupling.set_dt_s(laws.dt_s);
        if let Some(face) = &mut self.coupling.face {
            face.model = laws.grains(&laws.rough)?;
            face.dt_s = laws.dt_s;
        }
        Ok(())
    }
}

/// Builds the bed of `spec`: the skin at rest holding its fluid volume,
/// grains on a
/// jittered lattice round it filled bottom-up, then the surcharge rows.
pub fn build(spec: &ScenarioSpec) -> Result<Bed> {
    spec.validate()?;
    let r = spec.grain_radius_m;
    // The bed is built for settling, at the deposition modulus.
    let laws = Laws::of(spec, spec.deposition_modulus_pa);
    let dt = laws.dt_s;
    let mut params = Params::new(&laws.mat, &laws.rough, dt)?;
    params.gravity_m_s2 = Vector3::new(0.0, -GRAVITY_M_S2, 0.0);
    params.fluid_density_kg_m3 = spec.water_density_kg_m3;
    params.skin_m = 0.2 * spec.min_grain_radius_m();
    let (w, zl) = (spec.box_width_m, spec.slab_length_m());
    let planes = [
        (Vector3::new(0.0, -spec.below_m, 0.0), Vector3::y()),
        (Vector3::new(-0.5 * w, 0.0, 0.0), Vector3::x()),
        (Vector3::new(0.5 * w, 0.0, 0.0), -Vector3::x()),
        (Vector3::zeros(), Vector3::z()),
        (Vector3::new(0.0, 0.0, zl), -Vector3::z()),
    ];
    for ((point, normal), s) in planes.into_iter().zip(&laws.walls) {
        params
            .walls
            .push(Wall::plane(point, normal, &laws.mat, &laws.mat, s)?);
    }

    let mut skin = spec.skin(Ends::Head)?;
    skin.damping_per_s = 100.0;
    // The zone at rest (D0) holds its fluid volume while the bed settles
    // (the coelom is closed): the sand raises the pressure instead of
    // crushing the soft skin (held at a pressure of γ'·h instead, the zone
    // was dented to 17.1 mm at h = 40 mm; at 2γ'·h it swelled to 20.8 mm).
    skin.volume_control = Some(VolumeControl {
        target_volume_m3: skin.enclosed_volume_m3(),
        bulk_modulus_pa: FLUID_BULK_MODULUS_PA,
    });
    let zone_m = skin.spec.length_m;
    let mut coupling = Coupling::new(skin, laws.skin(&spec.skin_law()?)?, dt)?;
    coupling.set_mass_scaling(spec.skin_mass_scaling && spec.skin_kind.layers() > 0)?;
    // The face spans the clamped end ring's outer radius.
    let face_radius = coupling.skin.spec.mid_radius_m + 0.5 * coupling.skin.spec.thickness_m;
    let face_model = laws.grains(&laws.rough)?;
    coupling.face = FrontFace::new(
        Vector3::new(0.0, 0.0, zone_m),
        Vector3::z(),
        face_radius,
        face_model,
        dt,
    );
    let keep_out = 0.5 * coupling.skin.outer_diameter_at_mid_length_m() + 1.1 * r;

    let mut rng = rand::rngs::StdRng::seed_from_u64(spec.seed);
    // The face block first: a full jittered lattice of the fine grains
    // (solid fraction 0.45; it packs as it settles and the coarse sand
    // above follows).
    let block = spec.face_block_m(zone_m, face_radius);
    let mut fine = Vec::new();
    if let (Some((lo, hi)), Some(rf)) = (block, spec.face_grain_radius_m) {
        let pitch = 2.1 * rf;
        let jitter = 0.04 * rf;
        let count = |a: usize| ((hi[a] - lo[a]) / pitch).floor() as usize + 1;
        for k in 0..count(2) {
            for j in 0..count(1) {
                for i in 0..count(0) {
                    let mut jit = || rng.random_range(-jitter..=jitter);
                    let p = Vector3::new(
                        lo.x + i as f64 * pitch + jit(),
                        lo.y + j as f64 * pitch + jit(),
                        lo.z + k as f64 * pitch + jit(),
                    );
                    fine.push(p);
                }
            }
        }
    }
    let fine_radius = spec.face_grain_radius_m.unwrap_or(r);
    let ball = |radius: f64| 4.0 / 3.0 * std::f64::consts::PI * radius.powi(3);
    // A coarse grain closer to the block's lattice than the two radii and
    // both jitters would overlap a fine one.
    let margin = 1.04 * (r + fine_radius);
    let in_block = |p: &Vector3<f64>| {
        block.is_some_and(|(lo, hi)| (0..3).all(|a| p[a] > lo[a] - margin && p[a] < hi[a] + margin))
    };

    // Grain count for the slab at the assumed packing: the block's grains
    // count for their own volume.
    let zone_volume = std::f64::consts::PI * keep_out.powi(2) * zone_m;
    let slab_volume = w * (spec.below_m + spec.above_m()) * zl - zone_volume;
    let grain_volume = ball(r);
    let coarse = ((spec.packing * slab_volume - fine.len() as f64 * ball(fine_radius))
        / grain_volume)
        .round()
        .max(0.0) as usize;
    let slab_grains = fine.len() + coarse;

    let pitch = 2.1 * r;
    let jitter = 0.04 * r;
    let per_axis = |len: f64| ((len - pitch) / pitch).floor() as usize + 1;
    let (nx, nz) = (per_axis(w), per_axis(zl));
    let x0 = -0.5 * w + 0.5 * (w - (nx - 1) as f64 * pitch);
    let z0 = 0.5 * (zl - (nz - 1) as f64 * pitch);
    let mut positions = Vec::with_capacity(slab_grains + spec.surcharge_rows() * nx * nz);
    positions.append(&mut fine);
    let fine_grains = positions.len();
    let mut row = 0usize;
    let mut surcharge_start = None;
    while surcharge_start.is_none_or(|k0| row < k0 + spec.surcharge_rows()) {
        let y = -spec.below_m + 0.5 * pitch + row as f64 * pitch;
        for j in 0..nz {
            for i in 0..nx {
                if surcharge_start.is_none() && positions.len() == slab_grains {
                    break;
                }
                let mut jit = || rng.random_range(-jitter..=jitter);
                let p = Vector3::new(
                    x0 + i as f64 * pitch + jit(),
                    y + jit(),
                    z0 + j as f64 * pitch + jit(),
                );
                let by_zone = p.z < zone_m + r + 0.1 * r && p.x.hypot(p.y) < keep_out;
                if !by_zone && !in_block(&p) {
                    positions.push(p);
                }
            }
        }
        if surcharge_start.is_none() && positions.len() >= slab_grains {
            surcharge_start = Some(row + 1);
        }
        row += 1;
    }
    let surcharge_grains = positions.len() - slab_grains;
    ensure!(
        (surcharge_grains > 0) == (spec.surcharge_rows() > 0),
        "{surcharge_grains} surcharge grains placed for {} rows",
        spec.surcharge_rows()
    );
    let top_area_m2 = w * zl;
    // Each heavy grain's buoyant weight: its share of σ·A.
    let g_eff = GRAVITY_M_S2 * params.buoyancy_factor();
    let heavy_mass = spec.surcharge_pa() * top_area_m2 / (surcharge_grains.max(1) as f64 * g_eff);
    let heavy_density = heavy_mass / grain_volume;
    let mut particles = Particles::new();
    for (k, p) in positions.into_iter().enumerate() {
        let rho = if k < slab_grains {
            spec.grain_density_kg_m3
        } else {
            heavy_density
        };
        let radius = if k < fine_grains { fine_radius } else { r };
        particles.push(p, Vector3::zeros(), radius, rho)?;
    }
    Ok(Bed {
        spec: spec.clone(),
        params,
        state: State::new(particles),
        coupling,
        slab_grains,
        surcharge_grains,
        top_area_m2,
    })
}
