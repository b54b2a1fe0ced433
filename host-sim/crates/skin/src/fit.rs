//! Fitting strain-energy laws to a uniaxial test.
//!
//! Every registered law's nominal stress is linear in its coefficients,
//! P(λ) = Σ c_k·φ_k(λ), so the fit is ordinary linear least squares on
//! nominal stress, solved by Householder QR of the column-scaled design
//! matrix (nalgebra). Standard errors come from s²·(JᵀJ)⁻¹ with
//! s² = RSS/(n − p); (JᵀJ)⁻¹ = R⁻¹R⁻ᵀ from the same factorisation.
//!
//! Each fit also gets a Drucker stability scan of its uniaxial curve.

use nalgebra::{DMatrix, DVector};
use serde::Serialize;
use thiserror::Error;

use super::uniaxial::UniaxialTest;
use super::{LawSpec, StrainEnergy, LAWS};

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
    #[error("{law}: {rows} rows for {params} coefficients; need at least {}", params + 1)]
    TooFewRows {
        /// The law.
        law: &'static str,
        /// Rows in the test.
        rows: usize,
        /// Its coefficient count.
        params: usize,
    },
}

/// Where a law loses Drucker stability in uniaxial loading, i.e. where the
/// Cauchy stress–strain slope dσ/dε first stops being positive.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Stability {
    /// True when dσ/dε > 0 over the whole stretch range of the data.
    pub stable_over_data: bool,
    /// Stretch range of the data (λmin, λmax).
    pub data_stretch_range: (f64, f64),
    /// Smallest stretch in (1, [`SCAN_MAX_STRETCH`]] where dσ/dε ≤ 0
    /// (`Some(1.0)` when the law is unstable already at rest, μ ≤ 0).
    pub first_unstable_stretch_tension: Option<f64>,
    /// Largest stretch in [[`SCAN_MIN_STRETCH`], 1) where dσ/dε ≤ 0.
    pub first_unstable_stretch_compression: Option<f64>,
}

/// A law fitted to a uniaxial test.
#[derive(Clone, Debug, Serialize)]
pub struct LawFit {
    /// The law's registry row.
    #[serde(skip)]
    pub spec: &'static LawSpec,
    /// The law's name.
    pub law: &'static str,
    /// Coefficient names.
    pub parameter_names: &'static [&'static str],
    /// Fitted coefficients (kPa).
    pub parameters_kpa: Vec<f64>,
    /// Their standard errors (kPa), from s²·(JᵀJ)⁻¹.
    pub standard_errors_kpa: Vec<f64>,
    /// Coefficient of determination on nominal stress, 1 − RSS/TSS.
    pub r_squared: f64,
    /// Root-mean-square residual of nominal stress, sqrt(RSS/n) (kPa).
    pub rmse_kpa: f64,
    /// Rows fitted.
    pub points: usize,
    /// Drucker stability inside and beyond the data.
    pub stability: Stability,
}

impl LawFit {
    /// The fitted law.
    pub fn model(&self) -> Box<dyn StrainEnergy> {
        match (self.spec.from_parameters_kpa)(&self.parameters_kpa) {
            Some(m) => m,
            // The fitter sized the coefficients from the same spec.
            None => unreachable!("coefficient count fixed by the spec"),
        }
    }
}

/// Design matrix J: row i, column k = nominal stress (kPa) at stretch λ_i of
/// the law with coefficient k = 1 and the others 0.
pub fn design_matrix(spec: &LawSpec, stretches: &[f64]) -> DMatrix<f64> {
    let n = spec.parameter_names.len();
    let basis: Vec<Box<dyn StrainEnergy>> = (0..n)
        .map(|k| {
            let unit: Vec<f64> = (0..n).map(|j| if j == k { 1.0 } else { 0.0 }).collect();
            (spec.from_parameters_kpa)(&unit).unwrap_or_else(|| unreachable!("count from spec"))
        })
        .collect();
    DMatrix::from_fn(stretches.len(), n, |i, k| {
        basis[k].uniaxial_nominal_kpa(stretches[i])
    })
}

/// Fits one law to `test` by linear least squares on nominal stress.
pub fn fit_law(spec: &'static LawSpec, test: &UniaxialTest) -> Result<LawFit, FitError> {
    let p = spec.parameter_names.len();
    let n = test.strain.len();
    if n < p + 1 {
        return Err(FitError::TooFewRows {
            law: spec.name,
            rows: n,
            params: p,
        });
    }
    let stretches: Vec<f64> = test.stretch().collect();
    let j = design_matrix(spec, &stretches);
    let y = DVector::from_column_slice(&test.nominal_stress_kpa);

    // Scale columns to unit norm: the Yeoh columns differ by orders of
    // magnitude at large stretch, and scaling keeps R well conditioned.
    let scale: Vec<f64> = j.column_iter().map(|c| c.norm()).collect();
    if scale.iter().any(|s| *s <= 0.0 || !s.is_finite()) {
        return Err(FitError::RankDeficient {
            law: spec.name,
            params: p,
        });
    }
    let mut js = j.clone();
    for (k, s) in scale.iter().enumerate() {
        js.column_mut(k).unscale_mut(*s);
    }
    let qr = js.qr();
    let r = qr.r();
    let rmax = r.diagonal().amax();
    if r.diagonal().iter().any(|d| d.abs() <= 1e-12 * rmax) {
        return Err(FitError::RankDeficient {
            law: spec.name,
            params: p,
        });
    }
    let qty = qr.q().transpose() * &y;
    let rank_err = || FitError::RankDeficient {
        law: spec.name,
        params: p,
    };
    let cs = r.solve_upper_triangular(&qty).ok_or_else(rank_err)?;
    let r_inv = r
        .solve_upper_triangular(&DMatrix::identity(p, p))
        .ok_or_else(rank_err)?;
    let cov_scaled = &r_inv * r_inv.transpose();

    let params: Vec<f64> = (0..p).map(|k| cs[k] / scale[k]).collect();
    let residual = &y - &j * DVector::from_column_slice(&params);
    let rss = residual.norm_squared();
    let mean = y.mean();
    let tss: f64 = y.iter().map(|v| (v - mean).powi(2)).sum();
    let s2 = rss / (n - p) as f64;
    let errors: Vec<f64> = (0..p)
        .map(|k| (s2 * cov_scaled[(k, k)]).sqrt() / scale[k])
        .collect();

    let model = (spec.from_parameters_kpa)(&params).ok_or_else(rank_err)?;
    let stability = drucker_scan(model.as_ref(), test.stretch_range());
    Ok(LawFit {
        spec,
        law: spec.name,
        parameter_names: spec.parameter_names,
        parameters_kpa: params,
        standard_errors_kpa: errors,
        r_squared: 1.0 - rss / tss,
        rmse_kpa: (rss / n as f64).sqrt(),
        points: n,
        stability,
    })
}

/// Fits every law in [`LAWS`], in registry order.
pub fn fit_all(test: &UniaxialTest) -> Result<Vec<LawFit>, FitError> {
    LAWS.iter().map(|spec| fit_law(spec, test)).collect()
}

/// Scans dσ/dε of `law` in uniaxial tension up to [`SCAN_MAX_STRETCH`] and
/// compression down to [`SCAN_MIN_STRETCH`] for the first loss of Drucker
/// stability, located to 1e-9 in stretch by bisection.
pub fn drucker_scan(law: &dyn StrainEnergy, data_stretch_range: (f64, f64)) -> Stability {
    let stable = |l: f64| law.uniaxial_cauchy_slope_kpa(l) > 0.0;
    let first_loss = |to: f64| -> Option<f64> {
        if !stable(1.0) {
            return Some(1.0);
        }
        // Log-spaced grid, fine enough that no unstable window of a smooth
        // polynomial law wider than ~0.1 % of the stretch is missed.
        const STEPS: usize = 4000;
        let mut prev = 1.0;
        for i in 1..=STEPS {
            let l = to.powf(i as f64 / STEPS as f64);
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
                return Some(bad);
            }
            prev = l;
        }
        None
    };
    let tension = first_loss(SCAN_MAX_STRETCH);
    let compression = first_loss(SCAN_MIN_STRETCH);
    let (lo, hi) = data_stretch_range;
    let stable_over_data =
        tension.is_none_or(|l| l > hi && l > 1.0) && compression.is_none_or(|l| l < lo && l < 1.0);
    Stability {
        stable_over_data,
        data_stretch_range,
        first_unstable_stretch_tension: tension,
        first_unstable_stretch_compression: compression,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{MooneyRivlin, NeoHookean, Yeoh};

    fn synthetic(law: &dyn StrainEnergy) -> UniaxialTest {
        let strain: Vec<f64> = (0..30).map(|i| 0.1 * i as f64).collect();
        let stress = strain
            .iter()
            .map(|e| law.uniaxial_nominal_kpa(1.0 + e))
            .collect();
        UniaxialTest::from_nominal("synthetic", strain, stress)
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
            for (got, want) in fit.parameters_kpa.iter().zip(truth.parameters_kpa()) {
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
        let t = UniaxialTest::from_nominal("w", strain, y.clone());
        let fit = fit_law(&NeoHookean::SPEC, &t).unwrap();
        let spp: f64 = phi.iter().map(|p| p * p).sum();
        let c = phi.iter().zip(&y).map(|(p, v)| p * v).sum::<f64>() / spp;
        let rss: f64 = phi.iter().zip(&y).map(|(p, v)| (v - c * p).powi(2)).sum();
        let se = (rss / 7.0 / spp).sqrt();
        assert!((fit.parameters_kpa[0] - c).abs() < 1e-10 * c);
        assert!((fit.standard_errors_kpa[0] - se).abs() < 1e-10 * se);
        assert!((fit.rmse_kpa - (rss / 8.0).sqrt()).abs() < 1e-12);
    }

    #[test]
    fn rank_deficient_data_is_an_error_not_a_panic() {
        let t = UniaxialTest::from_nominal("flat", vec![0.0; 6], vec![0.0; 6]);
        assert!(matches!(
            fit_law(&Yeoh::SPEC, &t),
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
}
