//! Inflation of the skin as a thick-walled incompressible hyperelastic tube:
//! internal pressure (above the outside pressure) vs outer diameter, and the
//! stresses through the wall.
//!
//! Kinematics (reference radius R ∈ [Ri, Ro], current r, axial stretch λz):
//! incompressibility gives r² = ri² + (R² − Ri²)/λz, and the principal
//! stretches are λθ = r/R, λz, λr = 1/(λθ·λz).
//!
//! Radial equilibrium dσr/dr + (σr − σθ)/r = 0 with σr(ri) = −pi and
//! σr(ro) = −pe integrates to
//!
//! ```text
//! pi − pe = ∫[ri, ro] (σθ − σr) dr/r = ∫[Ri, Ro] (σθ − σr) · R / (λz·r²) dR
//! ```
//!
//! which depends on the deformation only, so the skin adds the same
//! pressure whatever the sand does: p_i = p_membrane(D) + p_e(D, h).
//!
//! Ends: in plane strain λz = 1. With closed ends the wall carries the
//! pressure on the end caps, N = pi·π·ri² (gauge, outside pressure zero);
//! integrating σr by parts turns that into
//! `∫ [2(σz − σr) − (σθ − σr)] r dr = 0`, an equation for λz alone.
//!
//! The integrals use Gauss–Legendre quadrature over R (the integrand is
//! smooth); [`Quadrature::Simpson`] is an independent rule for checks.

use serde::Serialize;
use thiserror::Error;

use super::StrainEnergy;

pub use fem::TubeGeometry;

/// How the tube's ends are held.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Ends {
    /// No axial strain (λz = 1): the zone is held at its length by the body.
    PlaneStrain,
    /// Closed ends, free length: the wall carries p·π·ri² axially.
    Closed,
}

impl Ends {
    /// Short label for tables and provenance lines.
    pub fn label(self) -> &'static str {
        match self {
            Self::PlaneStrain => "plane-strain",
            Self::Closed => "closed-end",
        }
    }
}

/// Rule for the through-thickness integrals.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Quadrature {
    /// Gauss–Legendre with this many points (production rule).
    GaussLegendre(usize),
    /// Composite Simpson with this many intervals (made even); for checks.
    Simpson(usize),
}

/// Why a state could not be computed.
#[derive(Debug, Error, PartialEq)]
pub enum MembraneError {
    /// The geometry is not a tube (non-positive radius or thickness).
    #[error("tube geometry is invalid: outer diameter {outer_diameter_mm} mm, wall {wall_thickness_mm} mm")]
    Geometry {
        /// D0 (mm).
        outer_diameter_mm: f64,
        /// Wall thickness (mm).
        wall_thickness_mm: f64,
    },
    /// The requested diameter leaves no room for the bore.
    #[error(
        "outer diameter {outer_diameter_mm} mm closes the bore (axial stretch {axial_stretch})"
    )]
    Closed {
        /// Requested outer diameter (mm).
        outer_diameter_mm: f64,
        /// Axial stretch tried.
        axial_stretch: f64,
    },
    /// No axial stretch in [0.05, 20] balances the end caps.
    #[error("no axial stretch balances the closed ends at outer diameter {outer_diameter_mm} mm")]
    NoAxialBalance {
        /// Requested outer diameter (mm).
        outer_diameter_mm: f64,
    },
}

/// The tube at one inflated state.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct InflationState {
    /// Outer diameter D (mm).
    pub outer_diameter_mm: f64,
    /// Inner diameter (mm).
    pub inner_diameter_mm: f64,
    /// Current wall thickness (mm).
    pub wall_thickness_mm: f64,
    /// Axial stretch λz (1 in plane strain).
    pub axial_stretch: f64,
    /// Hoop stretch at the outer surface, D/D0.
    pub hoop_stretch_outer: f64,
    /// Hoop stretch at the inner surface (the largest in the wall).
    pub hoop_stretch_inner: f64,
    /// Internal minus external pressure carried by the skin (kPa).
    pub pressure_kpa: f64,
    /// Largest von Mises stress in the wall (kPa).
    pub max_von_mises_kpa: f64,
    /// Reference radius R where it occurs (mm).
    pub max_von_mises_at_reference_radius_mm: f64,
    /// Fluid volume inside the zone, π·ri²·λz·L (mL).
    pub volume_ml: f64,
}

/// Stresses at one point through the wall (outside pressure zero).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct WallPoint {
    /// Reference radius R (mm).
    pub reference_radius_mm: f64,
    /// Current radius r (mm).
    pub radius_mm: f64,
    /// Radial Cauchy stress σr (kPa).
    pub radial_kpa: f64,
    /// Hoop Cauchy stress σθ (kPa).
    pub hoop_kpa: f64,
    /// Axial Cauchy stress σz (kPa).
    pub axial_kpa: f64,
    /// von Mises stress (kPa); unchanged by an outside pressure.
    pub von_mises_kpa: f64,
}

/// A skin tube of one strain-energy law.
#[derive(Clone, Debug)]
pub struct Tube<S: StrainEnergy> {
    /// Rest geometry.
    pub geometry: TubeGeometry,
    /// Skin material.
    pub skin: S,
    /// End condition.
    pub ends: Ends,
    /// (node, weight) pairs on [−1, 1], or Simpson's.
    rule: Vec<(f64, f64)>,
}

/// Points of the production Gauss–Legendre rule; the wall integrand is a
/// smooth function of R, and 24 points reach ~1e-14 relative on it.
pub const DEFAULT_QUADRATURE: Quadrature = Quadrature::GaussLegendre(24);

/// Points sampled through the wall when looking for the von Mises maximum.
const WALL_SAMPLES: usize = 33;

impl<S: StrainEnergy> Tube<S> {
    /// The paper's zone ([`TubeGeometry::PAPER`], valid by construction)
    /// with the production quadrature.
    pub fn paper(skin: S, ends: Ends) -> Self {
        Self {
            geometry: TubeGeometry::PAPER,
            skin,
            ends,
            rule: quadrature_rule(DEFAULT_QUADRATURE),
        }
    }

    /// A tube with the production quadrature.
    pub fn new(geometry: TubeGeometry, skin: S, ends: Ends) -> Result<Self, MembraneError> {
        Self::with_quadrature(geometry, skin, ends, DEFAULT_QUADRATURE)
    }

    /// A tube with a chosen quadrature rule.
    pub fn with_quadrature(
        geometry: TubeGeometry,
        skin: S,
        ends: Ends,
        quadrature: Quadrature,
    ) -> Result<Self, MembraneError> {
        let ok = geometry.wall_thickness_mm > 0.0
            && geometry.inner_radius_mm() > 0.0
            && geometry.outer_diameter_mm.is_finite();
        if !ok {
            return Err(MembraneError::Geometry {
                outer_diameter_mm: geometry.outer_diameter_mm,
                wall_thickness_mm: geometry.wall_thickness_mm,
            });
        }
        Ok(Self {
            geometry,
            skin,
            ends,
            rule: quadrature_rule(quadrature),
        })
    }

    /// Integrates `f(R)` over the rest wall [Ri, Ro].
    fn integrate(&self, f: impl Fn(f64) -> f64) -> f64 {
        self.integrate_to(self.geometry.outer_radius_mm(), f)
    }

    /// Integrates `f(R)` over [Ri, upper].
    fn integrate_to(&self, upper: f64, f: impl Fn(f64) -> f64) -> f64 {
        let lo = self.geometry.inner_radius_mm();
        let half = 0.5 * (upper - lo);
        let mid = 0.5 * (upper + lo);
        half * self
            .rule
            .iter()
            .map(|(x, w)| w * f(mid + half * x))
            .sum::<f64>()
    }

    /// Current inner radius ri² (mm²) for outer radius `ro` and axial
    /// stretch `lz`, from incompressibility.
    fn inner_radius_sq(&self, ro: f64, lz: f64) -> f64 {
        let (rro, rri) = (
            self.geometry.outer_radius_mm(),
            self.geometry.inner_radius_mm(),
        );
        ro * ro - (rro * rro - rri * rri) / lz
    }

    /// Principal stretches (r, θ, z) at reference radius `rr`.
    fn stretches(rr: f64, ri_sq: f64, lz: f64, rri: f64) -> ([f64; 3], f64) {
        let r = (ri_sq + (rr * rr - rri * rri) / lz).sqrt();
        let lt = r / rr;
        ([1.0 / (lt * lz), lt, lz], r)
    }

    /// Extra stresses (r, θ, z) and current radius at reference radius `rr`.
    fn extra_at(&self, rr: f64, ri_sq: f64, lz: f64) -> ([f64; 3], f64) {
        let (l, r) = Self::stretches(rr, ri_sq, lz, self.geometry.inner_radius_mm());
        (self.skin.extra_stress_kpa(l), r)
    }

    /// ∫ (σθ − σr) dr/r over [Ri, `upper`] at a given deformation (kPa).
    fn hoop_integral(&self, upper: f64, ri_sq: f64, lz: f64) -> f64 {
        self.integrate_to(upper, |rr| {
            let ([tr, tt, _], r) = self.extra_at(rr, ri_sq, lz);
            (tt - tr) * rr / (lz * r * r)
        })
    }

    /// Closed-end axial balance residual ∫ [2(σz − σr) − (σθ − σr)] r dr
    /// (kPa·mm²); zero at the equilibrium λz.
    fn axial_residual(&self, ro: f64, lz: f64) -> Option<f64> {
        let ri_sq = self.inner_radius_sq(ro, lz);
        if ri_sq <= 0.0 {
            return None;
        }
        Some(self.integrate(|rr| {
            let ([tr, tt, tz], _) = self.extra_at(rr, ri_sq, lz);
            (2.0 * (tz - tr) - (tt - tr)) * rr / lz
        }))
    }

    /// Axial stretch λz at outer diameter `outer_diameter_mm`.
    pub fn axial_stretch(&self, outer_diameter_mm: f64) -> Result<f64, MembraneError> {
        let ro = 0.5 * outer_diameter_mm;
        match self.ends {
            Ends::PlaneStrain => Ok(1.0),
            Ends::Closed => {
                let none = || MembraneError::NoAxialBalance { outer_diameter_mm };
                let g = |lz: f64| self.axial_residual(ro, lz);
                let g1 = g(1.0).ok_or_else(none)?;
                if g1 == 0.0 {
                    return Ok(1.0);
                }
                // The residual grows with λz; step away from 1 until it
                // changes sign, then bisect.
                let step: f64 = if g1 < 0.0 { 1.25 } else { 0.8 };
                let (mut a, mut b) = (1.0, 1.0);
                loop {
                    b *= step;
                    if !(0.05..=20.0).contains(&b) {
                        return Err(none());
                    }
                    match g(b) {
                        Some(gb) if (gb < 0.0) != (g1 < 0.0) => break,
                        Some(_) => a = b,
                        None => return Err(none()),
                    }
                }
                let mut ga = g(a).ok_or_else(none)?;
                for _ in 0..200 {
                    let m = 0.5 * (a + b);
                    if (b - a).abs() <= 1e-14 * m {
                        break;
                    }
                    let gm = g(m).ok_or_else(none)?;
                    if (gm < 0.0) == (ga < 0.0) {
                        a = m;
                        ga = gm;
                    } else {
                        b = m;
                    }
                }
                Ok(0.5 * (a + b))
            }
        }
    }

    /// Internal minus external pressure (kPa) at outer diameter
    /// `outer_diameter_mm`.
    pub fn pressure_kpa(&self, outer_diameter_mm: f64) -> Result<f64, MembraneError> {
        let lz = self.axial_stretch(outer_diameter_mm)?;
        let ri_sq = self.checked_inner_sq(outer_diameter_mm, lz)?;
        Ok(self.hoop_integral(self.geometry.outer_radius_mm(), ri_sq, lz))
    }

    fn checked_inner_sq(&self, outer_diameter_mm: f64, lz: f64) -> Result<f64, MembraneError> {
        let ri_sq = self.inner_radius_sq(0.5 * outer_diameter_mm, lz);
        if ri_sq > 0.0 && outer_diameter_mm.is_finite() {
            Ok(ri_sq)
        } else {
            Err(MembraneError::Closed {
                outer_diameter_mm,
                axial_stretch: lz,
            })
        }
    }

    /// Principal stresses through the wall at `points` (≥ 2) reference
    /// radii from Ri to Ro, with zero outside pressure.
    pub fn wall_profile(
        &self,
        outer_diameter_mm: f64,
        points: usize,
    ) -> Result<Vec<WallPoint>, MembraneError> {
        let lz = self.axial_stretch(outer_diameter_mm)?;
        let ri_sq = self.checked_inner_sq(outer_diameter_mm, lz)?;
        let (rri, rro) = (
            self.geometry.inner_radius_mm(),
            self.geometry.outer_radius_mm(),
        );
        let p = self.hoop_integral(rro, ri_sq, lz);
        let n = points.max(2);
        Ok((0..n)
            .map(|i| {
                let rr = rri + (rro - rri) * i as f64 / (n - 1) as f64;
                let ([tr, tt, tz], r) = self.extra_at(rr, ri_sq, lz);
                // σr(r) = −p + ∫[ri, r] (σθ − σr) dr/r; the others follow.
                let radial = -p + self.hoop_integral(rr, ri_sq, lz);
                let (hoop, axial) = (radial + (tt - tr), radial + (tz - tr));
                WallPoint {
                    reference_radius_mm: rr,
                    radius_mm: r,
                    radial_kpa: radial,
                    hoop_kpa: hoop,
                    axial_kpa: axial,
                    von_mises_kpa: von_mises([tr, tt, tz]),
                }
            })
            .collect())
    }

    /// The whole state at outer diameter `outer_diameter_mm`.
    pub fn state(&self, outer_diameter_mm: f64) -> Result<InflationState, MembraneError> {
        let lz = self.axial_stretch(outer_diameter_mm)?;
        let ri_sq = self.checked_inner_sq(outer_diameter_mm, lz)?;
        let g = &self.geometry;
        let (rri, rro) = (g.inner_radius_mm(), g.outer_radius_mm());
        let ri = ri_sq.sqrt();
        let mut max = (f64::NEG_INFINITY, rri);
        for i in 0..WALL_SAMPLES {
            let rr = rri + (rro - rri) * i as f64 / (WALL_SAMPLES - 1) as f64;
            let vm = von_mises(self.extra_at(rr, ri_sq, lz).0);
            if vm > max.0 {
                max = (vm, rr);
            }
        }
        Ok(InflationState {
            outer_diameter_mm,
            inner_diameter_mm: 2.0 * ri,
            wall_thickness_mm: 0.5 * outer_diameter_mm - ri,
            axial_stretch: lz,
            hoop_stretch_outer: outer_diameter_mm / g.outer_diameter_mm,
            hoop_stretch_inner: ri / rri,
            pressure_kpa: self.hoop_integral(rro, ri_sq, lz),
            max_von_mises_kpa: max.0,
            max_von_mises_at_reference_radius_mm: max.1,
            volume_ml: std::f64::consts::PI * ri_sq * lz * g.length_mm * 1e-3,
        })
    }

    /// States at each of `diameters_mm` (mm).
    pub fn inflation_curve(
        &self,
        diameters_mm: &[f64],
    ) -> Result<Vec<InflationState>, MembraneError> {
        diameters_mm.iter().map(|d| self.state(*d)).collect()
    }
}

/// von Mises stress of principal stresses (kPa); any common pressure cancels.
pub fn von_mises(s: [f64; 3]) -> f64 {
    let [a, b, c] = s;
    (0.5 * ((a - b).powi(2) + (b - c).powi(2) + (c - a).powi(2))).sqrt()
}

/// (node, weight) pairs on [−1, 1] for a rule.
fn quadrature_rule(q: Quadrature) -> Vec<(f64, f64)> {
    match q {
        Quadrature::GaussLegendre(n) => gauss_legendre(n.max(1)),
        Quadrature::Simpson(n) => {
            let n = (n.max(2) + 1) & !1;
            let h = 2.0 / n as f64;
            (0..=n)
                .map(|i| {
                    let w = match i {
                        0 => 1.0,
                        i if i == n => 1.0,
                        i if i % 2 == 1 => 4.0,
                        _ => 2.0,
                    };
                    (-1.0 + h * i as f64, w * h / 3.0)
                })
                .collect()
        }
    }
}

/// Gauss–Legendre nodes and weights on [−1, 1]: Newton's method on the
/// Legendre polynomial P_n from Chebyshev starting points.
fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    let nf = n as f64;
    (0..n)
        .map(|i| {
            let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (nf + 0.5)).cos();
            let mut dp = 1.0;
            for _ in 0..100 {
                // Three-term recurrence for P_n(x) and P_{n-1}(x).
                let (mut p0, mut p1) = (1.0, x);
                for k in 2..=n {
                    let kf = k as f64;
                    (p0, p1) = (p1, ((2.0 * kf - 1.0) * x * p1 - (kf - 1.0) * p0) / kf);
                }
                let (pn, pn1) = if n == 1 { (x, 1.0) } else { (p1, p0) };
                dp = nf * (x * pn - pn1) / (x * x - 1.0);
                let dx = pn / dp;
                x -= dx;
                if dx.abs() < 1e-16 {
                    break;
                }
            }
            (x, 2.0 / ((1.0 - x * x) * dp * dp))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{MooneyRivlin, NeoHookean, Yeoh};

    #[test]
    fn paper_tube_is_what_the_checked_constructor_builds() {
        let a = Tube::paper(NeoHookean { c10_kpa: 1.0 }, Ends::Closed);
        let b = Tube::new(
            TubeGeometry::PAPER,
            NeoHookean { c10_kpa: 1.0 },
            Ends::Closed,
        )
        .unwrap();
        assert_eq!(a.rule, b.rule);
        assert_eq!(a.geometry, b.geometry);
        let bad = TubeGeometry {
            wall_thickness_mm: 10.0,
            ..TubeGeometry::PAPER
        };
        assert!(Tube::new(bad, NeoHookean { c10_kpa: 1.0 }, Ends::Closed).is_err());
    }

    #[test]
    fn gauss_legendre_integrates_polynomials_exactly() {
        for n in [1, 2, 5, 24] {
            let rule = gauss_legendre(n);
            // Exact for degree ≤ 2n − 1: ∫ x^k over [−1, 1] = 2/(k+1) for even k.
            for k in 0..(2 * n) {
                let got: f64 = rule.iter().map(|(x, w)| w * x.powi(k as i32)).sum();
                let want = if k % 2 == 0 {
                    2.0 / (k as f64 + 1.0)
                } else {
                    0.0
                };
                assert!((got - want).abs() < 1e-13, "n={n} k={k}: {got} vs {want}");
            }
        }
    }

    /// Exact plane-strain thick tube of neo-Hookean material (μ = 2·C10),
    /// integrated by hand: p = μ[ln(λi/λo) + (λo⁻² − λi⁻²)/2].
    fn neo_hookean_plane_strain_exact(mu: f64, g: &TubeGeometry, d: f64) -> f64 {
        let (rro, rri) = (g.outer_radius_mm(), g.inner_radius_mm());
        let ro = 0.5 * d;
        let ri = (ro * ro - rro * rro + rri * rri).sqrt();
        let (lo, li) = (ro / rro, ri / rri);
        mu * ((li / lo).ln() + 0.5 * (lo.powi(-2) - li.powi(-2)))
    }

    #[test]
    fn plane_strain_neo_hookean_matches_the_exact_thick_wall_solution() {
        let g = TubeGeometry::PAPER;
        let skin = NeoHookean { c10_kpa: 25.0 };
        let tube = Tube::new(g, skin, Ends::PlaneStrain).unwrap();
        for d in [15.0, 18.7, 20.0, 25.0, 40.0] {
            let want = neo_hookean_plane_strain_exact(50.0, &g, d);
            let got = tube.pressure_kpa(d).unwrap();
            assert!(
                (got - want).abs() <= 1e-12 * want.abs().max(1e-12),
                "D={d}: {got} vs {want}"
            );
        }
        // Mooney–Rivlin in plane strain has I1 = I2, so it is neo-Hookean with
        // μ = 2(C10 + C01).
        let mr = Tube::new(
            g,
            MooneyRivlin {
                c10_kpa: 20.0,
                c01_kpa: 5.0,
            },
            Ends::PlaneStrain,
        )
        .unwrap();
        let want = neo_hookean_plane_strain_exact(50.0, &g, 25.0);
        assert!((mr.pressure_kpa(25.0).unwrap() - want).abs() < 1e-12 * want);
    }

    #[test]
    fn at_rest_there_is_no_pressure_stress_or_axial_stretch() {
        for ends in [Ends::PlaneStrain, Ends::Closed] {
            let tube = Tube::new(TubeGeometry::PAPER, crate::default_skin(), ends).unwrap();
            let s = tube.state(18.7).unwrap();
            assert!(s.pressure_kpa.abs() < 1e-12);
            assert!(s.max_von_mises_kpa.abs() < 1e-9);
            assert!((s.axial_stretch - 1.0).abs() < 1e-12);
            assert!((s.wall_thickness_mm - 1.75).abs() < 1e-12);
        }
    }

    #[test]
    fn gauss_and_simpson_agree_and_both_converge() {
        let skin = Yeoh {
            c10_kpa: 3.0,
            c20_kpa: -0.4,
            c30_kpa: 0.05,
        };
        for ends in [Ends::PlaneStrain, Ends::Closed] {
            let gl = Tube::new(TubeGeometry::PAPER, skin, ends).unwrap();
            let simpson =
                Tube::with_quadrature(TubeGeometry::PAPER, skin, ends, Quadrature::Simpson(2000))
                    .unwrap();
            for d in [19.5, 22.0, 25.0, 30.0] {
                let (a, b) = (gl.state(d).unwrap(), simpson.state(d).unwrap());
                assert!((a.pressure_kpa - b.pressure_kpa).abs() < 1e-10 * a.pressure_kpa.abs());
                assert!((a.axial_stretch - b.axial_stretch).abs() < 1e-10);
            }
        }
    }

    #[test]
    fn wall_profile_satisfies_the_boundary_conditions() {
        let skin = Yeoh {
            c10_kpa: 3.0,
            c20_kpa: 0.1,
            c30_kpa: 0.05,
        };
        for ends in [Ends::PlaneStrain, Ends::Closed] {
            let tube = Tube::new(TubeGeometry::PAPER, skin, ends).unwrap();
            let d = 25.0;
            let s = tube.state(d).unwrap();
            let prof = tube.wall_profile(d, 41).unwrap();
            let (first, last) = (prof[0], prof[40]);
            assert!((first.radial_kpa + s.pressure_kpa).abs() < 1e-12 * s.pressure_kpa);
            assert!(last.radial_kpa.abs() < 1e-12 * s.pressure_kpa);
            assert!((last.radius_mm - 12.5).abs() < 1e-12);
            let vm_max = prof.iter().map(|w| w.von_mises_kpa).fold(0.0, f64::max);
            assert!((vm_max - s.max_von_mises_kpa).abs() < 1e-9 * vm_max);
            if ends == Ends::Closed {
                // Axial force on the wall = pressure on the end cap.
                let force: f64 = prof
                    .windows(2)
                    .map(|w| {
                        let f = |p: &WallPoint| p.axial_kpa * p.radius_mm;
                        std::f64::consts::PI
                            * (f(&w[0]) + f(&w[1]))
                            * (w[1].radius_mm - w[0].radius_mm)
                    })
                    .sum();
                let cap =
                    s.pressure_kpa * std::f64::consts::PI * (0.5 * s.inner_diameter_mm).powi(2);
                assert!((force - cap).abs() < 1e-3 * cap, "{force} vs {cap}");
            }
        }
    }

    /// Relative gap between the thick-wall result and a thin-wall closed
    /// form, for wall/radius ratio `t_over_r` at outer stretch 1.3.
    fn thin_wall_gap(ends: Ends, t_over_r: f64) -> f64 {
        let (c10, c20, c30) = (3.0, 0.4, 0.05);
        let skin = Yeoh {
            c10_kpa: c10,
            c20_kpa: c20,
            c30_kpa: c30,
        };
        let ro = 10.0;
        let g = TubeGeometry {
            outer_diameter_mm: 2.0 * ro,
            wall_thickness_mm: t_over_r * ro,
            length_mm: 20.0,
        };
        let l = 1.3;
        let thick = Tube::new(g, skin, ends)
            .unwrap()
            .pressure_kpa(2.0 * ro * l)
            .unwrap();
        // Thin wall: p = (h/r)·σθ with σr ≈ 0, h = T·λr, r = λ·R.
        let lz = match ends {
            Ends::PlaneStrain => 1.0,
            // σz = σθ/2; for a law of I1 only that is λz² − λr² = (λ² − λr²)/2,
            // i.e. 2λz⁴ − λ²λz² − 1/λ² = 0.
            Ends::Closed => ((l * l + (l.powi(4) + 8.0 / (l * l)).sqrt()) / 4.0).sqrt(),
        };
        let lr = 1.0 / (l * lz);
        let x = l * l + lz * lz + lr * lr - 3.0;
        let w1 = c10 + 2.0 * c20 * x + 3.0 * c30 * x * x;
        let hoop = 2.0 * w1 * (l * l - lr * lr);
        let thin = (g.wall_thickness_mm * lr) / (l * ro) * hoop;
        (thick - thin).abs() / thin
    }

    #[test]
    fn thin_wall_limit_is_the_membrane_closed_form() {
        for ends in [Ends::PlaneStrain, Ends::Closed] {
            let gaps: Vec<f64> = [1e-2, 1e-3, 1e-4]
                .iter()
                .map(|t| thin_wall_gap(ends, *t))
                .collect();
            // The gap is first order in T/R and shrinks tenfold per decade.
            for (gap, t) in gaps.iter().zip([1e-2, 1e-3, 1e-4]) {
                assert!(*gap < 2.0 * t, "{ends:?}: gap {gap} at T/R {t}");
            }
            for w in gaps.windows(2) {
                let ratio = w[0] / w[1];
                assert!((7.0..14.0).contains(&ratio), "{ends:?}: ratio {ratio}");
            }
        }
    }
}
