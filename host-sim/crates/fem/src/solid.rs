//! The skin as a solid: trilinear hexahedra through the wall's thickness,
//! the paper's own element family (Abaqus C3D8R), total Lagrangian.
//!
//! The membrane ([`super::element`]) and the shell ([`super::bending`])
//! describe the wall by its mid-surface; where the skin folds over the
//! body's edge tighter than its thickness neither holds. Here the wall is
//! `layers` hexahedra thick, its inner surface loaded by the fluid and its
//! outer surface touched by the sand, so bending, through-thickness
//! stresses and the fold at a clamped edge come out of the continuum.
//!
//! The material is the skin law made slightly compressible, as Abaqus does
//! for its hyperelastic solids:
//!
//! ```text
//! W = W_law(Ī1, Ī2) + K/2·(J − 1)²,   Ī1 = J^(−2/3)·I1,  Ī2 = J^(−4/3)·I2
//! ```
//!
//! with K = [`BULK_RATIO`]·μ0 (ν ≈ 0.49). Locking is avoided the standard
//! way for nearly incompressible hexahedra (mean dilatation, Simo–Taylor–
//! Pister): the isochoric part is integrated at the 2×2×2 Gauss points, the
//! volumetric part takes one J per element, J̄ = v/V (current over rest
//! volume, both exact for the trilinear map under that rule). The nodal
//! forces are the exact gradient of that energy,
//!
//! ```text
//! f_a = Σ_g w_g·(P_iso(F_g) + p̄·J_g·F_g⁻ᵀ)·∇N_a(g),   p̄ = K·(J̄ − 1)
//! P_iso = 2W1·J^(−2/3)·(F − I1/3·F⁻ᵀ) + 2W2·J^(−4/3)·(I1·F − F·C − 2I2/3·F⁻ᵀ)
//! ```
//!
//! (checked against finite differences of the energy in `tests/fem.rs`).
//! The stress reported is the Cauchy stress at each element's centre, where
//! a reduced-integration C3D8R reports it.

use nalgebra::{Matrix3, Vector3};
use rayon::prelude::*;

use super::element::PA_PER_KPA;
use super::mesh::TubeMesh;
use super::FemError;
use crate::{LawVisitor, StrainEnergy};

/// Bulk modulus over the law's small-strain shear modulus, K/μ0: Poisson's
/// ratio ν = (3K/μ − 2)/(6K/μ + 2) ≈ 0.495 (Abaqus takes 20 when a
/// hyperelastic law is given as incompressible in Explicit). Stiff enough
/// that the wall's swelling is within about 1 % of the incompressible
/// one's (doubling K moves it by less: `tests/solid.rs`), soft enough that
/// the explicit step (∝ 1/√K) stays near the DEM's.
pub const BULK_RATIO: f64 = 100.0;

/// Natural coordinates of the 8 nodes: around (ξ), along (η), out (ζ).
const CORNERS: [[f64; 3]; 8] = [
    [-1.0, -1.0, -1.0],
    [1.0, -1.0, -1.0],
    [1.0, 1.0, -1.0],
    [-1.0, 1.0, -1.0],
    [-1.0, -1.0, 1.0],
    [1.0, -1.0, 1.0],
    [1.0, 1.0, 1.0],
    [-1.0, 1.0, 1.0],
];

/// The 2-point Gauss abscissa 1/√3.
const GAUSS: f64 = 0.577_350_269_189_625_8;

/// One hexahedron's reference data.
#[derive(Clone, Debug, PartialEq)]
pub struct Hex {
    /// Node indices: the inner face counter-clockwise seen from outside
    /// (around, then along), then the outer face in the same order.
    pub nodes: [usize; 8],
    /// Reference gradients ∇N_a (1/m) at the 8 Gauss points, then at the
    /// centre (index 8).
    gradients_per_m: [[Vector3<f64>; 8]; 9],
    /// Gauss weight × det J0 at each Gauss point (m³).
    weights_m3: [f64; 8],
    /// Σ_g w_g·Σ_a |∇N_a(g)|² (m): the gradients' bound in the stable step.
    gradient_sum_m: f64,
    /// Rest volume V (m³).
    pub volume_m3: f64,
}

/// The state of one hexahedron at the current positions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HexState {
    /// Current over rest volume J̄.
    pub volume_ratio: f64,
    /// Mean pressure term p̄ = K·(J̄ − 1) (Pa; positive in tension).
    pub mean_stress_pa: f64,
    /// Cauchy stress at the centre (Pa).
    pub cauchy_pa: Matrix3<f64>,
}

impl Hex {
    /// Reference data of the hexahedron on `nodes` at rest positions
    /// `rest` (m); `None` when it is degenerate or inside out.
    pub fn new(nodes: [usize; 8], rest: [Vector3<f64>; 8]) -> Option<Hex> {
        let mut gradients_per_m = [[Vector3::zeros(); 8]; 9];
        let mut weights_m3 = [0.0; 8];
        for (g, grads) in gradients_per_m.iter_mut().enumerate() {
            let at = if g < 8 {
                CORNERS[g].map(|c| c * GAUSS)
            } else {
                [0.0; 3]
            };
            let local = local_gradients(at);
            let mut jac = Matrix3::zeros();
            for (x, d) in rest.iter().zip(&local) {
                jac += x * d.transpose();
            }
            let det = jac.determinant();
            if !(det > 0.0 && det.is_finite()) {
                return None;
            }
            let inv_t = jac.try_inverse()?.transpose();
            for (out, d) in grads.iter_mut().zip(&local) {
                *out = inv_t * d;
            }
            if g < 8 {
                weights_m3[g] = det;
            }
        }
        let gradient_sum_m = (0..8)
            .map(|g| {
                weights_m3[g]
                    * gradients_per_m[g]
                        .iter()
                        .map(|d| d.norm_squared())
                        .sum::<f64>()
            })
            .sum();
        Some(Hex {
            nodes,
            gradients_per_m,
            weights_m3,
            gradient_sum_m,
            volume_m3: weights_m3.iter().sum(),
        })
    }

    /// Deformation gradient at point `g` (0–7 Gauss, 8 centre).
    #[inline(always)]
    fn deformation(&self, g: usize, x: &[Vector3<f64>; 8]) -> Matrix3<f64> {
        // Written out: nalgebra's outer product went through a generic
        // matrix–vector loop, the element loop's hot spot.
        let mut f = [[0.0; 3]; 3];
        for (xa, d) in x.iter().zip(&self.gradients_per_m[g]) {
            for (column, dj) in f.iter_mut().zip([d.x, d.y, d.z]) {
                column[0] += xa.x * dj;
                column[1] += xa.y * dj;
                column[2] += xa.z * dj;
            }
        }
        Matrix3::from_data(nalgebra::ArrayStorage(f))
    }

    /// Current volume v (m³): Σ w_g·J_g, exact for the trilinear map.
    fn volume_m3(&self, x: &[Vector3<f64>; 8]) -> f64 {
        (0..8)
            .map(|g| self.weights_m3[g] * self.deformation(g, x).determinant())
            .sum()
    }
}

/// ∂N_a/∂(ξ, η, ζ) of the trilinear shape functions at `at`.
fn local_gradients(at: [f64; 3]) -> [Vector3<f64>; 8] {
    CORNERS.map(|c| {
        let s = [1.0 + c[0] * at[0], 1.0 + c[1] * at[1], 1.0 + c[2] * at[2]];
        Vector3::new(c[0] * s[1] * s[2], s[0] * c[1] * s[2], s[0] * s[1] * c[2]) * 0.125
    })
}

/// The invariants of F: I1 and I2 of C = FᵀF, J^(−2/3), the isochoric
/// Ī1 = J^(−2/3)·I1 and Ī2 = J^(−4/3)·I2.
struct Invariants {
    i1: f64,
    i2: f64,
    j23: f64,
    bar1: f64,
    bar2: f64,
}

/// The cofactor matrix of F, cof F = J·F⁻ᵀ, and J = det F: F⁻ᵀ without a
/// division, which the mean-dilatation pressure term needs as J·F⁻ᵀ anyway.
#[inline(always)]
fn cofactor(f: &Matrix3<f64>) -> (Matrix3<f64>, f64) {
    let m = |i: usize, j: usize| f[(i, j)];
    #[rustfmt::skip]
    let c = Matrix3::new(
        m(1, 1) * m(2, 2) - m(1, 2) * m(2, 1), m(1, 2) * m(2, 0) - m(1, 0) * m(2, 2), m(1, 0) * m(2, 1) - m(1, 1) * m(2, 0),
        m(0, 2) * m(2, 1) - m(0, 1) * m(2, 2), m(0, 0) * m(2, 2) - m(0, 2) * m(2, 0), m(0, 1) * m(2, 0) - m(0, 0) * m(2, 1),
        m(0, 1) * m(1, 2) - m(0, 2) * m(1, 1), m(0, 2) * m(1, 0) - m(0, 0) * m(1, 2), m(0, 0) * m(1, 1) - m(0, 1) * m(1, 0),
    );
    let j = m(0, 0) * c[(0, 0)] + m(0, 1) * c[(0, 1)] + m(0, 2) * c[(0, 2)];
    (c, j)
}

/// The invariants of F of determinant `j`; `None` when J ≤ 0.
#[inline(always)]
fn invariants(f: &Matrix3<f64>, j: f64) -> Option<Invariants> {
    if !(j > 0.0 && j.is_finite()) {
        return None;
    }
    // C = FᵀF from the columns' dot products (symmetric: six of them).
    let col = |j: usize| Vector3::new(f[(0, j)], f[(1, j)], f[(2, j)]);
    let (a, b, c) = (col(0), col(1), col(2));
    let (caa, cbb, ccc) = (a.dot(&a), b.dot(&b), c.dot(&c));
    let (cab, cbc, cca) = (a.dot(&b), b.dot(&c), c.dot(&a));
    let i1 = caa + cbb + ccc;
    let tr_c2 = caa * caa + cbb * cbb + ccc * ccc + 2.0 * (cab * cab + cbc * cbc + cca * cca);
    let i2 = 0.5 * (i1 * i1 - tr_c2);
    let y = inverse_cube_root(j);
    let j23 = y * y;
    Some(Invariants {
        i1,
        i2,
        j23,
        bar1: j23 * i1,
        bar2: j23 * j23 * i2,
    })
}

/// J^(−1/3). Within a quarter of the rest volume (the mean-dilatation
/// wall's Gauss points: its J̄ stays within a few per cent, but single
/// points of a bent element stray by up to tens), three Newton steps from
/// the quadratic Taylor guess reach the last bit (its error 0.3 % at
/// worst, then 2e-5, 1e-9, 2e-18); elsewhere (a collapsing element) the
/// library root. The software cube root was the element loop's hot spot.
#[inline(always)]
fn inverse_cube_root(j: f64) -> f64 {
    let d = j - 1.0;
    if d.abs() > 0.25 {
        return 1.0 / j.cbrt();
    }
    const THIRD: f64 = 1.0 / 3.0;
    let mut y = 1.0 - d * THIRD + d * d * (2.0 / 9.0);
    for _ in 0..3 {
        y *= (4.0 - j * y * y * y) * THIRD;
    }
    y
}

/// The isochoric first Piola–Kirchhoff stress (Pa) of `law` at `f`, of
/// cofactor `cof` and determinant `j` ([`cofactor`]); `None` when J ≤ 0.
/// With F⁻ᵀ = cof/J it is a·F + b·cof, plus the I2 terms for laws that
/// have them.
#[inline(always)]
fn isochoric_stress<S: StrainEnergy + ?Sized>(
    law: &S,
    f: &Matrix3<f64>,
    cof: &Matrix3<f64>,
    j: f64,
) -> Option<Matrix3<f64>> {
    let v = invariants(f, j)?;
    let w1 = law.dw_di1_kpa(v.bar1, v.bar2) * PA_PER_KPA;
    let w2 = law.dw_di2_kpa(v.bar1, v.bar2) * PA_PER_KPA;
    let a = 2.0 * w1 * v.j23;
    let mut p = f * a - cof * (a * v.i1 / (3.0 * j));
    if w2 != 0.0 {
        let b = 2.0 * w2 * v.j23 * v.j23;
        p += (f * v.i1 - f * f.tr_mul(f)) * b - cof * (b * 2.0 * v.i2 / (3.0 * j));
    }
    Some(p)
}

/// The isochoric energy density (Pa) of `law` at `f`; `None` when J ≤ 0.
fn isochoric_energy_pa(law: &dyn StrainEnergy, f: &Matrix3<f64>) -> Option<f64> {
    let v = invariants(f, f.determinant())?;
    Some(law.energy_kpa(v.bar1, v.bar2) * PA_PER_KPA)
}

/// Hexahedra per parallel work item in the force loop.
const CHUNK: usize = 64;

/// The skin's wall as hexahedra: `layers` through the thickness on the
/// structured tube mesh, nodes numbered layer by layer (layer l, tube-mesh
/// node a: l·per_layer + a; layer 0 the inner surface).
#[derive(Clone, Debug, PartialEq)]
pub struct Solid {
    /// Hexahedra through the thickness.
    pub layers: usize,
    /// Nodes in each layer (the tube mesh's).
    pub per_layer: usize,
    /// Bulk modulus K (Pa).
    pub bulk_modulus_pa: f64,
    /// The elements.
    pub hexes: Vec<Hex>,
    /// Each element's density factor (≥ 1; 1: its own mass), set by
    /// [`Solid::scale_mass_to_step_s`].
    pub mass_scale: Vec<f64>,
    /// Whether the element loop may use its AVX2 copy (where the CPU has
    /// AVX2; same bits as the baseline). The caller sets it from its own
    /// instruction-set choice (the coupling: the DEM's); default on.
    pub avx2: bool,
}

impl Solid {
    /// The wall of rest mid-surface `mesh` and thickness `thickness_m`
    /// (m) as `layers` hexahedra through the thickness, of bulk modulus
    /// `bulk_modulus_pa` (Pa); with the rest positions of every node.
    pub fn new(
        mesh: &TubeMesh,
        thickness_m: f64,
        layers: usize,
        bulk_modulus_pa: f64,
    ) -> Result<(Solid, Vec<Vector3<f64>>), FemError> {
        if layers < 1 {
            return Err(FemError::param("layers", layers as f64));
        }
        if !(bulk_modulus_pa > 0.0 && bulk_modulus_pa.is_finite()) {
            return Err(FemError::param("bulk_modulus_pa", bulk_modulus_pa));
        }
        if thickness_m.partial_cmp(&(2.0 * mesh.radius_m)) != Some(std::cmp::Ordering::Less) {
            return Err(FemError::param("thickness_m", thickness_m));
        }
        let per_layer = mesh.rest_m.len();
        let mut rest_m = Vec::with_capacity(per_layer * (layers + 1));
        for l in 0..=layers {
            let r = mesh.radius_m + thickness_m * (l as f64 / layers as f64 - 0.5);
            let scale = r / mesh.radius_m;
            rest_m.extend(
                mesh.rest_m
                    .iter()
                    .map(|x| Vector3::new(x.x * scale, x.y * scale, x.z)),
            );
        }
        let around = mesh.around;
        let id = |i: usize, j: usize, l: usize| l * per_layer + j * around + i % around;
        let mut hexes = Vec::with_capacity(around * mesh.along * layers);
        for l in 0..layers {
            for j in 0..mesh.along {
                for i in 0..around {
                    let nodes = [
                        id(i, j, l),
                        id(i + 1, j, l),
                        id(i + 1, j + 1, l),
                        id(i, j + 1, l),
                        id(i, j, l + 1),
                        id(i + 1, j, l + 1),
                        id(i + 1, j + 1, l + 1),
                        id(i, j + 1, l + 1),
                    ];
                    let hex =
                        Hex::new(nodes, nodes.map(|a| rest_m[a])).ok_or(FemError::Collapsed {
                            element: hexes.len(),
                        })?;
                    hexes.push(hex);
                }
            }
        }
        Ok((
            Solid {
                layers,
                per_layer,
                bulk_modulus_pa,
                mass_scale: vec![1.0; hexes.len()],
                hexes,
                avx2: true,
            },
            rest_m,
        ))
    }

    /// Node index of tube-mesh node `a` in layer `l`.
    pub fn node(&self, l: usize, a: usize) -> usize {
        l * self.per_layer + a
    }

    /// Outer-surface triangles (the sand's) of the wall on `mesh`, normals
    /// pointing away from the axis. The inner surface's (the fluid's) are
    /// the mesh's own: layer 0 numbers its nodes as the mesh does.
    pub fn outer(&self, mesh: &TubeMesh) -> Vec<[usize; 3]> {
        let off = self.layers * self.per_layer;
        mesh.triangles.iter().map(|t| t.map(|a| a + off)).collect()
    }

    /// Node positions of hexahedron `k`.
    fn corners(&self, k: usize, position_m: &[Vector3<f64>]) -> [Vector3<f64>; 8] {
        self.hexes[k].nodes.map(|a| position_m[a])
    }

    /// Total strain energy (J).
    pub fn energy_j(
        &self,
        law: &dyn StrainEnergy,
        position_m: &[Vector3<f64>],
    ) -> Result<f64, FemError> {
        let mut e = 0.0;
        for (k, hex) in self.hexes.iter().enumerate() {
            let x = self.corners(k, position_m);
            for g in 0..8 {
                let w = isochoric_energy_pa(law, &hex.deformation(g, &x))
                    .ok_or(FemError::Collapsed { element: k })?;
                e += hex.weights_m3[g] * w;
            }
            let jbar = hex.volume_m3(&x) / hex.volume_m3;
            e += hex.volume_m3 * 0.5 * self.bulk_modulus_pa * (jbar - 1.0).powi(2);
        }
        Ok(e)
    }

    /// Adds the internal nodal forces ∂E/∂x (N) to `out`. The elements
    /// are evaluated in parallel and summed into `out` in element order,
    /// so the result is the same whatever the thread count.
    pub fn add_internal_forces_n<S: StrainEnergy>(
        &self,
        law: &S,
        position_m: &[Vector3<f64>],
        out: &mut [Vector3<f64>],
    ) -> Result<(), FemError> {
        /// The element loop, compiled for the law `visit` hands it.
        struct Forces<'a> {
            solid: &'a Solid,
            position_m: &'a [Vector3<f64>],
        }
        impl LawVisitor for Forces<'_> {
            type Output = Vec<Result<[Vector3<f64>; 8], FemError>>;
            fn visit<L: StrainEnergy + ?Sized>(self, law: &L) -> Self::Output {
                (0..self.solid.hexes.len())
                    .into_par_iter()
                    .with_min_len(CHUNK)
                    .map(|k| self.solid.hex_forces_dispatch(law, k, self.position_m))
                    .collect()
            }
        }
        let forces = law.visit(Forces {
            solid: self,
            position_m,
        });
        for (hex, f) in self.hexes.iter().zip(forces) {
            for (a, fa) in hex.nodes.iter().zip(f?) {
                out[*a] += fa;
            }
        }
        Ok(())
    }

    /// [`Solid::hex_forces_n`] in its AVX2 copy where [`Solid::avx2`]
    /// allows it and the CPU has AVX2, else the baseline one: the same
    /// operations in the same order, so the same bits.
    fn hex_forces_dispatch<S: StrainEnergy + ?Sized>(
        &self,
        law: &S,
        k: usize,
        position_m: &[Vector3<f64>],
    ) -> Result<[Vector3<f64>; 8], FemError> {
        #[cfg(target_arch = "x86_64")]
        if self.avx2 && std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2, checked just above.
            return unsafe { self.hex_forces_avx2(law, k, position_m) };
        }
        self.hex_forces_n(law, k, position_m)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn hex_forces_avx2<S: StrainEnergy + ?Sized>(
        &self,
        law: &S,
        k: usize,
        position_m: &[Vector3<f64>],
    ) -> Result<[Vector3<f64>; 8], FemError> {
        self.hex_forces_n(law, k, position_m)
    }

    /// The nodal forces (N) of hexahedron `k`.
    #[inline(always)]
    fn hex_forces_n<S: StrainEnergy + ?Sized>(
        &self,
        law: &S,
        k: usize,
        position_m: &[Vector3<f64>],
    ) -> Result<[Vector3<f64>; 8], FemError> {
        let hex = &self.hexes[k];
        let x = self.corners(k, position_m);
        // Written out, not `array::from_fn`: its closure, alike in every
        // law's copy of this function, is merged into one out-of-line
        // function once there are two copies (a law chosen at run time),
        // and the element loop ran ~20 % slower.
        let d = |g| hex.deformation(g, &x);
        let f = [d(0), d(1), d(2), d(3), d(4), d(5), d(6), d(7)];
        let c = |g: usize| cofactor(&f[g]);
        let cof = [c(0), c(1), c(2), c(3), c(4), c(5), c(6), c(7)];
        let jbar = (0..8).map(|g| hex.weights_m3[g] * cof[g].1).sum::<f64>() / hex.volume_m3;
        let pbar = self.bulk_modulus_pa * (jbar - 1.0);
        let mut out = [[0.0; 3]; 8];
        for (g, (fg, (cg, jg))) in f.iter().zip(&cof).enumerate() {
            let p_iso =
                isochoric_stress(law, fg, cg, *jg).ok_or(FemError::Collapsed { element: k })?;
            // The volumetric part J·p̄·F⁻ᵀ is p̄·cof F.
            let p = ((p_iso + cg * pbar) * hex.weights_m3[g]).data.0;
            // P·∇N_a on plain arrays (p's columns): no bounds checks.
            for (o, grad) in out.iter_mut().zip(&hex.gradients_per_m[g]) {
                for (i, oi) in o.iter_mut().enumerate() {
                    *oi += p[0][i] * grad.x + p[1][i] * grad.y + p[2][i] * grad.z;
                }
            }
        }
        Ok(out.map(Vector3::from))
    }

    /// The state of hexahedron `k`: J̄, p̄ and the Cauchy stress at its
    /// centre, σ = P_iso·Fᵀ/J + p̄·1.
    pub fn state(
        &self,
        law: &dyn StrainEnergy,
        k: usize,
        position_m: &[Vector3<f64>],
    ) -> Result<HexState, FemError> {
        let hex = &self.hexes[k];
        let x = self.corners(k, position_m);
        let jbar = hex.volume_m3(&x) / hex.volume_m3;
        let pbar = self.bulk_modulus_pa * (jbar - 1.0);
        let f = hex.deformation(8, &x);
        let (cof, j) = cofactor(&f);
        let p_iso = isochoric_stress(law, &f, &cof, j).ok_or(FemError::Collapsed { element: k })?;
        let cauchy = p_iso * f.transpose() / j + Matrix3::identity() * pbar;
        Ok(HexState {
            volume_ratio: jbar,
            mean_stress_pa: pbar,
            cauchy_pa: 0.5 * (cauchy + cauchy.transpose()),
        })
    }

    /// A stable explicit time step (s) at the current positions: the
    /// smallest of the elements' [`Solid::element_step_s`], each lengthened
    /// by the square root of its [`Solid::mass_scale`].
    pub fn stable_time_step_s(
        &self,
        law: &dyn StrainEnergy,
        density_kg_m3: f64,
        position_m: &[Vector3<f64>],
    ) -> Result<f64, FemError> {
        let mut dt = f64::INFINITY;
        for (k, scale) in self.mass_scale.iter().enumerate() {
            dt = dt.min(self.element_step_s(law, density_kg_m3, position_m, k)? * scale.sqrt());
        }
        Ok(dt)
    }

    /// Element `k`'s stable step at its own density (s): 0.9 × 2/ω_e,
    /// ω_e² a bound on the element's highest frequency at the current
    /// positions (the assembled mesh's is no higher, the element eigenvalue
    /// inequality for lumped masses m_a = ρV/8). The tangent splits into
    /// the mean-dilatation term, rank one, whose frequency is exact,
    ///
    /// ```text
    /// ω_vol² = K/V·Σ_a |g_a|²/m_a,   g_a = ∂v/∂x_a = Σ_g w_g·cof F_g·∇N_a(g),
    /// ```
    ///
    /// and the isochoric term, bounded by Cauchy–Schwarz through the law's
    /// tangent bound μ_t (as 2·μ_t) and Σ_g w_g·Σ_a |∇N_a(g)|². For the
    /// thin wall the first dominates: about the thinnest dimension over the
    /// bulk wave speed (`tests/solid.rs` checks the bound against the
    /// critical step found by power iteration).
    pub fn element_step_s(
        &self,
        law: &dyn StrainEnergy,
        density_kg_m3: f64,
        position_m: &[Vector3<f64>],
        k: usize,
    ) -> Result<f64, FemError> {
        let hex = &self.hexes[k];
        let x = self.corners(k, position_m);
        let mut g = [Vector3::<f64>::zeros(); 8];
        let mut tangent_pa = 0.0f64;
        for (p, weight) in hex.weights_m3.iter().enumerate() {
            let f = hex.deformation(p, &x);
            let (cof, j) = cofactor(&f);
            let v = invariants(&f, j).ok_or(FemError::Collapsed { element: k })?;
            for (ga, grad) in g.iter_mut().zip(&hex.gradients_per_m[p]) {
                *ga += cof * grad * *weight;
            }
            let (i1, b1, b2) = (v.i1, v.bar1, v.bar2);
            let w1 = law.dw_di1_kpa(b1, b2).abs();
            let w2 = law.dw_di2_kpa(b1, b2).abs();
            let w11 = law.d2w_di1_di1_kpa(b1, b2).abs();
            let w12 = law.d2w_di1_di2_kpa(b1, b2).abs();
            let w22 = law.d2w_di2_di2_kpa(b1, b2).abs();
            // Largest squared stretch ≤ tr C; small strain: 2·W1 = μ.
            let shear = PA_PER_KPA
                * (2.0 * (w1 + w2 * b1) * i1 + 4.0 * (w11 + 2.0 * w12 + w22) * b1 * b1 * i1);
            tangent_pa = tangent_pa.max(shear);
        }
        let mass_kg = density_kg_m3 * hex.volume_m3 / 8.0;
        let vol = self.bulk_modulus_pa / hex.volume_m3
            * g.iter().map(|ga| ga.norm_squared()).sum::<f64>()
            / mass_kg;
        let iso = 2.0 * tangent_pa * hex.gradient_sum_m / mass_kg;
        Ok(0.9 * 2.0 / (vol + iso).sqrt())
    }

    /// Mass scaling to a target step (Abaqus's "fixed mass scaling to a
    /// target time increment", re-applied as the wall deforms): every
    /// element whose [`Solid::element_step_s`] is shorter than `target_s`
    /// (s) gets the density factor (target / step)², the others their own
    /// mass. Returns the mass added, as a fraction of the wall's own. For
    /// quasi-static loading
    /// only: the added mass slows the scaled elements' own vibrations,
    /// which are far faster than the loading.
    pub fn scale_mass_to_step_s(
        &mut self,
        law: &dyn StrainEnergy,
        density_kg_m3: f64,
        position_m: &[Vector3<f64>],
        target_s: f64,
    ) -> Result<f64, FemError> {
        let (mut own_m3, mut scaled_m3) = (0.0, 0.0);
        for k in 0..self.hexes.len() {
            let step = self.element_step_s(law, density_kg_m3, position_m, k)?;
            self.mass_scale[k] = (target_s / step).powi(2).max(1.0);
            own_m3 += self.hexes[k].volume_m3;
            scaled_m3 += self.mass_scale[k] * self.hexes[k].volume_m3;
        }
        Ok(scaled_m3 / own_m3 - 1.0)
    }

    /// Lumped nodal masses (kg): each element's rest mass, times its
    /// [`Solid::mass_scale`], in eighths.
    pub fn lumped_masses_kg(&self, density_kg_m3: f64, out: &mut [f64]) {
        for (hex, scale) in self.hexes.iter().zip(&self.mass_scale) {
            for a in hex.nodes {
                out[a] += density_kg_m3 * scale * hex.volume_m3 / 8.0;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::inverse_cube_root;

    #[test]
    fn the_inverse_cube_root_is_the_library_one_to_the_last_bits() {
        // Across the Newton branch, its edges and the library branch.
        for k in 0..=20_000 {
            let j = 0.5 + k as f64 * 1e-4;
            let exact = 1.0 / j.cbrt();
            let got = inverse_cube_root(j);
            assert!(
                ((got - exact) / exact).abs() < 4.0 * f64::EPSILON,
                "J = {j}: {got} against {exact}"
            );
        }
    }
}
