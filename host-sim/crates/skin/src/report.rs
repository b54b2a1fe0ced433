//! The `fit-skin` command's library side: read a uniaxial test, fit every
//! registered law, write `<stem>-fit.json` and `<stem>-fit.svg`, and format
//! the short table the CLI prints.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use serde::Serialize;

use super::fit::{fit_all, LawFit, SCAN_MAX_STRETCH, SCAN_MIN_STRETCH};
use super::uniaxial::{StressMeasure, UniaxialTest};
use datafile::write_atomic;

/// What was read, as recorded in the JSON.
#[derive(Clone, Debug, Serialize)]
pub struct InputSummary {
    /// The CSV file.
    pub file: PathBuf,
    /// Which stress the file reported (fits are always on nominal stress).
    pub measured: StressMeasure,
    /// Rows read.
    pub rows: usize,
    /// Largest engineering strain in the file.
    pub max_strain: f64,
    /// Largest nominal stress in the file (kPa).
    pub max_nominal_stress_kpa: f64,
    /// Reader warnings (ignored columns).
    pub warnings: Vec<String>,
}

/// Everything `fit-skin` computes; serialised as the JSON result.
#[derive(Clone, Debug, Serialize)]
pub struct FitSkinReport {
    /// The input.
    pub input: InputSummary,
    /// What is fitted.
    pub fitted_quantity: &'static str,
    /// Tension limit of the Drucker scan (stretch).
    pub scan_max_stretch: f64,
    /// Compression limit of the Drucker scan (stretch).
    pub scan_min_stretch: f64,
    /// One entry per registered law.
    pub fits: Vec<LawFit>,
}

impl FitSkinReport {
    /// Reads `csv` and fits every law.
    pub fn from_file(csv: &Path) -> Result<Self> {
        let test = UniaxialTest::read(csv)?;
        Self::from_test(&test)
    }

    /// Fits every law to an already-read test.
    pub fn from_test(test: &UniaxialTest) -> Result<Self> {
        let fits = fit_all(test).with_context(|| format!("fitting {}", test.source.display()))?;
        Ok(Self {
            input: InputSummary {
                file: test.source.clone(),
                measured: test.measured,
                rows: test.strain.len(),
                max_strain: test.strain.iter().copied().fold(f64::MIN, f64::max),
                max_nominal_stress_kpa: test
                    .nominal_stress_kpa
                    .iter()
                    .copied()
                    .fold(f64::MIN, f64::max),
                warnings: test.warnings.clone(),
            },
            fitted_quantity: "nominal stress (kPa), ordinary least squares",
            scan_max_stretch: SCAN_MAX_STRETCH,
            scan_min_stretch: SCAN_MIN_STRETCH,
            fits,
        })
    }

    /// The fit of the law named `law`, if it was fitted.
    pub fn fit(&self, law: &str) -> Option<&LawFit> {
        self.fits.iter().find(|f| f.law == law)
    }

    /// A short plain-text table: one line per law.
    pub fn table(&self) -> String {
        let mut out = String::new();
        let _ = writeln!(
            out,
            "{} ({} rows, {} stress, max strain {:.3}); fitted on nominal stress",
            self.input.file.display(),
            self.input.rows,
            match self.input.measured {
                StressMeasure::Cauchy => "Cauchy",
                StressMeasure::Nominal => "nominal",
            },
            self.input.max_strain
        );
        let _ = writeln!(
            out,
            "{:<14} {:>8} {:>10}  {:<44} Drucker (dσ/dε > 0)",
            "law", "R²", "RMSE kPa", "coefficients kPa (± standard error)"
        );
        for f in &self.fits {
            let coeffs: Vec<String> = f
                .parameter_names
                .iter()
                .zip(f.parameters_kpa.iter().zip(&f.standard_errors_kpa))
                .map(|(n, (v, se))| {
                    format!("{}={} ± {}", n.trim_end_matches("_kpa"), sig(*v), sig(*se))
                })
                .collect();
            let s = &f.stability;
            let mut stab = String::from(if s.stable_over_data {
                "stable over data"
            } else {
                "UNSTABLE within data"
            });
            match s.first_unstable_stretch_tension {
                Some(l) => {
                    let _ = write!(stab, "; tension lost at λ={l:.3}");
                }
                None => {
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
            let _ = writeln!(
                out,
                "{:<14} {:>8.5} {:>10.3}  {:<44} {}",
                f.law,
                f.r_squared,
                f.rmse_kpa,
                coeffs.join(", "),
                stab
            );
        }
        out
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

/// `host-sim fit-skin`: reads `csv`, fits every law, writes
/// `<out_dir>/<stem>-fit.json` and `<out_dir>/<stem>-fit.svg` atomically.
pub fn fit_skin(csv: &Path, out_dir: &Path) -> Result<FitSkinOutput> {
    let test = UniaxialTest::read(csv)?;
    let report = FitSkinReport::from_test(&test)?;
    let stem = csv
        .file_stem()
        .map_or_else(|| "uniaxial".into(), |s| s.to_string_lossy().into_owned());
    let json_path = out_dir.join(format!("{stem}-fit.json"));
    let svg_path = out_dir.join(format!("{stem}-fit.svg"));
    let mut json = serde_json::to_string_pretty(&report).context("serialising the fit")?;
    json.push('\n');
    write_atomic(&json_path, json.as_bytes())?;
    let svg = super::plot::render_svg(&test, &report.fits)?;
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
    }
}
