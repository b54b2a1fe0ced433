//! # Particle–skin coupling
//!
//! DEM spheres against the FEM skin's outer surface, forces exchanged both
//! ways every DEM step. Each particle has at most one skin contact, with
//! the closest mid-surface triangle, offset outwards by half the
//! triangle's current thickness (a solid skin: its outer face, no offset;
//! [`Skin::contact_offset_m`]); the contact law is the DEM's own
//! [`ContactModel`] (Hertz normal penalty from the sand and skin moduli,
//! restitution damping, Mindlin tangential spring with history and a
//! Coulomb cap μ). The particle receives the force, the skin nodes the
//! opposite, spread by the contact point's barycentric (shape-function)
//! weights, so the exchanged forces sum to zero.
//!
//! [`Coupling`] is a DEM [`Sink`]: inside each DEM step it first advances
//! the skin to the particles' time with the contact forces of the previous
//! evaluation (central difference), then evaluates the contacts at that
//! common time. A [`FrontFace`] (the head's cap) can ride along; its sand
//! pressure is read after each step. [`expand`] drives a run: injected
//! volume at a constant rate up to a target diameter, sampled as it goes.

pub mod expansion;
pub mod face;
pub mod geometry;

use nalgebra::Vector3;
use rayon::prelude::*;

use dem::contact::{ContactForce, ContactGeometry, ContactModel, History};
use dem::{Particles, Sink};
pub use expansion::{expand, Expansion, ExpansionError, HeadDraw};
pub use face::FrontFace;
use fem::{FemError, Skin};
use geometry::closest_point_on_triangle;
use skin::StrainEnergy;

/// Totals of one contact evaluation.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Exchange {
    /// Sum of skin-contact forces on the particles (N).
    pub on_particles_n: Vector3<f64>,
    /// Sum of the opposite forces put on the skin nodes (N).
    pub on_skin_n: Vector3<f64>,
    /// Particles touching the skin.
    pub contacts: usize,
    /// Sum of the contacts' normal forces (N): how hard the sand presses
    /// on the skin.
    pub normal_force_n: f64,
}

/// What the coupled run reports at one instant.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Sample {
    /// Time (s).
    pub time_s: f64,
    /// Outer diameter at mid-length D (m).
    pub outer_diameter_m: f64,
    /// Smallest and largest outer caliper diameter at mid-length (m):
    /// how far the zone is from round ([`Skin::calipers_at_mid_length_m`]).
    pub calipers_m: (f64, f64),
    /// Internal (fluid) pressure p_i (Pa).
    pub internal_pressure_pa: f64,
    /// Sand pressure on the skin p_e (Pa): contact normal force over the
    /// skin's outer lateral area.
    pub sand_pressure_pa: f64,
    /// Sand pressure on the front face p_h (Pa), if one is resolved.
    pub face_pressure_pa: Option<f64>,
    /// Largest element von Mises stress in the skin (Pa).
    pub max_von_mises_pa: f64,
    /// Largest surface strain of the skin's bending (a shell skin;
    /// `None` for a membrane), see [`fem::bending::Bending::max_surface_strain`].
    pub max_bending_strain: Option<f64>,
    /// Particles touching the skin.
    pub contacts: usize,
    /// Head receding distance D_r (m), positive backwards; 0 when the
    /// skin has no free head.
    pub head_receding_m: f64,
    /// Force the body takes from a driven or drawn head (N, + pulling it
    /// back), [`fem::Head::pull_n`]; 0 for a free head.
    pub head_pull_n: f64,
}

/// The skin, its contact law with the particles, and an optional front
/// face, as one DEM [`Sink`].
#[derive(Debug)]
pub struct Coupling<S: StrainEnergy> {
    /// The FEM skin, advanced inside the DEM steps.
    pub skin: Skin<S>,
    /// Particle–skin contact law.
    pub model: ContactModel,
    /// The head's front face, if resolved.
    pub face: Option<FrontFace>,
    /// Scale a solid wall's mass so that it takes one step per DEM step
    /// ([`Skin::scale_mass_to_step_s`] to [`MASS_SCALING_MARGIN`] × `dt_s`,
    /// re-applied with each stable-step estimate). Off by default.
    pub mass_scaling: bool,
    /// The largest mass added by `mass_scaling` so far, as a fraction of
    /// the wall's own (0 without it).
    pub max_added_mass: f64,
    /// Skin steps taken so far (several per DEM step where the skin's
    /// stable step is the shorter).
    pub skin_steps: u64,
    /// DEM time step (s): the contacts' tangential histories advance by it.
    pub dt_s: f64,
    history: Vec<History>,
    /// The particles that touched the skin at the last exchange, ascending:
    /// the only ones whose history is not zero.
    touching: Vec<u32>,
    last: Exchange,
    error: Option<FemError>,
    synced: bool,
    /// The skin's stable step (s), refreshed every [`STABLE_STEP_REFRESH`]
    /// advances (the stiffening law shortens it as the skin stretches).
    skin_dt_s: f64,
    advances: u64,
}

/// Skin advances between re-estimates of its stable step.
const STABLE_STEP_REFRESH: u64 = 32;

/// The elements' target step under mass scaling, over the DEM step: the
/// margin leaves room for the fluid's stiffness (which shortens the whole
/// skin's step below its elements') and for the wall's thinning between
/// two estimates.
pub const MASS_SCALING_MARGIN: f64 = 1.25;

impl<S: StrainEnergy> Coupling<S> {
    /// Couples `skin` to particles through `model`, stepping with the DEM's
    /// `dt_s` (s); a DEM step longer than the skin's stable step is
    /// subcycled. The skin's time is taken as the DEM's at the first call.
    pub fn new(skin: Skin<S>, model: ContactModel, dt_s: f64) -> Result<Coupling<S>, FemError> {
        if !(dt_s > 0.0 && dt_s.is_finite()) {
            return Err(FemError::Param {
                name: "dt_s",
                value: dt_s,
            });
        }
        Ok(Coupling {
            skin,
            model,
            face: None,
            dt_s,
            history: Vec::new(),
            touching: Vec::new(),
            last: Exchange::default(),
            error: None,
            synced: false,
            skin_dt_s: 0.0,
            advances: 0,
            mass_scaling: false,
            max_added_mass: 0.0,
            skin_steps: 0,
        })
    }

    /// Changes the DEM step to `dt_s` (s); under `mass_scaling` the skin's
    /// mass and stable step are re-estimated at the next advance.
    pub fn set_dt_s(&mut self, dt_s: f64) {
        self.dt_s = dt_s;
        if self.mass_scaling {
            self.advances = 0;
        }
    }

    /// Turns `mass_scaling` on or off; off gives the wall its own mass
    /// back. The skin's stable step is re-estimated at the next advance.
    pub fn set_mass_scaling(&mut self, on: bool) -> Result<(), FemError> {
        if on == self.mass_scaling {
            return Ok(());
        }
        if !on {
            self.skin.unscale_mass();
        }
        self.mass_scaling = on;
        self.advances = 0;
        Ok(())
    }

    /// Totals of the last contact evaluation.
    pub fn last_exchange(&self) -> Exchange {
        self.last
    }

    /// The state at the last evaluation: D, p_i, p_e, p_h and the largest
    /// von Mises stress.
    pub fn sample(&self) -> Result<Sample, FemError> {
        let max_von_mises_pa = self.skin.von_mises_pa()?.into_iter().fold(0.0, f64::max);
        Ok(Sample {
            time_s: self.skin.time_s,
            outer_diameter_m: self.skin.outer_diameter_at_mid_length_m(),
            calipers_m: self.skin.calipers_at_mid_length_m(),
            internal_pressure_pa: self.skin.pressure_pa,
            sand_pressure_pa: self.last.normal_force_n / self.skin.outer_area_m2()?,
            face_pressure_pa: self.face.as_ref().map(FrontFace::pressure_pa),
            max_von_mises_pa,
            max_bending_strain: self
                .skin
                .bending
                .as_ref()
                .map(|b| b.max_surface_strain(&self.skin.position_m)),
            contacts: self.last.contacts,
            head_receding_m: self.skin.head.map_or(0.0, |h| h.receding_m()),
            head_pull_n: self.skin.head.map_or(0.0, |h| h.pull_n),
        })
    }

    /// The skin error that stopped the coupling, if any (a [`Sink`] cannot
    /// return one; check after each DEM step).
    pub fn error(&self) -> Option<&FemError> {
        self.error.as_ref()
    }

    /// Evaluates the particle–skin contacts at the current positions of
    /// both: adds forces to `particles`, sets `skin.external_force_n`.
    pub fn exchange(&mut self, particles: &mut Particles) -> Result<Exchange, FemError> {
        let skin = &mut self.skin;
        skin.external_force_n
            .iter_mut()
            .for_each(|f| *f = Vector3::zeros());
        let n = particles.len();
        if self.history.len() != n {
            self.history = vec![History::default(); n];
            self.touching.clear();
        }
        let offset_m: Vec<f64> = (0..skin.elements.len())
            .map(|k| skin.contact_offset_m(k))
            .collect::<Result<_, FemError>>()?;
        let reach = particles.max_radius_m() + offset_m.iter().copied().fold(0.0, f64::max);
        let grid = TriangleGrid::build(skin, reach);
        let (lo, hi) = grid.bounds;
        let (model, dt) = (&self.model, self.dt_s);
        let parts: &Particles = particles;
        let skin_ro: &Skin<S> = skin;
        let history = &self.history;
        // Only the particles in the box of the skin's reach can touch it (a
        // few hundred of the bed's thousands): their contacts in parallel,
        // each from its own history, collected in particle order and applied
        // below in that order, so the sums do not depend on threads.
        let hits: Vec<(usize, Hit, History)> = (0..n)
            .into_par_iter()
            .filter(|&i| in_box(&parts.position_m[i], &lo, &hi))
            .filter_map(|i| {
                let mut h = history[i];
                let hit = contact(skin_ro, &grid, &offset_m, parts, i, model, dt, &mut h);
                hit.map(|hit| (i, hit, h))
            })
            .collect();
        // A contact starts from zero history: the last exchange's contacts
        // are cleared, and those still touching get their advanced history.
        for &i in &self.touching {
            self.history[i as usize] = History::default();
        }
        self.touching.clear();
        let mut out = Exchange::default();
        for (i, hit, h) in hits {
            self.history[i] = h;
            self.touching.push(i as u32);
            let cf = hit.force;
            particles.force_n[i] += cf.force_n;
            particles.torque_n_m[i] +=
                cf.torque_per_radius_n * particles.radius_m[i] + cf.rolling_torque_n_m;
            for (a, wa) in skin.elements[hit.element].nodes.iter().zip(hit.weights) {
                skin.external_force_n[*a] -= cf.force_n * wa;
            }
            out.on_particles_n += cf.force_n;
            out.normal_force_n += cf.force_n.dot(&hit.normal);
            out.contacts += 1;
        }
        out.on_skin_n = skin.external_force_n.iter().sum();
        self.last = out;
        Ok(out)
    }

    fn advance_and_exchange(
        &mut self,
        time_s: f64,
        particles: &mut Particles,
    ) -> Result<(), FemError> {
        if !self.synced {
            self.skin.time_s = time_s;
            self.synced = true;
        }
        // Advance the skin to the particles' time with the forces of the
        // last evaluation (a repeated call at the same time only
        // re-evaluates the contacts).
        let lag = time_s - self.skin.time_s;
        if lag > 1e-9 * self.dt_s {
            if self.advances.is_multiple_of(STABLE_STEP_REFRESH) {
                if self.mass_scaling {
                    let added = self
                        .skin
                        .scale_mass_to_step_s(MASS_SCALING_MARGIN * self.dt_s)?;
                    self.max_added_mass = self.max_added_mass.max(added);
                }
                self.skin_dt_s = self.skin.stable_time_step_s()?;
            }
            self.advances += 1;
            // The sand on the face pushes the head (last evaluation's force).
            if let (Some(head), Some(face)) = (&mut self.skin.head, &self.face) {
                head.external_force_n = -face.normal_force_n() * face.normal.z;
            }
            let substeps = (lag / self.skin_dt_s).ceil().max(1.0);
            for _ in 0..substeps as u64 {
                self.skin.step(lag / substeps)?;
            }
            self.skin_steps += substeps as u64;
            self.skin.time_s = time_s;
            // The face rides on the head.
            if let (Some(head), Some(face)) = (&self.skin.head, &mut self.face) {
                face.centre_m.z = self.skin.spec.length_m + head.displacement_m;
                face.velocity_m_s.z = head.velocity_m_s;
            }
        }
        self.exchange(particles)?;
        if let Some(face) = &mut self.face {
            face.apply(particles);
        }
        Ok(())
    }
}

impl<S: StrainEnergy> Sink for Coupling<S> {
    fn add_external_forces(&mut self, time_s: f64, particles: &mut Particles) {
        if self.error.is_some() {
            return;
        }
        if let Err(e) = self.advance_and_exchange(time_s, particles) {
            self.error = Some(e);
        }
    }
}

/// One particle's skin contact.
struct Hit {
    element: usize,
    weights: [f64; 3],
    normal: Vector3<f64>,
    force: ContactForce,
}

/// Particle `i`'s contact with the closest triangle of `skin` within
/// reach, if any; advances its tangential `history`.
#[allow(clippy::too_many_arguments)]
fn contact<S: StrainEnergy>(
    skin: &Skin<S>,
    grid: &TriangleGrid,
    offset_m: &[f64],
    particles: &Particles,
    i: usize,
    model: &ContactModel,
    dt_s: f64,
    history: &mut History,
) -> Option<Hit> {
    let p = particles.position_m[i];
    let r = particles.radius_m[i];
    // Closest triangle among the candidates in the particle's cell.
    let mut best: Option<(f64, usize, Vector3<f64>, [f64; 3])> = None;
    for &k in grid.candidates(&p) {
        // Outside the triangle's box grown by the reach, it is farther than
        // r + half its thickness: skip the exact distance.
        if !grid.within_box(k, &p) {
            continue;
        }
        let x = skin.elements[k].nodes.map(|a| skin.position_m[a]);
        let (q, w) = closest_point_on_triangle(&p, x);
        let dist = (p - q).norm();
        if dist < r + offset_m[k] && best.is_none_or(|b| dist < b.0) {
            best = Some((dist, k, q, w));
        }
    }
    let (dist, k, q, w) = best?;
    let tri = &skin.elements[k];
    let x = tri.nodes.map(|a| skin.position_m[a]);
    let face_normal = (x[1] - x[0]).cross(&(x[2] - x[0])).normalize();
    let d = p - q;
    // Outer side: along the centre offset; a centre that crossed the
    // mid-surface is pushed back out along the face normal.
    let (normal, gap) = if d.dot(&face_normal) > 0.0 && dist > 0.0 {
        (d / dist, dist)
    } else {
        (face_normal, -dist)
    };
    let v_skin: Vector3<f64> = tri
        .nodes
        .iter()
        .zip(w)
        .map(|(a, wa)| skin.velocity_m_s[*a] * wa)
        .sum();
    let m_skin: f64 = tri
        .nodes
        .iter()
        .zip(w)
        .map(|(a, wa)| skin.mass_kg[*a] * wa)
        .sum();
    let m_i = particles.mass_kg[i];
    let g = ContactGeometry::sphere_on_surface(
        normal,
        r + offset_m[k] - gap,
        r,
        m_i * m_skin / (m_i + m_skin),
        particles.velocity_m_s[i] - v_skin,
        particles.angular_velocity_rad_s[i],
    );
    Some(Hit {
        element: k,
        weights: w,
        normal,
        force: model.evaluate(&g, dt_s, history),
    })
}

/// Whether `p` lies in the box from `lo` to `hi` (closed).
#[inline]
fn in_box(p: &Vector3<f64>, lo: &Vector3<f64>, hi: &Vector3<f64>) -> bool {
    (0..3).all(|a| p[a] >= lo[a] && p[a] <= hi[a])
}

/// Triangles binned on a uniform grid by their bounding boxes grown by the
/// contact reach, so a particle only tests the triangles of its own cell.
/// The cells are a dense block over the triangles' bounds, their lists
/// packed in one array (counting sort, triangles ascending in each cell):
/// the grid is rebuilt every step, and hashing cell keys was a hot spot.
struct TriangleGrid {
    /// Box holding every triangle's grown box (m).
    bounds: (Vector3<f64>, Vector3<f64>),
    cell_m: f64,
    /// Cells along x, y, z.
    dims: [usize; 3],
    /// Cell c's triangles are `triangles[start[c]..start[c + 1]]`.
    start: Vec<usize>,
    triangles: Vec<usize>,
    /// Each triangle's bounding box grown by the reach (m).
    boxes: Vec<(Vector3<f64>, Vector3<f64>)>,
}

impl TriangleGrid {
    fn build<S: StrainEnergy>(skin: &Skin<S>, reach_m: f64) -> TriangleGrid {
        let boxes: Vec<(Vector3<f64>, Vector3<f64>)> = skin
            .elements
            .iter()
            .map(|t| {
                let x = t.nodes.map(|a| skin.position_m[a]);
                let lo = x[0].inf(&x[1]).inf(&x[2]).add_scalar(-reach_m);
                let hi = x[0].sup(&x[1]).sup(&x[2]).add_scalar(reach_m);
                (lo, hi)
            })
            .collect();
        let cell_m = boxes
            .iter()
            .map(|(lo, hi)| (hi - lo).max())
            .fold(0.0, f64::max)
            .max(1e-9);
        let bounds = boxes.iter().fold(
            (
                Vector3::repeat(f64::INFINITY),
                Vector3::repeat(f64::NEG_INFINITY),
            ),
            |(lo, hi), (a, b)| (lo.inf(a), hi.sup(b)),
        );
        // Every box is at most a cell wide, so it spans at most two cells
        // per axis: the block is the bounds over the cell size, plus one.
        let dims = if boxes.is_empty() {
            [0; 3]
        } else {
            [0, 1, 2].map(|a| ((bounds.1[a] - bounds.0[a]) / cell_m).floor() as usize + 1)
        };
        let mut grid = TriangleGrid {
            bounds,
            cell_m,
            dims,
            start: vec![0; dims.iter().product::<usize>() + 1],
            triangles: Vec::new(),
            boxes,
        };
        // Count into start[c + 1], turn the counts into offsets by a
        // running sum, then place each triangle, ascending, from its
        // cells' offsets.
        let spans: Vec<_> = (0..grid.boxes.len()).map(|k| grid.span(k)).collect();
        for span in &spans {
            for c in grid.cells(span) {
                grid.start[c + 1] += 1;
            }
        }
        for c in 1..grid.start.len() {
            grid.start[c] += grid.start[c - 1];
        }
        grid.triangles = vec![0; grid.start[grid.start.len() - 1]];
        let mut next = grid.start.clone();
        for (k, span) in spans.iter().enumerate() {
            for c in grid.cells(span) {
                grid.triangles[next[c]] = k;
                next[c] += 1;
            }
        }
        grid
    }

    /// The first and last cell (per axis) of triangle `k`'s grown box.
    fn span(&self, k: usize) -> ([usize; 3], [usize; 3]) {
        let (lo, hi) = &self.boxes[k];
        (self.cell_of(lo), self.cell_of(hi))
    }

    /// The indices of the cells from `span.0` to `span.1`.
    fn cells(&self, span: &([usize; 3], [usize; 3])) -> impl Iterator<Item = usize> {
        let ([i0, j0, l0], [i1, j1, l1]) = *span;
        let dims = self.dims;
        (l0..=l1).flat_map(move |l| {
            (j0..=j1).flat_map(move |j| (i0..=i1).map(move |i| cell_index(dims, [i, j, l])))
        })
    }

    /// The cell (per axis) of a point inside the bounds.
    fn cell_of(&self, x: &Vector3<f64>) -> [usize; 3] {
        [0, 1, 2].map(|a| {
            let c = ((x[a] - self.bounds.0[a]) / self.cell_m).floor();
            (c.max(0.0) as usize).min(self.dims[a].saturating_sub(1))
        })
    }

    /// Whether `p` lies in triangle `k`'s grown box (every point within the
    /// reach of the triangle does).
    #[inline]
    fn within_box(&self, k: usize, p: &Vector3<f64>) -> bool {
        let (lo, hi) = &self.boxes[k];
        in_box(p, lo, hi)
    }

    /// The triangles whose grown boxes may hold `p` (a point inside the
    /// bounds; [`Coupling::exchange`] filters on them first).
    fn candidates(&self, p: &Vector3<f64>) -> &[usize] {
        if self.triangles.is_empty() {
            return &[];
        }
        let c = cell_index(self.dims, self.cell_of(p));
        &self.triangles[self.start[c]..self.start[c + 1]]
    }
}

/// The index of cell `[i, j, l]` in a block of `dims` cells, x fastest.
fn cell_index(dims: [usize; 3], [i, j, l]: [usize; 3]) -> usize {
    (l * dims[1] + j) * dims[0] + i
}
