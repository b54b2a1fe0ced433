//! The experiment folder of `shared/data-format.md`: `rig.toml` (the physical
//! set-up) plus one or more `*.csv` time series. Lab rigs, the firmware's
//! telemetry ([`crate::telemetry`]) and the emulator all write it with
//! [`Experiment::write`]; the workbench reads nothing but
//! [`Experiment::read`].
//!
//! Reading is strict: a missing key or column, a value that is not a finite
//! number, rows out of time order, a run split across files or interleaved
//! with another, a depth that changes within a run, or a run below sand
//! with no `[sand]` section is an error naming the file, the line and the
//! key or column. Unknown keys, sections and columns are only warnings;
//! unknown columns are kept as text ([`Experiment::extra_columns`]) so they
//! survive a read/write round trip.

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::{Context, Result};
use serde::{Deserialize, Serialize};

use datafile::{decode_utf8, write_atomic, DataError, Table, TomlDoc};

pub mod telemetry;

/// Name of the set-up file inside an experiment folder.
pub const RIG_FILE: &str = "rig.toml";

/// Name of the time-series file [`Experiment::write`] writes.
pub const RUNS_FILE: &str = "runs.csv";

// ---------------------------------------------------------------------------
// rig.toml

/// `[actuator]`: the soft head's geometry at rest.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Actuator {
    /// Outer diameter at rest, D0 (mm).
    pub initial_diameter_mm: f64,
    /// Length of the zone that expands radially (mm).
    pub expansion_length_mm: f64,
    /// Skin thickness at rest (mm).
    pub skin_thickness_mm: f64,
}

impl Actuator {
    /// The expansion zone's skin tube at rest.
    pub fn tube(&self) -> skin::membrane::TubeGeometry {
        skin::membrane::TubeGeometry {
            outer_diameter_mm: self.initial_diameter_mm,
            wall_thickness_mm: self.skin_thickness_mm,
            length_mm: self.expansion_length_mm,
        }
    }
}

/// `[skin]`: known Yeoh coefficients; absent = calibrate them.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Skin {
    /// Yeoh C10 (kPa).
    pub c10_kpa: f64,
    /// Yeoh C20 (kPa).
    pub c20_kpa: f64,
    /// Yeoh C30 (kPa).
    pub c30_kpa: f64,
}

impl Skin {
    /// These coefficients as the skin model's Yeoh law.
    pub fn yeoh(&self) -> skin::Yeoh {
        skin::Yeoh {
            c10_kpa: self.c10_kpa,
            c20_kpa: self.c20_kpa,
            c30_kpa: self.c30_kpa,
        }
    }
}

/// `[sand]`: the granular bed; required when any run has `depth_mm > 0`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Sand {
    /// Mean grain radius (mm).
    pub grain_radius_mm: f64,
    /// Grain material density (kg/m^3).
    pub grain_density_kg_m3: f64,
    /// Pore volume fraction (0–1).
    pub porosity: f64,
    /// Inter-particle Coulomb friction coefficient.
    pub friction: f64,
}

/// `[fluid]`: the water inside the actuator and in the pores.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Fluid {
    /// Density (kg/m^3).
    pub density_kg_m3: f64,
    /// Water column above the sand surface (mm).
    pub water_above_sand_mm: f64,
}

/// `[container]`: the box the sand is in; absent = a wide tank.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Container {
    /// Inner width (mm); `None`: a wide tank, its walls far from the zone.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub width_mm: Option<f64>,
    /// Inner length (mm).
    pub length_mm: f64,
}

impl Container {
    /// Hydraulic radius of the box's cross-section (mm), area over
    /// perimeter, W·L/(2(W + L)): the length over which its walls take
    /// the sand's weight in Janssen's law (W/2 for a long slot); `None`
    /// for a wide tank.
    pub fn hydraulic_radius_mm(&self) -> Option<f64> {
        self.width_mm
            .map(|w| w * self.length_mm / (2.0 * (w + self.length_mm)))
    }
}

/// `[pump]`: the syringe.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Pump {
    /// Inner diameter of the syringe barrel (mm).
    pub syringe_bore_mm: f64,
}

/// Where `pressure_kpa` comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PressureSource {
    /// A pressure sensor on the water line.
    LineSensor,
    /// Piston force divided by the bore area (includes seal friction).
    PistonForce,
}

impl PressureSource {
    /// The spelling in `rig.toml`.
    pub fn as_str(self) -> &'static str {
        match self {
            PressureSource::LineSensor => "line_sensor",
            PressureSource::PistonForce => "piston_force",
        }
    }
}

/// `[measurement]`: how pressure was measured.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Measurement {
    /// Where `pressure_kpa` comes from.
    pub pressure_source: PressureSource,
    /// Standard deviation of one pressure reading (kPa), if known.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pressure_noise_kpa: Option<f64>,
}

/// The physical set-up of `rig.toml`: what is known, not fitted. Field and
/// section names are the file's keys.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Rig {
    /// `[actuator]`.
    pub actuator: Actuator,
    /// `[skin]`, optional.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub skin: Option<Skin>,
    /// `[sand]`, optional when every run is in free water.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sand: Option<Sand>,
    /// `[fluid]`.
    pub fluid: Fluid,
    /// `[container]`, optional (absent = a wide tank).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub container: Option<Container>,
    /// `[pump]`.
    pub pump: Pump,
    /// `[measurement]`.
    pub measurement: Measurement,
    /// A fitted law that replaces `[skin]` (`--skin-fit`, fit-skin's
    /// report; [`Rig::use_skin_fit`]): any registered law, where the file's
    /// `[skin]` is a Yeoh law only. Not part of rig.toml: never read from
    /// it nor written to it.
    #[serde(skip)]
    pub skin_fit: Option<skin::ChosenLaw>,
}

/// One section of `rig.toml` as the format defines it.
struct SectionSchema {
    /// Section name.
    name: &'static str,
    /// Whether the section must be present.
    required: bool,
    /// Its keys, each with whether it must be present when the section is.
    keys: &'static [(&'static str, bool)],
}

/// Every section and key `rig.toml` knows.
const SCHEMA: &[SectionSchema] = &[
    SectionSchema {
        name: "actuator",
        required: true,
        keys: &[
            ("initial_diameter_mm", true),
            ("expansion_length_mm", true),
            ("skin_thickness_mm", true),
        ],
    },
    SectionSchema {
        name: "skin",
        required: false,
        keys: &[("c10_kpa", true), ("c20_kpa", true), ("c30_kpa", true)],
    },
    SectionSchema {
        name: "sand",
        required: false,
        keys: &[
            ("grain_radius_mm", true),
            ("grain_density_kg_m3", true),
            ("porosity", true),
            ("friction", true),
        ],
    },
    SectionSchema {
        name: "fluid",
        required: true,
        keys: &[("density_kg_m3", true), ("water_above_sand_mm", true)],
    },
    SectionSchema {
        name: "container",
        required: false,
        keys: &[("width_mm", false), ("length_mm", true)],
    },
    SectionSchema {
        name: "pump",
        required: true,
        keys: &[("syringe_bore_mm", true)],
    },
    SectionSchema {
        name: "measurement",
        required: true,
        keys: &[("pressure_source", true), ("pressure_noise_kpa", false)],
    },
];

/// Accepted range of a number, for messages and checks.
#[derive(Clone, Copy)]
enum Range {
    /// > 0.
    Positive,
    /// ≥ 0.
    NonNegative,
    /// Strictly between 0 and 1.
    Fraction,
    /// Any finite value.
    Finite,
}

impl Range {
    fn accepts(self, v: f64) -> bool {
        v.is_finite()
            && match self {
                Range::Positive => v > 0.0,
                Range::NonNegative => v >= 0.0,
                Range::Fraction => v > 0.0 && v < 1.0,
                Range::Finite => true,
            }
    }

    fn describe(self) -> &'static str {
        match self {
            Range::Positive => "a finite number > 0",
            Range::NonNegative => "a finite number ≥ 0",
            Range::Fraction => "a number strictly between 0 and 1",
            Range::Finite => "a finite number",
        }
    }
}

/// A parsed `rig.toml`: its values and the line of any key.
struct RigDoc<'a> {
    doc: TomlDoc<'a>,
}

impl<'a> RigDoc<'a> {
    fn parse(file: &str, text: &'a str) -> Result<Self, DataError> {
        Ok(RigDoc {
            doc: TomlDoc::parse(file, text)?,
        })
    }

    /// `key` (`section.key`) is missing: where, the file cannot say.
    fn missing_key(&self, section: &str, key: &str) -> DataError {
        DataError::new(self.doc.file(), "missing key").with_key(format!("{section}.{key}"))
    }

    fn section(&self, name: &str) -> Result<Option<&toml::Table>, DataError> {
        match self.doc.values().get(name) {
            None => Ok(None),
            Some(toml::Value::Table(t)) => Ok(Some(t)),
            Some(other) => Err(self.doc.error(
                &[name],
                format!("must be a section [{name}], found a {}", other.type_str()),
            )),
        }
    }

    fn require_section(&self, name: &str) -> Result<&toml::Table, DataError> {
        self.section(name)?
            .ok_or_else(|| DataError::new(self.doc.file(), "missing section").with_key(name))
    }

    fn number(&self, section: &str, key: &str, range: Range) -> Result<f64, DataError> {
        self.optional_number(section, key, range)?
            .ok_or_else(|| self.missing_key(section, key))
    }

    fn optional_number(
        &self,
        section: &str,
        key: &str,
        range: Range,
    ) -> Result<Option<f64>, DataError> {
        let Some(value) = self.section(section)?.and_then(|t| t.get(key)) else {
            return Ok(None);
        };
        let v = match value {
            toml::Value::Float(f) => *f,
            // Integers convert exactly up to 2^53, far beyond any quantity here.
            toml::Value::Integer(i) => *i as f64,
            other => {
                return Err(self.doc.error(
                    &[section, key],
                    format!("expected a number, found a {} ({other})", other.type_str()),
                ))
            }
        };
        if !range.accepts(v) {
            return Err(self
                .doc
                .error(&[section, key], format!("{v} is not {}", range.describe())));
        }
        Ok(Some(v))
    }

    fn pressure_source(&self) -> Result<PressureSource, DataError> {
        let (section, key) = ("measurement", "pressure_source");
        let value = self
            .require_section(section)?
            .get(key)
            .ok_or_else(|| self.missing_key(section, key))?;
        match value.as_str() {
            Some("line_sensor") => Ok(PressureSource::LineSensor),
            Some("piston_force") => Ok(PressureSource::PistonForce),
            _ => Err(self.doc.error(
                &[section, key],
                format!("{value} is not \"line_sensor\" or \"piston_force\""),
            )),
        }
    }

    /// Unknown sections and keys, one warning each.
    fn unknown_keys(&self) -> Vec<String> {
        let mut warnings = Vec::new();
        let file = self.doc.file();
        let at = |line: Option<u64>| match line {
            Some(l) => format!("{file} line {l}"),
            None => file.to_owned(),
        };
        for (name, value) in self.doc.values() {
            let Some(schema) = SCHEMA.iter().find(|s| s.name == name) else {
                warnings.push(format!(
                    "{}: unknown section or key `{name}` ignored",
                    at(self.doc.line(&[name]))
                ));
                continue;
            };
            if let toml::Value::Table(t) = value {
                for key in t.keys() {
                    if !schema.keys.iter().any(|(k, _)| k == key) {
                        warnings.push(format!(
                            "{}: unknown key `{name}.{key}` ignored",
                            at(self.doc.line(&[name, key]))
                        ));
                    }
                }
            }
        }
        warnings
    }
}

impl Rig {
    /// The skin's law: the fitted law of `--skin-fit`, else the `[skin]`
    /// coefficients, else the project's default skin.
    pub fn skin_law(&self) -> skin::SkinLaw {
        match (&self.skin_fit, &self.skin) {
            (Some(fit), _) => fit.law.clone(),
            (None, Some(s)) => s.yeoh().into(),
            (None, None) => skin::default_skin().into(),
        }
    }

    /// The skin in use, in one line, for records such as the workbench's
    /// ledger: the `--skin-fit` law and its source, the `[skin]` law, or
    /// the default skin with its scale fitted.
    pub fn skin_description(&self) -> String {
        let law = self.skin_law().describe();
        match (&self.skin_fit, &self.skin) {
            (Some(fit), _) => format!("{law} ({}, --skin-fit)", fit.source),
            (None, Some(_)) => format!("[skin] {law}"),
            (None, None) => format!("the default skin, {law}, its scale fitted"),
        }
    }

    /// Whether the skin's law is known (`--skin-fit` or `[skin]`): its
    /// stiffness is then used as measured, not fitted.
    pub fn skin_known(&self) -> bool {
        self.skin_fit.is_some() || self.skin.is_some()
    }

    /// The skin of `chosen` (read from `--skin-fit`) replaces this rig's:
    /// returns the warnings, one naming both laws when `rig_file` has a
    /// `[skin]`, and the report's own doubts about the law.
    pub fn use_skin_fit(&mut self, chosen: skin::ChosenLaw, rig_file: &str) -> Vec<String> {
        let mut warnings = Vec::new();
        if let Some(s) = &self.skin {
            warnings.push(format!(
                "{rig_file}: [skin] (Yeoh c10_kpa = {}, c20_kpa = {}, c30_kpa = {}) is replaced by {}, {} (--skin-fit)",
                s.c10_kpa,
                s.c20_kpa,
                s.c30_kpa,
                chosen.source,
                chosen.law.describe()
            ));
        }
        warnings.extend(chosen.warnings.iter().cloned());
        self.skin_fit = Some(chosen);
        warnings
    }

    /// The paper's set-up, as in the example of `shared/data-format.md`.
    /// From the paper: D0 18.7 mm, 20 mm expansion zone, 1.75 mm skin, grain
    /// radius 0.36 mm, grain density 2920 kg/m^3, friction 0.25, 180 mm of
    /// water, the 40 × 200 mm box, the 29.21 mm syringe bore. Not in the
    /// paper (the example's assumptions): the Yeoh coefficients, porosity
    /// 0.40, water density 1025 kg/m^3, a line sensor with 0.03 kPa noise
    /// (the paper's balloon test measured piston force).
    pub fn paper_default() -> Rig {
        Rig {
            actuator: Actuator {
                initial_diameter_mm: 18.7,
                expansion_length_mm: 20.0,
                skin_thickness_mm: 1.75,
            },
            skin: Some(Skin {
                c10_kpa: 2.0,
                c20_kpa: 0.0,
                c30_kpa: 0.016,
            }),
            sand: Some(Sand {
                grain_radius_mm: 0.36,
                grain_density_kg_m3: 2920.0,
                porosity: 0.40,
                friction: 0.25,
            }),
            fluid: Fluid {
                density_kg_m3: constants::SEAWATER_DENSITY_KG_M3,
                water_above_sand_mm: 180.0,
            },
            container: Some(Container {
                width_mm: Some(40.0),
                length_mm: 200.0,
            }),
            pump: Pump {
                syringe_bore_mm: 29.21,
            },
            measurement: Measurement {
                pressure_source: PressureSource::LineSensor,
                pressure_noise_kpa: Some(0.03),
            },
            skin_fit: None,
        }
    }

    /// Parses `rig.toml` text; `file` names it in errors. Returns the rig and
    /// the warnings (unknown sections and keys). Whether `[sand]` is needed
    /// depends on the runs, so [`Experiment::parse`] checks that.
    pub fn parse(file: &str, text: &str) -> Result<(Rig, Vec<String>), DataError> {
        let doc = RigDoc::parse(file, text)?;
        let warnings = doc.unknown_keys();
        for schema in SCHEMA {
            let section = schema.name;
            let table = if schema.required {
                Some(doc.require_section(section)?)
            } else {
                doc.section(section)?
            };
            // A present section must be complete, optional or not.
            if let Some(table) = table {
                for (key, needed) in schema.keys {
                    if *needed && !table.contains_key(*key) {
                        return Err(doc.missing_key(section, key));
                    }
                }
            }
        }
        use Range::*;
        let rig = Rig {
            actuator: Actuator {
                initial_diameter_mm: doc.number("actuator", "initial_diameter_mm", Positive)?,
                expansion_length_mm: doc.number("actuator", "expansion_length_mm", Positive)?,
                skin_thickness_mm: doc.number("actuator", "skin_thickness_mm", Positive)?,
            },
            skin: match doc.section("skin")? {
                None => None,
                Some(_) => Some(Skin {
                    c10_kpa: doc.number("skin", "c10_kpa", Finite)?,
                    c20_kpa: doc.number("skin", "c20_kpa", Finite)?,
                    c30_kpa: doc.number("skin", "c30_kpa", Finite)?,
                }),
            },
            sand: match doc.section("sand")? {
                None => None,
                Some(_) => Some(Sand {
                    grain_radius_mm: doc.number("sand", "grain_radius_mm", Positive)?,
                    grain_density_kg_m3: doc.number("sand", "grain_density_kg_m3", Positive)?,
                    porosity: doc.number("sand", "porosity", Fraction)?,
                    friction: doc.number("sand", "friction", NonNegative)?,
                }),
            },
            fluid: Fluid {
                density_kg_m3: doc.number("fluid", "density_kg_m3", Positive)?,
                water_above_sand_mm: doc.number("fluid", "water_above_sand_mm", NonNegative)?,
            },
            container: match doc.section("container")? {
                None => None,
                Some(_) => Some(Container {
                    width_mm: doc.optional_number("container", "width_mm", Positive)?,
                    length_mm: doc.number("container", "length_mm", Positive)?,
                }),
            },
            pump: Pump {
                syringe_bore_mm: doc.number("pump", "syringe_bore_mm", Positive)?,
            },
            measurement: Measurement {
                pressure_source: doc.pressure_source()?,
                pressure_noise_kpa: doc.optional_number(
                    "measurement",
                    "pressure_noise_kpa",
                    NonNegative,
                )?,
            },
            skin_fit: None,
        };
        let a = &rig.actuator;
        if a.skin_thickness_mm >= a.initial_diameter_mm / 2.0 {
            return Err(doc.doc.error(
                &["actuator", "skin_thickness_mm"],
                format!(
                    "{} is not below half of `actuator.initial_diameter_mm` ({})",
                    a.skin_thickness_mm, a.initial_diameter_mm
                ),
            ));
        }
        Ok((rig, warnings))
    }

    /// Reads a `rig.toml` file on its own (e.g. a set-up given to a
    /// converter); returns the rig and its warnings.
    pub fn read(path: &Path) -> Result<(Rig, Vec<String>)> {
        let text =
            std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
        let name = path.file_name().map_or_else(
            || path.display().to_string(),
            |n| n.to_string_lossy().into_owned(),
        );
        Ok(Rig::parse(&name, &text)?)
    }

    /// Reads the set-up `path` names: a `rig.toml`, or the one in an
    /// experiment folder. Returns the rig, the file it came from (for
    /// errors and provenance) and its warnings.
    pub fn read_setup(path: &Path) -> Result<(Rig, String, Vec<String>)> {
        let file = if path.is_dir() {
            path.join(RIG_FILE)
        } else {
            path.to_path_buf()
        };
        let (rig, warnings) = Rig::read(&file)?;
        Ok((rig, file.display().to_string(), warnings))
    }

    /// The `rig.toml` text of this rig.
    pub fn to_toml(&self) -> Result<String> {
        toml::to_string_pretty(self).context("serializing rig.toml")
    }
}

// ---------------------------------------------------------------------------
// *.csv

/// Columns every time-series file must have, in the order they are written.
pub const REQUIRED_COLUMNS: [&str; 5] = ["run", "t_s", "depth_mm", "volume_ml", "pressure_kpa"];

/// The optional column of the format.
pub const DIAMETER_COLUMN: &str = "diameter_mm";

/// Where a numeric column's values must lie to be taken as a reading:
/// outside it a value is refused as absurd (a unit slip, a logger's
/// overflow, a corrupt cell), naming its line and column.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlausibleRange {
    /// The column.
    pub column: &'static str,
    /// Smallest plausible value, in the column's unit.
    pub min: f64,
    /// Largest plausible value, in the column's unit.
    pub max: f64,
    /// Why, in words.
    pub why: &'static str,
}

/// The stated plausibility range of every numeric column.
pub const PLAUSIBLE_RANGES: [PlausibleRange; 5] = [
    PlausibleRange {
        column: "t_s",
        min: 0.0,
        max: 1.0e6,
        why: "time since the start of a run, at most 11.6 days",
    },
    PlausibleRange {
        column: "depth_mm",
        min: 0.0,
        max: 1.0e4,
        why: "sand cover above the axis, at most 10 m",
    },
    PlausibleRange {
        column: "volume_ml",
        min: -1.0e4,
        max: 1.0e4,
        why: "net volume pumped, within ±10 L",
    },
    PlausibleRange {
        column: "pressure_kpa",
        min: -constants::ATMOSPHERE_KPA,
        max: 1.0e4,
        why: "a gauge reading, above absolute vacuum and below 10 MPa",
    },
    PlausibleRange {
        column: DIAMETER_COLUMN,
        min: 0.0,
        max: 1.0e4,
        why: "the zone's outer diameter, at most 10 m",
    },
];

/// Refuses `value` of `column` outside its [`PLAUSIBLE_RANGES`] entry.
fn plausible(row: &datafile::Row<'_>, column: &str, value: f64) -> Result<(), DataError> {
    match PLAUSIBLE_RANGES.iter().find(|r| r.column == column) {
        Some(r) if !(r.min..=r.max).contains(&value) => Err(row.error(
            column,
            format!(
                "{value} is outside the plausible range {} to {} ({})",
                r.min, r.max, r.why
            ),
        )),
        _ => Ok(()),
    }
}

/// One row of a run.
#[derive(Clone, Debug, PartialEq)]
pub struct Sample {
    /// Time since the start of the run (s).
    pub t_s: f64,
    /// Net volume pushed by the pump since the run started (mL).
    pub volume_ml: f64,
    /// Gauge pressure as measured by `measurement.pressure_source` (kPa).
    pub pressure_kpa: f64,
    /// Measured outer diameter of the expansion zone (mm), where known.
    pub diameter_mm: Option<f64>,
    /// Values of [`Experiment::extra_columns`], same order, as text (empty
    /// where a file lacked the column).
    pub extra: Vec<String>,
}

/// One continuous recording at one depth.
#[derive(Clone, Debug, PartialEq)]
pub struct Run {
    /// Run id, unique within the folder.
    pub id: String,
    /// Sand cover above the actuator axis (mm); 0 = free in water.
    pub depth_mm: f64,
    /// Rows in strictly increasing time.
    pub samples: Vec<Sample>,
}

/// An experiment folder in memory.
#[derive(Clone, Debug)]
pub struct Experiment {
    /// The set-up.
    pub rig: Rig,
    /// Runs in the order they appear (files sorted by name).
    pub runs: Vec<Run>,
    /// Columns outside the format, kept as text in [`Sample::extra`].
    pub extra_columns: Vec<String>,
    /// What reading found odd but accepted (unknown keys, columns…). Not
    /// data: ignored by `==`.
    pub warnings: Vec<String>,
    /// Where each run's rows were read, one per run in [`Experiment::runs`]
    /// order: empty for an experiment built in code. Not data: ignored by
    /// `==`.
    pub sources: Vec<RunSource>,
}

/// The file and lines a run was read from.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct RunSource {
    /// File name inside the folder.
    pub file: String,
    /// 1-based line of each sample, in [`Run::samples`] order.
    pub lines: Vec<u64>,
}

impl PartialEq for Experiment {
    fn eq(&self, other: &Self) -> bool {
        self.rig == other.rig
            && self.runs == other.runs
            && self.extra_columns == other.extra_columns
    }
}

/// Where each run came from, to name it in later errors.
struct RunOrigin {
    file: String,
    first_line: u64,
    last_line: u64,
    /// Every sample's line.
    lines: Vec<u64>,
}

/// Collects runs across files, enforcing contiguity and uniqueness.
#[derive(Default)]
struct RunCollector {
    runs: Vec<Run>,
    origins: Vec<RunOrigin>,
    index: BTreeMap<String, usize>,
    extra_columns: Vec<String>,
    warnings: Vec<String>,
}

/// Column positions of one file's header.
struct Header {
    required: [usize; 5],
    diameter: Option<usize>,
    /// (index in the file, index in `extra_columns`).
    extra: Vec<(usize, usize)>,
}

impl RunCollector {
    fn header(&mut self, table: &Table<'_>) -> Result<Header, DataError> {
        let (file, names) = (table.file(), table.columns());
        let mut seen: BTreeMap<&str, usize> = BTreeMap::new();
        for (i, name) in names.iter().enumerate() {
            if name.is_empty() {
                return Err(table.header_error(format!("column {} has no name", i + 1)));
            }
            if seen.insert(name, i).is_some() {
                return Err(table
                    .header_error("appears twice in the header")
                    .with_key(name.as_str()));
            }
        }
        let mut required = [0; 5];
        for (slot, column) in required.iter_mut().zip(REQUIRED_COLUMNS) {
            *slot = table.require(column)?;
        }
        let mut extra = Vec::new();
        for (i, name) in names.iter().enumerate() {
            if REQUIRED_COLUMNS.contains(&name.as_str()) || name == DIAMETER_COLUMN {
                continue;
            }
            self.warnings.push(format!(
                "{file} line {}: column `{name}` is not in the format; kept as text, ignored by the tools",
                table.header_line()
            ));
            let slot = match self.extra_columns.iter().position(|c| c == name) {
                Some(slot) => slot,
                None => {
                    self.extra_columns.push(name.clone());
                    for sample in self.runs.iter_mut().flat_map(|r| r.samples.iter_mut()) {
                        sample.extra.push(String::new());
                    }
                    self.extra_columns.len() - 1
                }
            };
            extra.push((i, slot));
        }
        Ok(Header {
            required,
            diameter: table.column(DIAMETER_COLUMN),
            extra,
        })
    }

    fn file(&mut self, file: &str, text: &str) -> Result<(), DataError> {
        let mut table = Table::parse(file, text.as_bytes())?;
        let header = self.header(&table)?;
        // Which run this file is filling, as an index into `runs`.
        let mut current: Option<usize> = None;
        let mut rows = 0usize;
        for row in table.rows() {
            let row = row?;
            let line = row.line();
            rows += 1;
            let number = |slot: usize| row.number(header.required[slot]);
            let id = row.get(header.required[0]);
            if id.is_empty() {
                return Err(row.error("run", "empty run id"));
            }
            let t_s = number(1)?;
            let depth_mm = number(2)?;
            let sample = Sample {
                t_s,
                volume_ml: number(3)?,
                pressure_kpa: number(4)?,
                diameter_mm: match header.diameter {
                    Some(column) if !row.get(column).is_empty() => Some(row.number(column)?),
                    _ => None,
                },
                extra: {
                    let mut extra = vec![String::new(); self.extra_columns.len()];
                    for &(column, slot) in &header.extra {
                        if let Some(v) = extra.get_mut(slot) {
                            *v = row.get(column).to_owned();
                        }
                    }
                    extra
                },
            };
            if t_s < 0.0 {
                return Err(row.error(
                    "t_s",
                    format!("{t_s} is negative (time since the start of the run)"),
                ));
            }
            if depth_mm < 0.0 {
                return Err(row.error("depth_mm", format!("{depth_mm} is negative")));
            }
            if let Some(d) = sample.diameter_mm {
                if d <= 0.0 {
                    return Err(row.error(DIAMETER_COLUMN, format!("{d} is not > 0")));
                }
                plausible(&row, DIAMETER_COLUMN, d)?;
            }
            plausible(&row, "t_s", t_s)?;
            plausible(&row, "depth_mm", depth_mm)?;
            plausible(&row, "volume_ml", sample.volume_ml)?;
            plausible(&row, "pressure_kpa", sample.pressure_kpa)?;
            let same_run = current.is_some_and(|i| self.runs.get(i).is_some_and(|r| r.id == id));
            let index = if same_run {
                current.unwrap_or_default()
            } else {
                self.start_run(file, line, id, depth_mm)?
            };
            current = Some(index);
            let (Some(run), Some(origin)) = (self.runs.get_mut(index), self.origins.get_mut(index))
            else {
                continue;
            };
            if depth_mm != run.depth_mm {
                return Err(row.error(
                    "depth_mm",
                    format!(
                        "{depth_mm} differs from the depth {} of run `{id}` (line {}); depth \
                         must be constant within a run",
                        run.depth_mm, origin.first_line
                    ),
                ));
            }
            if let Some(prev) = run.samples.last() {
                if t_s <= prev.t_s {
                    return Err(row.error(
                        "t_s",
                        format!(
                            "{t_s} is not after {} (line {}); rows of run `{id}` must be in \
                             increasing time",
                            prev.t_s, origin.last_line
                        ),
                    ));
                }
            }
            run.samples.push(sample);
            origin.last_line = line;
            origin.lines.push(line);
        }
        if rows == 0 {
            self.warnings.push(format!("{file}: no rows"));
        }
        Ok(())
    }

    fn start_run(
        &mut self,
        file: &str,
        line: u64,
        id: &str,
        depth_mm: f64,
    ) -> Result<usize, DataError> {
        if let Some(origin) = self.index.get(id).and_then(|&i| self.origins.get(i)) {
            let message = if origin.file == file {
                format!(
                    "run `{id}` continues after other rows (it ran from line {} to {}); \
                     the rows of a run must be contiguous",
                    origin.first_line, origin.last_line
                )
            } else {
                format!(
                    "run `{id}` already appeared in {} (lines {}–{}); a run id must be unique \
                     within the folder and a run may not be split across files",
                    origin.file, origin.first_line, origin.last_line
                )
            };
            return Err(DataError::new(file, message)
                .with_line(line)
                .with_key("run"));
        }
        self.runs.push(Run {
            id: id.to_owned(),
            depth_mm,
            samples: Vec::new(),
        });
        self.origins.push(RunOrigin {
            file: file.to_owned(),
            first_line: line,
            last_line: line,
            lines: Vec::new(),
        });
        let index = self.runs.len() - 1;
        self.index.insert(id.to_owned(), index);
        Ok(index)
    }
}

impl Experiment {
    /// An experiment with no extra columns and no warnings.
    pub fn new(rig: Rig, runs: Vec<Run>) -> Experiment {
        Experiment {
            rig,
            runs,
            extra_columns: Vec::new(),
            warnings: Vec::new(),
            sources: Vec::new(),
        }
    }

    /// The run named `id`, if any.
    pub fn run(&self, id: &str) -> Option<&Run> {
        self.runs.iter().find(|r| r.id == id)
    }

    /// Parses a folder given as text: `rig.toml` and the CSV files as
    /// (name, text) in the order to read them. Names appear in errors.
    pub fn parse(rig_toml: &str, csv_files: &[(&str, &str)]) -> Result<Experiment, DataError> {
        let (rig, mut warnings) = Rig::parse(RIG_FILE, rig_toml)?;
        let mut collector = RunCollector::default();
        for (name, text) in csv_files {
            collector.file(name, text)?;
        }
        warnings.append(&mut collector.warnings);
        if collector.runs.is_empty() {
            let names: Vec<&str> = csv_files.iter().map(|(n, _)| *n).collect();
            let file = if names.is_empty() {
                "*.csv".to_owned()
            } else {
                names.join(", ")
            };
            return Err(DataError::new(file, "no samples: the folder holds no run"));
        }
        if rig.sand.is_none() {
            let buried = collector
                .runs
                .iter()
                .zip(&collector.origins)
                .find(|(r, _)| r.depth_mm > 0.0);
            if let Some((run, origin)) = buried {
                return Err(DataError::new(
                    RIG_FILE,
                    format!(
                        "missing section, required because run `{}` ({} line {}) has \
                         depth_mm = {}",
                        run.id, origin.file, origin.first_line, run.depth_mm
                    ),
                )
                .with_key("sand"));
            }
        }
        let sources = collector
            .origins
            .into_iter()
            .map(|o| RunSource {
                file: o.file,
                lines: o.lines,
            })
            .collect();
        Ok(Experiment {
            rig,
            runs: collector.runs,
            extra_columns: collector.extra_columns,
            warnings,
            sources,
        })
    }

    /// Reads an experiment folder: `rig.toml` and every `*.csv` in it,
    /// sorted by file name.
    pub fn read(dir: &Path) -> Result<Experiment> {
        let context = || format!("experiment folder {}", dir.display());
        let rig_path = dir.join(RIG_FILE);
        let rig_text = std::fs::read_to_string(&rig_path)
            .with_context(|| format!("reading {}", rig_path.display()))
            .with_context(context)?;
        let mut csv_files = Vec::new();
        for name in csv_names(dir).with_context(context)? {
            let path = dir.join(&name);
            let bytes =
                std::fs::read(&path).with_context(|| format!("reading {}", path.display()))?;
            let text = decode_utf8(&name, bytes).with_context(context)?;
            csv_files.push((name, text));
        }
        let files: Vec<(&str, &str)> = csv_files
            .iter()
            .map(|(n, t)| (n.as_str(), t.as_str()))
            .collect();
        Experiment::parse(&rig_text, &files).with_context(context)
    }

    /// The `runs.csv` text: the required columns, `diameter_mm` when any
    /// sample has one, then the extra columns. Numbers use Rust's shortest
    /// round-trip form, so reading gives back the same `f64` bits.
    pub fn to_csv(&self) -> Result<String> {
        let with_diameter = self
            .runs
            .iter()
            .flat_map(|r| &r.samples)
            .any(|s| s.diameter_mm.is_some());
        let mut writer = csv::Writer::from_writer(Vec::new());
        let mut header: Vec<&str> = REQUIRED_COLUMNS.to_vec();
        if with_diameter {
            header.push(DIAMETER_COLUMN);
        }
        header.extend(self.extra_columns.iter().map(String::as_str));
        writer.write_record(&header)?;
        for run in &self.runs {
            for s in &run.samples {
                let mut row = vec![
                    run.id.clone(),
                    s.t_s.to_string(),
                    run.depth_mm.to_string(),
                    s.volume_ml.to_string(),
                    s.pressure_kpa.to_string(),
                ];
                if with_diameter {
                    row.push(s.diameter_mm.map(|d| d.to_string()).unwrap_or_default());
                }
                anyhow::ensure!(
                    s.extra.len() == self.extra_columns.len(),
                    "run `{}` at t = {} s has {} extra values for {} extra columns",
                    run.id,
                    s.t_s,
                    s.extra.len(),
                    self.extra_columns.len()
                );
                row.extend(s.extra.iter().cloned());
                writer.write_record(&row)?;
            }
        }
        let bytes = writer.into_inner().context("writing CSV")?;
        String::from_utf8(bytes).context("CSV is UTF-8")
    }

    /// Writes `rig.toml` and `runs.csv` into `dir` (each atomically). Refuses
    /// anything that would not read back identically, and a folder holding
    /// other `*.csv` files (they would be read together with `runs.csv`).
    pub fn write(&self, dir: &Path) -> Result<()> {
        let rig_text = self.rig.to_toml()?;
        let csv_text = self.to_csv()?;
        let again = Experiment::parse(&rig_text, &[(RUNS_FILE, &csv_text)])
            .context("refusing to write an experiment that does not read back")?;
        anyhow::ensure!(
            again == *self,
            "refusing to write: the experiment would not read back identically (run ids with \
             surrounding spaces, or extra columns named like format columns?)"
        );
        if dir.exists() {
            let others: Vec<String> = csv_names(dir)?
                .into_iter()
                .filter(|n| n != RUNS_FILE)
                .collect();
            anyhow::ensure!(
                others.is_empty(),
                "refusing to write into {}: it holds other CSV files ({}) that would be read \
                 as part of the experiment",
                dir.display(),
                others.join(", ")
            );
        }
        write_atomic(&dir.join(RIG_FILE), rig_text.as_bytes())?;
        write_atomic(&dir.join(RUNS_FILE), csv_text.as_bytes())?;
        Ok(())
    }
}

/// Names of the `*.csv` files directly in `dir`, sorted.
fn csv_names(dir: &Path) -> Result<Vec<String>> {
    let mut names = Vec::new();
    for entry in std::fs::read_dir(dir).with_context(|| format!("listing {}", dir.display()))? {
        let entry = entry.with_context(|| format!("listing {}", dir.display()))?;
        let name = entry.file_name().to_string_lossy().into_owned();
        let is_file = entry.file_type().map(|t| !t.is_dir()).unwrap_or(false);
        if is_file && name.ends_with(".csv") {
            names.push(name);
        }
    }
    names.sort();
    Ok(names)
}
