//! Reading a uniaxial tensile test (`shared/data-format.md`, "Uniaxial skin
//! tests"): a CSV with `strain` (engineering) and either
//! `cauchy_stress_kpa` or `nominal_stress_kpa`. Everything is converted to
//! nominal stress, the quantity the fitter works on: for an incompressible
//! uniaxial test σ = λ·P.

use std::path::{Path, PathBuf};

use serde::Serialize;
use thiserror::Error;

/// Which stress a test file reported.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum StressMeasure {
    /// True stress, force over the current area (`cauchy_stress_kpa`).
    Cauchy,
    /// Engineering stress, force over the initial area (`nominal_stress_kpa`).
    Nominal,
}

impl StressMeasure {
    /// The CSV column that carries this measure.
    pub fn column(self) -> &'static str {
        match self {
            Self::Cauchy => "cauchy_stress_kpa",
            Self::Nominal => "nominal_stress_kpa",
        }
    }
}

/// A bad uniaxial file; every variant names the file, and the line and
/// column where there is one.
#[derive(Debug, Error)]
pub enum UniaxialError {
    /// The file could not be opened or read.
    #[error("{file}: {source}")]
    Io {
        /// The file.
        file: PathBuf,
        /// What the system said.
        source: std::io::Error,
    },
    /// The CSV itself is malformed (quoting, ragged rows, encoding).
    #[error("{file}:{line}: {message}")]
    Csv {
        /// The file.
        file: PathBuf,
        /// 1-based line number.
        line: u64,
        /// What the CSV reader said.
        message: String,
    },
    /// A required column is missing from the header.
    #[error("{file}:1: missing column `{column}` (header: {header})")]
    MissingColumn {
        /// The file.
        file: PathBuf,
        /// The column that was expected.
        column: &'static str,
        /// The header that was found.
        header: String,
    },
    /// A cell is not a number, not finite, or out of range.
    #[error("{file}:{line}: column `{column}`: {message}")]
    BadValue {
        /// The file.
        file: PathBuf,
        /// 1-based line number.
        line: u64,
        /// The column.
        column: &'static str,
        /// What is wrong with the value.
        message: String,
    },
    /// Fewer rows than any fit needs.
    #[error("{file}: {rows} data rows; at least {needed} are needed")]
    TooFewRows {
        /// The file.
        file: PathBuf,
        /// Rows found.
        rows: usize,
        /// Rows needed.
        needed: usize,
    },
}

/// Fewest rows accepted: the largest law has three coefficients, and its
/// standard errors need at least one degree of freedom left.
pub const MIN_ROWS: usize = 4;

/// One uniaxial test, converted to nominal stress.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct UniaxialTest {
    /// Where it was read from (for messages and reports).
    pub source: PathBuf,
    /// Which stress the file reported.
    pub measured: StressMeasure,
    /// Engineering strain ε = λ − 1 of each row.
    pub strain: Vec<f64>,
    /// Nominal stress P of each row (kPa).
    pub nominal_stress_kpa: Vec<f64>,
    /// Things the reader ignored (extra columns, a second stress column).
    pub warnings: Vec<String>,
}

impl UniaxialTest {
    /// Builds a test from strain and nominal stress (kPa) directly.
    pub fn from_nominal(
        source: impl Into<PathBuf>,
        strain: Vec<f64>,
        nominal_stress_kpa: Vec<f64>,
    ) -> Self {
        Self {
            source: source.into(),
            measured: StressMeasure::Nominal,
            strain,
            nominal_stress_kpa,
            warnings: Vec::new(),
        }
    }

    /// Reads a test file.
    pub fn read(path: &Path) -> Result<Self, UniaxialError> {
        let file = std::fs::File::open(path).map_err(|source| UniaxialError::Io {
            file: path.to_path_buf(),
            source,
        })?;
        Self::from_reader(path, file)
    }

    /// Reads a test from any reader; `source` names it in messages.
    pub fn from_reader(source: &Path, reader: impl std::io::Read) -> Result<Self, UniaxialError> {
        let file = || source.to_path_buf();
        let csv_err = |e: csv::Error| UniaxialError::Csv {
            file: file(),
            line: e.position().map_or(1, |p| p.line()),
            message: e.to_string(),
        };
        let mut rdr = csv::ReaderBuilder::new()
            .trim(csv::Trim::All)
            .from_reader(reader);
        let header = rdr.headers().map_err(csv_err)?.clone();
        let find = |name: &str| header.iter().position(|h| h == name);
        let header_text = || header.iter().collect::<Vec<_>>().join(",");
        let strain_col = find("strain").ok_or_else(|| UniaxialError::MissingColumn {
            file: file(),
            column: "strain",
            header: header_text(),
        })?;
        let mut warnings = Vec::new();
        let (measured, stress_col) = match (
            find(StressMeasure::Nominal.column()),
            find(StressMeasure::Cauchy.column()),
        ) {
            (Some(n), Some(_)) => {
                warnings.push(format!(
                    "{}: both stress columns present; using `nominal_stress_kpa`, ignoring `cauchy_stress_kpa`",
                    source.display()
                ));
                (StressMeasure::Nominal, n)
            }
            (Some(n), None) => (StressMeasure::Nominal, n),
            (None, Some(c)) => (StressMeasure::Cauchy, c),
            (None, None) => {
                return Err(UniaxialError::MissingColumn {
                    file: file(),
                    column: "cauchy_stress_kpa` or `nominal_stress_kpa",
                    header: header_text(),
                })
            }
        };
        for (i, h) in header.iter().enumerate() {
            let known = i == strain_col || i == stress_col || h == StressMeasure::Cauchy.column();
            if !known {
                warnings.push(format!(
                    "{}: ignoring unknown column `{h}`",
                    source.display()
                ));
            }
        }

        let mut strain = Vec::new();
        let mut nominal_stress_kpa = Vec::new();
        for record in rdr.records() {
            let record = record.map_err(csv_err)?;
            let line = record.position().map_or(0, |p| p.line());
            let cell = |col: usize, column: &'static str| -> Result<f64, UniaxialError> {
                let bad = |message: String| UniaxialError::BadValue {
                    file: file(),
                    line,
                    column,
                    message,
                };
                let text = record.get(col).unwrap_or("");
                let v: f64 = text
                    .parse()
                    .map_err(|_| bad(format!("`{text}` is not a number")))?;
                if !v.is_finite() {
                    return Err(bad(format!("`{text}` is not finite")));
                }
                Ok(v)
            };
            let e = cell(strain_col, "strain")?;
            if e <= -1.0 {
                return Err(UniaxialError::BadValue {
                    file: file(),
                    line,
                    column: "strain",
                    message: format!("{e} would mean a stretch λ = 1 + ε ≤ 0"),
                });
            }
            let s = cell(stress_col, measured.column())?;
            strain.push(e);
            nominal_stress_kpa.push(match measured {
                StressMeasure::Nominal => s,
                // Incompressible uniaxial: A = A0/λ, so σ = λ·P.
                StressMeasure::Cauchy => s / (1.0 + e),
            });
        }
        if strain.len() < MIN_ROWS {
            return Err(UniaxialError::TooFewRows {
                file: file(),
                rows: strain.len(),
                needed: MIN_ROWS,
            });
        }
        Ok(Self {
            source: source.to_path_buf(),
            measured,
            strain,
            nominal_stress_kpa,
            warnings,
        })
    }

    /// Stretch λ = 1 + ε of each row.
    pub fn stretch(&self) -> impl Iterator<Item = f64> + '_ {
        self.strain.iter().map(|e| 1.0 + e)
    }

    /// Cauchy stress σ = λ·P of each row (kPa).
    pub fn cauchy_stress_kpa(&self) -> Vec<f64> {
        self.stretch()
            .zip(&self.nominal_stress_kpa)
            .map(|(l, p)| l * p)
            .collect()
    }

    /// Smallest and largest stretch in the test.
    pub fn stretch_range(&self) -> (f64, f64) {
        self.stretch()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), l| {
                (lo.min(l), hi.max(l))
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<UniaxialTest, UniaxialError> {
        UniaxialTest::from_reader(Path::new("t.csv"), text.as_bytes())
    }

    #[test]
    fn cauchy_input_is_converted_to_nominal() {
        let t = parse("strain,cauchy_stress_kpa\n0,0\n1,10\n2,30\n3,80\n").unwrap();
        assert_eq!(t.measured, StressMeasure::Cauchy);
        assert_eq!(t.nominal_stress_kpa, vec![0.0, 5.0, 10.0, 20.0]);
        assert_eq!(t.cauchy_stress_kpa(), vec![0.0, 10.0, 30.0, 80.0]);
        assert!(t.warnings.is_empty());
    }

    #[test]
    fn extra_columns_are_warned_about_not_fatal() {
        let t =
            parse("strain,nominal_stress_kpa,temp_c\n0,0,20\n1,1,20\n2,2,20\n3,3,20\n").unwrap();
        assert_eq!(t.warnings.len(), 1);
        assert!(t.warnings[0].contains("temp_c"));
    }

    #[test]
    fn errors_name_file_line_and_column() {
        let e = parse("strain,nominal_stress_kpa\n0,0\n0.5,abc\n").unwrap_err();
        assert_eq!(
            e.to_string(),
            "t.csv:3: column `nominal_stress_kpa`: `abc` is not a number"
        );
        let e = parse("strain,stress\n0,0\n").unwrap_err();
        assert!(
            e.to_string()
                .starts_with("t.csv:1: missing column `cauchy_stress_kpa` or `nominal_stress_kpa`"),
            "{e}"
        );
        let e = parse("strain,nominal_stress_kpa\n0,0\n-1.5,2\n").unwrap_err();
        assert!(e.to_string().starts_with("t.csv:3: column `strain`"), "{e}");
        let e = parse("strain,nominal_stress_kpa\n0,0\n1,inf\n").unwrap_err();
        assert!(e.to_string().contains("not finite"), "{e}");
        let e = parse("strain,nominal_stress_kpa\n0,0\n1,2\n").unwrap_err();
        assert!(
            matches!(e, UniaxialError::TooFewRows { rows: 2, .. }),
            "{e}"
        );
        let e = parse("strain,nominal_stress_kpa\n0,0\n1,2,3\n").unwrap_err();
        assert!(e.to_string().starts_with("t.csv:3:"), "{e}");
    }
}
