//! Ogden (1972), one to three terms:
//! W = Σp μp/αp·(λ1^αp + λ2^αp + λ3^αp − 3), μ = ½·Σp μp·αp.
//!
//! The law is written in principal stretches; the FEM skin and the
//! interface ask for W(I1, I2) and its derivatives. For incompressible
//! stretches the squares c_a = λa² are the roots of
//! p(z) = z³ − I1·z² + I2·z − 1, and with h(z) = Σp (μp/2)·z^(αp/2):
//!
//! - W1 = ∂W/∂I1 = (z·h)\[c1, c2, c3\] and W2 = ∂W/∂I2 = −h\[c1, c2, c3\]
//!   (second divided differences: the quadratic that interpolates z·h at
//!   the roots gives the stress t_a = 2·W1·c_a − 2·W2/c_a + const);
//! - the second derivatives are the same divided differences with every
//!   node doubled: W11 = (z³h)\[c1 c1 c2 c2 c3 c3\], W12 = −(z²h)\[…\],
//!   W22 = (z·h)\[…\].
//!
//! A divided difference over the roots of p is the contour integral
//! (1/2πi)∮ f(z)/p(z) dz (1/p² for doubled nodes), taken here in
//! s = ln z around an ellipse that encloses every ln c_a: no roots are
//! computed, coincident stretches (at rest, uniaxial, equibiaxial) need no
//! special case, and the result is smooth in (I1, I2). The trapezoid rule
//! converges geometrically on it; the node count follows the ellipse's
//! aspect so the error stays near rounding (checked against Mooney–Rivlin,
//! which is Ogden with α = 2 and −2, and against finite differences).
//!
//! The homogeneous tests and the tube use the principal-stretch closed
//! forms directly (t_a = Σp μp·λa^αp), which are exact and cheap.

use serde::{Deserialize, Serialize};

use super::{Form, LawSpec, SignPair, StrainEnergy};

/// One Ogden term: μp/αp·(Σa λa^αp − 3).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct OgdenTerm {
    /// μp (kPa).
    pub mu_kpa: f64,
    /// αp (dimensionless, nonzero).
    pub alpha: f64,
}

/// Ogden strain energy with one to three terms.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Ogden {
    terms: Vec<OgdenTerm>,
}

/// Bounds of every exponent in a fit: beyond |α| = 12 the terms overflow
/// long before any rubber needs them.
const ALPHA_BOUND: f64 = 12.0;
/// Bounds of every modulus in a fit (kPa).
const MU_BOUND_KPA: f64 = 1e7;

/// Coefficient names of the three registry rows.
const NAMES: [&[&str]; 3] = [
    &["mu1_kpa", "alpha1"],
    &["mu1_kpa", "alpha1", "mu2_kpa", "alpha2"],
    &[
        "mu1_kpa", "alpha1", "mu2_kpa", "alpha2", "mu3_kpa", "alpha3",
    ],
];
const BOUNDS: &[(f64, f64)] = &[
    (-MU_BOUND_KPA, MU_BOUND_KPA),
    (-ALPHA_BOUND, ALPHA_BOUND),
    (-MU_BOUND_KPA, MU_BOUND_KPA),
    (-ALPHA_BOUND, ALPHA_BOUND),
    (-MU_BOUND_KPA, MU_BOUND_KPA),
    (-ALPHA_BOUND, ALPHA_BOUND),
];

/// Starting exponents the fitter tries (moduli then by linear least
/// squares): the published Treloar shapes and spreads around them. A
/// start's exponent signs fix its terms' signs ([`SIGN_PAIRS`]), so the
/// starts cover every sign pattern up to the terms' order but all-negative.
fn alpha_starts(terms: usize) -> Vec<Vec<f64>> {
    match terms {
        1 => vec![
            vec![2.0],
            vec![1.0],
            vec![3.0],
            vec![5.0],
            vec![-2.0],
            vec![8.0],
        ],
        2 => vec![
            vec![1.3, 5.0],
            vec![2.0, -2.0],
            vec![1.0, 4.0],
            vec![3.0, -1.0],
            vec![0.5, 7.0],
            vec![1.5, 9.0],
            vec![-1.0, -4.0],
        ],
        _ => vec![
            vec![1.3, 5.0, -2.0],
            vec![2.0, 4.0, -1.0],
            vec![1.0, 6.0, -3.0],
            vec![0.5, 3.0, -2.0],
            vec![1.8, 8.0, -0.5],
            vec![3.0, 1.0, -4.0],
            vec![1.2, 5.5, 2.5],
            vec![2.0, -1.0, -3.0],
        ],
    }
}

/// Which coefficients the stresses are linear in (the moduli).
const MU_INDEX: &[usize] = &[0, 2, 4];

/// Each term's μp and αp share their sign in a fit (μp·αp > 0, Ogden
/// 1972): every term then stiffens in tension and adds to the shear
/// modulus ½Σμpαp, so a fit is never unstable at rest.
const SIGN_PAIRS: &[SignPair] = &[
    SignPair {
        modulus: 0,
        exponent: 1,
    },
    SignPair {
        modulus: 2,
        exponent: 3,
    },
    SignPair {
        modulus: 4,
        exponent: 5,
    },
];

fn one(p: &[f64]) -> Option<Box<dyn StrainEnergy>> {
    sized(p, 1)
}
fn two(p: &[f64]) -> Option<Box<dyn StrainEnergy>> {
    sized(p, 2)
}
fn three(p: &[f64]) -> Option<Box<dyn StrainEnergy>> {
    sized(p, 3)
}
fn sized(p: &[f64], terms: usize) -> Option<Box<dyn StrainEnergy>> {
    (p.len() == 2 * terms)
        .then(|| Ogden::from_flat(p))
        .flatten()
        .map(|o| Box::new(o) as Box<dyn StrainEnergy>)
}

impl Ogden {
    /// Registry rows for one, two and three terms.
    pub const SPECS: [LawSpec; 3] = [
        LawSpec {
            name: "Ogden-1",
            parameter_names: NAMES[0],
            from_parameters: one,
            form: Form::Nonlinear {
                bounds: BOUNDS.split_at(2).0,
                linear_in: MU_INDEX.split_at(1).0,
                starts: || alpha_starts(1),
                sign_pairs: SIGN_PAIRS.split_at(1).0,
            },
        },
        LawSpec {
            name: "Ogden-2",
            parameter_names: NAMES[1],
            from_parameters: two,
            form: Form::Nonlinear {
                bounds: BOUNDS.split_at(4).0,
                linear_in: MU_INDEX.split_at(2).0,
                starts: || alpha_starts(2),
                sign_pairs: SIGN_PAIRS.split_at(2).0,
            },
        },
        LawSpec {
            name: "Ogden-3",
            parameter_names: NAMES[2],
            from_parameters: three,
            form: Form::Nonlinear {
                bounds: BOUNDS,
                linear_in: MU_INDEX,
                starts: || alpha_starts(3),
                sign_pairs: SIGN_PAIRS.split_at(3).0,
            },
        },
    ];

    /// The published three-term fit of Ogden (1972) to Treloar's data:
    /// μ = 0.63, 0.0012, −0.01 MPa; α = 1.3, 5.0, −2.0 (μ = ½Σμpαp ≈ 0.42 MPa).
    pub fn ogden_1972_treloar() -> Ogden {
        Ogden::new(&[
            OgdenTerm {
                mu_kpa: 630.0,
                alpha: 1.3,
            },
            OgdenTerm {
                mu_kpa: 1.2,
                alpha: 5.0,
            },
            OgdenTerm {
                mu_kpa: -10.0,
                alpha: -2.0,
            },
        ])
        .unwrap_or_else(|| unreachable!("three nonzero exponents"))
    }

    /// An Ogden law of 1–3 terms; `None` for another count, a zero or
    /// non-finite exponent, or a non-finite modulus.
    pub fn new(terms: &[OgdenTerm]) -> Option<Ogden> {
        let ok = (1..=3).contains(&terms.len())
            && terms
                .iter()
                .all(|t| t.mu_kpa.is_finite() && t.alpha.is_finite() && t.alpha != 0.0);
        ok.then(|| Ogden {
            terms: terms.to_vec(),
        })
    }

    /// From (μ1, α1, μ2, α2, …).
    fn from_flat(p: &[f64]) -> Option<Ogden> {
        if !p.len().is_multiple_of(2) {
            return None;
        }
        let terms: Vec<OgdenTerm> = p
            .chunks_exact(2)
            .map(|c| OgdenTerm {
                mu_kpa: c[0],
                alpha: c[1],
            })
            .collect();
        Ogden::new(&terms)
    }

    /// The terms.
    pub fn terms(&self) -> &[OgdenTerm] {
        &self.terms
    }

    /// (1/2πi)∮ F(s) ds around every ln c_a, for F given at (s, z = e^s,
    /// p(z)): the trapezoid rule on an ellipse in s = ln z.
    fn contour(i1: f64, i2: f64, f: impl Fn(Complex, Complex, Complex) -> Complex) -> f64 {
        // Real positive roots lie in [1/I2, I1] (all c_a > 0, Σc = I1,
        // Σ1/c = I2 when Πc = 1); a margin of 1 keeps the poles off the path.
        let (lo, hi) = (-i2.max(1.0).ln(), i1.max(1.0).ln());
        let centre = 0.5 * (lo + hi);
        let a = 0.5 * (hi - lo) + 1.0;
        // Semi-minor axis: well clear of the pole copies at ln c ± 2πi.
        let b = 1.5_f64.min(a);
        // Trapezoid error ~ e^(−N·ξ0), ξ0 the ellipse's elliptic radius:
        // 40/ξ0 nodes give near rounding.
        let xi0 = (b / a).atanh();
        let n = ((40.0 / xi0).ceil() as usize).clamp(48, 2048);
        let mut acc = 0.0;
        for j in 0..n {
            let th = std::f64::consts::TAU * (j as f64 + 0.5) / n as f64;
            let (sin, cos) = th.sin_cos();
            let s = Complex::new(centre + a * cos, b * sin);
            let ds = Complex::new(-a * sin, b * cos);
            let z = s.exp();
            let p = ((z - i1) * z + i2) * z - 1.0;
            // (1/2πi)·(2π/N)·Σ F·s′: the real part is Im(F·s′)/N (the
            // imaginary part cancels by symmetry).
            acc += (f(s, z, p) * ds).im;
        }
        acc / n as f64
    }

    /// z^(αp/2)-weighted sum Σp w(t)·z^(αp/2) at s = ln z.
    fn powers(&self, s: Complex, w: impl Fn(&OgdenTerm) -> f64) -> Complex {
        self.terms.iter().fold(Complex::new(0.0, 0.0), |acc, t| {
            acc + (s * (0.5 * t.alpha)).exp() * w(t)
        })
    }

    /// (1/2πi)∮ z^k·h(z)/p(z)^m dz (m = 1 or 2): a divided difference of
    /// z^k·h over the roots (each doubled when m = 2).
    fn divided(&self, i1: f64, i2: f64, k: i32, m: i32) -> f64 {
        Self::contour(i1, i2, |s, _, p| {
            let h = self.powers(s, |t| 0.5 * t.mu_kpa);
            let pm = if m == 2 { p * p } else { p };
            // dz = z·ds.
            (s * f64::from(k + 1)).exp() * h / pm
        })
    }

    /// Σa φ(c_a) with φ(z) = Σp μp/αp·z^(αp/2): (1/2πi)∮ φ·p′/p dz.
    fn trace_energy(&self, i1: f64, i2: f64) -> f64 {
        Self::contour(i1, i2, |s, z, p| {
            let phi = self.powers(s, |t| t.mu_kpa / t.alpha);
            let dp = (z * 3.0 - 2.0 * i1) * z + i2;
            phi * dp / p * z
        })
    }
}

impl StrainEnergy for Ogden {
    fn name(&self) -> &'static str {
        match self.terms.len() {
            1 => Self::SPECS[0].name,
            2 => Self::SPECS[1].name,
            _ => Self::SPECS[2].name,
        }
    }
    fn parameters(&self) -> Vec<f64> {
        self.terms
            .iter()
            .flat_map(|t| [t.mu_kpa, t.alpha])
            .collect()
    }
    fn energy_kpa(&self, i1: f64, i2: f64) -> f64 {
        let rest: f64 = self.terms.iter().map(|t| 3.0 * t.mu_kpa / t.alpha).sum();
        self.trace_energy(i1, i2) - rest
    }
    fn dw_di1_kpa(&self, i1: f64, i2: f64) -> f64 {
        self.divided(i1, i2, 1, 1)
    }
    fn dw_di2_kpa(&self, i1: f64, i2: f64) -> f64 {
        -self.divided(i1, i2, 0, 1)
    }
    fn d2w_di1_di1_kpa(&self, i1: f64, i2: f64) -> f64 {
        self.divided(i1, i2, 3, 2)
    }
    fn d2w_di1_di2_kpa(&self, i1: f64, i2: f64) -> f64 {
        -self.divided(i1, i2, 2, 2)
    }
    fn d2w_di2_di2_kpa(&self, i1: f64, i2: f64) -> f64 {
        self.divided(i1, i2, 1, 2)
    }

    fn shear_modulus_kpa(&self) -> f64 {
        0.5 * self.terms.iter().map(|t| t.mu_kpa * t.alpha).sum::<f64>()
    }
    fn extra_stress_kpa(&self, stretches: [f64; 3]) -> [f64; 3] {
        stretches.map(|l| self.terms.iter().map(|t| t.mu_kpa * l.powf(t.alpha)).sum())
    }
    fn uniaxial_nominal_slope_kpa(&self, stretch: f64) -> f64 {
        // P = Σ μp·(λ^(αp−1) − λ^(−αp/2−1)).
        let l = stretch;
        self.terms
            .iter()
            .map(|t| {
                let a = t.alpha;
                t.mu_kpa * ((a - 1.0) * l.powf(a - 2.0) + (0.5 * a + 1.0) * l.powf(-0.5 * a - 2.0))
            })
            .sum()
    }
}

/// The little complex arithmetic the contour needs (no new dependency).
#[derive(Clone, Copy, Debug)]
struct Complex {
    re: f64,
    im: f64,
}

impl Complex {
    const fn new(re: f64, im: f64) -> Self {
        Self { re, im }
    }
    fn exp(self) -> Self {
        let m = self.re.exp();
        let (s, c) = self.im.sin_cos();
        Self::new(m * c, m * s)
    }
}

impl std::ops::Add for Complex {
    type Output = Self;
    fn add(self, o: Self) -> Self {
        Self::new(self.re + o.re, self.im + o.im)
    }
}
impl std::ops::Sub<f64> for Complex {
    type Output = Self;
    fn sub(self, o: f64) -> Self {
        Self::new(self.re - o, self.im)
    }
}
impl std::ops::Add<f64> for Complex {
    type Output = Self;
    fn add(self, o: f64) -> Self {
        Self::new(self.re + o, self.im)
    }
}
impl std::ops::Mul for Complex {
    type Output = Self;
    fn mul(self, o: Self) -> Self {
        Self::new(
            self.re * o.re - self.im * o.im,
            self.re * o.im + self.im * o.re,
        )
    }
}
impl std::ops::Mul<f64> for Complex {
    type Output = Self;
    fn mul(self, o: f64) -> Self {
        Self::new(self.re * o, self.im * o)
    }
}
impl std::ops::Div for Complex {
    type Output = Self;
    fn div(self, o: Self) -> Self {
        let d = o.re * o.re + o.im * o.im;
        Self::new(
            (self.re * o.re + self.im * o.im) / d,
            (self.im * o.re - self.re * o.im) / d,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{invariants, MooneyRivlin};

    fn close(a: f64, b: f64, tol: f64, what: &str) {
        assert!(
            (a - b).abs() <= tol * a.abs().max(b.abs()).max(1.0),
            "{what}: {a} vs {b}"
        );
    }

    #[test]
    fn alpha_two_and_minus_two_is_mooney_rivlin_in_every_derivative() {
        // μ1/2·(Σλ² − 3) − μ2/2·(Σλ⁻² − 3): C10 = μ1/2, C01 = −μ2/2.
        let o = Ogden::new(&[
            OgdenTerm {
                mu_kpa: 300.0,
                alpha: 2.0,
            },
            OgdenTerm {
                mu_kpa: -80.0,
                alpha: -2.0,
            },
        ])
        .unwrap();
        let mr = MooneyRivlin {
            c10_kpa: 150.0,
            c01_kpa: 40.0,
        };
        // At rest, uniaxial and equibiaxial (coincident roots), planar,
        // and extreme stretches.
        let points = [
            [1.0, 1.0, 1.0],
            [1.5, 1.5_f64.powf(-0.5), 1.5_f64.powf(-0.5)],
            [8.0, 8.0_f64.powf(-0.5), 8.0_f64.powf(-0.5)],
            [0.3, 0.3_f64.powf(-0.5), 0.3_f64.powf(-0.5)],
            [5.0, 5.0, 0.04],
            [2.0, 1.0, 0.5],
            [1.7, 1.2, 1.0 / (1.7 * 1.2)],
            [1.0 + 1e-7, 1.0, 1.0 / (1.0 + 1e-7)],
        ];
        for l in points {
            let (i1, i2) = invariants(l);
            let w = format!("{l:?}");
            close(o.energy_kpa(i1, i2), mr.energy_kpa(i1, i2), 1e-11, &w);
            close(o.dw_di1_kpa(i1, i2), 150.0, 1e-11, &w);
            close(o.dw_di2_kpa(i1, i2), 40.0, 1e-11, &w);
            close(o.d2w_di1_di1_kpa(i1, i2), 0.0, 1e-10, &w);
            close(o.d2w_di1_di2_kpa(i1, i2), 0.0, 1e-10, &w);
            close(o.d2w_di2_di2_kpa(i1, i2), 0.0, 1e-10, &w);
        }
        assert_eq!(o.shear_modulus_kpa(), mr.shear_modulus_kpa());
    }

    #[test]
    fn invariant_derivatives_reproduce_the_principal_stresses() {
        // t_a = 2·W1·λa² − 2·W2·λa⁻² must equal Σ μp·λa^αp up to a common
        // pressure, for a general law at distinct and coincident stretches.
        let o = Ogden::ogden_1972_treloar();
        for l in [
            [2.0, 1.1, 1.0 / 2.2],
            [6.0, 6.0_f64.powf(-0.5), 6.0_f64.powf(-0.5)],
            [3.0, 3.0, 1.0 / 9.0],
            [1.0, 1.0, 1.0],
            [0.5, 1.3, 1.0 / 0.65],
        ] {
            let (i1, i2) = invariants(l);
            let (w1, w2) = (o.dw_di1_kpa(i1, i2), o.dw_di2_kpa(i1, i2));
            let inv: Vec<f64> = l
                .iter()
                .map(|x| 2.0 * w1 * x * x - 2.0 * w2 / (x * x))
                .collect();
            let pri = o.extra_stress_kpa(l);
            for (a, b) in [(0, 1), (1, 2), (0, 2)] {
                close(inv[a] - inv[b], pri[a] - pri[b], 1e-10, &format!("{l:?}"));
            }
            // And W itself: Σp μp/αp·(Σ λ^αp − 3).
            let w: f64 = o
                .terms()
                .iter()
                .map(|t| {
                    t.mu_kpa / t.alpha * (l.iter().map(|x| x.powf(t.alpha)).sum::<f64>() - 3.0)
                })
                .sum();
            close(o.energy_kpa(i1, i2), w, 1e-10, "W");
        }
        // The literature's shear modulus, ½Σμpαp ≈ 0.42 MPa.
        close(o.shear_modulus_kpa(), 422.5, 1e-12, "μ");
    }
}
