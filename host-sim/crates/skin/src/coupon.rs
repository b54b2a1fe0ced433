//! Reading skin tests (`shared/data-format.md`, "Skin tests"): a CSV with
//! an optional `mode` column (`uniaxial`, the default, `equibiaxial` or
//! `planar`), `strain` (engineering, in the loaded direction) and either
//! `cauchy_stress_kpa` or `nominal_stress_kpa`. A file may hold several
//! modes; it becomes one [`CouponTest`] per mode. Everything is converted
//! to nominal stress, the quantity the fitter works on: in all three
//! incompressible tests the loaded face's area is A0/λ, so σ = λ·P.

use std::fmt;
use std::path::{Path, PathBuf};

use datafile::{DataError, Table};
use serde::Serialize;

use super::StrainEnergy;

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

/// A homogeneous, incompressible test mode.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Mode {
    /// Uniaxial tension/compression: λ, λ^(−1/2), λ^(−1/2).
    Uniaxial,
    /// Equibiaxial tension: λ, λ, λ⁻² (the inflated tube's hoop/axial state
    /// is between this and planar).
    Equibiaxial,
    /// Planar tension (pure shear): λ, 1, 1/λ.
    Planar,
}

impl Mode {
    /// Every mode, in the order reports list them.
    pub const ALL: [Mode; 3] = [Mode::Uniaxial, Mode::Equibiaxial, Mode::Planar];

    /// The name in the `mode` column.
    pub fn name(self) -> &'static str {
        match self {
            Self::Uniaxial => "uniaxial",
            Self::Equibiaxial => "equibiaxial",
            Self::Planar => "planar",
        }
    }

    /// The mode named `text` (case and surrounding blanks ignored).
    pub fn parse(text: &str) -> Option<Mode> {
        let t = text.trim();
        Self::ALL
            .into_iter()
            .find(|m| m.name().eq_ignore_ascii_case(t))
    }

    /// Nominal stress (kPa) of `law` in this test at stretch `stretch`.
    pub fn nominal_kpa(self, law: &dyn StrainEnergy, stretch: f64) -> f64 {
        match self {
            Self::Uniaxial => law.uniaxial_nominal_kpa(stretch),
            Self::Equibiaxial => law.equibiaxial_nominal_kpa(stretch),
            Self::Planar => law.planar_nominal_kpa(stretch),
        }
    }
}

impl fmt::Display for Mode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Fewest rows accepted in one file: the smallest useful fit (one
/// coefficient) with standard errors needs two, and a file of fewer than
/// four rows is more likely a cut export than a test. Whether a law has
/// enough rows for its own coefficients is the fitter's check.
pub const MIN_ROWS: usize = 4;

/// One test mode of one file, converted to nominal stress.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CouponTest {
    /// Where it was read from (for messages and reports).
    pub source: PathBuf,
    /// The test mode.
    pub mode: Mode,
    /// Which stress the file reported.
    pub measured: StressMeasure,
    /// Engineering strain ε = λ − 1 of each row.
    pub strain: Vec<f64>,
    /// Nominal stress P of each row (kPa).
    pub nominal_stress_kpa: Vec<f64>,
    /// Line of each row in the file (1 = header).
    pub lines: Vec<u64>,
    /// Things the reader ignored or doubts (extra columns, a second stress
    /// column, a stress that falls while the strain rises), each naming
    /// the file and, where it applies, the line.
    pub warnings: Vec<String>,
}

impl CouponTest {
    /// Builds a test from strain and nominal stress (kPa) directly; rows
    /// are numbered as if read from a file with a header.
    pub fn from_nominal(
        source: impl Into<PathBuf>,
        mode: Mode,
        strain: Vec<f64>,
        nominal_stress_kpa: Vec<f64>,
    ) -> Self {
        let lines = (2..).take(strain.len()).collect();
        Self {
            source: source.into(),
            mode,
            measured: StressMeasure::Nominal,
            strain,
            nominal_stress_kpa,
            lines,
            warnings: Vec::new(),
        }
    }

    /// Reads a file that holds exactly one mode.
    pub fn read(path: &Path) -> Result<Self, DataError> {
        let mut tests = read_file(path)?;
        match tests.len() {
            1 => Ok(tests.remove(0)),
            _ => Err(DataError::new(
                path.display().to_string(),
                format!(
                    "holds {} modes ({}); read it with `read_file`",
                    tests.len(),
                    tests
                        .iter()
                        .map(|t| t.mode.name())
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            )
            .with_key("mode")),
        }
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

    /// `file (lines a–b)`, for messages.
    pub fn place(&self) -> String {
        let (a, b) = (
            self.lines.iter().min().copied().unwrap_or(0),
            self.lines.iter().max().copied().unwrap_or(0),
        );
        format!("{} ({}, lines {a}–{b})", self.source.display(), self.mode)
    }
}

/// Reads a skin-test file: one [`CouponTest`] per mode, in the order the
/// modes first appear.
pub fn read_file(path: &Path) -> Result<Vec<CouponTest>, DataError> {
    let file = std::fs::File::open(path)
        .map_err(|e| DataError::new(path.display().to_string(), e.to_string()))?;
    from_reader(path, file)
}

/// Reads a skin-test file from any reader; `source` names it in messages.
pub fn from_reader(
    source: &Path,
    mut reader: impl std::io::Read,
) -> Result<Vec<CouponTest>, DataError> {
    let name = source.display().to_string();
    let mut bytes = Vec::new();
    reader
        .read_to_end(&mut bytes)
        .map_err(|e| DataError::new(&name, e.to_string()))?;
    let mut table = Table::parse(&name, &bytes)?;
    let strain_col = table.require("strain")?;
    let mode_col = table.column("mode");
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
        let known = i == strain_col
            || i == stress_col
            || Some(i) == mode_col
            || h == StressMeasure::Cauchy.column();
        if !known {
            warnings.push(format!("{name}: ignoring unknown column `{h}`"));
        }
    }

    let mut tests: Vec<CouponTest> = Vec::new();
    let mut rows = 0;
    for row in table.rows() {
        let row = row?;
        let mode = match mode_col {
            None => Mode::Uniaxial,
            Some(c) => Mode::parse(row.get(c)).ok_or_else(|| {
                row.error_in(
                    c,
                    format!(
                        "`{}` is not a test mode (uniaxial, equibiaxial or planar)",
                        row.get(c).trim()
                    ),
                )
            })?,
        };
        let e = row.number(strain_col)?;
        if e <= -1.0 {
            return Err(row.error_in(
                strain_col,
                format!("{e} would mean a stretch λ = 1 + ε ≤ 0"),
            ));
        }
        let s = row.number(stress_col)?;
        let nominal = match measured {
            StressMeasure::Nominal => s,
            // Incompressible, every mode: the loaded face is A0/λ, σ = λ·P.
            StressMeasure::Cauchy => s / (1.0 + e),
        };
        let test = match tests.iter_mut().position(|t| t.mode == mode) {
            Some(i) => &mut tests[i],
            None => {
                tests.push(CouponTest {
                    source: source.to_path_buf(),
                    mode,
                    measured,
                    strain: Vec::new(),
                    nominal_stress_kpa: Vec::new(),
                    lines: Vec::new(),
                    warnings: Vec::new(),
                });
                let last = tests.len() - 1;
                &mut tests[last]
            }
        };
        test.strain.push(e);
        test.nominal_stress_kpa.push(nominal);
        test.lines.push(row.line());
        rows += 1;
    }
    if rows < MIN_ROWS {
        return Err(DataError::new(
            name,
            format!("{rows} data rows; at least {MIN_ROWS} are needed"),
        ));
    }
    for (k, t) in tests.iter_mut().enumerate() {
        if k == 0 {
            t.warnings = warnings.clone();
        }
        t.warnings.extend(monotonicity_warnings(&name, t));
    }
    Ok(tests)
}

/// A Drucker-stable law's nominal stress rises with stretch in every mode
/// (in tension, and falls further in compression): where the data, taken
/// in order of strain, fall while the strain rises, no such law can follow
/// them (unloading rows mixed in, a slipping grip). One warning per fall,
/// naming both lines.
fn monotonicity_warnings(name: &str, t: &CouponTest) -> Vec<String> {
    let mut order: Vec<usize> = (0..t.strain.len()).collect();
    order.sort_by(|&a, &b| t.strain[a].total_cmp(&t.strain[b]).then(a.cmp(&b)));
    order
        .windows(2)
        .filter(|w| {
            t.strain[w[1]] > t.strain[w[0]]
                && t.nominal_stress_kpa[w[1]] < t.nominal_stress_kpa[w[0]]
        })
        .map(|w| {
            format!(
                "{name}:{}: {} nominal stress falls to {} kPa from {} kPa at line {} while the strain rises ({} → {}); no Drucker-stable law can follow this (unloading rows mixed in?)",
                t.lines[w[1]],
                t.mode,
                t.nominal_stress_kpa[w[1]],
                t.nominal_stress_kpa[w[0]],
                t.lines[w[0]],
                t.strain[w[0]],
                t.strain[w[1]],
            )
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<CouponTest, DataError> {
        let mut t = from_reader(Path::new("t.csv"), text.as_bytes())?;
        assert_eq!(t.len(), 1);
        Ok(t.remove(0))
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
        let e = CouponTest::read(Path::new("/nonexistent/test.csv")).unwrap_err();
        assert_eq!(place(&e), ("/nonexistent/test.csv", None, None));
    }

    #[test]
    fn modes_are_split_and_an_unknown_mode_is_named() {
        let t = from_reader(
            Path::new("m.csv"),
            "mode,strain,nominal_stress_kpa\nplanar,0,0\nequibiaxial,0.5,3\nPlanar,1,2\nequibiaxial,1,5\n"
                .as_bytes(),
        )
        .unwrap();
        assert_eq!(t.len(), 2);
        assert_eq!((t[0].mode, t[0].lines.clone()), (Mode::Planar, vec![2, 4]));
        assert_eq!(
            (t[1].mode, t[1].strain.clone()),
            (Mode::Equibiaxial, vec![0.5, 1.0])
        );
        // Without a `mode` column every row is uniaxial.
        assert_eq!(
            parse("strain,nominal_stress_kpa\n0,0\n1,1\n2,2\n3,3\n")
                .unwrap()
                .mode,
            Mode::Uniaxial
        );
        let e = from_reader(
            Path::new("m.csv"),
            "mode,strain,nominal_stress_kpa\nuniaxial,0,0\nbiaxial,1,1\n".as_bytes(),
        )
        .unwrap_err();
        assert_eq!(place(&e), ("m.csv", Some(3), Some("mode")));
        assert!(
            e.to_string().contains("`biaxial` is not a test mode"),
            "{e}"
        );
        // Several modes cannot be read as one test.
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("two.csv");
        std::fs::write(
            &p,
            "mode,strain,nominal_stress_kpa\nplanar,0,0\nplanar,1,1\nuniaxial,1,1\nuniaxial,2,2\n",
        )
        .unwrap();
        assert_eq!(
            CouponTest::read(&p).unwrap_err().key.as_deref(),
            Some("mode")
        );
    }

    #[test]
    fn a_stress_that_falls_while_the_strain_rises_is_warned_about_with_its_lines() {
        // Row order does not matter; the fall from line 3 to line 2 does.
        let t = parse("strain,nominal_stress_kpa\n1.0,8\n0.5,9\n0,0\n2,20\n").unwrap();
        assert_eq!(t.warnings.len(), 1, "{:?}", t.warnings);
        assert!(
            t.warnings[0].starts_with(
                "t.csv:2: uniaxial nominal stress falls to 8 kPa from 9 kPa at line 3"
            ),
            "{}",
            t.warnings[0]
        );
        let t = parse("strain,nominal_stress_kpa\n0,0\n0.5,9\n1,12\n2,20\n").unwrap();
        assert!(t.warnings.is_empty());
    }

    #[test]
    fn cauchy_input_is_converted_in_every_mode() {
        let t = from_reader(
            Path::new("c.csv"),
            "mode,strain,cauchy_stress_kpa\nequibiaxial,0,0\nequibiaxial,1,10\nplanar,1,10\nplanar,3,80\n".as_bytes(),
        )
        .unwrap();
        assert_eq!(t[0].nominal_stress_kpa, vec![0.0, 5.0]);
        assert_eq!(t[1].nominal_stress_kpa, vec![5.0, 20.0]);
    }
}
