//! Reading a uniaxial tensile test (`shared/data-format.md`, "Uniaxial skin
//! tests"): a CSV with `strain` (engineering) and either
//! `cauchy_stress_kpa` or `nominal_stress_kpa`. Everything is converted to
//! nominal stress, the quantity the fitter works on: for an incompressible
//! uniaxial test σ = λ·P.

use std::path::{Path, PathBuf};

use datafile::{DataError, Table};
use serde::Serialize;

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
    pub fn read(path: &Path) -> Result<Self, DataError> {
        let file = std::fs::File::open(path)
            .map_err(|e| DataError::new(path.display().to_string(), e.to_string()))?;
        Self::from_reader(path, file)
    }

    /// Reads a test from any reader; `source` names it in messages.
    pub fn from_reader(source: &Path, mut reader: impl std::io::Read) -> Result<Self, DataError> {
        let name = source.display().to_string();
        let mut bytes = Vec::new();
        reader
            .read_to_end(&mut bytes)
            .map_err(|e| DataError::new(&name, e.to_string()))?;
        let mut table = Table::parse(&name, &bytes)?;
        let strain_col = table.require("strain")?;
        let mut warnings = Vec::new();
        let (measured, stress_col) = match (
            table.column(StressMeasure::Nominal.column()),
            table.column(StressMeasure::Cauchy.column()),
        ) {
            (Some(n), Some(_)) => {
                warnings.push(format!(
                    "{name}: both stress columns present; using `nominal_stress_kpa`, ignoring `cauchy_stress_kpa`"
                ));
                (StressMeasure::Nominal, n)
            }
            (Some(n), None) => (StressMeasure::Nominal, n),
            (None, Some(c)) => (StressMeasure::Cauchy, c),
            (None, None) => {
                return Err(table.header_error(format!(
                    "missing column `cauchy_stress_kpa` or `nominal_stress_kpa` (header: {})",
                    table.columns().join(", ")
                )))
            }
        };
        for (i, h) in table.columns().iter().enumerate() {
            let known = i == strain_col || i == stress_col || h == StressMeasure::Cauchy.column();
            if !known {
                warnings.push(format!("{name}: ignoring unknown column `{h}`"));
            }
        }

        let mut strain = Vec::new();
        let mut nominal_stress_kpa = Vec::new();
        for row in table.rows() {
            let row = row?;
            let e = row.number(strain_col)?;
            if e <= -1.0 {
                return Err(row.error_in(
                    strain_col,
                    format!("{e} would mean a stretch λ = 1 + ε ≤ 0"),
                ));
            }
            let s = row.number(stress_col)?;
            strain.push(e);
            nominal_stress_kpa.push(match measured {
                StressMeasure::Nominal => s,
                // Incompressible uniaxial: A = A0/λ, so σ = λ·P.
                StressMeasure::Cauchy => s / (1.0 + e),
            });
        }
        if strain.len() < MIN_ROWS {
            return Err(DataError::new(
                name,
                format!("{} data rows; at least {MIN_ROWS} are needed", strain.len()),
            ));
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

    fn parse(text: &str) -> Result<UniaxialTest, DataError> {
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

    /// (file, line, column) of an error.
    fn place(e: &DataError) -> (&str, Option<u64>, Option<&str>) {
        (e.file.as_str(), e.line, e.key.as_deref())
    }

    #[test]
    fn errors_name_file_line_and_column() {
        let e = parse("strain,nominal_stress_kpa\n0,0\n0.5,abc\n").unwrap_err();
        assert_eq!(
            e.to_string(),
            "t.csv:3: nominal_stress_kpa: `abc` is not a number"
        );
        assert_eq!(place(&e), ("t.csv", Some(3), Some("nominal_stress_kpa")));
        let e = parse("stress,nominal_stress_kpa\n0,0\n").unwrap_err();
        assert_eq!(place(&e), ("t.csv", Some(1), Some("strain")));
        assert_eq!(
            e.to_string(),
            "t.csv:1: strain: missing column (header: stress, nominal_stress_kpa)"
        );
        let e = parse("strain,stress\n0,0\n").unwrap_err();
        assert_eq!(place(&e), ("t.csv", Some(1), None));
        assert!(
            e.to_string()
                .starts_with("t.csv:1: missing column `cauchy_stress_kpa` or `nominal_stress_kpa`"),
            "{e}"
        );
        let e = parse("strain,nominal_stress_kpa\n0,0\n-1.5,2\n").unwrap_err();
        assert_eq!(place(&e), ("t.csv", Some(3), Some("strain")));
        assert!(e.to_string().starts_with("t.csv:3: strain: "), "{e}");
        let e = parse("strain,nominal_stress_kpa\n0,0\n1,inf\n").unwrap_err();
        assert_eq!(place(&e), ("t.csv", Some(3), Some("nominal_stress_kpa")));
        assert!(e.to_string().contains("not a finite number"), "{e}");
        let e = parse("strain,nominal_stress_kpa\n0,0\n1,2\n").unwrap_err();
        assert_eq!(place(&e), ("t.csv", None, None));
        assert_eq!(e.message, "2 data rows; at least 4 are needed");
        let e = parse("strain,nominal_stress_kpa\n0,0\n1,2,3\n").unwrap_err();
        assert_eq!(place(&e), ("t.csv", Some(3), None));
        assert_eq!(e.to_string(), "t.csv:3: 3 fields, but the header has 2");
    }

    #[test]
    fn spreadsheet_exports_read() {
        let t =
            parse("\u{feff}strain , nominal_stress_kpa\r\n0,0\r\n1, 1\r\n2,2\r\n3,3\r\n").unwrap();
        assert_eq!(t.strain, [0.0, 1.0, 2.0, 3.0]);
        assert_eq!(t.nominal_stress_kpa, [0.0, 1.0, 2.0, 3.0]);
        assert!(t.warnings.is_empty(), "{:?}", t.warnings);
    }

    #[test]
    fn a_missing_file_is_named() {
        let e = UniaxialTest::read(Path::new("/nonexistent/test.csv")).unwrap_err();
        assert_eq!(place(&e), ("/nonexistent/test.csv", None, None));
    }
}
