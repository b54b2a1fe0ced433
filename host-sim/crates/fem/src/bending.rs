//! Bending of the skin: a rotation-free Kirchhoff–Love shell term on the
//! structured tube mesh.
//!
//! The membrane ([`super::element`]) carries the skin's stretch; this adds
//! the resistance of its thickness to bending, which the membrane lacks:
//! where the zone meets the rigid body and head, the skin leaves the clamp
//! along the axis and turns outwards over a boundary layer (≈ √(RT) in
//! linear theory, about a millimetre in the paper's inflated zone), and
//! there its surfaces carry the largest stresses (the paper's "stress
//! concentrated in the more curved areas").
//!
//! At each node the bending measures are the normal components of the
//! second differences of the positions along the axis and around the ring,
//! in reference lengths (the rotation-free Kirchhoff–Love strains
//! b_αα = n·∂²x/∂S_α², twist left out: the bulge is axisymmetric to first
//! order), minus their rest values. The energy is linear in them,
//!
//! ```text
//! W = Σ_nodes A0·D/2·(Δb_z² + Δb_θ² + 2ν·Δb_z·Δb_θ),   D = E·T³/(12(1 − ν²))
//! ```
//!
//! with E = 3μ0 and ν = ½ (incompressible; μ0 the law's small-strain shear
//! modulus) and T the rest thickness; the nodal forces are its exact
//! gradient, the unit normal n = (x_{θ+} − x_{θ−}) × (x_{z+} − x_{z−})/|…|
//! included. A clamped end holds the skin's slope along the axis: the
//! ghost node beyond the end ring is the mirror image of the first row
//! inside (the second-order closure of w′ = 0, so the end ring's axial
//! measure is the skin's curvature there). A free end carries no moment
//! (no axial term at its ring).
//!
//! Linear bending on top of the nonlinear membrane: good while the surface
//! bending strains T/2·|Δb| stay small ([`Bending::max_surface_strain`];
//! at 0.3 a neo-Hookean skin's surface stress is within ≈ 10 % of the
//! linear one), and while the skin bends over lengths longer than its
//! thickness (a thin shell). Where it folds tighter, as over the body's
//! edge in the paper's case, the stress it reports is the linear
//! extrapolation, not the thick wall's.

use nalgebra::{Matrix3, Vector3};

use super::mesh::TubeMesh;

/// The bending term of one skin tube.
#[derive(Clone, Debug, PartialEq)]
pub struct Bending {
    /// Bending rigidity D (N·m).
    pub rigidity_n_m: f64,
    /// Plane-stress modulus E/(1 − ν²) (Pa), for the surface stresses.
    pub plate_modulus_pa: f64,
    /// Rest thickness T (m).
    pub thickness_m: f64,
    /// Poisson's ratio ν (½).
    pub poisson: f64,
    /// Whether the end rings are clamped (ghost nodes) or free.
    pub clamped: bool,
    around: usize,
    along: usize,
    /// Rest row lengths along the axis (m), row j between rings j, j + 1.
    rows_m: Vec<f64>,
    /// Reference spacing around the ring (m).
    h_around_m: f64,
    /// Rest values of n·k along and around, per node (1/m).
    rest: Vec<[f64; 2]>,
}

/// The bending state at one node.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct NodeBending {
    /// Change of the axial bending measure Δb_z (1/m).
    pub along_per_m: f64,
    /// Change of the hoop bending measure Δb_θ (1/m).
    pub around_per_m: f64,
}

/// An axial neighbour of a node: a node, or the ghost beyond a clamped
/// end ring, the mirror of node `of` in the plane of the ring through
/// node `about` (x, y of `of`; z = 2·z_about − z_of).
#[derive(Clone, Copy)]
enum Link {
    Node(usize),
    Mirror { of: usize, about: usize },
}

impl Link {
    fn position(self, x: &[Vector3<f64>]) -> Vector3<f64> {
        match self {
            Link::Node(a) => x[a],
            Link::Mirror { of, about } => {
                Vector3::new(x[of].x, x[of].y, 2.0 * x[about].z - x[of].z)
            }
        }
    }

    /// Adds a derivative `g` with respect to this neighbour's position to
    /// the nodes it is made of.
    fn route(self, g: Vector3<f64>, out: &mut [Vector3<f64>]) {
        match self {
            Link::Node(a) => out[a] += g,
            Link::Mirror { of, about } => {
                out[of] += Vector3::new(g.x, g.y, -g.z);
                out[about].z += 2.0 * g.z;
            }
        }
    }
}

/// The stencil of one node: its neighbours' positions, and where their
/// derivatives go.
struct Stencil {
    x: Vector3<f64>,
    around: [Vector3<f64>; 2],
    around_id: [usize; 2],
    /// Axial neighbours' positions (behind, ahead); `None` at a free end.
    along: Option<[Vector3<f64>; 2]>,
    /// The ends of the axial chord the normal is built from (behind,
    /// ahead): the axial neighbours, or the node itself at a free end.
    chord: [Link; 2],
    /// Weights of (behind, node, ahead) in the axial second difference
    /// (1/m²): 2/(h_b(h_b + h_f)), −2/(h_b·h_f), 2/(h_f(h_b + h_f)).
    weights: [f64; 3],
    /// The axial chord, ahead minus behind.
    axis_chord: Vector3<f64>,
    area_m2: f64,
}

impl Bending {
    /// The bending term of `mesh` for a skin of rest thickness
    /// `thickness_m` (m) and small-strain shear modulus `shear_modulus_pa`
    /// (Pa); `clamped`: the end rings are held at their slope (body and
    /// head), else free.
    pub fn new(mesh: &TubeMesh, thickness_m: f64, shear_modulus_pa: f64, clamped: bool) -> Bending {
        let poisson = 0.5;
        let young_pa = 2.0 * shear_modulus_pa * (1.0 + poisson);
        let plate_modulus_pa = young_pa / (1.0 - poisson * poisson);
        let mut b = Bending {
            rigidity_n_m: plate_modulus_pa * thickness_m.powi(3) / 12.0,
            plate_modulus_pa,
            thickness_m,
            poisson,
            clamped,
            around: mesh.around,
            along: mesh.along,
            rows_m: (0..mesh.along).map(|j| mesh.row_m(j)).collect(),
            h_around_m: (mesh.rest_m[1] - mesh.rest_m[0]).norm(),
            rest: vec![[0.0; 2]; mesh.rest_m.len()],
        };
        b.rest = (0..mesh.rest_m.len())
            .map(|a| b.measures(&b.stencil(&mesh.rest_m, a)).0)
            .collect();
        b
    }

    fn id(&self, i: usize, j: usize) -> usize {
        j * self.around + i % self.around
    }

    fn stencil(&self, x: &[Vector3<f64>], a: usize) -> Stencil {
        let (i, j) = (a % self.around, a / self.around);
        let around_id = [self.id(i + self.around - 1, j), self.id(i + 1, j)];
        let link = |jj: usize| Link::Node(self.id(i, jj));
        let mirror = |jj: usize| Link::Mirror {
            of: self.id(i, jj),
            about: a,
        };
        let behind = if j > 0 {
            Some(link(j - 1))
        } else {
            self.clamped.then(|| mirror(1))
        };
        let ahead = if j < self.along {
            Some(link(j + 1))
        } else {
            self.clamped.then(|| mirror(self.along - 1))
        };
        // Rows behind and ahead (a mirror ghost repeats the end row).
        let h_b = self.rows_m[j.saturating_sub(1).min(self.along - 1)];
        let h_f = self.rows_m[j.min(self.along - 1)];
        let (h_b, h_f) = match j {
            0 => (h_f, h_f),
            _ if j == self.along => (h_b, h_b),
            _ => (h_b, h_f),
        };
        let area_along = match (j == 0, j == self.along) {
            (true, _) => 0.5 * h_f,
            (_, true) => 0.5 * h_b,
            _ => 0.5 * (h_b + h_f),
        };
        let sum = h_b + h_f;
        let chord = [
            behind.unwrap_or(Link::Node(a)),
            ahead.unwrap_or(Link::Node(a)),
        ];
        let [b, f] = chord.map(|l| l.position(x));
        Stencil {
            x: x[a],
            around: around_id.map(|k| x[k]),
            around_id,
            along: (behind.is_some() && ahead.is_some()).then_some([b, f]),
            chord,
            weights: [2.0 / (h_b * sum), -2.0 / (h_b * h_f), 2.0 / (h_f * sum)],
            axis_chord: f - b,
            area_m2: area_along * self.h_around_m,
        }
    }

    /// The measures [n·k_z, n·k_θ] of a stencil, its normal, its second
    /// differences and the unnormalised normal's length.
    fn measures(&self, s: &Stencil) -> ([f64; 2], Vector3<f64>, [Vector3<f64>; 2], f64) {
        let c = (s.around[1] - s.around[0]).cross(&s.axis_chord);
        let len = c.norm();
        let n = c / len;
        let [wb, wx, wf] = s.weights;
        let k_along = s
            .along
            .map_or(Vector3::zeros(), |[b, f]| b * wb + s.x * wx + f * wf);
        let k_around =
            (s.around[0] - 2.0 * s.x + s.around[1]) / (self.h_around_m * self.h_around_m);
        (
            [n.dot(&k_along), n.dot(&k_around)],
            n,
            [k_along, k_around],
            len,
        )
    }

    /// The change of the bending measures at every node for positions `x`.
    pub fn node_bending(&self, x: &[Vector3<f64>]) -> Vec<NodeBending> {
        (0..x.len())
            .map(|a| {
                let (m, ..) = self.measures(&self.stencil(x, a));
                NodeBending {
                    along_per_m: m[0] - self.rest[a][0],
                    around_per_m: m[1] - self.rest[a][1],
                }
            })
            .collect()
    }

    /// The largest surface strain of the bending, T/2·|Δb| over the nodes
    /// and both directions, at positions `x`: where it passes ≈ 0.3 the
    /// linear bending (and the thin-shell picture) no longer holds.
    pub fn max_surface_strain(&self, x: &[Vector3<f64>]) -> f64 {
        self.node_bending(x)
            .iter()
            .map(|b| b.along_per_m.abs().max(b.around_per_m.abs()))
            .fold(0.0, f64::max)
            * 0.5
            * self.thickness_m
    }

    /// Bending energy (J) at positions `x`.
    pub fn energy_j(&self, x: &[Vector3<f64>]) -> f64 {
        self.node_bending(x)
            .iter()
            .enumerate()
            .map(|(a, b)| {
                let area = self.stencil(x, a).area_m2;
                let (m, h) = (b.along_per_m, b.around_per_m);
                0.5 * area * self.rigidity_n_m * (m * m + h * h + 2.0 * self.poisson * m * h)
            })
            .sum()
    }

    /// Adds ∂W/∂x (N), the bending's internal nodal forces, to `out`.
    pub fn add_internal_forces_n(&self, x: &[Vector3<f64>], out: &mut [Vector3<f64>]) {
        for a in 0..x.len() {
            let s = self.stencil(x, a);
            let (m, n, k, len) = self.measures(&s);
            let dm = m[0] - self.rest[a][0];
            let dh = m[1] - self.rest[a][1];
            let scale = s.area_m2 * self.rigidity_n_m;
            // ∂W/∂(n·k_z) and ∂W/∂(n·k_θ), over A0·D.
            let (wm, wh) = if s.along.is_some() {
                (dm + self.poisson * dh, dh + self.poisson * dm)
            } else {
                (0.0, dh)
            };
            // Through the second differences, n held.
            let along = n * (scale * wm);
            let around = n * (scale * wh / (self.h_around_m * self.h_around_m));
            if s.along.is_some() {
                let [wb, wx, wf] = s.weights;
                s.chord[0].route(along * wb, out);
                s.chord[1].route(along * wf, out);
                out[a] += along * wx;
            }
            out[s.around_id[0]] += around;
            out[s.around_id[1]] += around;
            out[a] -= 2.0 * around;
            // Through the normal: g·dn = q·dc, c = b × a_z.
            let g = k[0] * wm + k[1] * wh;
            let q = (g - n * g.dot(&n)) * (scale / len);
            let b = s.around[1] - s.around[0];
            let on_b = s.axis_chord.cross(&q);
            let on_a = q.cross(&b);
            out[s.around_id[1]] += on_b;
            out[s.around_id[0]] -= on_b;
            s.chord[1].route(on_a, out);
            s.chord[0].route(-on_a, out);
        }
    }

    /// Largest squared angular frequency (1/s²) of the bending term for a
    /// node mass per reference area `mass_per_area_kg_m2` (kg/m²): the
    /// finite-difference biharmonic's bound 16·D/(ρT)·(1/h_z² + 1/h_θ²)²,
    /// h_z the shortest row.
    pub fn max_frequency_squared(&self, mass_per_area_kg_m2: f64) -> f64 {
        let h_along = self.rows_m.iter().copied().fold(f64::INFINITY, f64::min);
        let s = 1.0 / (h_along * h_along) + 1.0 / (self.h_around_m * self.h_around_m);
        16.0 * self.rigidity_n_m / mass_per_area_kg_m2 * s * s
    }

    /// The bending stress tensor (Pa) on the outer surface at a node in
    /// state `b`, in the plane spanned by `along` and `around` (current
    /// unit tangents): −E/(1 − ν²)·T/2·(Δb_z + νΔb_θ) along and likewise
    /// around; the inner surface carries the opposite.
    pub fn outer_surface_stress_pa(
        &self,
        b: &NodeBending,
        along: &Vector3<f64>,
        around: &Vector3<f64>,
    ) -> Matrix3<f64> {
        let (m, h) = (b.along_per_m, b.around_per_m);
        let c = -self.plate_modulus_pa * 0.5 * self.thickness_m;
        along * along.transpose() * (c * (m + self.poisson * h))
            + around * around.transpose() * (c * (h + self.poisson * m))
    }
}

/// von Mises stress (Pa) of a 3D stress tensor.
pub fn von_mises_3d_pa(s: &Matrix3<f64>) -> f64 {
    let d = [
        s[(0, 0)] - s[(1, 1)],
        s[(1, 1)] - s[(2, 2)],
        s[(2, 2)] - s[(0, 0)],
    ];
    let shear = s[(0, 1)].powi(2) + s[(1, 2)].powi(2) + s[(2, 0)].powi(2);
    (0.5 * (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) + 3.0 * shear)
        .max(0.0)
        .sqrt()
}
