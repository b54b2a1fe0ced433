//! Fitting a law's shape to the actuator's own free inflation: pressure
//! against outer diameter of the expansion zone, through the thick-walled
//! closed-end tube of [`crate::membrane`].
//!
//! The points come from an experiment folder's free runs (depth 0; the
//! folder is read by the application that calls this): the pump's volume
//! gives the diameter, the gauge pressure is the skin's alone. Only
//! inflated states (D ≥ D0) are used, averaged in equal-width diameter
//! bins so a long hold does not outweigh the rest of the curve.
//!
//! With closed ends the axial balance depends on the ratios of the
//! coefficients, so p(D) is nonlinear in every law's coefficients: every
//! law is fitted by the bounded Levenberg–Marquardt of [`crate::lm`] from
//! several starts. Standard errors from s²·(JᵀJ)⁻¹ over the bins.

use serde::Serialize;

use super::coupon::CouponTest;
use super::fit::{FitError, LawFit, ModeFit};
use super::lm;
use super::membrane::{Ends, Tube, TubeGeometry};
use super::{Form, LawSpec, NeoHookean, StrainEnergy};

/// Diameter bins the samples are averaged into (at most).
pub const MAX_BINS: usize = 40;

/// One point of a free inflation.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct InflationPoint {
    /// Outer diameter of the expansion zone (mm).
    pub diameter_mm: f64,
    /// Gauge pressure carried by the skin (kPa).
    pub pressure_kpa: f64,
}

/// Averages `points` with D ≥ `d0_mm` into at most [`MAX_BINS`]
/// equal-width diameter bins (empty bins dropped).
pub fn bin(points: &[InflationPoint], d0_mm: f64) -> Vec<InflationPoint> {
    let inflated: Vec<&InflationPoint> = points
        .iter()
        .filter(|p| {
            p.diameter_mm >= d0_mm && p.diameter_mm.is_finite() && p.pressure_kpa.is_finite()
        })
        .collect();
    let hi = inflated.iter().map(|p| p.diameter_mm).fold(d0_mm, f64::max);
    if inflated.is_empty() || hi <= d0_mm {
        return Vec::new();
    }
    let width = (hi - d0_mm) / MAX_BINS as f64;
    let mut sums = vec![(0.0, 0.0, 0usize); MAX_BINS];
    for p in inflated {
        let k = (((p.diameter_mm - d0_mm) / width) as usize).min(MAX_BINS - 1);
        sums[k].0 += p.diameter_mm;
        sums[k].1 += p.pressure_kpa;
        sums[k].2 += 1;
    }
    sums.into_iter()
        .filter(|s| s.2 > 0)
        .map(|(d, p, n)| InflationPoint {
            diameter_mm: d / n as f64,
            pressure_kpa: p / n as f64,
        })
        .collect()
}

/// A law fitted to a free inflation.
#[derive(Clone, Debug, Serialize)]
pub struct InflationFit {
    /// The law's registry row.
    #[serde(skip)]
    pub spec: &'static LawSpec,
    /// The law's name.
    pub law: &'static str,
    /// Coefficient names (with units).
    pub parameter_names: &'static [&'static str],
    /// Fitted coefficients.
    pub parameters: Vec<f64>,
    /// Their standard errors (`None`, `null` in JSON, where undetermined).
    pub standard_errors: Vec<Option<f64>>,
    /// Small-strain shear modulus of the fitted law (kPa).
    pub shear_modulus_kpa: f64,
    /// 1 − RSS/TSS of the pressure over the bins.
    pub r_squared: f64,
    /// sqrt(RSS/n) of the pressure over the bins (kPa).
    pub rmse_kpa: f64,
    /// Bins fitted.
    pub points: usize,
    /// Starts tried.
    pub starts: usize,
    /// Levenberg–Marquardt iterations of the winning start (at most
    /// [`lm::TUBE`]'s cap: reaching it means the curve does not
    /// determine every coefficient).
    pub iterations: usize,
}

impl InflationFit {
    /// The fitted law.
    pub fn model(&self) -> Box<dyn StrainEnergy> {
        match (self.spec.from_parameters)(&self.parameters) {
            Some(m) => m,
            None => unreachable!("coefficients accepted by the spec when fitted"),
        }
    }
}

/// Tube pressures of `law` at every point; `None` where the tube cannot be
/// solved or the law gives no finite stress.
pub fn tube_pressures_kpa(
    law: Box<dyn StrainEnergy>,
    geometry: TubeGeometry,
    points: &[InflationPoint],
) -> Option<Vec<f64>> {
    let tube = Tube::new(geometry, law, Ends::Closed).ok()?;
    points
        .iter()
        .map(|p| {
            tube.pressure_kpa(p.diameter_mm)
                .ok()
                .filter(|v| v.is_finite())
        })
        .collect()
}

/// (R², RMSE kPa) of `predicted` against the points.
pub fn agreement(points: &[InflationPoint], predicted: &[f64]) -> (f64, f64) {
    let n = points.len().max(1) as f64;
    let mean = points.iter().map(|p| p.pressure_kpa).sum::<f64>() / n;
    let (rss, tss) = points
        .iter()
        .zip(predicted)
        .fold((0.0, 0.0), |(r, t), (p, q)| {
            (
                r + (q - p.pressure_kpa).powi(2),
                t + (p.pressure_kpa - mean).powi(2),
            )
        });
    (1.0 - rss / tss, (rss / n).sqrt())
}

/// Fits `spec` to `points` (already binned) of a tube of rest geometry
/// `geometry`. `hint` (e.g. a coupon fit of the same law) is tried as one
/// more start.
pub fn fit_inflation(
    spec: &'static LawSpec,
    geometry: TubeGeometry,
    points: &[InflationPoint],
    hint: Option<&[f64]>,
) -> Result<InflationFit, FitError> {
    let p = spec.parameter_names.len();
    let n = points.len();
    if n < p + 1 {
        return Err(FitError::TooFewRows {
            law: spec.name,
            rows: n,
            params: p,
            places: "the free runs' diameter bins".into(),
        });
    }
    // The scale: a neo-Hookean tube's pressure is exactly proportional to
    // C10 (the closed-end balance is homogeneous in stress), so one
    // projection gives the small-strain modulus to start from.
    let unit = tube_pressures_kpa(Box::new(NeoHookean { c10_kpa: 1.0 }), geometry, points)
        .ok_or(FitError::NoStart { law: spec.name })?;
    let c10 = points
        .iter()
        .zip(&unit)
        .map(|(a, b)| a.pressure_kpa * b)
        .sum::<f64>()
        / unit.iter().map(|b| b * b).sum::<f64>();
    let mu = 2.0 * c10;
    let (bounds, mut starts): (Vec<(f64, f64)>, Vec<Vec<f64>>) = match spec.form {
        Form::Linear => {
            // Neo-Hookean-like: μ in the first coefficient, the others 0
            // (MR's C01 and Yeoh's C20, C30 start flat), and a stiffening
            // Yeoh-like shape scaled to the same μ.
            let flat: Vec<f64> = (0..p)
                .map(|k| if k == 0 { 0.5 * mu } else { 0.0 })
                .collect();
            let mut stiff = flat.clone();
            if p == 3 {
                stiff[2] = 1e-3 * mu;
            }
            (vec![(-1e7, 1e7); p], vec![flat, stiff])
        }
        Form::Nonlinear {
            bounds,
            linear_in,
            starts,
            ..
        } => {
            let nonlinear: Vec<usize> = (0..p).filter(|k| !linear_in.contains(k)).collect();
            let starts = starts()
                .into_iter()
                .map(|s| {
                    let mut x = vec![0.0; p];
                    for (k, v) in nonlinear.iter().zip(&s) {
                        x[*k] = *v;
                    }
                    // Moduli so that the small-strain modulus is μ: Ogden's
                    // ½Σμpαp shared equally, Gent's μ directly.
                    let terms = linear_in.len() as f64;
                    for &k in linear_in {
                        x[k] = match spec.parameter_names.get(k + 1) {
                            Some(n) if n.starts_with("alpha") => 2.0 * mu / (x[k + 1] * terms),
                            _ => mu,
                        };
                    }
                    x
                })
                .collect();
            (bounds.to_vec(), starts)
        }
    };
    if let Some(h) = hint.filter(|h| h.len() == p) {
        starts.insert(0, h.to_vec());
    }
    let residuals = |x: &[f64]| -> Option<Vec<f64>> {
        let law = (spec.from_parameters)(x)?;
        let q = tube_pressures_kpa(law, geometry, points)?;
        Some(
            q.iter()
                .zip(points)
                .map(|(q, p)| q - p.pressure_kpa)
                .collect(),
        )
    };
    let mut best: Option<lm::Minimum> = None;
    for s in &starts {
        // Nonlinear laws keep their sign pairs (Ogden's μp·αp > 0).
        let held = spec.bounds_from(s).unwrap_or_else(|| bounds.clone());
        let Some(m) = lm::minimise_until(residuals, s, &held, lm::TUBE) else {
            continue;
        };
        if best.as_ref().is_none_or(|b| m.rss < b.rss) {
            best = Some(m);
        }
    }
    let best = best.ok_or(FitError::NoStart { law: spec.name })?;
    let law = (spec.from_parameters)(&best.x).ok_or(FitError::NoStart { law: spec.name })?;
    let predicted: Vec<f64> = best
        .residuals
        .iter()
        .zip(points)
        .map(|(r, p)| r + p.pressure_kpa)
        .collect();
    let (r_squared, rmse_kpa) = agreement(points, &predicted);
    Ok(InflationFit {
        spec,
        law: spec.name,
        parameter_names: spec.parameter_names,
        standard_errors: lm::standard_errors(&best.jacobian, best.rss),
        shear_modulus_kpa: law.shear_modulus_kpa(),
        parameters: best.x,
        r_squared,
        rmse_kpa,
        points: n,
        starts: starts.len(),
        iterations: best.iterations,
    })
}

/// How an inflation fit and a coupon fit of the same law agree.
#[derive(Clone, Debug, Serialize)]
pub struct CouponComparison {
    /// The law compared.
    pub law: &'static str,
    /// The coupon fit's coefficients.
    pub coupon_parameters: Vec<f64>,
    /// The coupon-fitted law's tube pressure against the free inflation:
    /// R² over the bins.
    pub coupon_law_on_inflation_r_squared: f64,
    /// Same, RMSE (kPa).
    pub coupon_law_on_inflation_rmse_kpa: f64,
    /// The inflation-fitted law's prediction of each coupon mode.
    pub inflation_law_on_coupons: Vec<ModeFit>,
    /// Small-strain shear modulus, inflation fit over coupon fit.
    pub shear_modulus_ratio: f64,
}

/// Compares `inflation` with `coupon` (same law) on both data sets.
pub fn compare(
    inflation: &InflationFit,
    coupon: &LawFit,
    geometry: TubeGeometry,
    points: &[InflationPoint],
    coupons: &[CouponTest],
) -> Option<CouponComparison> {
    let on_inflation = tube_pressures_kpa(coupon.model(), geometry, points)?;
    let (r2, rmse) = agreement(points, &on_inflation);
    // The inflation law's coupon statistics: a fit with no fitted mode
    // whose every mode is a prediction.
    let mut as_coupon = coupon.clone();
    as_coupon.parameters = inflation.parameters.clone();
    as_coupon.modes.clear();
    as_coupon.predict(coupons);
    Some(CouponComparison {
        law: inflation.law,
        coupon_parameters: coupon.parameters.clone(),
        coupon_law_on_inflation_r_squared: r2,
        coupon_law_on_inflation_rmse_kpa: rmse,
        inflation_law_on_coupons: as_coupon.modes,
        shear_modulus_ratio: inflation.shear_modulus_kpa / coupon.shear_modulus_kpa,
    })
}

/// The inflation part of a `fit-skin` report.
#[derive(Clone, Debug, Serialize)]
pub struct InflationReport {
    /// The experiment folder.
    pub folder: std::path::PathBuf,
    /// Free runs used (depth 0).
    pub runs: Vec<String>,
    /// Samples with D ≥ D0 in them.
    pub samples: usize,
    /// The rest geometry of the zone's tube.
    pub geometry: TubeGeometry,
    /// What the folder's reading or the fit found doubtful.
    pub warnings: Vec<String>,
    /// The bins fitted.
    pub bins: Vec<InflationPoint>,
    /// The fit.
    pub fit: InflationFit,
    /// Agreement with the coupon fit of the same law, when coupons were
    /// given.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub coupon: Option<CouponComparison>,
}

impl InflationReport {
    /// The plain-text lines the CLI prints.
    pub fn table(&self) -> String {
        use std::fmt::Write as _;
        let mut out = String::new();
        for w in &self.warnings {
            let _ = writeln!(out, "warning: {w}");
        }
        let f = &self.fit;
        let _ = writeln!(
            out,
            "free inflation {} ({} runs at depth 0, {} samples in {} bins, D {:.2}–{:.2} mm):",
            self.folder.display(),
            self.runs.len(),
            self.samples,
            self.bins.len(),
            self.bins.first().map_or(f64::NAN, |b| b.diameter_mm),
            self.bins.last().map_or(f64::NAN, |b| b.diameter_mm),
        );
        let coeffs: Vec<String> = f
            .parameter_names
            .iter()
            .zip(f.parameters.iter().zip(&f.standard_errors))
            .map(|(n, (v, se))| match se {
                Some(se) => format!("{n}={v:.5} ± {se:.2e}"),
                None => format!("{n}={v:.5} (undetermined)"),
            })
            .collect();
        let _ = writeln!(
            out,
            "  {} through the closed-end tube: R² {:.5}, RMSE {:.4} kPa, μ = {:.4} kPa; {}{}",
            f.law,
            f.r_squared,
            f.rmse_kpa,
            f.shear_modulus_kpa,
            coeffs.join(", "),
            if f.iterations >= lm::TUBE.max_iterations {
                " (iteration cap reached: the curve does not determine every coefficient)"
            } else {
                ""
            }
        );
        if let Some(c) = &self.coupon {
            let _ = writeln!(
                out,
                "  coupon {} on this inflation: R² {:.5}, RMSE {:.4} kPa; μ inflation/coupon = {:.3}",
                c.law, c.coupon_law_on_inflation_r_squared, c.coupon_law_on_inflation_rmse_kpa, c.shear_modulus_ratio
            );
            for m in &c.inflation_law_on_coupons {
                if m.no_stress_rows > 0 {
                    let _ = writeln!(
                        out,
                        "  inflation {} on the {} coupons: no finite stress at {} of {} rows (beyond the law's limit)",
                        c.law, m.mode, m.no_stress_rows, m.points
                    );
                } else {
                    let _ = writeln!(
                        out,
                        "  inflation {} on the {} coupons: R² {:.5}, RMSE {:.4} kPa",
                        c.law, m.mode, m.r_squared, m.rmse_kpa
                    );
                }
            }
        }
        out
    }
}
