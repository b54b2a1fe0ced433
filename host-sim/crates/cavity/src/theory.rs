//! The continuum estimate of the cavity problem: a cylindrical cavity
//! expanded in an infinite, cohesionless, elastic–perfectly plastic
//! Mohr–Coulomb medium under plane strain, from an isotropic in-situ
//! stress p0, with non-associated flow (friction angle φ, dilatancy angle
//! ψ) — the problem of Carter, Booker & Yeung (1986, small strain) and Yu
//! & Houlsby (1991, large strain).
//!
//! Stresses are compressive positive, strains and velocities tensile
//! positive. The medium yields where σr/σθ reaches Nφ = (1 + sin φ)/(1 −
//! sin φ), at the cavity pressure p_y = p0·(1 + sin φ). In the plastic
//! zone a ≤ r ≤ c equilibrium, dσr/dr + (σr − σθ)/r = 0, with σθ = σr/Nφ
//! gives σr = p_y·(c/r)^α, α = (Nφ − 1)/Nφ, so the cavity pressure is
//! p = p_y·(c/a)^α. The flow rule makes the plastic strain rates
//! ε̇θᵖ = −Nψ·ε̇rᵖ; subtracting the elastic rates (plane-strain Hooke on the
//! material stress rates) from v' and v/r gives, for the radial velocity
//! v(r) per unit growth of c,
//!
//! Nψ·v' + v/r = −K·σ̇r,  K = [Nψ·(1 − ν − ν/Nφ) + (1 − ν)/Nφ − ν]/(2G),
//!
//! with σ̇r = α·σr·(1/c − v/r) following the material (large strain) or
//! α·σr/c at a fixed point (small strain). The elastic zone r ≥ c is
//! Lamé's: its boundary moves at v(c) = p0·sin φ/G per unit c.
//!
//! - [`CavityTheory::small_strain`]: the closed form of that equation in
//!   the reference configuration (r = a0), derived here;
//! - [`CavityTheory::large_strain`]: the same equation in the current
//!   configuration, with the convected stress rate, integrated across the
//!   plastic zone (RK4) at each step of c while the cavity wall moves at
//!   v(a) — the large-strain solution that Yu & Houlsby (1991) write as a
//!   series, here integrated numerically. For a/a0 → 1 it meets the closed
//!   form; for a/a0 → ∞ the pressure tends to the limit of a cavity grown
//!   from zero radius.

use anyhow::{ensure, Result};
use serde::Serialize;

/// The medium: Mohr–Coulomb, cohesionless, elastic–perfectly plastic.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Soil {
    /// Friction angle φ (degrees), 0 < φ < 90.
    pub friction_deg: f64,
    /// Dilatancy angle ψ (degrees), 0 ≤ ψ ≤ φ.
    pub dilatancy_deg: f64,
    /// Shear modulus G (kPa), > 0.
    pub shear_modulus_kpa: f64,
    /// Poisson's ratio ν, 0 ≤ ν < 0.5.
    pub poisson: f64,
}

/// N = (1 + sin θ)/(1 − sin θ) for an angle θ in degrees.
fn flow_factor(deg: f64) -> f64 {
    let s = deg.to_radians().sin();
    (1.0 + s) / (1.0 - s)
}

/// One point of a pressure–expansion curve.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct TheoryPoint {
    /// Cavity radius over its initial radius, a/a0.
    pub radius_ratio: f64,
    /// Radius of the plastic zone over the initial radius, c/a0 (1 while
    /// the medium is elastic).
    pub plastic_radius_ratio: f64,
    /// Cavity pressure (kPa).
    pub pressure_kpa: f64,
}

/// A cylindrical cavity in [`Soil`] under the in-situ stress p0.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct CavityTheory {
    /// The medium.
    pub soil: Soil,
    /// Isotropic in-situ stress p0 (kPa), > 0.
    pub in_situ_kpa: f64,
}

impl CavityTheory {
    /// Checks the parameters' ranges.
    pub fn new(soil: Soil, in_situ_kpa: f64) -> Result<Self> {
        ensure!(
            soil.friction_deg > 0.0 && soil.friction_deg < 90.0,
            "friction angle {}° outside (0, 90)",
            soil.friction_deg
        );
        ensure!(
            soil.dilatancy_deg >= 0.0 && soil.dilatancy_deg <= soil.friction_deg,
            "dilatancy angle {}° outside [0, φ = {}°]",
            soil.dilatancy_deg,
            soil.friction_deg
        );
        ensure!(
            soil.shear_modulus_kpa > 0.0 && soil.shear_modulus_kpa.is_finite(),
            "shear modulus {} kPa must be positive",
            soil.shear_modulus_kpa
        );
        ensure!(
            (0.0..0.5).contains(&soil.poisson),
            "Poisson's ratio {} outside [0, 0.5)",
            soil.poisson
        );
        ensure!(
            in_situ_kpa > 0.0 && in_situ_kpa.is_finite(),
            "in-situ stress {in_situ_kpa} kPa must be positive"
        );
        Ok(Self { soil, in_situ_kpa })
    }

    /// Cavity pressure at first yield, p_y = p0·(1 + sin φ) (kPa).
    pub fn yield_pressure_kpa(&self) -> f64 {
        self.in_situ_kpa * (1.0 + self.soil.friction_deg.to_radians().sin())
    }

    /// Rigidity index G/p0.
    pub fn rigidity_index(&self) -> f64 {
        self.soil.shear_modulus_kpa / self.in_situ_kpa
    }

    /// α = (Nφ − 1)/Nφ: the plastic zone's stress decays as r^(−α).
    fn alpha(&self) -> f64 {
        let n = flow_factor(self.soil.friction_deg);
        (n - 1.0) / n
    }

    /// K of the velocity equation (1/kPa).
    fn k(&self) -> f64 {
        let nf = flow_factor(self.soil.friction_deg);
        let np = flow_factor(self.soil.dilatancy_deg);
        let nu = self.soil.poisson;
        (np * (1.0 - nu - nu / nf) + (1.0 - nu) / nf - nu) / (2.0 * self.soil.shear_modulus_kpa)
    }

    /// Velocity of the elastic–plastic boundary's material per unit c.
    fn boundary_velocity(&self) -> f64 {
        self.in_situ_kpa * self.soil.friction_deg.to_radians().sin() / self.soil.shear_modulus_kpa
    }

    /// The elastic stage: a/a0 = 1 + (p − p0)/(2G) for p0 ≤ p ≤ p_y.
    fn elastic(&self, pressure_kpa: f64) -> TheoryPoint {
        TheoryPoint {
            radius_ratio: 1.0
                + (pressure_kpa - self.in_situ_kpa) / (2.0 * self.soil.shear_modulus_kpa),
            plastic_radius_ratio: 1.0,
            pressure_kpa,
        }
    }

    /// Small-strain closed form at plastic radius c = `rho`·a0 (ρ ≥ 1):
    /// u_a/a0 = p0 sin φ/(2G) + (v_c + K')·(ρ^(1+1/Nψ) − 1)/(1 + 1/Nψ)
    /// − K'·(ρ^α − 1)/α, K' = K·α·p_y/(Nψ(1 − α) + 1), and p = p_y·ρ^α.
    pub fn small_strain(&self, rho: f64) -> TheoryPoint {
        let rho = rho.max(1.0);
        let alpha = self.alpha();
        let np = flow_factor(self.soil.dilatancy_deg);
        let py = self.yield_pressure_kpa();
        let kp = self.k() * alpha * py / (np * (1.0 - alpha) + 1.0);
        let vc = self.boundary_velocity();
        let e = 1.0 + 1.0 / np;
        let ua =
            0.5 * vc + (vc + kp) * (rho.powf(e) - 1.0) / e - kp * (rho.powf(alpha) - 1.0) / alpha;
        TheoryPoint {
            radius_ratio: 1.0 + ua,
            plastic_radius_ratio: rho,
            pressure_kpa: py * rho.powf(alpha),
        }
    }

    /// The small-strain curve from p0 to the cavity radius `a_end` = a/a0,
    /// `points` points of the plastic stage, after the elastic one.
    pub fn small_strain_curve(&self, a_end: f64, points: usize) -> Vec<TheoryPoint> {
        let mut out = vec![
            self.elastic(self.in_situ_kpa),
            self.elastic(self.yield_pressure_kpa()),
        ];
        // ρ at a_end by bisection: a/a0 grows monotonically with ρ.
        let (mut lo, mut hi) = (1.0, 2.0);
        while self.small_strain(hi).radius_ratio < a_end && hi < 1e9 {
            hi *= 2.0;
        }
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if self.small_strain(mid).radius_ratio < a_end {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let n = points.max(2);
        for k in 1..=n {
            // Geometric in ρ − 1: the curve turns sharply just after yield.
            let rho = 1.0 + (hi - 1.0) * (k as f64 / n as f64).powi(3);
            out.push(self.small_strain(rho));
        }
        out
    }

    /// The large-strain curve from p0 until the cavity radius reaches
    /// `a_end` = a/a0 (> 1), in steps of c of at most `dc_rel` of c;
    /// `n_r` RK4 steps across the plastic zone at each. Lengths are in
    /// units of a0.
    pub fn large_strain(&self, a_end: f64, dc_rel: f64, n_r: usize) -> Vec<TheoryPoint> {
        let alpha = self.alpha();
        let np = flow_factor(self.soil.dilatancy_deg);
        let py = self.yield_pressure_kpa();
        let k = self.k();
        let vc = self.boundary_velocity();
        let yield_point = self.elastic(py);
        let mut out = vec![self.elastic(self.in_situ_kpa), yield_point];
        // At first yield the plastic zone is the cavity's wall.
        let mut a = yield_point.radius_ratio;
        let mut c = a;
        // v across the plastic zone, from r = c inwards to r = a: the
        // material velocity per unit growth of c.
        let wall_velocity = |a: f64, c: f64| -> f64 {
            let f = |r: f64, v: f64| -> f64 {
                let sigma = py * (c / r).powf(alpha);
                (-k * alpha * sigma * (1.0 / c - v / r) - v / r) / np
            };
            rk4(f, c, a, vc, n_r)
        };
        while a < a_end {
            let dc = dc_rel * c;
            // Heun's step of da/dc = v(a; c).
            let v0 = wall_velocity(a, c);
            let a1 = a + dc * v0;
            let v1 = wall_velocity(a1, c + dc);
            a += 0.5 * dc * (v0 + v1);
            c += dc;
            out.push(TheoryPoint {
                radius_ratio: a,
                plastic_radius_ratio: c,
                pressure_kpa: py * (c / a).powf(alpha),
            });
        }
        out
    }

    /// The large-strain cavity pressure (kPa) at a/a0 = `a`, interpolated
    /// on a curve from [`CavityTheory::large_strain`].
    pub fn pressure_at(curve: &[TheoryPoint], a: f64) -> Option<f64> {
        let i = curve.iter().position(|p| p.radius_ratio >= a)?;
        if i == 0 {
            return Some(curve[0].pressure_kpa);
        }
        let (p, q) = (curve[i - 1], curve[i]);
        let t = (a - p.radius_ratio) / (q.radius_ratio - p.radius_ratio).max(1e-300);
        Some(p.pressure_kpa + t * (q.pressure_kpa - p.pressure_kpa))
    }
}

/// v(`to`) of dv/dr = `f`(r, v) from v(`from`) = `v0`, in `steps` (≥ 1)
/// classical Runge–Kutta steps.
fn rk4(f: impl Fn(f64, f64) -> f64, from: f64, to: f64, v0: f64, steps: usize) -> f64 {
    let n = steps.max(1);
    let h = (to - from) / n as f64;
    let (mut r, mut v) = (from, v0);
    for _ in 0..n {
        let k1 = f(r, v);
        let k2 = f(r + 0.5 * h, v + 0.5 * h * k1);
        let k3 = f(r + 0.5 * h, v + 0.5 * h * k2);
        let k4 = f(r + h, v + h * k3);
        v += h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
        r += h;
    }
    v
}

/// Shear modulus (kPa) of a random packing of Hertz–Mindlin spheres under
/// the mean stress `p_kpa`, effective-medium theory (Walton 1987; Mavko,
/// Mukerji & Dvorkin, *The Rock Physics Handbook*, §5.4): G = (5 −
/// 4ν)/(5(2 − ν))·[3 Z²(1 − n)² μ² p/(2π²(1 − ν)²)]^(1/3), for grains of
/// shear modulus μ (kPa) and Poisson's ratio ν, Z contacts per grain and
/// porosity n. Effective-medium theory is known to over-predict the shear
/// modulus of frictional packings (it assumes affine motion): an upper
/// estimate.
pub fn hertz_mindlin_shear_modulus_kpa(
    grain_shear_modulus_kpa: f64,
    grain_poisson: f64,
    coordination: f64,
    porosity: f64,
    p_kpa: f64,
) -> f64 {
    let nu = grain_poisson;
    let mu = grain_shear_modulus_kpa;
    let bracket = 3.0 * coordination.powi(2) * (1.0 - porosity).powi(2) * mu * mu * p_kpa
        / (2.0 * std::f64::consts::PI.powi(2) * (1.0 - nu).powi(2));
    (5.0 - 4.0 * nu) / (5.0 * (2.0 - nu)) * bracket.cbrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn theory(rigidity: f64) -> CavityTheory {
        CavityTheory::new(
            Soil {
                friction_deg: 30.0,
                dilatancy_deg: 10.0,
                shear_modulus_kpa: rigidity,
                poisson: 0.3,
            },
            1.0,
        )
        .unwrap()
    }

    #[test]
    fn yield_at_one_plus_sin_phi() {
        let t = theory(100.0);
        assert!((t.yield_pressure_kpa() - 1.5).abs() < 1e-12);
        // The plastic stage starts where the elastic one ends.
        let first = t.small_strain(1.0);
        assert!((first.pressure_kpa - 1.5).abs() < 1e-12);
        assert!((first.radius_ratio - (1.0 + 0.5 / 200.0)).abs() < 1e-12);
    }

    #[test]
    fn the_closed_form_solves_its_equation() {
        // Differentiate u_a(ρ) numerically and compare with v(a0; c) from
        // the velocity equation integrated by RK4 at a fixed point (small
        // strain: no convection, r from c to a0).
        let t = theory(50.0);
        let (alpha, np) = (t.alpha(), flow_factor(10.0));
        let (py, k, vc) = (t.yield_pressure_kpa(), t.k(), t.boundary_velocity());
        for rho in [1.2, 2.0, 5.0] {
            let h = 1e-6;
            let closed = (t.small_strain(rho + h).radius_ratio
                - t.small_strain(rho - h).radius_ratio)
                / (2.0 * h);
            let f = |r: f64, v: f64| (-k * alpha * py * (rho / r).powf(alpha) / rho - v / r) / np;
            let v = rk4(f, rho, 1.0, vc, 4000);
            assert!(
                (closed - v).abs() <= 1e-7 * v.abs().max(1e-12),
                "ρ {rho}: closed form {closed} against integrated {v}"
            );
        }
    }

    #[test]
    fn large_strain_meets_small_strain_at_small_expansion() {
        // A stiff medium: at 1 % expansion the two agree to O(u/a).
        let t = theory(2000.0);
        let large = t.large_strain(1.01, 1e-3, 200);
        let small = t.small_strain_curve(1.01, 400);
        let pl = CavityTheory::pressure_at(&large, 1.01).unwrap();
        let ps = CavityTheory::pressure_at(&small, 1.01).unwrap();
        assert!((pl / ps - 1.0).abs() < 0.01, "large {pl} small {ps}");
    }

    #[test]
    fn large_strain_converges_and_tends_to_a_limit() {
        let t = theory(100.0);
        let coarse = t.large_strain(3.0, 4e-3, 100);
        let fine = t.large_strain(3.0, 1e-3, 400);
        let (pc, pf) = (
            CavityTheory::pressure_at(&coarse, 3.0).unwrap(),
            CavityTheory::pressure_at(&fine, 3.0).unwrap(),
        );
        assert!((pc / pf - 1.0).abs() < 1e-3, "{pc} vs {pf}");
        // Grown from a small hole the cavity's pressure stops rising: the
        // problem has no length scale left.
        let long = t.large_strain(200.0, 2e-3, 200);
        let p100 = CavityTheory::pressure_at(&long, 100.0).unwrap();
        let p200 = CavityTheory::pressure_at(&long, 200.0).unwrap();
        assert!((p200 / p100 - 1.0).abs() < 2e-3, "{p100} → {p200}");
        // Well above the yield pressure, and rising before the limit.
        let p2 = CavityTheory::pressure_at(&long, 2.0).unwrap();
        assert!(p2 > t.yield_pressure_kpa() && p100 > p2);
    }

    #[test]
    fn incompressible_limit_is_vesic() {
        // ψ = 0 and ν → 0.5: the plastic zone keeps its volume, and the
        // limit pressure is Vesić's (1972) cylindrical one with Δ = 0,
        // p_lim = p0·(1 + sin φ)·(I_r sec φ)^(sin φ/(1 + sin φ)), his
        // rigidity index I_r = G/(p0 tan φ).
        for (phi, g) in [(30.0, 100.0), (20.0, 1000.0)] {
            let t = CavityTheory::new(
                Soil {
                    friction_deg: phi,
                    dilatancy_deg: 0.0,
                    shear_modulus_kpa: g,
                    poisson: 0.4999,
                },
                1.0,
            )
            .unwrap();
            let s = f64::to_radians(phi).sin();
            let ir = g / f64::to_radians(phi).tan();
            let vesic = (1.0 + s) * (ir / f64::to_radians(phi).cos()).powf(s / (1.0 + s));
            let curve = t.large_strain(100.0, 2e-3, 100);
            let p = CavityTheory::pressure_at(&curve, 100.0).unwrap();
            assert!(
                (p / vesic - 1.0).abs() < 2e-3,
                "φ {phi}: {p} against Vesić {vesic}"
            );
        }
    }

    #[test]
    fn a_stiffer_or_more_dilatant_medium_pushes_back_harder() {
        let at = |t: CavityTheory| {
            CavityTheory::pressure_at(&t.large_strain(1.3, 1e-3, 200), 1.3).unwrap()
        };
        let base = at(theory(100.0));
        assert!(at(theory(400.0)) > base);
        let mut dense = theory(100.0);
        dense.soil.dilatancy_deg = 20.0;
        assert!(at(dense) > base);
    }

    #[test]
    fn refuses_absurd_parameters() {
        let soil = theory(1.0).soil;
        assert!(CavityTheory::new(
            Soil {
                dilatancy_deg: 40.0,
                ..soil
            },
            1.0
        )
        .is_err());
        assert!(CavityTheory::new(
            Soil {
                poisson: 0.5,
                ..soil
            },
            1.0
        )
        .is_err());
        assert!(CavityTheory::new(soil, 0.0).is_err());
    }
}
