//! The sand law the firmware tables use: p_e(D, h) from the FEM–DEM
//! solver's stored results ([`DATA_PATH`], written by `host-sim
//! solver-sand`: the burrow crate's `solver_sand`).
//!
//! The file holds, per solver depth, p_e binned over the outer diameter
//! (already smoothed: each row is the mean of the solver's samples in one
//! diameter bin). It is read as a lateral coefficient K(D) = p_e/σ'v per
//! stored depth, with σ'v = γ'·h from the buoyant unit weight γ' the file
//! itself states (the solver's, so K is the solver's own ratio). On the
//! loading branch:
//!
//! - K is made non-decreasing in D per depth by a running max (see
//!   [`DepthCurve::coefficients`] for why);
//! - K is linear in D between stored rows and held at the end rows' values
//!   outside a depth's diameter range;
//! - K is linear in h between stored depths and held at the nearest stored
//!   depth's K outside their range, so p_e ∝ h there, as both the paper's
//!   balloon table and the solver show.
//!
//! How a cycle starts and how the sand unloads is the shared rule of
//! [`super::Unloading`]; the solver has only loaded so far, so its slope
//! and floor are the balloon-calibrated parametric law's.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::Context;
use datafile::{comment_lines, DataError, Table};
use serde::Serialize;

use super::{ParametricSand, SandHistory, SandLaw, SandParams, Unloading};

/// Where the solver's results are stored, relative to the repository root.
pub const DATA_PATH: &str = "host-sim/data/sand/solver-pe.csv";

/// The header key (in a `# key = value` comment line) of the buoyant unit
/// weight γ' the solver used, in kPa per mm of depth.
pub const UNIT_WEIGHT_KEY: &str = "buoyant_unit_weight_kpa_per_mm";

/// Header key of the actuator's rest diameter D0 (mm), written by
/// `solver-sand --rig`; absent: the paper's 18.7 mm.
pub const INITIAL_DIAMETER_KEY: &str = "initial_diameter_mm";

/// Header key of the skin's law the solver runs used
/// (the skin crate's `SkinLaw::describe` of the law as run, its scale
/// applied):
/// the tables add the file's sand share only to that skin.
pub const SKIN_LAW_KEY: &str = "skin_law";

/// The data columns, in the order `host-sim solver-sand` writes them.
pub const COLUMNS: [&str; 4] = ["depth_mm", "diameter_mm", "p_e_kpa", "samples"];

/// One stored depth: the binned solver samples and the coefficient read
/// from them.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DepthCurve {
    /// Depth of the zone's axis h (mm).
    pub depth_mm: f64,
    /// Bin diameters D (mm), strictly increasing.
    pub diameters_mm: Vec<f64>,
    /// Stored p_e (kPa), as in the file.
    pub pressures_kpa: Vec<f64>,
    /// Solver samples in each bin.
    pub samples: Vec<u64>,
    /// K = p_e/σ'v at each row, made non-decreasing by a running max: on
    /// the loading branch of a cavity expansion the sand's resistance rises
    /// to a plateau and does not fall, so a dip in the binned DEM output is
    /// the noise of the few grains touching the skin; and the firmware
    /// inverts p_i(D), which must strictly increase, so a dip kept here
    /// would make two diameters read the same pressure. (The max biases
    /// the curve up by about the noise where it plateaus.)
    pub coefficients: Vec<f64>,
}

impl DepthCurve {
    /// K at `diameter_mm`: linear between rows, held outside them.
    pub fn coefficient_at(&self, diameter_mm: f64) -> f64 {
        let (xs, ys) = (&self.diameters_mm, &self.coefficients);
        // At least two rows (the reader refuses fewer).
        let i = xs.partition_point(|&x| x <= diameter_mm);
        match (
            i.checked_sub(1).and_then(|j| xs.get(j).zip(ys.get(j))),
            xs.get(i).zip(ys.get(i)),
        ) {
            (Some((x0, y0)), Some((x1, y1))) => y0 + (y1 - y0) * (diameter_mm - x0) / (x1 - x0),
            (Some((_, y)), None) | (None, Some((_, y))) => *y,
            (None, None) => f64::NAN,
        }
    }
}

/// p_e(D, h) from the FEM–DEM solver's stored results.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SolverSand {
    curves: Vec<DepthCurve>,
    unit_weight_kpa_per_mm: f64,
    settings: Vec<(String, String)>,
    source: String,
    crc32: u32,
    initial_diameter_mm: f64,
    at_rest_coefficient: f64,
    unloading: Unloading,
}

impl SolverSand {
    /// The committed results ([`DATA_PATH`]), compiled in: what the
    /// emulator's plant and the workbench's baseline are fitted to (see
    /// [`super::ParametricSand::fitted_to_solver`]), so they push back as
    /// the firmware table (made from the same file) expects.
    pub fn committed() -> Result<Self, DataError> {
        let mut sand = Self::parse(include_str!("../../../data/sand/solver-pe.csv"), DATA_PATH)?;
        sand.source = DATA_PATH.to_string();
        Ok(sand)
    }

    /// Reads the stored results under the repository root `repo_root`
    /// ([`DATA_PATH`]); the description names the file by that relative
    /// path, so it does not depend on where the repository is checked out.
    pub fn from_repo(repo_root: &Path) -> anyhow::Result<Self> {
        let mut sand = Self::load(&repo_root.join(DATA_PATH))?;
        sand.source = DATA_PATH.to_string();
        Ok(sand)
    }

    /// Reads the solver results file at `path`.
    pub fn load(path: &Path) -> anyhow::Result<Self> {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("reading solver sand data {}", path.display()))?;
        Ok(Self::parse(&text, &path.display().to_string())?)
    }

    /// Parses solver results `text`; `file` names it in errors and in the
    /// description.
    pub fn parse(text: &str, file: &str) -> Result<Self, DataError> {
        let err = |line: u64, key: &str, message: String| {
            DataError::new(file, message).with_line(line).with_key(key)
        };
        // Settings: `# key = value` comment lines.
        let mut settings = Vec::new();
        let mut unit_weight = None;
        let mut initial_diameter = None;
        for (line_no, comment) in comment_lines(text) {
            let Some((key, value)) = comment.split_once('=') else {
                continue;
            };
            let (key, value) = (key.trim(), value.trim());
            // Only `name = value` with a plain name is a setting; prose
            // comments may contain '=' too.
            let plain = |c: char| c.is_ascii_alphanumeric() || c == '_';
            if key.is_empty() || !key.chars().all(plain) {
                continue;
            }
            let positive = || -> Result<f64, DataError> {
                let v: f64 = value
                    .parse()
                    .map_err(|_| err(line_no, key, format!("`{value}` is not a number")))?;
                if !(v.is_finite() && v > 0.0) {
                    return Err(err(
                        line_no,
                        key,
                        format!("{value} is not a positive finite number"),
                    ));
                }
                Ok(v)
            };
            if key == UNIT_WEIGHT_KEY {
                unit_weight = Some(positive()?);
            } else if key == INITIAL_DIAMETER_KEY {
                // Files of another actuator (`solver-sand --rig`) say its D0.
                initial_diameter = Some(positive()?);
                settings.push((key.to_string(), value.to_string()));
            } else {
                settings.push((key.to_string(), value.to_string()));
            }
        }

        let mut table = Table::parse_with_comments(file, text.as_bytes())?;
        let header_line = table.header_line();
        let mut index = [0usize; 4];
        for (slot, name) in index.iter_mut().zip(COLUMNS) {
            *slot = table.require(name)?;
        }
        let Some(unit_weight) = unit_weight else {
            return Err(err(
                header_line,
                UNIT_WEIGHT_KEY,
                format!("missing header line `# {UNIT_WEIGHT_KEY} = <value>` (the solver's γ', needed for K = p_e/σ'v)"),
            ));
        };

        // Rows, grouped by depth (with the line of each group's first row).
        let mut groups: Vec<(u64, DepthCurve)> = Vec::new();
        for row in table.rows() {
            let row = row?;
            let depth_mm = row.number(index[0])?;
            let diameter_mm = row.number(index[1])?;
            let p_e_kpa = row.number(index[2])?;
            let raw = row.get(index[3]);
            let samples: u64 = raw.parse().map_err(|_| {
                row.error(
                    COLUMNS[3],
                    format!("`{raw}` is not a whole number of samples"),
                )
            })?;
            if depth_mm <= 0.0 {
                return Err(row.error(
                    COLUMNS[0],
                    format!("depth {depth_mm} mm is not below the surface"),
                ));
            }
            if diameter_mm <= 0.0 {
                return Err(row.error(
                    COLUMNS[1],
                    format!("diameter {diameter_mm} mm is not positive"),
                ));
            }
            if p_e_kpa < 0.0 {
                return Err(row.error(
                    COLUMNS[2],
                    format!("negative pressure {p_e_kpa} kPa (sand cannot pull on the skin)"),
                ));
            }
            if samples == 0 {
                return Err(row.error(COLUMNS[3], "a bin with no samples (such bins are left out)"));
            }
            match groups.last_mut() {
                Some((_, curve)) if curve.depth_mm == depth_mm => {
                    let last = curve
                        .diameters_mm
                        .last()
                        .copied()
                        .unwrap_or(f64::NEG_INFINITY);
                    if diameter_mm <= last {
                        return Err(row.error(
                            COLUMNS[1],
                            format!("{diameter_mm} mm does not increase on the previous row's {last} mm at depth {depth_mm} mm"),
                        ));
                    }
                    curve.diameters_mm.push(diameter_mm);
                    curve.pressures_kpa.push(p_e_kpa);
                    curve.samples.push(samples);
                }
                previous => {
                    if let Some((_, curve)) = previous {
                        if depth_mm < curve.depth_mm {
                            return Err(row.error(
                                COLUMNS[0],
                                format!("depth {depth_mm} mm after {} mm: rows must come in increasing depth, each depth's rows together", curve.depth_mm),
                            ));
                        }
                    }
                    groups.push((
                        row.line(),
                        DepthCurve {
                            depth_mm,
                            diameters_mm: vec![diameter_mm],
                            pressures_kpa: vec![p_e_kpa],
                            samples: vec![samples],
                            coefficients: Vec::new(),
                        },
                    ));
                }
            }
        }
        if groups.is_empty() {
            return Err(err(
                header_line,
                COLUMNS[0],
                "no depths: the file has no data rows".into(),
            ));
        }
        let mut curves = Vec::with_capacity(groups.len());
        for (first_line, mut curve) in groups {
            if curve.diameters_mm.len() < 2 {
                return Err(err(
                    first_line,
                    COLUMNS[0],
                    format!(
                        "depth {} mm has {} row(s); at least 2 are needed to interpolate in D",
                        curve.depth_mm,
                        curve.diameters_mm.len()
                    ),
                ));
            }
            let sigma_v = unit_weight * curve.depth_mm;
            let mut running = f64::NEG_INFINITY;
            curve.coefficients = curve
                .pressures_kpa
                .iter()
                .map(|p| {
                    running = running.max(p / sigma_v);
                    running
                })
                .collect();
            curves.push(curve);
        }

        // Cycles start where the parametric law's do, at the zone's rest
        // diameter D0; K0 there is the stored depths' mean (a history does
        // not know its depth; loading at D ≥ D0 reads the depth's own K).
        let d0 = initial_diameter.unwrap_or(SandParams::paper_uncalibrated().initial_diameter_mm);
        let at_rest_coefficient =
            curves.iter().map(|c| c.coefficient_at(d0)).sum::<f64>() / curves.len() as f64;
        Ok(Self {
            curves,
            unit_weight_kpa_per_mm: unit_weight,
            settings,
            source: file.to_string(),
            crc32: urechis::table::CHECKSUM_ALGORITHM.checksum(text.as_bytes()),
            initial_diameter_mm: d0,
            at_rest_coefficient,
            unloading: ParametricSand::calibrated_to_balloon().unloading(),
        })
    }

    /// Rest outer diameter of the actuator the runs were made with, D0 (mm):
    /// the file's `initial_diameter_mm`, else the paper's 18.7 mm.
    pub fn initial_diameter_mm(&self) -> f64 {
        self.initial_diameter_mm
    }

    /// The skin's law the runs used ([`SKIN_LAW_KEY`]), as the file
    /// states it; `None` for a file that does not say.
    pub fn skin_law(&self) -> Option<&str> {
        self.settings
            .iter()
            .find(|(k, _)| k == SKIN_LAW_KEY)
            .map(|(_, v)| v.as_str())
    }

    /// The stored depths, in increasing depth.
    pub fn curves(&self) -> &[DepthCurve] {
        &self.curves
    }

    /// The buoyant unit weight γ' the file states (kPa/mm).
    pub fn unit_weight_kpa_per_mm(&self) -> f64 {
        self.unit_weight_kpa_per_mm
    }

    /// The file as it is named in errors and in the description.
    pub fn source(&self) -> &str {
        &self.source
    }

    /// CRC-32 (the firmware table's algorithm) of the file's bytes.
    pub fn crc32(&self) -> u32 {
        self.crc32
    }

    /// The unloading rule (shared with the parametric law).
    pub fn unloading(&self) -> Unloading {
        self.unloading
    }

    /// Vertical effective stress σ'v = γ'·h (kPa) at `depth_mm`, with the
    /// file's γ'.
    pub fn vertical_effective_stress_kpa(&self, depth_mm: f64) -> f64 {
        self.unit_weight_kpa_per_mm * depth_mm.max(0.0)
    }

    /// K on the loading branch at `diameter_mm` and `depth_mm`: linear in
    /// D and h between stored points, held outside them.
    pub fn loading_coefficient(&self, diameter_mm: f64, depth_mm: f64) -> f64 {
        let above = self.curves.partition_point(|c| c.depth_mm <= depth_mm);
        let lower = above.checked_sub(1).and_then(|j| self.curves.get(j));
        match (lower, self.curves.get(above)) {
            (Some(lo), Some(hi)) => {
                let t = (depth_mm - lo.depth_mm) / (hi.depth_mm - lo.depth_mm);
                let (k0, k1) = (
                    lo.coefficient_at(diameter_mm),
                    hi.coefficient_at(diameter_mm),
                );
                k0 + t * (k1 - k0)
            }
            (Some(c), None) | (None, Some(c)) => c.coefficient_at(diameter_mm),
            (None, None) => f64::NAN,
        }
    }
}

impl SandLaw for SolverSand {
    fn fresh_cycle(&self) -> SandHistory {
        SandHistory::at_rest(self.initial_diameter_mm, self.at_rest_coefficient)
    }

    fn external_pressure_kpa(
        &self,
        history: &mut SandHistory,
        diameter_mm: f64,
        depth_mm: f64,
    ) -> f64 {
        let k = self.unloading.coefficient(history, diameter_mm, |d| {
            self.loading_coefficient(d, depth_mm)
        });
        k * self.vertical_effective_stress_kpa(depth_mm)
    }

    fn describe(&self) -> String {
        let depths: Vec<String> = self
            .curves
            .iter()
            .map(|c| format!("{}", c.depth_mm))
            .collect();
        let d_min = self
            .curves
            .iter()
            .filter_map(|c| c.diameters_mm.first())
            .fold(f64::INFINITY, |a, &b| a.min(b));
        let d_max = self
            .curves
            .iter()
            .filter_map(|c| c.diameters_mm.last())
            .fold(f64::NEG_INFINITY, |a, &b| a.max(b));
        let mut s = format!(
            "FEM-DEM solver sand from {} (CRC-32 0x{:08X}): h = {} mm, D {:.2}-{:.2} mm, \
             K = p_e/(gamma' h) with the file's gamma'={} kPa/mm, running max in D, \
             linear in D and h, held outside; solver:",
            self.source,
            self.crc32,
            depths.join("/"),
            d_min,
            d_max,
            self.unit_weight_kpa_per_mm,
        );
        for (k, v) in &self.settings {
            let _ = write!(s, " {k}={v}");
        }
        s
    }
}
