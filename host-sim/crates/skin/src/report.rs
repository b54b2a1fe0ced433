//! The `fit-skin` command's library side: read skin tests of any modes,
//! fit every registered law jointly to the modes asked for, predict the
//! others, write `<stem>-fit.json` and `<stem>-fit.svg`, and format the
//! short tables the CLI prints.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use serde::Serialize;

use super::coupon::{read_file, CouponTest, Mode, StressMeasure};
use super::fit::{fit_all, LawFit, SCAN_MAX_STRETCH, SCAN_MIN_STRETCH};
use super::inflation::InflationReport;
use datafile::write_atomic;

/// What was read, as recorded in the JSON: one entry per file and mode.
#[derive(Clone, Debug, Serialize)]
pub struct InputSummary {
    /// The CSV file.
    pub file: PathBuf,
    /// The test mode of these rows.
    pub mode: Mode,
    /// Whether these rows were fitted (`false`: only predicted).
    pub fitted: bool,
    /// Which stress the file reported (fits are always on nominal stress).
    pub measured: StressMeasure,
    /// Rows read.
    pub rows: usize,
    /// Largest engineering strain.
    pub max_strain: f64,
    /// Largest nominal stress (kPa).
    pub max_nominal_stress_kpa: f64,
}

/// Everything `fit-skin` computes; serialised as the JSON result.
#[derive(Clone, Debug, Serialize)]
pub struct FitSkinReport {
    /// The inputs.
    pub inputs: Vec<InputSummary>,
    /// Modes fitted, jointly.
    pub fit_modes: Vec<Mode>,
    /// Modes in the data that were only predicted.
    pub predicted_modes: Vec<Mode>,
    /// What is fitted.
    pub fitted_quantity: &'static str,
    /// Tension limit of the Drucker scan (stretch).
    pub scan_max_stretch: f64,
    /// Compression limit of the Drucker scan (stretch).
    pub scan_min_stretch: f64,
    /// One entry per registered law that could be fitted.
    pub fits: Vec<LawFit>,
    /// Laws that could not be fitted, and why.
    pub not_fitted: Vec<String>,
    /// Reader warnings (ignored columns, falling stress) and the laws not
    /// fitted, each naming its file and line where it has one.
    pub warnings: Vec<String>,
    /// The free-inflation fit, when an experiment folder was given.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub inflation: Option<InflationReport>,
}

impl FitSkinReport {
    /// Fits every law to one test.
    pub fn from_test(test: &CouponTest) -> Result<Self> {
        Self::from_tests(std::slice::from_ref(test), None)
    }

    /// Fits every law to the tests of `fit_modes` (all modes present when
    /// `None`) jointly and predicts the rest. A mode asked for that no
    /// test holds is an error naming the files.
    pub fn from_tests(tests: &[CouponTest], fit_modes: Option<&[Mode]>) -> Result<Self> {
        if tests.is_empty() {
            bail!("no skin test given");
        }
        let present: Vec<Mode> = Mode::ALL
            .into_iter()
            .filter(|m| tests.iter().any(|t| t.mode == *m))
            .collect();
        let fit_modes: Vec<Mode> = match fit_modes {
            None => present.clone(),
            Some(asked) => {
                for m in asked {
                    if !present.contains(m) {
                        let held: Vec<String> = tests
                            .iter()
                            .map(|t| format!("{}: {}", t.source.display(), t.mode))
                            .collect();
                        bail!(
                            "fit mode `{m}`: no file holds rows of that mode ({})",
                            held.join(", ")
                        );
                    }
                }
                Mode::ALL
                    .into_iter()
                    .filter(|m| asked.contains(m))
                    .collect()
            }
        };
        let predicted_modes: Vec<Mode> = present
            .iter()
            .copied()
            .filter(|m| !fit_modes.contains(m))
            .collect();
        let fit_on: Vec<CouponTest> = tests
            .iter()
            .filter(|t| fit_modes.contains(&t.mode))
            .cloned()
            .collect();
        let predict: Vec<CouponTest> = tests
            .iter()
            .filter(|t| !fit_modes.contains(&t.mode))
            .cloned()
            .collect();
        let mut warnings: Vec<String> = tests.iter().flat_map(|t| t.warnings.clone()).collect();
        warnings.dedup();
        let mut fits = Vec::new();
        let mut not_fitted = Vec::new();
        for result in fit_all(&fit_on) {
            match result {
                Ok(mut f) => {
                    f.predict(&predict);
                    fits.push(f);
                }
                Err(e) => not_fitted.push(format!("not fitted: {e}")),
            }
        }
        if fits.is_empty() {
            bail!("no law could be fitted: {}", not_fitted.join("; "));
        }
        warnings.extend(not_fitted.iter().cloned());
        Ok(Self {
            inputs: tests
                .iter()
                .map(|t| InputSummary {
                    file: t.source.clone(),
                    mode: t.mode,
                    fitted: fit_modes.contains(&t.mode),
                    measured: t.measured,
                    rows: t.strain.len(),
                    max_strain: t.strain.iter().copied().fold(f64::MIN, f64::max),
                    max_nominal_stress_kpa: t
                        .nominal_stress_kpa
                        .iter()
                        .copied()
                        .fold(f64::MIN, f64::max),
                })
                .collect(),
            fit_modes,
            predicted_modes,
            fitted_quantity: "nominal stress (kPa), least squares, each mode's residuals weighted by 1/sqrt(TSS of its stresses): maximises the summed per-mode R²",
            scan_max_stretch: SCAN_MAX_STRETCH,
            scan_min_stretch: SCAN_MIN_STRETCH,
            fits,
            not_fitted,
            warnings,
            inflation: None,
        })
    }

    /// The fit of the law named `law`, if it was fitted.
    pub fn fit(&self, law: &str) -> Option<&LawFit> {
        self.fits.iter().find(|f| f.law == law)
    }

    /// A short plain-text report: the inputs, one line per law (fit
    /// statistics, coefficients, stability), then R² and RMSE per mode.
    pub fn table(&self) -> String {
        let mut out = String::new();
        for i in &self.inputs {
            let _ = writeln!(
                out,
                "{} {} ({} rows, {} stress, max strain {:.3}){}",
                i.file.display(),
                i.mode,
                i.rows,
                match i.measured {
                    StressMeasure::Cauchy => "Cauchy",
                    StressMeasure::Nominal => "nominal",
                },
                i.max_strain,
                if i.fitted {
                    ""
                } else {
                    ": predicted, not fitted"
                }
            );
        }
        let names = |m: &[Mode]| m.iter().map(|m| m.name()).collect::<Vec<_>>().join(" + ");
        let _ = writeln!(
            out,
            "fitted on nominal stress, {}{}{}",
            names(&self.fit_modes),
            if self.fit_modes.len() > 1 {
                " jointly"
            } else {
                ""
            },
            if self.predicted_modes.is_empty() {
                String::new()
            } else {
                format!("; predicting {}", names(&self.predicted_modes))
            }
        );
        let _ = writeln!(
            out,
            "{:<14} {:>8} {:>10}  {:<64} Drucker (dσ/dε > 0)",
            "law", "R²", "RMSE kPa", "coefficients (± standard error)"
        );
        for f in &self.fits {
            let coeffs: Vec<String> = f
                .parameter_names
                .iter()
                .zip(f.parameters.iter().zip(&f.standard_errors))
                .map(|(n, (v, se))| {
                    let n = n.trim_end_matches("_kpa");
                    match se {
                        Some(se) => format!("{n}={} ± {}", sig(*v), sig(*se)),
                        None => format!("{n}={} (undetermined)", sig(*v)),
                    }
                })
                .collect();
            let s = &f.stability;
            let mut stab = String::from(if s.stable_over_data {
                "stable over data"
            } else {
                "UNSTABLE within data"
            });
            match (s.first_unstable_stretch_tension, s.locking_stretch_tension) {
                (Some(l), _) => {
                    let _ = write!(stab, "; tension lost at λ={l:.3}");
                }
                (None, Some(l)) => {
                    let _ = write!(stab, "; tension ok to its lock at λ={l:.3}");
                }
                (None, None) => {
                    let _ = write!(stab, "; tension ok to λ={SCAN_MAX_STRETCH}");
                }
            }
            match s.first_unstable_stretch_compression {
                Some(l) => {
                    let _ = write!(stab, "; compression lost at λ={l:.3}");
                }
                None => {
                    let _ = write!(stab, "; compression ok to λ={SCAN_MIN_STRETCH}");
                }
            }
            if !f.at_bound.is_empty() {
                let _ = write!(stab, "; at a bound: {}", f.at_bound.join(", "));
            }
            let _ = writeln!(
                out,
                "{:<14} {:>8.5} {:>10.3}  {:<64} {}",
                f.law,
                f.r_squared,
                f.rmse_kpa,
                coeffs.join(", "),
                stab
            );
        }
        let modes: Vec<Mode> = self
            .fit_modes
            .iter()
            .chain(&self.predicted_modes)
            .copied()
            .collect();
        if modes.len() > 1 || !self.predicted_modes.is_empty() {
            let _ = write!(out, "per mode, R² (RMSE kPa); * = predicted\n{:<14}", "law");
            for m in &modes {
                let _ = write!(out, " {:>24}", m.name());
            }
            out.push('\n');
            for f in &self.fits {
                let _ = write!(out, "{:<14}", f.law);
                for m in &modes {
                    let cell = f.mode(*m).map_or_else(String::new, |s| {
                        if s.no_stress_rows > 0 {
                            return format!(
                                "{}no stress at {} rows",
                                if s.fitted { "" } else { "*" },
                                s.no_stress_rows
                            );
                        }
                        format!(
                            "{}{} ({})",
                            if s.fitted { "" } else { "*" },
                            r_squared_text(s.r_squared),
                            sig(s.rmse_kpa)
                        )
                    });
                    let _ = write!(out, " {cell:>24}");
                }
                out.push('\n');
            }
        }
        if let Some(inf) = &self.inflation {
            out.push_str(&inf.table());
        }
        out
    }
}

/// R² to four decimals; far below zero (a prediction that misses by
/// orders of magnitude) in scientific form, so a column stays readable.
pub fn r_squared_text(r2: f64) -> String {
    if r2 > -10.0 || !r2.is_finite() {
        format!("{r2:.4}")
    } else {
        format!("{r2:.2e}")
    }
}

/// Four significant digits, plain or scientific, whichever is shorter.
fn sig(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        format!("{v:.3}")
    } else if (1e-3..1e5).contains(&v.abs()) {
        let digits = (3 - v.abs().log10().floor() as i32).clamp(0, 8) as usize;
        format!("{v:.digits$}")
    } else {
        format!("{v:.3e}")
    }
}

/// Files `fit-skin` wrote.
#[derive(Clone, Debug)]
pub struct FitSkinOutput {
    /// The fits.
    pub report: FitSkinReport,
    /// The JSON result.
    pub json_path: PathBuf,
    /// The SVG plot.
    pub svg_path: PathBuf,
}

/// Reads every file of `files` (each one test per mode it holds).
pub fn read_tests(files: &[PathBuf]) -> Result<Vec<CouponTest>> {
    let mut tests = Vec::new();
    for f in files {
        tests.extend(read_file(f)?);
    }
    Ok(tests)
}

/// The output stem: the file's own for one file, `skin` for several.
pub fn output_stem(files: &[PathBuf]) -> String {
    match files {
        [one] => one
            .file_stem()
            .map_or_else(|| "skin".into(), |s| s.to_string_lossy().into_owned()),
        _ => "skin".into(),
    }
}

/// `host-sim fit-skin` for one file, every mode it holds fitted: writes
/// `<out_dir>/<stem>-fit.json` and `<out_dir>/<stem>-fit.svg` atomically.
pub fn fit_skin(csv: &Path, out_dir: &Path) -> Result<FitSkinOutput> {
    let files = [csv.to_path_buf()];
    let tests = read_tests(&files)?;
    let report = FitSkinReport::from_tests(&tests, None)?;
    write_report(report, &tests, &output_stem(&files), out_dir)
}

/// Writes `report` as `<out_dir>/<stem>-fit.json` and the plot of `tests`
/// and its fits as `<out_dir>/<stem>-fit.svg`, atomically.
pub fn write_report(
    report: FitSkinReport,
    tests: &[CouponTest],
    stem: &str,
    out_dir: &Path,
) -> Result<FitSkinOutput> {
    let json_path = out_dir.join(format!("{stem}-fit.json"));
    let svg_path = out_dir.join(format!("{stem}-fit.svg"));
    let mut json = serde_json::to_string_pretty(&report).context("serialising the fit")?;
    json.push('\n');
    write_atomic(&json_path, json.as_bytes())?;
    let svg = super::plot::render_svg(tests, &report.fits, report.inflation.as_ref())?;
    write_atomic(&svg_path, svg.as_bytes())?;
    Ok(FitSkinOutput {
        report,
        json_path,
        svg_path,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn significant_digit_formatting() {
        assert_eq!(sig(123.456), "123.5");
        assert_eq!(sig(0.012345), "0.01235");
        assert_eq!(sig(-4.0), "-4.000");
        assert_eq!(sig(1.5e-6), "1.500e-6");
        assert_eq!(sig(0.0), "0.000");
        assert_eq!(r_squared_text(0.89286), "0.8929");
        assert_eq!(r_squared_text(-5240.0082), "-5.24e3");
    }
}
