//! # FEM skin
//!
//! The expansion zone's skin as a 3D hyperelastic membrane: constant-strain
//! triangles on the mid-surface of the tube ([`mesh`]), total Lagrangian,
//! incompressible (thickness stretch λ3 = 1/(λ1·λ2)), with the strain
//! energy of any [`StrainEnergy`] law (the skin model's Yeoh by default) —
//! see [`element`]. Loaded by an internal pressure acting on the deformed
//! surface (a follower load). Time integration is explicit central
//! difference with lumped masses and mass-proportional damping
//! ([`Skin::step`]); quasi-static states come from dynamic relaxation with
//! kinetic damping ([`Skin::relax`]). Loads: a prescribed pressure, or an
//! injected volume ([`VolumeControl`]); [`vtk`] writes the state for
//! ParaView.
//!
//! With [`SkinKind::Shell`] the skin is a shell: [`bending`] adds the
//! wall's resistance to bending (rotation-free Kirchhoff–Love, clamped
//! ends holding the slope), and the element stresses become those of its
//! outer and inner surfaces. [`SkinSpec::end_row_m`] grades the rows
//! ([`mesh::TubeMesh::graded`]) so the bending layer at the clamped ends
//! is resolved.
//!
//! With [`SkinKind::Solid`] the wall is a solid ([`solid`]):
//! hexahedra through its thickness, the law made slightly compressible,
//! the fluid on the inner surface and the sand on the outer one; the node
//! arrays then hold every layer, and [`Skin::elements`] is the outer
//! surface the sand touches.
//!
//! SI units throughout (m, kg, s, N, Pa), like the DEM it is coupled to.
//!
//! Any law that gives W(I1, I2) and its derivatives drives it; here a
//! neo-Hookean one, W = C10 (I1 − 3):
//!
//! ```
//! use fem::{Ends, Skin, SkinSpec, StrainEnergy};
//!
//! #[derive(Debug)]
//! struct NeoHookean { c10_kpa: f64 }
//!
//! impl StrainEnergy for NeoHookean {
//!     fn name(&self) -> &'static str { "neo-Hookean" }
//!     fn parameters(&self) -> Vec<f64> { vec![self.c10_kpa] }
//!     fn energy_kpa(&self, i1: f64, _: f64) -> f64 { self.c10_kpa * (i1 - 3.0) }
//!     fn dw_di1_kpa(&self, _: f64, _: f64) -> f64 { self.c10_kpa }
//!     fn dw_di2_kpa(&self, _: f64, _: f64) -> f64 { 0.0 }
//!     fn d2w_di1_di1_kpa(&self, _: f64, _: f64) -> f64 { 0.0 }
//!     fn d2w_di1_di2_kpa(&self, _: f64, _: f64) -> f64 { 0.0 }
//!     fn d2w_di2_di2_kpa(&self, _: f64, _: f64) -> f64 { 0.0 }
//! }
//!
//! let law = NeoHookean { c10_kpa: 10.0 };
//! let mut skin = Skin::new(law, &SkinSpec::paper(16, 4), Ends::Clamped).unwrap();
//! skin.pressure_pa = 500.0;
//! skin.relax(1e-4, 200_000).unwrap();
//! assert!(skin.outer_diameter_at_mid_length_m() > 18.7e-3);
//! ```

pub mod bending;
pub mod element;
pub mod mesh;
pub mod solid;
pub mod vtk;

mod strain_energy;
mod tube;
pub use strain_energy::{LawVisitor, StrainEnergy};
pub use tube::TubeGeometry;

use std::num::NonZeroUsize;

use nalgebra::{Matrix2, Matrix3, Vector3};

use bending::{von_mises_3d_pa, Bending};
use element::{internal_forces_n, Strain, Triangle};
use mesh::TubeMesh;
use solid::Solid;

/// What can go wrong in the skin solver.
#[derive(Clone, Debug, thiserror::Error, PartialEq)]
pub enum FemError {
    /// A parameter is out of its range.
    #[error("FEM parameter {name} = {value} is out of range")]
    Param {
        /// Which parameter.
        name: &'static str,
        /// Its value.
        value: f64,
    },
    /// A triangle collapsed or turned inside out (time step too large, or
    /// a load the membrane cannot carry).
    #[error("skin element {element} collapsed (det C ≤ 0 or not finite)")]
    Collapsed {
        /// Its index.
        element: usize,
    },
    /// Dynamic relaxation did not reach the tolerance.
    #[error("dynamic relaxation stopped after {steps} steps at residual {residual_n} N (tolerance {tolerance_n} N)")]
    NotConverged {
        /// Steps taken.
        steps: usize,
        /// Largest nodal out-of-balance force left (N).
        residual_n: f64,
        /// The tolerance asked for (N).
        tolerance_n: f64,
    },
}

impl FemError {
    pub(crate) fn param(name: &'static str, value: f64) -> FemError {
        FemError::Param { name, value }
    }
}

/// Geometry, mesh density and density of the skin.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SkinSpec {
    /// Rest mid-surface radius (m).
    pub mid_radius_m: f64,
    /// Rest wall thickness T (m).
    pub thickness_m: f64,
    /// Rest length of the zone (m).
    pub length_m: f64,
    /// Skin density (kg/m³).
    pub density_kg_m3: f64,
    /// Nodes round the circumference.
    pub around: usize,
    /// Element rows along the axis.
    pub along: usize,
    /// How the wall is modelled: mid-surface membrane (the default of
    /// [`SkinSpec::from_tube`]), bending shell, or solid hexahedra.
    pub kind: SkinKind,
    /// Graded rows: `Some(h)` makes the rows h long (m) at both ends,
    /// growing towards the middle up to `length_m / along`
    /// ([`TubeMesh::graded`]), to resolve the bending layer at clamped
    /// ends; `None`: `along` rows of equal length.
    pub end_row_m: Option<f64>,
}

/// How the skin's wall is modelled. A solid resists bending of itself, so
/// a "solid shell" cannot be asked for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SkinKind {
    /// Triangles on the mid-surface, no bending stiffness.
    Membrane,
    /// The membrane plus Kirchhoff–Love bending ([`bending`]).
    Shell,
    /// A solid wall of hexahedra ([`solid`]), `layers` through the
    /// thickness.
    Solid {
        /// Hexahedra through the thickness.
        layers: NonZeroUsize,
    },
}

impl SkinKind {
    /// A solid wall `layers` hexahedra thick; `None` for zero layers.
    pub fn solid(layers: usize) -> Option<SkinKind> {
        NonZeroUsize::new(layers).map(|layers| SkinKind::Solid { layers })
    }

    /// Hexahedra through the wall: 0 for a membrane or a shell.
    pub fn layers(self) -> usize {
        match self {
            SkinKind::Solid { layers } => layers.get(),
            SkinKind::Membrane | SkinKind::Shell => 0,
        }
    }

    /// Whether the mid-surface carries the bending energy.
    pub fn is_shell(self) -> bool {
        self == SkinKind::Shell
    }
}

impl SkinSpec {
    /// Density of the skin tissue (kg/m³): water-like soft tissue.
    pub const TISSUE_DENSITY_KG_M3: f64 = 1050.0;

    /// The mid-surface of a tube of rest geometry `g`: radius
    /// (Ro + Ri)/2, thickness and length from `g`.
    pub fn from_tube(g: &TubeGeometry, around: usize, along: usize) -> SkinSpec {
        SkinSpec {
            mid_radius_m: 0.5 * (g.outer_radius_mm() + g.inner_radius_mm()) * 1e-3,
            thickness_m: g.wall_thickness_mm * 1e-3,
            length_m: g.length_mm * 1e-3,
            density_kg_m3: Self::TISSUE_DENSITY_KG_M3,
            around,
            along,
            kind: SkinKind::Membrane,
            end_row_m: None,
        }
    }

    /// The paper's zone (D0 = 18.7 mm outer, 1.75 mm wall, 20 mm long).
    pub fn paper(around: usize, along: usize) -> SkinSpec {
        Self::from_tube(&TubeGeometry::PAPER, around, along)
    }
}

/// Node indices of ring `j` in every layer of a wall `layers` elements
/// thick (0: the mid-surface mesh's ring alone), layers numbered as
/// [`Solid::node`].
fn layered_ring(mesh: &TubeMesh, layers: usize, j: usize) -> impl Iterator<Item = usize> {
    let (ring, per_layer) = (mesh.ring(j), mesh.rest_m.len());
    (0..=layers).flat_map(move |l| ring.clone().map(move |a| l * per_layer + a))
}

/// How the ends of the zone are held.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Ends {
    /// End rings held axially, free radially: a long tube's uniform
    /// inflation in plane strain (λz = 1), for verification.
    PlaneStrain,
    /// End rings fixed to the rigid rest of the body.
    Clamped,
    /// Closed ends, free length: the z = 0 ring held axially (free
    /// radially), the far ring free and pulled by the pressure on a flat
    /// end cap spanning it (the closed-end tube, for verification).
    Closed,
    /// The back ring fixed to the body, the front ring to a rigid head
    /// ([`Head`]) that slides along the axis: the ring keeps its radius
    /// and moves with the head, which the skin's axial pull and the sand
    /// on its face drive. The fluid loads the skin only: the head cap's
    /// share is carried by the body's longitudinal muscles (not modelled),
    /// as in the paper's FEM–DEM model, where the bulging skin draws the
    /// head back (the head receding distance D_r).
    Head,
}

/// The rigid head closing the front ring of [`Ends::Head`]: one axial
/// degree of freedom.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Head {
    /// Mass of the head (kg), the front ring's nodes not included.
    pub mass_kg: f64,
    /// Axial displacement from rest (m), positive forwards (+z).
    pub displacement_m: f64,
    /// Axial velocity (m/s), at the half step like the nodes'.
    pub velocity_m_s: f64,
    /// Axial force on the head from outside the skin (N), e.g. the sand on
    /// its front face; set by the caller before each step.
    pub external_force_n: f64,
    /// Displacement D_r is measured from (m), e.g. where the head sat
    /// when the expansion began.
    pub origin_m: f64,
    /// When set, the head is driven at this axial velocity (m/s) whatever
    /// the forces on it (the body pushing it forward); `None`: free.
    pub driven_m_s: Option<f64>,
    /// The axial force of the skin and the sand on a driven head in its
    /// last step (N, + forward): what the body that drives it takes, its
    /// inertia left out (+: the body pulls it back). 0 when free.
    pub pull_n: f64,
}

impl Head {
    /// A free head at rest of `mass_kg` (kg).
    pub fn at_rest(mass_kg: f64) -> Head {
        Head {
            mass_kg,
            displacement_m: 0.0,
            velocity_m_s: 0.0,
            external_force_n: 0.0,
            origin_m: 0.0,
            driven_m_s: None,
            pull_n: 0.0,
        }
    }

    /// How far the head has receded from [`Head::origin_m`], D_r (m),
    /// positive backwards.
    pub fn receding_m(&self) -> f64 {
        self.origin_m - self.displacement_m
    }
}

/// Loading by injected volume: the fluid inside is a penalty (a stiff
/// compressible liquid), p = K·(V_target − V)/V_target, so the enclosed
/// volume V (end planes included, see [`Skin::enclosed_volume_m3`]) reaches
/// the target to within p/K.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VolumeControl {
    /// Volume of fluid the skin must enclose (m³).
    pub target_volume_m3: f64,
    /// Penalty bulk modulus K (Pa): ≫ the pressures expected; it also
    /// shortens the stable time step (see [`Skin::stable_time_step_s`]).
    pub bulk_modulus_pa: f64,
}

/// Result of a dynamic relaxation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Relaxed {
    /// Steps taken.
    pub steps: usize,
    /// Largest nodal out-of-balance force left (N).
    pub residual_n: f64,
}

/// The skin: mesh, law and the evolving nodal state.
#[derive(Clone, Debug)]
pub struct Skin<S: StrainEnergy> {
    /// The strain-energy law.
    pub law: S,
    /// Rest geometry and mesh density.
    pub spec: SkinSpec,
    /// The mid-surface mesh.
    pub mesh: TubeMesh,
    /// The bending term (`None`: not a [`SkinKind::Shell`]).
    pub bending: Option<Bending>,
    /// The solid wall (`None`: a membrane or shell, see
    /// [`SkinSpec::kind`]). With it the nodes are the wall's layers ([`Solid::node`]).
    pub solid: Option<Solid>,
    /// Element reference data, one per `mesh.triangles` entry: the
    /// mid-surface membrane, or for a solid wall its outer surface (what
    /// the sand touches; no mechanics of its own).
    pub elements: Vec<Triangle>,
    /// Rest node positions (m): the mesh's, or every layer's of a solid.
    pub rest_m: Vec<Vector3<f64>>,
    /// Current node positions (m).
    pub position_m: Vec<Vector3<f64>>,
    /// Node velocities (m/s), at the half step in [`Skin::step`].
    pub velocity_m_s: Vec<Vector3<f64>>,
    /// Lumped nodal masses (kg).
    pub mass_kg: Vec<f64>,
    /// Per node and component: held fixed.
    pub fixed: Vec<[bool; 3]>,
    /// How the ends are held.
    pub ends: Ends,
    /// Internal minus external fluid pressure on the inner surface (Pa):
    /// set by the caller, or by [`Skin::volume_control`] when that is on.
    pub pressure_pa: f64,
    /// Injected-volume loading: when set, the pressure follows the
    /// enclosed volume instead of being prescribed.
    pub volume_control: Option<VolumeControl>,
    /// Mass-proportional damping coefficient c (1/s): the damping force
    /// on a node is −c·m·v. Default 0.
    pub damping_per_s: f64,
    /// Forces from outside the skin (contacts) on each node (N), applied
    /// by [`Skin::step`] and left for the caller to clear.
    pub external_force_n: Vec<Vector3<f64>>,
    /// Simulated time (s).
    pub time_s: f64,
    /// The rigid head of [`Ends::Head`] (`None` for the other ends). Its
    /// default mass is a tissue hemisphere of the zone's outer radius.
    pub head: Option<Head>,
    /// [`Ends::Head`]: the body's axial velocity (m/s), carrying the back
    /// ring (the body advancing with its head); 0 at rest.
    pub body_velocity_m_s: f64,
    /// [`Ends::Head`]: how far the body has carried the back ring from
    /// rest along +z (m).
    pub body_displacement_m: f64,
    /// Keep the rings round in [`Skin::step`]: each inner ring moves only
    /// radially and axially as a whole (an axisymmetric constraint, off by
    /// default). It isolates the response of what surrounds the skin to a
    /// round expansion from the skin's own choice of shape; [`Skin::relax`]
    /// ignores it.
    pub round_rings: bool,
}

impl<S: StrainEnergy> Skin<S> {
    /// A skin of law `law`, geometry `spec`, held by `ends`, at rest.
    pub fn new(law: S, spec: &SkinSpec, ends: Ends) -> Result<Skin<S>, FemError> {
        if !(spec.thickness_m > 0.0 && spec.thickness_m.is_finite()) {
            return Err(FemError::param("thickness_m", spec.thickness_m));
        }
        if !(spec.density_kg_m3 > 0.0 && spec.density_kg_m3.is_finite()) {
            return Err(FemError::param("density_kg_m3", spec.density_kg_m3));
        }
        let mesh = match spec.end_row_m {
            None => TubeMesh::tube(spec.mid_radius_m, spec.length_m, spec.around, spec.along)?,
            Some(end) => TubeMesh::graded(
                spec.mid_radius_m,
                spec.length_m,
                spec.around,
                end,
                spec.length_m / spec.along.max(1) as f64,
            )?,
        };
        let (solid, rest_m) = if let SkinKind::Solid { layers } = spec.kind {
            let bulk = solid::BULK_RATIO * law.shear_modulus_kpa() * element::PA_PER_KPA;
            let (s, rest) = Solid::new(&mesh, spec.thickness_m, layers.get(), bulk)?;
            (Some(s), rest)
        } else {
            (None, mesh.rest_m.clone())
        };
        let n = rest_m.len();
        let surface = solid
            .as_ref()
            .map_or_else(|| mesh.triangles.clone(), |s| s.outer(&mesh));
        let mut elements = Vec::with_capacity(surface.len());
        let mut mass_kg = vec![0.0; n];
        for (k, t) in surface.iter().enumerate() {
            let tri = Triangle::new(*t, t.map(|a| rest_m[a]))
                .ok_or(FemError::Collapsed { element: k })?;
            if solid.is_none() {
                for a in t {
                    mass_kg[*a] += spec.density_kg_m3 * spec.thickness_m * tri.area_m2 / 3.0;
                }
            }
            elements.push(tri);
        }
        if let Some(s) = &solid {
            s.lumped_masses_kg(spec.density_kg_m3, &mut mass_kg);
        }
        let layers = spec.kind.layers();
        let mut fixed = vec![[false; 3]; n];
        for j in [0, mesh.along] {
            for a in layered_ring(&mesh, layers, j) {
                fixed[a] = match (ends, j) {
                    (Ends::PlaneStrain, _) | (Ends::Closed, 0) => [false, false, true],
                    // The head's ring moves only with the head (see step).
                    (Ends::Clamped | Ends::Head, _) => [true; 3],
                    (Ends::Closed, _) => [false; 3],
                };
            }
        }
        let clamped = matches!(ends, Ends::Clamped | Ends::Head);
        let bending = spec.kind.is_shell().then(|| {
            Bending::new(
                &mesh,
                spec.thickness_m,
                law.shear_modulus_kpa() * element::PA_PER_KPA,
                clamped,
            )
        });
        Ok(Skin {
            law,
            spec: *spec,
            bending,
            solid,
            position_m: rest_m.clone(),
            rest_m,
            velocity_m_s: vec![Vector3::zeros(); n],
            external_force_n: vec![Vector3::zeros(); n],
            ends,
            mesh,
            elements,
            mass_kg,
            fixed,
            pressure_pa: 0.0,
            volume_control: None,
            damping_per_s: 0.0,
            time_s: 0.0,
            head: (ends == Ends::Head).then(|| {
                let outer = spec.mid_radius_m + 0.5 * spec.thickness_m;
                Head::at_rest(2.0 / 3.0 * std::f64::consts::PI * outer.powi(3) * spec.density_kg_m3)
            }),
            body_velocity_m_s: 0.0,
            body_displacement_m: 0.0,
            round_rings: false,
        })
    }

    /// Number of nodes.
    pub fn node_count(&self) -> usize {
        self.position_m.len()
    }

    /// Hexahedra through the wall (0 for a membrane or shell).
    fn layers(&self) -> usize {
        self.solid.as_ref().map_or(0, |s| s.layers)
    }

    /// Node indices of ring `j` through the whole wall: the mesh's ring,
    /// or that ring in every layer of a solid.
    pub fn ring_nodes(&self, j: usize) -> impl Iterator<Item = usize> + '_ {
        layered_ring(&self.mesh, self.layers(), j)
    }

    /// How far outside surface element `k` ([`Skin::elements`]) the
    /// skin's outer surface lies (m): half the current thickness of a
    /// membrane's mid-surface triangle, 0 for a solid's outer face.
    pub fn contact_offset_m(&self, k: usize) -> Result<f64, FemError> {
        if self.solid.is_some() {
            return Ok(0.0);
        }
        Ok(0.5 * self.spec.thickness_m * self.strain(k)?.thickness_stretch())
    }

    /// The triangles bounding the fluid, normals outwards: the mesh's,
    /// which are the mid-surface of a membrane and the inner surface
    /// (layer 0) of a solid.
    fn fluid_triangles(&self) -> impl Iterator<Item = [usize; 3]> + '_ {
        self.mesh.triangles.iter().copied()
    }

    /// Membrane strain of surface element `k` at the current positions
    /// (of a solid wall: its outer face's stretch, which carries no
    /// mechanics; the wall's own state is [`Solid::state`]).
    pub fn strain(&self, k: usize) -> Result<Strain, FemError> {
        let tri = &self.elements[k];
        tri.strain(tri.nodes.map(|a| self.position_m[a]))
            .ok_or(FemError::Collapsed { element: k })
    }

    /// Membrane 2nd Piola–Kirchhoff stress of element `k` (Pa).
    fn stress(&self, e: &Strain) -> Matrix2<f64> {
        e.second_piola_kirchhoff_pa(&self.law)
    }

    /// Total strain energy (J) at the current positions.
    pub fn strain_energy_j(&self) -> Result<f64, FemError> {
        if let Some(s) = &self.solid {
            return s.energy_j(&self.law, &self.position_m);
        }
        let membrane: f64 = (0..self.elements.len())
            .map(|k| {
                let e = self.strain(k)?;
                Ok(e.energy_density_pa(&self.law)
                    * self.elements[k].area_m2
                    * self.spec.thickness_m)
            })
            .sum::<Result<f64, FemError>>()?;
        let bending = self
            .bending
            .as_ref()
            .map_or(0.0, |b| b.energy_j(&self.position_m));
        Ok(membrane + bending)
    }

    /// Internal nodal forces ∂E/∂x (N) at the current positions into `out`.
    pub fn internal_forces_n(&self, out: &mut [Vector3<f64>]) -> Result<(), FemError> {
        out.iter_mut().for_each(|f| *f = Vector3::zeros());
        if let Some(s) = &self.solid {
            return s.add_internal_forces_n(&self.law, &self.position_m, out);
        }
        for (k, tri) in self.elements.iter().enumerate() {
            let e = self.strain(k)?;
            let f = internal_forces_n(tri, &e, &self.stress(&e), self.spec.thickness_m);
            for (a, fa) in tri.nodes.iter().zip(f) {
                out[*a] += fa;
            }
        }
        if let Some(b) = &self.bending {
            b.add_internal_forces_n(&self.position_m, out);
        }
        Ok(())
    }

    /// Nodal forces (N) of the internal pressure on the deformed surface,
    /// added to `out`: p times each triangle's area vector, a third per node.
    pub fn add_pressure_forces_n(&self, out: &mut [Vector3<f64>]) {
        self.add_area_vectors_m2(self.pressure_pa, out);
    }

    /// Adds `scale` times each node's share of the outward area vectors
    /// (m², a third of each touching triangle's) to `out`; with scale 1
    /// these are ∂V/∂x of the enclosed volume up to terms that cancel
    /// over a closed surface (what the stability bound needs).
    fn add_area_vectors_m2(&self, scale: f64, out: &mut [Vector3<f64>]) {
        for t in self.fluid_triangles() {
            let [a, b, c] = t.map(|a| self.position_m[a]);
            let share = (b - a).cross(&(c - a)) * (scale / 6.0);
            for n in t {
                out[n] += share;
            }
        }
    }

    /// Out-of-balance force on each node (N): pressure + external −
    /// internal, zero on fixed components.
    pub fn residual_n(&self, out: &mut [Vector3<f64>]) -> Result<(), FemError> {
        self.residual_and_head_force_n(out).map(|_| ())
    }

    /// [`Skin::residual_n`], returning also the axial force the skin puts
    /// on the head: the front ring's out-of-balance z forces before they
    /// are zeroed (N; 0 without a head).
    fn residual_and_head_force_n(&self, out: &mut [Vector3<f64>]) -> Result<f64, FemError> {
        self.internal_forces_n(out)?;
        out.iter_mut().for_each(|f| *f = -*f);
        self.add_pressure_forces_n(out);
        if self.ends == Ends::Closed {
            self.add_end_cap_forces_n(out);
        }
        for (r, ext) in out.iter_mut().zip(&self.external_force_n) {
            *r += ext;
        }
        let head_n = if self.head.is_some() {
            self.ring_nodes(self.mesh.along).map(|a| out[a].z).sum()
        } else {
            0.0
        };
        for (r, fix) in out.iter_mut().zip(&self.fixed) {
            for k in 0..3 {
                if fix[k] {
                    r[k] = 0.0;
                }
            }
        }
        Ok(head_n)
    }

    /// The pressure on the flat cap closing the far ring (closed ends),
    /// shared equally by the ring's nodes: p times the ring polygon's
    /// area vector ½Σ (x_i − c) × (x_{i+1} − c), c its centroid (a solid:
    /// its inner ring's polygon, the cap's load spread over the end face
    /// through the wall, each layer's ring by its share of the face's
    /// rest area, so the wall takes it as a uniform axial stress).
    fn add_end_cap_forces_n(&self, out: &mut [Vector3<f64>]) {
        let ring = self.mesh.ring(self.mesh.along);
        let n = ring.len();
        let x = &self.position_m[ring.clone()];
        let c = x.iter().sum::<Vector3<f64>>() / n as f64;
        let area: Vector3<f64> = (0..n)
            .map(|i| 0.5 * (x[i] - c).cross(&(x[(i + 1) % n] - c)))
            .sum();
        let layers = self.layers();
        let per_layer = self.mesh.rest_m.len();
        // Trapezoidal weights across the face, ∝ each layer's rest radius.
        let weight = |l: usize| {
            let end = if layers > 0 && (l == 0 || l == layers) {
                0.5
            } else {
                1.0
            };
            end * self.rest_m[ring.start + l * per_layer].xy().norm()
        };
        let total: f64 = (0..=layers).map(weight).sum();
        for l in 0..=layers {
            let share = area * (self.pressure_pa * weight(l) / total / n as f64);
            for a in ring.clone() {
                out[a + l * per_layer] += share;
            }
        }
    }

    /// A stable explicit time step (s) at the current strain: half the
    /// smallest element transit time of the bounded wave speed.
    pub fn stable_time_step_s(&self) -> Result<f64, FemError> {
        let dt = self.element_time_step_s()?;
        let Some(vc) = self.volume_control else {
            return Ok(dt);
        };
        // The fluid penalty is a rank-one stiffness K/V·g gᵀ (g ≈ ∂V/∂x,
        // the nodal area vectors): its frequency ω² = K/V·Σ|g_a|²/m_a
        // adds to the elements'.
        let mut g = vec![Vector3::zeros(); self.node_count()];
        self.add_area_vectors_m2(1.0, &mut g);
        let sum: f64 = g
            .iter()
            .zip(&self.mass_kg)
            .zip(&self.fixed)
            .filter(|(_, fix)| !fix.iter().all(|f| *f))
            .map(|((g, m), _)| g.norm_squared() / m)
            .sum();
        let w2 = vc.bulk_modulus_pa / vc.target_volume_m3 * sum;
        Ok(1.0 / (dt.powi(-2) + w2).sqrt())
    }

    /// Scales the wall's mass so that no element's own stable step is
    /// shorter than `target_s` (s) (see [`Solid::scale_mass_to_step_s`];
    /// a solid wall only: a membrane's elements are far longer-lived than
    /// any DEM step, and are left as they are). Velocities are kept.
    /// Returns the mass added, as a fraction of the wall's own (0 for a
    /// membrane).
    pub fn scale_mass_to_step_s(&mut self, target_s: f64) -> Result<f64, FemError> {
        if !(target_s > 0.0 && target_s.is_finite()) {
            return Err(FemError::param("target_s", target_s));
        }
        let Some(s) = &mut self.solid else {
            return Ok(0.0);
        };
        let added = s.scale_mass_to_step_s(
            &self.law,
            self.spec.density_kg_m3,
            &self.position_m,
            target_s,
        )?;
        self.lump_solid_masses();
        Ok(added)
    }

    /// Gives a solid wall's elements their own masses back (undoes
    /// [`Skin::scale_mass_to_step_s`]; nothing for a membrane).
    pub fn unscale_mass(&mut self) {
        if let Some(s) = &mut self.solid {
            s.mass_scale.iter_mut().for_each(|k| *k = 1.0);
        }
        self.lump_solid_masses();
    }

    /// A solid wall's nodal masses from its elements' scaled masses.
    fn lump_solid_masses(&mut self) {
        if let Some(s) = &self.solid {
            self.mass_kg.iter_mut().for_each(|m| *m = 0.0);
            s.lumped_masses_kg(self.spec.density_kg_m3, &mut self.mass_kg);
        }
    }

    /// Sets the pressure from the enclosed volume when volume-controlled.
    pub fn update_pressure(&mut self) {
        if let Some(vc) = self.volume_control {
            let v = self.enclosed_volume_m3();
            self.pressure_pa = vc.bulk_modulus_pa * (vc.target_volume_m3 - v) / vc.target_volume_m3;
        }
    }

    /// The elements' stable step (s), without the fluid.
    fn element_time_step_s(&self) -> Result<f64, FemError> {
        if let Some(s) = &self.solid {
            return s.stable_time_step_s(&self.law, self.spec.density_kg_m3, &self.position_m);
        }
        let mut dt = f64::INFINITY;
        for (k, tri) in self.elements.iter().enumerate() {
            let e = self.strain(k)?;
            let c2 = e.tangent_modulus_bound_pa(&self.law) / self.spec.density_kg_m3;
            dt = dt.min(tri.min_altitude_m / c2.sqrt());
        }
        let dt = 0.5 * dt;
        let Some(b) = &self.bending else {
            return Ok(dt);
        };
        // The bending's highest mode, with the same safety factor (½ of
        // the 2/ω limit).
        let w2 = b.max_frequency_squared(self.spec.density_kg_m3 * self.spec.thickness_m);
        Ok(1.0 / (dt.powi(-2) + w2).sqrt())
    }

    /// Advances by `dt_s` (s) with central differences: with forces at the
    /// current positions, v(t + dt/2) from v(t − dt/2) (mass-proportional
    /// damping, implicit in the damping term), then x(t + dt).
    pub fn step(&mut self, dt_s: f64) -> Result<(), FemError> {
        if !(dt_s > 0.0 && dt_s.is_finite()) {
            return Err(FemError::param("dt_s", dt_s));
        }
        let mut r = vec![Vector3::zeros(); self.node_count()];
        self.update_pressure();
        let head_n = self.residual_and_head_force_n(&mut r)?;
        let c = 0.5 * self.damping_per_s * dt_s;
        for ((v, m), f) in self.velocity_m_s.iter_mut().zip(&self.mass_kg).zip(&r) {
            *v = (*v * (1.0 - c) + f * (dt_s / m)) / (1.0 + c);
        }
        if self.round_rings {
            self.keep_rings_round();
        }
        for (x, v) in self.position_m.iter_mut().zip(&self.velocity_m_s) {
            *x += *v * dt_s;
        }
        let layers = self.layers();
        if let Some(head) = &mut self.head {
            let front = self.mesh.along;
            // The head and its ring move as one rigid body along z.
            let m = head.mass_kg
                + layered_ring(&self.mesh, layers, front)
                    .map(|a| self.mass_kg[a])
                    .sum::<f64>();
            let f = head_n + head.external_force_n;
            head.pull_n = if head.driven_m_s.is_some() { f } else { 0.0 };
            head.velocity_m_s = match head.driven_m_s {
                Some(v) => v,
                None => (head.velocity_m_s * (1.0 - c) + f * (dt_s / m)) / (1.0 + c),
            };
            head.displacement_m += head.velocity_m_s * dt_s;
            for a in layered_ring(&self.mesh, layers, front) {
                self.position_m[a].z = self.rest_m[a].z + head.displacement_m;
                self.velocity_m_s[a].z = head.velocity_m_s;
            }
            // The body carries the back ring.
            self.body_displacement_m += self.body_velocity_m_s * dt_s;
            for a in layered_ring(&self.mesh, layers, 0) {
                self.position_m[a].z = self.rest_m[a].z + self.body_displacement_m;
                self.velocity_m_s[a].z = self.body_velocity_m_s;
            }
        }
        self.time_s += dt_s;
        Ok(())
    }

    /// Gives every node of each inner ring the ring's mean radial and axial
    /// velocity and no tangential one ([`Skin::round_rings`]): the
    /// momentum-preserving projection (the ring's nodes have equal masses)
    /// onto the axisymmetric motions, so rings that start round stay round.
    fn keep_rings_round(&mut self) {
        let per_layer = self.mesh.rest_m.len();
        for (l, j) in (0..=self.layers()).flat_map(|l| (1..self.mesh.along).map(move |j| (l, j))) {
            let ring = self.mesh.ring(j);
            let ring = ring.start + l * per_layer..ring.end + l * per_layer;
            let n = ring.len() as f64;
            let radial = |a: usize, x: &[Vector3<f64>]| {
                let r = x[a].xy();
                let len = r.norm();
                Vector3::new(r.x / len, r.y / len, 0.0)
            };
            let (mut vr, mut vz) = (0.0, 0.0);
            for a in ring.clone() {
                vr += self.velocity_m_s[a].dot(&radial(a, &self.position_m));
                vz += self.velocity_m_s[a].z;
            }
            let (vr, vz) = (vr / n, vz / n);
            for a in ring {
                self.velocity_m_s[a] = radial(a, &self.position_m) * vr + Vector3::z() * vz;
            }
        }
    }

    /// Dynamic relaxation to the static equilibrium under the current loads
    /// (pressure and `external_force_n`), with kinetic damping: velocities
    /// are zeroed whenever the kinetic energy passes a peak. Stops when the
    /// largest nodal out-of-balance force is below `tolerance_n` (N);
    /// errs after `max_steps`. Leaves the skin at rest; time is not advanced.
    ///
    /// The masses are fictitious here: a solid wall's elements all get the
    /// longest element's step for the relaxation (mass scaling, so its thin
    /// end rows do not set the pace), and their own masses back after.
    pub fn relax(&mut self, tolerance_n: f64, max_steps: usize) -> Result<Relaxed, FemError> {
        let Some(s) = &self.solid else {
            return self.relax_with_own_masses(tolerance_n, max_steps);
        };
        let own = s.mass_scale.clone();
        let mut longest = 0.0f64;
        for k in 0..s.hexes.len() {
            let step = s.element_step_s(&self.law, self.spec.density_kg_m3, &self.position_m, k)?;
            longest = longest.max(step);
        }
        self.scale_mass_to_step_s(longest)?;
        let relaxed = self.relax_with_own_masses(tolerance_n, max_steps);
        if let Some(s) = &mut self.solid {
            s.mass_scale = own;
        }
        self.lump_solid_masses();
        relaxed
    }

    /// [`Skin::relax`] at the current masses.
    fn relax_with_own_masses(
        &mut self,
        tolerance_n: f64,
        max_steps: usize,
    ) -> Result<Relaxed, FemError> {
        let n = self.node_count();
        let mut r = vec![Vector3::zeros(); n];
        self.velocity_m_s
            .iter_mut()
            .for_each(|v| *v = Vector3::zeros());
        // A solid's stable step is a tight bound (0.9 of it); kinetic
        // damping that close to the limit stalls and can blow up (its
        // restarts leave the highest mode undamped), so it relaxes at half
        // of it. The membrane's estimate has that margin built in.
        let rs = if self.solid.is_some() { 0.5 } else { 1.0 };
        let mut dt = rs * self.stable_time_step_s()?;
        let mut ke_prev = 0.0;
        let mut residual = f64::INFINITY;
        for steps in 0..max_steps {
            if steps % 64 == 63 {
                dt = rs * self.stable_time_step_s()?;
            }
            self.update_pressure();
            self.residual_n(&mut r)?;
            residual = r.iter().map(|f| f.norm()).fold(0.0, f64::max);
            if residual <= tolerance_n {
                self.velocity_m_s
                    .iter_mut()
                    .for_each(|v| *v = Vector3::zeros());
                return Ok(Relaxed {
                    steps,
                    residual_n: residual,
                });
            }
            let mut ke = 0.0;
            for ((v, m), f) in self.velocity_m_s.iter_mut().zip(&self.mass_kg).zip(&r) {
                *v += f * (dt / m);
                ke += 0.5 * m * v.norm_squared();
            }
            if ke < ke_prev {
                // Past the peak: the state is near a minimum of the total
                // potential along the motion; restart from rest.
                self.velocity_m_s
                    .iter_mut()
                    .for_each(|v| *v = Vector3::zeros());
                ke = 0.0;
            }
            ke_prev = ke;
            for a in 0..n {
                self.position_m[a] += self.velocity_m_s[a] * dt;
            }
        }
        Err(FemError::NotConverged {
            steps: max_steps,
            residual_n: residual,
            tolerance_n,
        })
    }

    /// Mean current mid-surface radius of ring `j` about the z axis (m):
    /// of a solid, the mean of its inner and outer surfaces'.
    pub fn ring_radius_m(&self, j: usize) -> f64 {
        match self.layers() {
            0 => self.layer_ring_radius_m(0, j),
            outer => 0.5 * (self.layer_ring_radius_m(0, j) + self.layer_ring_radius_m(outer, j)),
        }
    }

    /// Mean current radius of ring `j` of layer `l` (m).
    fn layer_ring_radius_m(&self, l: usize, j: usize) -> f64 {
        let ring = self.mesh.ring(j);
        let n = ring.len() as f64;
        let off = l * self.mesh.rest_m.len();
        ring.map(|a| self.position_m[a + off].xy().norm())
            .sum::<f64>()
            / n
    }

    /// Current wall thickness (m) of the elements touching ring `j`, mean.
    /// Of a solid: the mean radial distance between its outer and inner
    /// surfaces at the ring.
    pub fn ring_thickness_m(&self, j: usize) -> Result<f64, FemError> {
        if self.solid.is_some() {
            let layers = self.layers();
            return Ok(self.layer_ring_radius_m(layers, j) - self.layer_ring_radius_m(0, j));
        }
        let ring = self.mesh.ring(j);
        let mut sum = 0.0;
        let mut count = 0usize;
        for (k, tri) in self.elements.iter().enumerate() {
            if tri.nodes.iter().any(|a| ring.contains(a)) {
                sum += self.strain(k)?.thickness_stretch();
                count += 1;
            }
        }
        Ok(self.spec.thickness_m * sum / count.max(1) as f64)
    }

    /// Outer diameter at mid-length (m): twice the middle ring's mean
    /// mid-surface radius plus the current wall thickness there.
    pub fn outer_diameter_at_mid_length_m(&self) -> f64 {
        let j = self.mesh.middle_ring();
        let t = self.ring_thickness_m(j).unwrap_or(self.spec.thickness_m);
        2.0 * self.ring_radius_m(j) + t
    }

    /// The smallest and largest outer caliper diameters at mid-length (m):
    /// over the middle ring's directions, the distance between opposite
    /// nodes (the mid-surface radii r(θ) + r(θ + π), or 2·r(θ) with an
    /// odd node count) plus the current wall thickness. Their spread is
    /// how far the zone is from round; their mean is close to
    /// [`Skin::outer_diameter_at_mid_length_m`].
    pub fn calipers_at_mid_length_m(&self) -> (f64, f64) {
        let j = self.mesh.middle_ring();
        let ring = self.mesh.ring(j);
        // A solid's outer surface is measured directly; a membrane's is
        // its mid-surface plus the thickness.
        let (off, t) = match self.solid {
            Some(_) => (self.layers() * self.mesh.rest_m.len(), 0.0),
            None => (0, self.ring_thickness_m(j).unwrap_or(self.spec.thickness_m)),
        };
        let r: Vec<f64> = ring.map(|a| self.position_m[a + off].xy().norm()).collect();
        let n = r.len();
        let across = |i: usize| {
            if n.is_multiple_of(2) {
                r[i] + r[(i + n / 2) % n]
            } else {
                2.0 * r[i]
            }
        };
        (0..n)
            .map(|i| across(i) + t)
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), d| {
                (lo.min(d), hi.max(d))
            })
    }

    /// von Mises stress of each element (Pa), plane stress: of the
    /// membrane stress, or with bending the largest over its nodes and
    /// the two surfaces of the element's membrane stress ± that node's
    /// bending stress (the bending field is nodal: at a clamped end it
    /// peaks on the end ring, which an element mean would smear).
    /// A solid's: each hexahedron's at its centre (as C3D8R reports it).
    pub fn von_mises_pa(&self) -> Result<Vec<f64>, FemError> {
        if let Some(s) = &self.solid {
            return (0..s.hexes.len())
                .map(|k| {
                    Ok(von_mises_3d_pa(
                        &s.state(&self.law, k, &self.position_m)?.cauchy_pa,
                    ))
                })
                .collect();
        }
        let nodes = self
            .bending
            .as_ref()
            .map(|b| b.node_bending(&self.position_m));
        (0..self.elements.len())
            .map(|k| {
                let e = self.strain(k)?;
                let s = self.stress(&e);
                let (Some(b), Some(nodes)) = (&self.bending, &nodes) else {
                    return Ok(e.von_mises_pa(&s));
                };
                // Cauchy stress F·S·Fᵀ (J = 1), in space.
                let sigma: Matrix3<f64> = e.deformation * s * e.deformation.transpose();
                let tri = &self.elements[k];
                let [p, q, r] = tri.nodes.map(|a| self.position_m[a]);
                let normal = (q - p).cross(&(r - p)).normalize();
                let around = Vector3::z().cross(&normal).normalize();
                let along = normal.cross(&around);
                Ok(tri
                    .nodes
                    .iter()
                    .map(|&a| {
                        let outer = b.outer_surface_stress_pa(&nodes[a], &along, &around);
                        von_mises_3d_pa(&(sigma + outer)).max(von_mises_3d_pa(&(sigma - outer)))
                    })
                    .fold(0.0, f64::max))
            })
            .collect()
    }

    /// Current outer lateral area of the skin (m²): each triangle's
    /// mid-surface area scaled by (ρ + h/2)/ρ, ρ its centroid's distance
    /// from the axis and h its current thickness; a solid's outer faces
    /// as they are.
    pub fn outer_area_m2(&self) -> Result<f64, FemError> {
        (0..self.elements.len())
            .map(|k| {
                let tri = &self.elements[k];
                let [a, b, c] = tri.nodes.map(|a| self.position_m[a]);
                let area = 0.5 * (b - a).cross(&(c - a)).norm();
                let rho = ((a + b + c) / 3.0).xy().norm();
                Ok(area * (1.0 + self.contact_offset_m(k)? / rho))
            })
            .sum()
    }

    /// Volume enclosed by the skin and the planes of its end rings (m³):
    /// the flux of (x, y, 0)/2 through the lateral surface (none crosses
    /// flat end caps normal to z).
    pub fn enclosed_volume_m3(&self) -> f64 {
        self.fluid_triangles()
            .map(|t| {
                let [a, b, c] = t.map(|a| self.position_m[a]);
                let area = 0.5 * (b - a).cross(&(c - a));
                let centroid = (a + b + c) / 3.0;
                0.5 * (centroid.x * area.x + centroid.y * area.y)
            })
            .sum()
    }
}
