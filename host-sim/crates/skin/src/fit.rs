//! Fitting strain-energy laws to coupon tests of one or several modes.
//!
//! The fit is least squares on nominal stress over every row of every test
//! given, all modes jointly, each mode's residuals weighted by 1/√TSS of
//! its rows (TSS: the sum of squared deviations of its stresses from their
//! mean). The objective is then Σ over modes of (1 − R²_mode): the fit
//! maximises the summed per-mode R² the report prints, and every mode
//! counts equally whatever its stress level and row count (Treloar's
//! uniaxial test reaches 6.3 MPa, the planar one 1.8 MPa; unweighted
//! residuals let the uniaxial tail decide alone). With one mode the weight
//! is a constant and the fit is ordinary least squares on nominal stress.
//!
//! - [`Form::Linear`] laws (NH, MR, Yeoh): the nominal stress of every mode
//!   is linear in the coefficients, P(λ) = Σ c_k·φ_k(λ), so the fit is
//!   ordinary linear least squares, solved by Householder QR of the
//!   column-scaled design matrix (nalgebra). Standard errors from
//!   s²·(JᵀJ)⁻¹ with s² = RSS/(n − p); (JᵀJ)⁻¹ = R⁻¹R⁻ᵀ.
//! - [`Form::Nonlinear`] laws (Ogden, Gent): from each of the law's starts
//!   the moduli are solved by the same linear least squares with the
//!   exponents held, then every coefficient by the bounded
//!   Levenberg–Marquardt of [`crate::lm`]; the lowest sum of squares wins.
//!   Standard errors from s²·(JᵀJ)⁻¹ with J at the minimum.
//!
//! Every fit reports R² and RMSE per mode, for the modes it was fitted to
//! and for the modes it only predicts, and a Drucker stability scan of its
//! uniaxial curve.

use std::collections::BTreeMap;

use nalgebra::{DMatrix, DVector};
use serde::Serialize;
use thiserror::Error;

use super::coupon::{CouponTest, Mode};
use super::lm;
use super::{Form, LawSpec, StrainEnergy, LAWS};

/// Largest stretch the stability scan looks at in tension.
pub const SCAN_MAX_STRETCH: f64 = 10.0;
/// Smallest stretch the stability scan looks at in compression.
pub const SCAN_MIN_STRETCH: f64 = 0.1;

/// Why a fit could not be made.
#[derive(Debug, Error)]
pub enum FitError {
    /// The data do not determine every coefficient (e.g. all strains equal).
    #[error(
        "{law}: the data do not determine all {params} coefficients (rank-deficient design matrix)"
    )]
    RankDeficient {
        /// The law.
        law: &'static str,
        /// Its coefficient count.
        params: usize,
    },
    /// Not enough rows for the coefficients plus one degree of freedom.
    #[error("{law}: {rows} rows in {places} for {params} coefficients; need at least {}", params + 1)]
    TooFewRows {
        /// The law.
        law: &'static str,
        /// Rows in the tests.
        rows: usize,
        /// Its coefficient count.
        params: usize,
        /// The files, modes and lines the rows came from.
        places: String,
    },
    /// No start gave a finite stress at every row.
    #[error("{law}: no start gave a finite stress at every row")]
    NoStart {
        /// The law.
        law: &'static str,
    },
}

/// Where a law loses Drucker stability in uniaxial loading, i.e. where the
/// Cauchy stress–strain slope dσ/dε first stops being positive.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Stability {
    /// True when dσ/dε > 0 over the whole stretch range of the data.
    pub stable_over_data: bool,
    /// Stretch range of the data, every mode (λmin, λmax).
    pub data_stretch_range: (f64, f64),
    /// Smallest stretch in (1, [`SCAN_MAX_STRETCH`]] where dσ/dε ≤ 0
    /// (`Some(1.0)` when the law is unstable already at rest, μ ≤ 0).
    pub first_unstable_stretch_tension: Option<f64>,
    /// Largest stretch in [[`SCAN_MIN_STRETCH`], 1) where dσ/dε ≤ 0.
    pub first_unstable_stretch_compression: Option<f64>,
    /// Stretch beyond which the law has no finite stress (Gent's chain
    /// limit), where the tension scan stopped; `None` for the others.
    pub locking_stretch_tension: Option<f64>,
}

/// R² and RMSE of a law on one mode's rows.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ModeFit {
    /// The mode.
    pub mode: Mode,
    /// Whether these rows were fitted (`false`: predicted only).
    pub fitted: bool,
    /// Rows of this mode.
    pub points: usize,
    /// 1 − RSS/TSS on nominal stress over this mode's rows.
    pub r_squared: f64,
    /// sqrt(RSS/n) of nominal stress over this mode's rows (kPa).
    pub rmse_kpa: f64,
    /// Rows where the law gives no finite stress (beyond Gent's lock);
    /// R² and RMSE are then NaN (`null` in JSON).
    pub no_stress_rows: usize,
}

/// A law fitted to coupon tests.
#[derive(Clone, Debug, Serialize)]
pub struct LawFit {
    /// The law's registry row.
    #[serde(skip)]
    pub spec: &'static LawSpec,
    /// The law's name.
    pub law: &'static str,
    /// Coefficient names (with units).
    pub parameter_names: &'static [&'static str],
    /// Fitted coefficients, units as in their names.
    pub parameters: Vec<f64>,
    /// Their standard errors, from s²·(JᵀJ)⁻¹ (`None`, `null` in JSON,
    /// where the data do not determine a coefficient).
    pub standard_errors: Vec<Option<f64>>,
    /// Small-strain shear modulus of the fitted law (kPa).
    pub shear_modulus_kpa: f64,
    /// Coefficient of determination on nominal stress over every fitted
    /// row, 1 − RSS/TSS.
    pub r_squared: f64,
    /// Root-mean-square residual of nominal stress over the fitted rows,
    /// sqrt(RSS/n) (kPa).
    pub rmse_kpa: f64,
    /// Rows fitted.
    pub points: usize,
    /// Per mode: the fitted modes, then those only predicted.
    pub modes: Vec<ModeFit>,
    /// Starts tried (nonlinear laws; 1 for a linear one).
    pub starts: usize,
    /// Coefficients that ended on a bound of the nonlinear fit (the data
    /// would take them further: a sign of too many coefficients).
    pub at_bound: Vec<&'static str>,
    /// Drucker stability inside and beyond the data.
    pub stability: Stability,
}

impl LawFit {
    /// The fitted law.
    pub fn model(&self) -> Box<dyn StrainEnergy> {
        match (self.spec.from_parameters)(&self.parameters) {
            Some(m) => m,
            // The fitter built the same law from the same coefficients.
            None => unreachable!("coefficients accepted by the spec when fitted"),
        }
    }

    /// The statistics of `mode`, if its rows were fitted or predicted.
    pub fn mode(&self, mode: Mode) -> Option<&ModeFit> {
        self.modes.iter().find(|m| m.mode == mode)
    }

    /// Adds R² and RMSE for the modes of `tests` that were not fitted.
    pub fn predict(&mut self, tests: &[CouponTest]) {
        let law = self.model();
        for (mode, rows) in by_mode(tests) {
            if self.mode(mode).is_none() {
                self.modes
                    .push(mode_stats(law.as_ref(), mode, &rows, false));
            }
        }
        let range = stretch_range(tests.iter());
        let (lo, hi) = self.stability.data_stretch_range;
        self.stability = drucker_scan(law.as_ref(), (lo.min(range.0), hi.max(range.1)));
    }
}

/// The residual weight of each mode in a joint fit: 1/√TSS of its nominal
/// stresses (1 for a mode whose stresses are all equal). A single mode is
/// not weighted at all: the constant would only perturb the last bits of
/// ordinary least squares.
fn mode_weights(tests: &[CouponTest]) -> BTreeMap<Mode, f64> {
    let modes = by_mode(tests);
    let single = modes.len() == 1;
    modes
        .into_iter()
        .map(|(mode, rows)| {
            let mean = rows.iter().map(|r| r.1).sum::<f64>() / rows.len() as f64;
            let ss: f64 = rows.iter().map(|r| (r.1 - mean).powi(2)).sum();
            (
                mode,
                if ss > 0.0 && !single {
                    1.0 / ss.sqrt()
                } else {
                    1.0
                },
            )
        })
        .collect()
}

/// Every row of `tests`, grouped by mode: (stretch, nominal stress).
fn by_mode(tests: &[CouponTest]) -> BTreeMap<Mode, Vec<(f64, f64)>> {
    let mut out: BTreeMap<Mode, Vec<(f64, f64)>> = BTreeMap::new();
    for t in tests {
        out.entry(t.mode)
            .or_default()
            .extend(t.stretch().zip(t.nominal_stress_kpa.iter().copied()));
    }
    out
}

fn stretch_range<'a>(tests: impl Iterator<Item = &'a CouponTest>) -> (f64, f64) {
    tests.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), t| {
        let (a, b) = t.stretch_range();
        (lo.min(a), hi.max(b))
    })
}

/// R² and RMSE of `law` on `rows` of `mode`.
fn mode_stats(law: &dyn StrainEnergy, mode: Mode, rows: &[(f64, f64)], fitted: bool) -> ModeFit {
    let n = rows.len();
    let mean = rows.iter().map(|r| r.1).sum::<f64>() / n.max(1) as f64;
    let predicted: Vec<f64> = rows
        .iter()
        .map(|(l, _)| mode.nominal_kpa(law, *l))
        .collect();
    let no_stress_rows = predicted.iter().filter(|p| !p.is_finite()).count();
    let (rss, tss) = rows
        .iter()
        .zip(&predicted)
        .fold((0.0, 0.0), |(rss, tss), ((_, p), q)| {
            (rss + (q - p).powi(2), tss + (p - mean).powi(2))
        });
    let (r_squared, rmse_kpa) = if no_stress_rows > 0 {
        (f64::NAN, f64::NAN)
    } else {
        (1.0 - rss / tss, (rss / n.max(1) as f64).sqrt())
    };
    ModeFit {
        mode,
        fitted,
        points: n,
        r_squared,
        rmse_kpa,
        no_stress_rows,
    }
}

/// Design matrix J: row i, column k = nominal stress (kPa) in row i's mode
/// at its stretch of the law with coefficient k = 1 and the others 0. For
/// a nonlinear law, `fixed` holds the other coefficients and only the
/// `columns` vary.
fn design_matrix(
    spec: &LawSpec,
    rows: &[(Mode, f64)],
    columns: &[usize],
    fixed: &[f64],
) -> Option<DMatrix<f64>> {
    let basis: Vec<Box<dyn StrainEnergy>> = columns
        .iter()
        .map(|&k| {
            let mut p = fixed.to_vec();
            for &j in columns {
                p[j] = if j == k { 1.0 } else { 0.0 };
            }
            (spec.from_parameters)(&p)
        })
        .collect::<Option<_>>()?;
    let j = DMatrix::from_fn(rows.len(), columns.len(), |i, k| {
        rows[i].0.nominal_kpa(basis[k].as_ref(), rows[i].1)
    });
    j.iter().all(|v| v.is_finite()).then_some(j)
}

/// Linear least squares by QR of the column-scaled J: the coefficients
/// and their residual sum of squares; `None` when J is rank-deficient.
fn linear_solve(j: &DMatrix<f64>, y: &DVector<f64>) -> Option<(Vec<f64>, f64)> {
    // Scale columns to unit norm: the Yeoh columns differ by orders of
    // magnitude at large stretch, and scaling keeps R well conditioned.
    let scale: Vec<f64> = j.column_iter().map(|c| c.norm()).collect();
    if scale.iter().any(|s| *s <= 0.0 || !s.is_finite()) {
        return None;
    }
    let mut js = j.clone();
    for (k, s) in scale.iter().enumerate() {
        js.column_mut(k).unscale_mut(*s);
    }
    let qr = js.qr();
    let r = qr.r();
    let rmax = r.diagonal().amax();
    if r.diagonal().iter().any(|d| d.abs() <= 1e-12 * rmax) {
        return None;
    }
    let qty = qr.q().transpose() * y;
    let cs = r.solve_upper_triangular(&qty)?;
    let params: Vec<f64> = cs.iter().zip(&scale).map(|(c, s)| c / s).collect();
    let rss = (y - j * DVector::from_column_slice(&params)).norm_squared();
    Some((params, rss))
}

/// Fits one law to `tests` (every mode they hold, jointly) by least
/// squares on nominal stress.
pub fn fit_law(spec: &'static LawSpec, tests: &[CouponTest]) -> Result<LawFit, FitError> {
    let p = spec.parameter_names.len();
    let rows: Vec<(Mode, f64)> = tests
        .iter()
        .flat_map(|t| t.stretch().map(move |l| (t.mode, l)))
        .collect();
    let y = DVector::from_iterator(
        rows.len(),
        tests
            .iter()
            .flat_map(|t| t.nominal_stress_kpa.iter().copied()),
    );
    let n = rows.len();
    let weights = mode_weights(tests);
    let w = DVector::from_iterator(
        n,
        tests
            .iter()
            .flat_map(|t| std::iter::repeat_n(weights[&t.mode], t.strain.len())),
    );
    let yw = y.component_mul(&w);
    if n < p + 1 {
        return Err(FitError::TooFewRows {
            law: spec.name,
            rows: n,
            params: p,
            places: tests
                .iter()
                .map(CouponTest::place)
                .collect::<Vec<_>>()
                .join(", "),
        });
    }
    let rank_err = || FitError::RankDeficient {
        law: spec.name,
        params: p,
    };
    let mut at_bound = Vec::new();
    let (params, errors, starts) = match spec.form {
        Form::Linear => {
            let all: Vec<usize> = (0..p).collect();
            let j = design_matrix(spec, &rows, &all, &vec![0.0; p]).ok_or_else(rank_err)?;
            let j = DMatrix::from_diagonal(&w) * j;
            let (params, rss) = linear_solve(&j, &yw).ok_or_else(rank_err)?;
            (params, lm::standard_errors(&j, rss), 1)
        }
        Form::Nonlinear {
            bounds,
            linear_in,
            starts,
            ..
        } => {
            let residuals = |x: &[f64]| -> Option<Vec<f64>> {
                let law = (spec.from_parameters)(x)?;
                Some(
                    rows.iter()
                        .zip(y.iter().zip(w.iter()))
                        .map(|((m, l), (v, w))| w * (m.nominal_kpa(law.as_ref(), *l) - v))
                        .collect(),
                )
            };
            let nonlinear: Vec<usize> = (0..p).filter(|k| !linear_in.contains(k)).collect();
            let starts = starts();
            let mut best: Option<(lm::Minimum, Vec<(f64, f64)>)> = None;
            for start in &starts {
                let mut x = vec![0.0; p];
                for (k, v) in nonlinear.iter().zip(start) {
                    x[*k] = *v;
                }
                // Moduli by least squares at these exponents.
                let Some(j) = design_matrix(spec, &rows, linear_in, &x) else {
                    continue;
                };
                let j = DMatrix::from_diagonal(&w) * j;
                let Some((mu, _)) = linear_solve(&j, &yw) else {
                    continue;
                };
                for (k, v) in linear_in.iter().zip(mu) {
                    x[*k] = v;
                }
                // This start's bounds: the law's, with its sign pairs
                // held (Ogden's μp·αp > 0).
                let held = spec.bounds_from(&x).unwrap_or_else(|| bounds.to_vec());
                let Some(m) = lm::minimise(residuals, &x, &held) else {
                    continue;
                };
                if best.as_ref().is_none_or(|(b, _)| m.rss < b.rss) {
                    best = Some((m, held));
                }
            }
            let (best, held) = best.ok_or(FitError::NoStart { law: spec.name })?;
            let errors = lm::standard_errors(&best.jacobian, best.rss);
            at_bound = best
                .x
                .iter()
                .zip(&held)
                .zip(spec.parameter_names)
                .filter(|((v, (lo, hi)), _)| *v <= lo || *v >= hi)
                .map(|(_, n)| *n)
                .collect();
            (best.x, errors, starts.len())
        }
    };

    let model = (spec.from_parameters)(&params).ok_or_else(rank_err)?;
    let law = model.as_ref();
    let rss: f64 = rows
        .iter()
        .zip(y.iter())
        .map(|((m, l), v)| (m.nominal_kpa(law, *l) - v).powi(2))
        .sum();
    let mean = y.mean();
    let tss: f64 = y.iter().map(|v| (v - mean).powi(2)).sum();
    let modes = by_mode(tests)
        .into_iter()
        .map(|(mode, r)| mode_stats(law, mode, &r, true))
        .collect();
    let stability = drucker_scan(law, stretch_range(tests.iter()));
    Ok(LawFit {
        spec,
        law: spec.name,
        parameter_names: spec.parameter_names,
        shear_modulus_kpa: law.shear_modulus_kpa(),
        parameters: params,
        standard_errors: errors,
        r_squared: 1.0 - rss / tss,
        rmse_kpa: (rss / n as f64).sqrt(),
        points: n,
        modes,
        starts,
        at_bound,
        stability,
    })
}

/// Fits every law in [`LAWS`], in registry order: a law that cannot be
/// fitted (too few rows for its coefficients, …) is an `Err` in its place.
pub fn fit_all(tests: &[CouponTest]) -> Vec<Result<LawFit, FitError>> {
    LAWS.iter().map(|spec| fit_law(spec, tests)).collect()
}

/// Scans dσ/dε of `law` in uniaxial tension up to [`SCAN_MAX_STRETCH`] and
/// compression down to [`SCAN_MIN_STRETCH`] for the first loss of Drucker
/// stability, located to 1e-9 in stretch by bisection. A law with no finite
/// stress beyond some stretch (Gent) is scanned up to there.
pub fn drucker_scan(law: &dyn StrainEnergy, data_stretch_range: (f64, f64)) -> Stability {
    let slope = |l: f64| law.uniaxial_cauchy_slope_kpa(l);
    let stable = |l: f64| slope(l) > 0.0;
    let finite = |l: f64| slope(l).is_finite() && law.uniaxial_nominal_kpa(l).is_finite();
    // (first loss, where the stress stopped being finite)
    let first_loss = |to: f64| -> (Option<f64>, Option<f64>) {
        if !stable(1.0) {
            return (Some(1.0), None);
        }
        // Log-spaced grid, fine enough that no unstable window of a smooth
        // polynomial law wider than ~0.1 % of the stretch is missed.
        const STEPS: usize = 4000;
        let mut prev = 1.0;
        for i in 1..=STEPS {
            let l = to.powf(i as f64 / STEPS as f64);
            if !finite(l) {
                let (mut ok, mut bad) = (prev, l);
                while (bad - ok).abs() > 1e-9 {
                    let mid = 0.5 * (ok + bad);
                    if finite(mid) {
                        ok = mid;
                    } else {
                        bad = mid;
                    }
                }
                return (None, Some(bad));
            }
            if !stable(l) {
                let (mut ok, mut bad) = (prev, l);
                while (bad - ok).abs() > 1e-9 {
                    let mid = 0.5 * (ok + bad);
                    if stable(mid) {
                        ok = mid;
                    } else {
                        bad = mid;
                    }
                }
                return (Some(bad), None);
            }
            prev = l;
        }
        (None, None)
    };
    let (tension, locking) = first_loss(SCAN_MAX_STRETCH);
    let (compression, _) = first_loss(SCAN_MIN_STRETCH);
    let (lo, hi) = data_stretch_range;
    let stable_over_data = tension.is_none_or(|l| l > hi && l > 1.0)
        && compression.is_none_or(|l| l < lo && l < 1.0)
        && locking.is_none_or(|l| l > hi);
    Stability {
        stable_over_data,
        data_stretch_range,
        first_unstable_stretch_tension: tension,
        first_unstable_stretch_compression: compression,
        locking_stretch_tension: locking,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::coupon::{CouponTest, Mode};
    use crate::{MooneyRivlin, NeoHookean, Yeoh};

    fn synthetic(law: &dyn StrainEnergy) -> Vec<CouponTest> {
        let strain: Vec<f64> = (0..30).map(|i| 0.1 * i as f64).collect();
        let stress = strain
            .iter()
            .map(|e| law.uniaxial_nominal_kpa(1.0 + e))
            .collect();
        vec![CouponTest::from_nominal(
            "synthetic",
            Mode::Uniaxial,
            strain,
            stress,
        )]
    }

    #[test]
    fn every_law_recovers_its_own_coefficients_exactly() {
        let truths: [Box<dyn StrainEnergy>; 3] = [
            Box::new(NeoHookean { c10_kpa: 210.0 }),
            Box::new(MooneyRivlin {
                c10_kpa: 180.0,
                c01_kpa: 25.0,
            }),
            Box::new(Yeoh {
                c10_kpa: 40.0,
                c20_kpa: -1.2,
                c30_kpa: 0.05,
            }),
        ];
        for (spec, truth) in LAWS.iter().zip(&truths) {
            let fit = fit_law(spec, &synthetic(truth.as_ref())).unwrap();
            for (got, want) in fit.parameters.iter().zip(truth.parameters()) {
                assert!(
                    (got - want).abs() < 1e-9 * want.abs(),
                    "{}: {got} vs {want}",
                    spec.name
                );
            }
            assert!(fit.r_squared > 1.0 - 1e-12);
            assert!(fit.rmse_kpa < 1e-9);
        }
    }

    #[test]
    fn standard_errors_match_the_closed_form_for_one_coefficient() {
        // One coefficient: se = sqrt(s² / Σφ²), s² = RSS/(n − 1).
        let strain: Vec<f64> = (1..9).map(|i| 0.25 * i as f64).collect();
        let phi: Vec<f64> = strain
            .iter()
            .map(|e| {
                let l = 1.0 + e;
                2.0 * (l - 1.0 / (l * l))
            })
            .collect();
        // Exact line 50·φ plus a fixed, zero-mean-ish wiggle.
        let wiggle = [1.0, -2.0, 0.5, 1.5, -1.0, 0.0, 2.0, -0.5];
        let y: Vec<f64> = phi.iter().zip(wiggle).map(|(p, w)| 50.0 * p + w).collect();
        let t = CouponTest::from_nominal("w", Mode::Uniaxial, strain, y.clone());
        let fit = fit_law(&NeoHookean::SPEC, &[t]).unwrap();
        let spp: f64 = phi.iter().map(|p| p * p).sum();
        let c = phi.iter().zip(&y).map(|(p, v)| p * v).sum::<f64>() / spp;
        let rss: f64 = phi.iter().zip(&y).map(|(p, v)| (v - c * p).powi(2)).sum();
        let se = (rss / 7.0 / spp).sqrt();
        assert!((fit.parameters[0] - c).abs() < 1e-10 * c);
        assert!((fit.standard_errors[0].unwrap() - se).abs() < 1e-10 * se);
        assert!((fit.rmse_kpa - (rss / 8.0).sqrt()).abs() < 1e-12);
    }

    #[test]
    fn rank_deficient_data_is_an_error_not_a_panic() {
        let t = CouponTest::from_nominal("flat", Mode::Uniaxial, vec![0.0; 6], vec![0.0; 6]);
        assert!(matches!(
            fit_law(&Yeoh::SPEC, &[t]),
            Err(FitError::RankDeficient { .. })
        ));
    }

    #[test]
    fn mooney_rivlin_with_negative_c01_loses_stability_where_the_formula_says() {
        // σ = 2(λ² − 1/λ)(C10 + C01/λ): with C10 + C01 > 0 but C01 < 0 the
        // second factor changes sign at λ = −C01/C10 = 0.9, so σ turns
        // positive in compression below it: a loss of stability in (0.9, 1).
        let m = MooneyRivlin {
            c10_kpa: 100.0,
            c01_kpa: -90.0,
        };
        let s = drucker_scan(&m, (1.0, 2.0));
        let l = s.first_unstable_stretch_compression.unwrap();
        assert!(m.uniaxial_cauchy_slope_kpa(l + 1e-6) > 0.0);
        assert!(m.uniaxial_cauchy_slope_kpa(l - 1e-6) <= 0.0);
        assert!(l > 0.9 && l < 1.0, "{l}");
        assert!(s.stable_over_data);
        // Neo-Hookean with μ > 0 is stable everywhere.
        let s = drucker_scan(&NeoHookean { c10_kpa: 1.0 }, (1.0, 8.0));
        assert_eq!(s.first_unstable_stretch_tension, None);
        assert_eq!(s.first_unstable_stretch_compression, None);
        // μ < 0: unstable at rest.
        let s = drucker_scan(&NeoHookean { c10_kpa: -1.0 }, (1.0, 8.0));
        assert_eq!(s.first_unstable_stretch_tension, Some(1.0));
        assert!(!s.stable_over_data);
    }

    #[test]
    fn yeoh_with_negative_c20_loses_stability_where_dsigma_changes_sign() {
        // Strongly negative C20 and no C30: W1 = C10 + 2·C20·(I1 − 3) falls to
        // zero at I1 − 3 = C10/(−2·C20); the slope turns before that.
        let m = Yeoh {
            c10_kpa: 10.0,
            c20_kpa: -1.0,
            c30_kpa: 0.0,
        };
        let s = drucker_scan(&m, (1.0, 1.5));
        let l = s.first_unstable_stretch_tension.unwrap();
        assert!(m.uniaxial_cauchy_slope_kpa(l - 1e-6) > 0.0);
        assert!(m.uniaxial_cauchy_slope_kpa(l + 1e-6) <= 0.0);
        let x = l * l + 2.0 / l - 3.0;
        assert!(x < 5.0, "loses stability before W1 = 0 (I1 − 3 = 5): {x}");
    }

    #[test]
    fn rows_beyond_a_locking_law_are_counted_not_averaged() {
        // Gent fitted on small strains, asked about strains past its lock.
        let truth = crate::Gent {
            mu_kpa: 10.0,
            jm: 1.0,
        };
        let small: Vec<f64> = (0..8).map(|i| 0.05 * f64::from(i)).collect();
        let p = small
            .iter()
            .map(|e| truth.uniaxial_nominal_kpa(1.0 + e))
            .collect();
        let fit_on = CouponTest::from_nominal("s", Mode::Uniaxial, small, p);
        let mut fit = fit_law(&crate::Gent::SPEC, &[fit_on]).unwrap();
        let far = CouponTest::from_nominal(
            "far",
            Mode::Equibiaxial,
            vec![0.1, 0.5, 1.0, 2.0],
            vec![1.0, 5.0, 20.0, 80.0],
        );
        fit.predict(&[far]);
        let m = fit.mode(Mode::Equibiaxial).unwrap();
        // I1 − 3 at equibiaxial λ = 1.5 is 1.69 > Jm = 1: three rows locked.
        assert_eq!(m.no_stress_rows, 3);
        assert!(m.r_squared.is_nan() && m.rmse_kpa.is_nan());
        assert_eq!(fit.mode(Mode::Uniaxial).unwrap().no_stress_rows, 0);
    }
}
