//! The parametric sand law, standing in for the FEM–DEM solver wherever a
//! smooth, calibrated law is wanted (the emulator's plant, the workbench).
//!
//! Its loading branch: K = K0 + (N − K0)·tanh(ΔD/ΔDc), ΔD = D − D0, from
//! the at-rest K0, first linear, then the slope falls as grains start to
//! slide, then a plateau at the limit N (the paper's Figure 3b). Unloading
//! (the shared [`Unloading`] rule) has the slope s = m·(N − K0)/ΔDc, m
//! times the initial loading slope. σ'v = γ'·h with the buoyant unit weight
//! of the saturated sand γ' = (ρs − ρw)(1 − n)·g.
//!
//! N is calibrated in code ([`calibrate_limit_coefficient`]) to the
//! balloon experiment ([`BALLOON_TABLE`]), taken as p_e at the end of the
//! expansion, D = 25 mm.

use serde::Serialize;

use super::{SandHistory, SandLaw, Unloading};
use constants::{GRAVITY_M_S2, SEAWATER_DENSITY_KG_M3};

/// Sand and fluid properties and the law's coefficients.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct SandParams {
    /// Grain density ρs (kg/m³); paper: 2920 ± 80.
    pub grain_density_kg_m3: f64,
    /// Pore fluid density ρw (kg/m³); sea water 1025.
    pub fluid_density_kg_m3: f64,
    /// Porosity n (void volume fraction); ≈ 0.40 for a loose uniform sand.
    pub porosity: f64,
    /// At-rest coefficient K0 = p_e/σ'v before any expansion.
    pub at_rest_coefficient: f64,
    /// Limit coefficient N = p_e/σ'v once the surrounding grains slide.
    pub limit_coefficient: f64,
    /// Active coefficient Ka, the floor while the zone shrinks.
    pub active_coefficient: f64,
    /// Outer diameter at which the law starts, D0 (mm).
    pub initial_diameter_mm: f64,
    /// Diameter increase ΔDc over which K rises (tanh scale) (mm).
    pub characteristic_diameter_increase_mm: f64,
    /// Unloading slope as a multiple m of the initial loading slope.
    pub unloading_stiffness_ratio: f64,
    /// [`Unloading::curvature`] of the unloading branch (1: a straight
    /// line).
    pub unloading_curvature: f64,
    /// Shape c of the rise, x = ΔD/ΔDc: f = (1 − e^(−(1+c)x))/(1 + c·e^(−(1+c)x)),
    /// which is tanh(x) at c = 1 (the law's own), 1 − e^(−x) at c = 0 (a
    /// more gradual approach to N), steeper above 1; always f'(0) = 1.
    pub rise_shape: f64,
}

/// Effective friction angle assumed for the sand (degrees): a loose,
/// uniform, rounded sand. It is not the 0.25 inter-grain friction of the
/// paper's DEM (atan 0.25 = 14°): interlocking makes the bulk angle larger.
pub const FRICTION_ANGLE_DEG: f64 = 30.0;

/// Diameter by which the expansion has done 95 % of its work on the sand
/// (mm): the paper reports the change "mostly before D ≈ 2.2 cm".
pub const RISE_DONE_DIAMETER_MM: f64 = 22.0;

impl SandParams {
    /// The paper's sand and actuator, with N still to be calibrated (set
    /// to K0): ρs = 2920, ρw = 1025 kg/m³, n = 0.40, D0 = 18.7 mm;
    /// K0 = 1 − sin φ' (Jaky), Ka = (1 − sin φ')/(1 + sin φ') (Rankine),
    /// φ' = [`FRICTION_ANGLE_DEG`]; ΔDc such that tanh reaches 0.95 at
    /// [`RISE_DONE_DIAMETER_MM`]; unloading 5× stiffer than first loading
    /// (a typical unload/reload to virgin stiffness ratio for sand).
    pub fn paper_uncalibrated() -> Self {
        let sin_phi = FRICTION_ANGLE_DEG.to_radians().sin();
        let d0 = 18.7;
        Self {
            grain_density_kg_m3: 2920.0,
            fluid_density_kg_m3: SEAWATER_DENSITY_KG_M3,
            porosity: 0.40,
            at_rest_coefficient: 1.0 - sin_phi,
            limit_coefficient: 1.0 - sin_phi,
            active_coefficient: (1.0 - sin_phi) / (1.0 + sin_phi),
            initial_diameter_mm: d0,
            characteristic_diameter_increase_mm: (RISE_DONE_DIAMETER_MM - d0) / 0.95_f64.atanh(),
            unloading_stiffness_ratio: 5.0,
            unloading_curvature: 1.0,
            rise_shape: 1.0,
        }
    }

    /// Buoyant unit weight γ' = (ρs − ρw)(1 − n)·g, in kPa per mm of depth.
    pub fn buoyant_unit_weight_kpa_per_mm(&self) -> f64 {
        (self.grain_density_kg_m3 - self.fluid_density_kg_m3)
            * (1.0 - self.porosity)
            * GRAVITY_M_S2
            * 1e-6
    }

    /// Vertical effective stress σ'v (kPa) at depth `depth_mm` below the
    /// sand surface.
    pub fn vertical_effective_stress_kpa(&self, depth_mm: f64) -> f64 {
        self.buoyant_unit_weight_kpa_per_mm() * depth_mm.max(0.0)
    }
}

/// The parametric law of this module.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ParametricSand {
    /// Its parameters.
    pub params: SandParams,
}

impl ParametricSand {
    /// The paper's sand with N calibrated to [`BALLOON_TABLE`].
    pub fn calibrated_to_balloon() -> Self {
        let base = SandParams::paper_uncalibrated();
        let cal = calibrate_limit_coefficient(&base, &BALLOON_TABLE, BALLOON_FINAL_DIAMETER_MM);
        Self {
            params: SandParams {
                limit_coefficient: cal.limit_coefficient,
                ..base
            },
        }
    }

    /// The paper's sand with N and ΔDc fitted to the FEM–DEM solver's
    /// results `solver` along the whole loading branch, so that the law
    /// pushes back as the solver's sand does at every diameter, not only at
    /// the end (the firmware table's sand is that solver's, and the
    /// emulator's plant and the workbench's baseline are this law): least
    /// squares over every stored row of every depth, each row's residual
    /// taken relative to that depth's σ'v (so every depth weighs the same),
    /// on the solver's running-max K that the table uses. p_e is linear in
    /// N at a given ΔDc, so N is solved exactly for each ΔDc and ΔDc is
    /// found by a golden-section search in its logarithm ([`fit_rise`]).
    /// K0, Ka, the densities and the porosity stay the paper's: the
    /// porosity's γ' against the solver bed's goes into N.
    pub fn fitted_to_solver(solver: &super::SolverSand) -> Self {
        let base = SandParams::paper_uncalibrated();
        // The solver's K read with this law's γ' (same p_e).
        let ratio = solver.unit_weight_kpa_per_mm() / base.buoyant_unit_weight_kpa_per_mm();
        let rows: Vec<(f64, f64)> = solver
            .curves()
            .iter()
            .flat_map(|c| {
                c.diameters_mm
                    .iter()
                    .zip(&c.coefficients)
                    .map(move |(d, k)| (*d, k * ratio))
            })
            .collect();
        let fit = fit_rise(&base, &rows);
        Self {
            params: SandParams {
                limit_coefficient: fit.limit_coefficient,
                characteristic_diameter_increase_mm: fit.rise_mm,
                ..base
            },
        }
    }

    /// K on the loading branch at diameter `diameter_mm` (≥ D0).
    pub fn loading_coefficient(&self, diameter_mm: f64) -> f64 {
        let p = &self.params;
        let x =
            (diameter_mm - p.initial_diameter_mm).max(0.0) / p.characteristic_diameter_increase_mm;
        let f = if p.rise_shape == 1.0 {
            x.tanh()
        } else {
            let e = (-(1.0 + p.rise_shape) * x).exp();
            (1.0 - e) / (1.0 + p.rise_shape * e)
        };
        p.at_rest_coefficient + (p.limit_coefficient - p.at_rest_coefficient) * f
    }

    /// Unloading slope s = dK/dD (1/mm).
    pub fn unloading_slope_per_mm(&self) -> f64 {
        let p = &self.params;
        p.unloading_stiffness_ratio * (p.limit_coefficient - p.at_rest_coefficient)
            / p.characteristic_diameter_increase_mm
    }

    /// Its unloading rule: slope [`Self::unloading_slope_per_mm`], floor
    /// Ka, shape [`SandParams::unloading_curvature`].
    pub fn unloading(&self) -> Unloading {
        Unloading {
            slope_per_mm: self.unloading_slope_per_mm(),
            active_coefficient: self.params.active_coefficient,
            curvature: self.params.unloading_curvature,
        }
    }
}

impl SandLaw for ParametricSand {
    fn fresh_cycle(&self) -> SandHistory {
        SandHistory::at_rest(
            self.params.initial_diameter_mm,
            self.params.at_rest_coefficient,
        )
    }

    fn external_pressure_kpa(
        &self,
        history: &mut SandHistory,
        diameter_mm: f64,
        depth_mm: f64,
    ) -> f64 {
        let k = self
            .unloading()
            .coefficient(history, diameter_mm, |d| self.loading_coefficient(d));
        k * self.params.vertical_effective_stress_kpa(depth_mm)
    }

    fn describe(&self) -> String {
        let s = &self.params;
        format!(
            "parametric sand K0={:.3} N={:.3} dDc={:.3} mm, \
             gamma'={:.5} kPa/mm",
            s.at_rest_coefficient,
            s.limit_coefficient,
            s.characteristic_diameter_increase_mm,
            s.buoyant_unit_weight_kpa_per_mm(),
        )
    }
}

/// One row of the paper's balloon experiment: external pressure at the end
/// of the expansion (internal pressure minus its h = 0 value).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct BalloonPoint {
    /// Sand cover h (mm).
    pub depth_mm: f64,
    /// p_e (kPa).
    pub external_pressure_kpa: f64,
    /// Standard deviation of the internal pressure at that depth (kPa).
    pub sd_kpa: f64,
}

/// The paper's balloon table (`paper-figures.md`): Δp column and SDs.
pub const BALLOON_TABLE: [BalloonPoint; 4] = [
    BalloonPoint {
        depth_mm: 40.0,
        external_pressure_kpa: 3.86,
        sd_kpa: 1.24,
    },
    BalloonPoint {
        depth_mm: 50.0,
        external_pressure_kpa: 5.18,
        sd_kpa: 1.61,
    },
    BalloonPoint {
        depth_mm: 70.0,
        external_pressure_kpa: 7.24,
        sd_kpa: 1.05,
    },
    BalloonPoint {
        depth_mm: 100.0,
        external_pressure_kpa: 9.07,
        sd_kpa: 2.42,
    },
];

/// The balloon's internal pressure at h = 0 (kPa, ± [`BALLOON_FREE_SD_KPA`]):
/// its own skin's pressure at the 9.8 mL injected, what the experiment
/// subtracts from each depth's (the piston force 9.10 N over 6.70 cm²;
/// any seal friction of the syringe is in it and cancels in the
/// differences).
pub const BALLOON_FREE_PRESSURE_KPA: f64 = 13.59;

/// Standard deviation of [`BALLOON_FREE_PRESSURE_KPA`] (kPa).
pub const BALLOON_FREE_SD_KPA: f64 = 0.71;

impl BalloonPoint {
    /// The balloon's internal pressure at this depth (kPa; its SD is
    /// [`BalloonPoint::sd_kpa`]): the h = 0 pressure plus p_e, the
    /// experiment's table as measured (17.45 kPa at 40 mm).
    pub fn internal_pressure_kpa(&self) -> f64 {
        BALLOON_FREE_PRESSURE_KPA + self.external_pressure_kpa
    }
}

/// Diameter at which the balloon values are taken to apply (mm): the
/// animal's final expanded diameter.
pub const BALLOON_FINAL_DIAMETER_MM: f64 = 25.0;

/// Result of calibrating N.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Calibration {
    /// Weighted least-squares N.
    pub limit_coefficient: f64,
    /// Its standard error from the stated SDs, 1/sqrt(Σ w·b²).
    pub limit_coefficient_se: f64,
    /// Model p_e at each point (kPa).
    pub model_kpa: Vec<f64>,
    /// Model minus measurement at each point (kPa).
    pub residuals_kpa: Vec<f64>,
    /// Σ (residual/SD)².
    pub chi_squared: f64,
}

/// Calibrates N of `base` to `points` at diameter `diameter_mm` by weighted
/// least squares (weights 1/SD²). p_e is linear in N,
/// p_e = a_h + b_h·N, so the solution is N = Σ w·b·(p − a) / Σ w·b².
pub fn calibrate_limit_coefficient(
    base: &SandParams,
    points: &[BalloonPoint],
    diameter_mm: f64,
) -> Calibration {
    let at = |n: f64, h: f64| {
        ParametricSand {
            params: SandParams {
                limit_coefficient: n,
                ..*base
            },
        }
        .loading_pressure_kpa(diameter_mm, h)
    };
    let (mut swbb, mut swby) = (0.0, 0.0);
    for pt in points {
        let a = at(0.0, pt.depth_mm);
        let b = at(1.0, pt.depth_mm) - a;
        let w = pt.sd_kpa.powi(-2);
        swbb += w * b * b;
        swby += w * b * (pt.external_pressure_kpa - a);
    }
    let n = swby / swbb;
    let model_kpa: Vec<f64> = points.iter().map(|p| at(n, p.depth_mm)).collect();
    let residuals_kpa: Vec<f64> = model_kpa
        .iter()
        .zip(points)
        .map(|(m, p)| m - p.external_pressure_kpa)
        .collect();
    let chi_squared = residuals_kpa
        .iter()
        .zip(points)
        .map(|(r, p)| (r / p.sd_kpa).powi(2))
        .sum();
    Calibration {
        limit_coefficient: n,
        limit_coefficient_se: swbb.sqrt().recip(),
        model_kpa,
        residuals_kpa,
        chi_squared,
    }
}

/// A loading branch fitted to a curve ([`fit_rise`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct RiseFit {
    /// Limit coefficient N.
    pub limit_coefficient: f64,
    /// Rise length ΔDc (mm).
    pub rise_mm: f64,
    /// Root-mean-square residual in K (the rows' unit).
    pub rms: f64,
}

/// Fits N and ΔDc of `base`'s loading branch, K(D) = K0 + (N − K0)·tanh((D
/// − D0)/ΔDc), to `rows` of (D in mm, K wanted) by least squares. For a
/// given ΔDc the best N is closed-form (K is linear in N); ΔDc is searched
/// between 0.05 and 50 mm by golden section in ln ΔDc, the residual being
/// unimodal there for curves that rise and level off. Rows at or below D0
/// carry no information on N and are skipped.
pub fn fit_rise(base: &SandParams, rows: &[(f64, f64)]) -> RiseFit {
    let (d0, k0) = (base.initial_diameter_mm, base.at_rest_coefficient);
    let at = |rise: f64| -> RiseFit {
        let t: Vec<(f64, f64)> = rows
            .iter()
            .filter(|(d, _)| *d > d0)
            .map(|(d, k)| (((d - d0) / rise).tanh(), *k))
            .collect();
        // K − K0 = (N − K0)·t: the slope through the origin.
        let (stt, sty) = t
            .iter()
            .fold((0.0, 0.0), |(a, b), (t, k)| (a + t * t, b + t * (k - k0)));
        let n = k0 + sty / stt;
        let ss: f64 = t.iter().map(|(t, k)| (k0 + (n - k0) * t - k).powi(2)).sum();
        RiseFit {
            limit_coefficient: n,
            rise_mm: rise,
            rms: (ss / t.len().max(1) as f64).sqrt(),
        }
    };
    let g = 0.5 * (5.0_f64.sqrt() - 1.0);
    let (mut a, mut b) = (0.05_f64.ln(), 50.0_f64.ln());
    let (mut c, mut d) = (b - g * (b - a), a + g * (b - a));
    let (mut fc, mut fd) = (at(c.exp()).rms, at(d.exp()).rms);
    for _ in 0..80 {
        if fc < fd {
            (b, d, fd) = (d, c, fc);
            c = b - g * (b - a);
            fc = at(c.exp()).rms;
        } else {
            (a, c, fc) = (c, d, fd);
            d = a + g * (b - a);
            fd = at(d.exp()).rms;
        }
    }
    at((0.5 * (a + b)).exp())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn buoyant_unit_weight_is_the_hand_value() {
        // (2920 − 1025)·0.6·9.81 N/m³ = 11154 N/m³ = 0.01115 kPa/mm.
        let p = SandParams::paper_uncalibrated();
        assert!((p.buoyant_unit_weight_kpa_per_mm() - 0.011_153_97).abs() < 1e-8);
        assert!((p.at_rest_coefficient - 0.5).abs() < 1e-12);
        assert!((p.active_coefficient - 1.0 / 3.0).abs() < 1e-12);
    }

    #[test]
    fn calibration_fits_the_balloon_table_within_its_sds() {
        let base = SandParams::paper_uncalibrated();
        let cal = calibrate_limit_coefficient(&base, &BALLOON_TABLE, BALLOON_FINAL_DIAMETER_MM);
        for (r, p) in cal.residuals_kpa.iter().zip(&BALLOON_TABLE) {
            assert!(
                r.abs() < p.sd_kpa,
                "h = {} mm: residual {r} kPa",
                p.depth_mm
            );
        }
        // A limit well above at rest, as in cavity-expansion in sand.
        assert!(cal.limit_coefficient > 5.0 * base.at_rest_coefficient);
        let sand = ParametricSand::calibrated_to_balloon();
        assert_eq!(sand.params.limit_coefficient, cal.limit_coefficient);
    }

    #[test]
    fn calibration_recovers_a_known_coefficient() {
        let base = SandParams::paper_uncalibrated();
        let truth = ParametricSand {
            params: SandParams {
                limit_coefficient: 7.25,
                ..base
            },
        };
        let points: Vec<BalloonPoint> = [30.0, 60.0, 90.0]
            .iter()
            .map(|&h| BalloonPoint {
                depth_mm: h,
                external_pressure_kpa: truth.loading_pressure_kpa(24.0, h),
                sd_kpa: 1.0,
            })
            .collect();
        let cal = calibrate_limit_coefficient(&base, &points, 24.0);
        assert!((cal.limit_coefficient - 7.25).abs() < 1e-12);
        assert!(cal.chi_squared < 1e-20);
    }

    #[test]
    fn the_rise_fit_recovers_a_known_branch() {
        let base = SandParams::paper_uncalibrated();
        let truth = ParametricSand {
            params: SandParams {
                limit_coefficient: 6.3,
                characteristic_diameter_increase_mm: 2.7,
                ..base
            },
        };
        let rows: Vec<(f64, f64)> = (0..30)
            .map(|i| {
                let d = 18.7 + 0.25 * f64::from(i);
                (d, truth.loading_coefficient(d))
            })
            .collect();
        let fit = fit_rise(&base, &rows);
        assert!((fit.limit_coefficient - 6.3).abs() < 1e-6, "{fit:?}");
        assert!((fit.rise_mm - 2.7).abs() < 1e-6, "{fit:?}");
        assert!(fit.rms < 1e-9, "{fit:?}");
    }

    #[test]
    fn the_solver_fit_follows_the_stored_curves_along_d() {
        let solver = crate::SolverSand::committed().unwrap();
        let sand = ParametricSand::fitted_to_solver(&solver);
        // The residual in K over every stored row (what the fit minimises),
        // against the law whose N is fitted at 25 mm only and whose ΔDc is
        // the paper's "done by 22 mm": the whole-curve fit follows the
        // solver's sand along D at least a quarter closer.
        let base = SandParams::paper_uncalibrated();
        let ends: Vec<BalloonPoint> = solver
            .curves()
            .iter()
            .map(|c| BalloonPoint {
                depth_mm: c.depth_mm,
                external_pressure_kpa: solver.loading_pressure_kpa(25.0, c.depth_mm),
                sd_kpa: 1.0,
            })
            .collect();
        let end_only = ParametricSand {
            params: SandParams {
                limit_coefficient: calibrate_limit_coefficient(&base, &ends, 25.0)
                    .limit_coefficient,
                ..base
            },
        };
        let rms = |law: &ParametricSand| {
            let mut r = Vec::new();
            for c in solver.curves() {
                let sv = solver.vertical_effective_stress_kpa(c.depth_mm);
                for &d in &c.diameters_mm {
                    let (got, want) = (
                        law.loading_pressure_kpa(d, c.depth_mm),
                        solver.loading_pressure_kpa(d, c.depth_mm),
                    );
                    r.push(((got - want) / sv).powi(2));
                }
            }
            (r.iter().sum::<f64>() / r.len() as f64).sqrt()
        };
        let (fitted, old) = (rms(&sand), rms(&end_only));
        assert!(fitted < 0.75 * old, "rms K {fitted} against {old}");
        // And the end of the expansion stays within 10 % at every depth
        // where the solver's K at 25 mm does not fall with depth (one N
        // for all; with the committed file the law's K 3.74 is +4.3 /
        // −3.6 / −8.1 % off at 40 / 50 / 70 mm). Where it falls (100 mm:
        // K 3.28 against 4.07 at 70 mm, one bed of three 12 % under the
        // others), one N cannot follow: the law's K there lies between
        // the solver's own and the shallower depth's (+14 %).
        let k_at = |law: &dyn Fn(f64, f64) -> f64, h: f64| {
            law(25.0, h) / solver.vertical_effective_stress_kpa(h)
        };
        let law = |d, h| sand.loading_pressure_kpa(d, h);
        let data = |d, h| solver.loading_pressure_kpa(d, h);
        let mut shallower: Option<f64> = None;
        for c in solver.curves() {
            let h = c.depth_mm;
            let (got, want) = (k_at(&law, h), k_at(&data, h));
            match shallower {
                Some(k_above) if want < k_above => assert!(
                    got > want && got < k_above,
                    "h {h}: the law's K {got} outside the solver's {want} .. {k_above}"
                ),
                _ => assert!(
                    (got / want - 1.0).abs() < 0.10,
                    "h {h}: K {got} against {want}"
                ),
            }
            shallower = Some(want);
        }
    }

    #[test]
    fn loading_rises_from_at_rest_to_the_limit() {
        let sand = ParametricSand::calibrated_to_balloon();
        let p = sand.params;
        let sv = p.vertical_effective_stress_kpa(40.0);
        let at = |d: f64| sand.loading_pressure_kpa(d, 40.0);
        assert!((at(18.7) - p.at_rest_coefficient * sv).abs() < 1e-12);
        assert!((at(60.0) - p.limit_coefficient * sv).abs() < 1e-9);
        // 95 % of the rise done at 22 mm.
        let frac = (at(22.0) - at(18.7)) / (at(60.0) - at(18.7));
        assert!((frac - 0.95).abs() < 1e-9, "{frac}");
        // Strictly increasing and concave on the loading branch.
        let ds: Vec<f64> = (0..40).map(|i| 18.7 + 0.2 * f64::from(i)).collect();
        for w in ds.windows(3) {
            let (a, b, c) = (at(w[0]), at(w[1]), at(w[2]));
            assert!(b > a && c > b);
            assert!(c - b < b - a);
        }
        // Free water: no sand, no pressure.
        assert_eq!(sand.loading_pressure_kpa(25.0, 0.0), 0.0);
    }

    #[test]
    fn unloading_is_stiffer_floored_and_reversible_up_to_the_peak() {
        let sand = ParametricSand::calibrated_to_balloon();
        let p = sand.params;
        let sv = p.vertical_effective_stress_kpa(50.0);
        let mut h = sand.fresh_cycle();
        let peak = sand.external_pressure_kpa(&mut h, 21.0, 50.0);
        assert_eq!(h.peak_diameter_mm, 21.0);
        // Shrinking by 0.1 mm drops p_e by s·0.1·σ'v.
        let back = sand.external_pressure_kpa(&mut h, 20.9, 50.0);
        let want = peak - sand.unloading_slope_per_mm() * 0.1 * sv;
        assert!((back - want).abs() < 1e-12);
        // Steeper than the loading branch at the same place.
        let load_slope =
            (sand.loading_pressure_kpa(21.0, 50.0) - sand.loading_pressure_kpa(20.9, 50.0)) / 0.1;
        assert!((peak - back) / 0.1 > load_slope);
        // Back to D0: floored at active.
        let end = sand.external_pressure_kpa(&mut h, 18.7, 50.0);
        assert!((end - p.active_coefficient * sv).abs() < 1e-12);
        // Regrowing retraces the unloading line, then joins loading.
        let again = sand.external_pressure_kpa(&mut h, 20.95, 50.0);
        assert!(again < sand.loading_pressure_kpa(20.95, 50.0));
        let beyond = sand.external_pressure_kpa(&mut h, 22.0, 50.0);
        assert_eq!(beyond, sand.loading_pressure_kpa(22.0, 50.0));
        // A fresh cycle forgets the peak.
        let mut fresh = sand.fresh_cycle();
        assert!(
            (sand.external_pressure_kpa(&mut fresh, 18.7, 50.0) - p.at_rest_coefficient * sv).abs()
                < 1e-12
        );
    }

    #[test]
    fn rise_shapes_share_the_slope_at_rest_and_the_limit() {
        let base = ParametricSand::calibrated_to_balloon().params;
        let (d0, dc) = (
            base.initial_diameter_mm,
            base.characteristic_diameter_increase_mm,
        );
        let span = base.limit_coefficient - base.at_rest_coefficient;
        for c in [-0.5, 0.0, 1.0, 3.0] {
            let sand = ParametricSand {
                params: SandParams {
                    rise_shape: c,
                    ..base
                },
            };
            let k = |d: f64| sand.loading_coefficient(d);
            assert_eq!(k(d0), base.at_rest_coefficient, "c {c}");
            let h = 1e-6;
            let slope = (k(d0 + h) - k(d0)) / h;
            assert!(
                (slope - span / dc).abs() < 1e-4 * span / dc,
                "c {c}: {slope}"
            );
            assert!(
                (k(d0 + 40.0 * dc) - base.limit_coefficient).abs() < 1e-6,
                "c {c}"
            );
        }
        // c = 0 is the exponential approach; c = 1 is the law's tanh.
        let at = |c: f64, x: f64| {
            ParametricSand {
                params: SandParams {
                    rise_shape: c,
                    ..base
                },
            }
            .loading_coefficient(d0 + x * dc)
        };
        for x in [0.3f64, 1.0, 2.5] {
            let exp = base.at_rest_coefficient + span * (1.0 - (-x).exp());
            let tanh = base.at_rest_coefficient + span * x.tanh();
            assert!((at(0.0, x) - exp).abs() < 1e-12);
            assert!((at(1.0, x) - tanh).abs() < 1e-12);
        }
    }

    #[test]
    fn unloading_curves_keep_the_initial_slope_and_the_floor() {
        let (slope, ka) = (4.0, 0.3);
        let peak = SandHistory {
            peak_diameter_mm: 22.0,
            peak_coefficient: 2.3,
        };
        let loading = |_: f64| -> f64 { unreachable!("only unloading is asked") };
        for c in [-1.0, 0.0, 0.5, 1.0] {
            let rule = Unloading {
                slope_per_mm: slope,
                active_coefficient: ka,
                curvature: c,
            };
            let k = |back: f64| rule.coefficient(&mut peak.clone(), 22.0 - back, loading);
            let h = 1e-7;
            assert!(((2.3 - k(h)) / h - slope).abs() < 1e-4 * slope, "c {c}");
            // Never below the floor, and there (or nearly) far down.
            for back in [0.1, 0.5, 1.0, 3.0] {
                assert!(k(back) >= ka && k(back) <= 2.3, "c {c} back {back}");
            }
            assert!(k(50.0) - ka < 0.05, "c {c}: {}", k(50.0));
        }
        // c = 0: an exponential decay to the floor; c = 1: the straight
        // line, at the floor from 2.0/4 = 0.5 mm back.
        let rule = |c: f64| Unloading {
            slope_per_mm: slope,
            active_coefficient: ka,
            curvature: c,
        };
        let k0 = rule(0.0).coefficient(&mut peak.clone(), 21.6, loading);
        assert!((k0 - (ka + 2.0 * (-slope * 0.4 / 2.0f64).exp())).abs() < 1e-12);
        let k1 = rule(1.0).coefficient(&mut peak.clone(), 21.8, loading);
        assert!((k1 - (2.3 - slope * 0.2)).abs() < 1e-12);
        assert_eq!(rule(1.0).coefficient(&mut peak.clone(), 21.4, loading), ka);
    }
}
