//! The constant-strain triangle membrane of an incompressible hyperelastic
//! skin, in total Lagrangian form.
//!
//! Each triangle keeps its reference shape-function gradients in a local
//! orthonormal basis of its rest plane. The mid-surface deformation
//! gradient F (3×2) gives the in-plane right Cauchy–Green tensor C = FᵀF
//! (2×2); incompressibility fixes the thickness stretch λ3² = 1/det C, so
//! I1 = tr C + 1/det C and I2 = det C + tr C/det C. The reduced energy
//! W(C) already has the plane-stress pressure eliminated, and the membrane
//! second Piola–Kirchhoff stress is S = 2 ∂W/∂C:
//!
//! ```text
//! ∂I1/∂C = 1 − C⁻¹/det C
//! ∂I2/∂C = det C·C⁻¹ + 1/det C − (tr C/det C)·C⁻¹
//! ```
//!
//! The nodal internal force is f_a = A0·T·F·S·∇N_a, exactly ∂E/∂x_a for the
//! element energy E = A0·T·W (checked against finite differences in
//! `tests/fem.rs`).

use nalgebra::{Matrix2, Matrix3x2, Vector2, Vector3};

use crate::StrainEnergy;

/// Pa per kPa: the strain-energy laws are in kPa, the solver in SI.
pub const PA_PER_KPA: f64 = 1e3;

/// One triangle's reference data.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Triangle {
    /// Node indices, counter-clockwise seen from the outside (the side the
    /// normal (x2 − x1) × (x3 − x1) points to).
    pub nodes: [usize; 3],
    /// Reference gradients of the three shape functions in the rest
    /// plane's local basis (1/m).
    pub gradients_per_m: [Vector2<f64>; 3],
    /// Rest area A0 (m²).
    pub area_m2: f64,
    /// Smallest rest altitude (m), for the stable time step.
    pub min_altitude_m: f64,
}

/// The state of strain and stress in one triangle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Strain {
    /// Mid-surface deformation gradient (3×2).
    pub deformation: Matrix3x2<f64>,
    /// In-plane right Cauchy–Green tensor C = FᵀF.
    pub right_cauchy_green: Matrix2<f64>,
    /// det C = (λ1·λ2)².
    pub det_c: f64,
    /// First invariant of the 3D C (with λ3² = 1/det C).
    pub i1: f64,
    /// Second invariant of the 3D C.
    pub i2: f64,
}

impl Triangle {
    /// Builds the reference data of the triangle on `nodes` at rest
    /// positions `rest` (m); `None` when it is degenerate.
    pub fn new(nodes: [usize; 3], rest: [Vector3<f64>; 3]) -> Option<Triangle> {
        let (e21, e31) = (rest[1] - rest[0], rest[2] - rest[0]);
        let normal = e21.cross(&e31);
        let twice_area = normal.norm();
        let l21 = e21.norm();
        if !(twice_area > 0.0 && l21 > 0.0 && twice_area.is_finite()) {
            return None;
        }
        let b1 = e21 / l21;
        let b2 = (normal / twice_area).cross(&b1);
        let p = rest.map(|x| Vector2::new((x - rest[0]).dot(&b1), (x - rest[0]).dot(&b2)));
        let inv = 1.0 / twice_area;
        let gradients_per_m = [
            Vector2::new(p[1].y - p[2].y, p[2].x - p[1].x) * inv,
            Vector2::new(p[2].y - p[0].y, p[0].x - p[2].x) * inv,
            Vector2::new(p[0].y - p[1].y, p[1].x - p[0].x) * inv,
        ];
        let longest = [e21.norm(), e31.norm(), (rest[2] - rest[1]).norm()]
            .into_iter()
            .fold(0.0, f64::max);
        Some(Triangle {
            nodes,
            gradients_per_m,
            area_m2: 0.5 * twice_area,
            min_altitude_m: twice_area / longest,
        })
    }

    /// Strain at current node positions `x` (m); `None` when the triangle
    /// has collapsed (det C ≤ 0 or not finite).
    pub fn strain(&self, x: [Vector3<f64>; 3]) -> Option<Strain> {
        let deformation: Matrix3x2<f64> = (0..3)
            .map(|a| x[a] * self.gradients_per_m[a].transpose())
            .sum();
        let c = deformation.transpose() * deformation;
        let det_c = c.determinant();
        if !(det_c > 0.0 && det_c.is_finite()) {
            return None;
        }
        let tr = c.trace();
        Some(Strain {
            deformation,
            right_cauchy_green: c,
            det_c,
            i1: tr + 1.0 / det_c,
            i2: det_c + tr / det_c,
        })
    }
}

impl Strain {
    /// Thickness stretch λ3 = 1/√det C.
    pub fn thickness_stretch(&self) -> f64 {
        1.0 / self.det_c.sqrt()
    }

    /// Membrane second Piola–Kirchhoff stress S = 2 ∂W/∂C (Pa).
    pub fn second_piola_kirchhoff_pa(&self, law: &dyn StrainEnergy) -> Matrix2<f64> {
        let c = &self.right_cauchy_green;
        let (det, tr) = (self.det_c, c.trace());
        // Closed-form 2×2 inverse (det > 0 is checked when the strain is built).
        let c_inv = Matrix2::new(c[(1, 1)], -c[(0, 1)], -c[(1, 0)], c[(0, 0)]) / det;
        let id = Matrix2::identity();
        let d_i1 = id - c_inv / det;
        let d_i2 = c_inv * det + id / det - c_inv * (tr / det);
        let w1 = law.dw_di1_kpa(self.i1, self.i2);
        let w2 = law.dw_di2_kpa(self.i1, self.i2);
        (d_i1 * w1 + d_i2 * w2) * (2.0 * PA_PER_KPA)
    }

    /// Strain-energy density W (J/m³ = Pa).
    pub fn energy_density_pa(&self, law: &dyn StrainEnergy) -> f64 {
        law.energy_kpa(self.i1, self.i2) * PA_PER_KPA
    }

    /// In-plane principal Cauchy stresses (Pa) for the stress `s` (the
    /// eigenvalues of F·S·Fᵀ, which are those of S·C; J = 1).
    pub fn principal_cauchy_pa(&self, s: &Matrix2<f64>) -> [f64; 2] {
        let sc = s * self.right_cauchy_green;
        let (tr, det) = (sc.trace(), sc.determinant());
        let disc = (0.25 * tr * tr - det).max(0.0).sqrt();
        [0.5 * tr + disc, 0.5 * tr - disc]
    }

    /// von Mises stress (Pa) of the plane-stress state (σ3 = 0):
    /// √(σ1² − σ1σ2 + σ2²).
    pub fn von_mises_pa(&self, s: &Matrix2<f64>) -> f64 {
        let [a, b] = self.principal_cauchy_pa(s);
        (a * a - a * b + b * b).max(0.0).sqrt()
    }

    /// Small-strain-free bound on the squared longitudinal wave speed
    /// times density (Pa) of the material at this strain: an upper
    /// estimate of the tangent modulus, for the explicit stable step.
    pub fn tangent_modulus_bound_pa(&self, law: &dyn StrainEnergy) -> f64 {
        let (i1, i2) = (self.i1, self.i2);
        let w1 = law.dw_di1_kpa(i1, i2).abs();
        let w2 = law.dw_di2_kpa(i1, i2).abs();
        let w11 = law.d2w_di1_di1_kpa(i1, i2).abs();
        let w12 = law.d2w_di1_di2_kpa(i1, i2).abs();
        let w22 = law.d2w_di2_di2_kpa(i1, i2).abs();
        let lmax2 = self.right_cauchy_green.trace();
        // Small strain: 8·W1 is the plane-stress modulus 4μ; the rest bound
        // the growth with stretch and the thickness term 1/det C.
        PA_PER_KPA
            * (8.0 * (w1 + w2 * i1) * (1.0 + 1.0 / self.det_c) * lmax2.max(1.0)
                + 16.0 * (w11 + 2.0 * w12 + w22) * i1 * i1 * lmax2.max(1.0))
    }
}

/// Internal nodal forces f_a = A0·T·F·S·∇N_a (N) of a triangle of
/// thickness `thickness_m` at strain `e` with stress `s` (Pa).
pub fn internal_forces_n(
    tri: &Triangle,
    e: &Strain,
    s: &Matrix2<f64>,
    thickness_m: f64,
) -> [Vector3<f64>; 3] {
    let fs = e.deformation * s * (tri.area_m2 * thickness_m);
    tri.gradients_per_m.map(|g| fs * g)
}
