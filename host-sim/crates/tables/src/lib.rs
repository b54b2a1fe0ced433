//! Generates the firmware's pressure→diameter table (`src/table/generated.rs`
//! in the root crate) from the physics, deterministically: the same inputs
//! give the same bytes, so CI can regenerate and compare.
//!
//! The table format and checksum are the firmware's own
//! ([`urechis::table::Table`]), so the generator and the boot check cannot
//! drift apart.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};

use rig::Rig;
use urechis::table::{Table, FORMAT_VERSION};

/// How the committed table is regenerated.
pub const DEFAULT_COMMAND: &str = "cargo sim tables";

/// Where the generated table lives, relative to the repository root.
pub const GENERATED_PATH: &str = "src/table/generated.rs";

/// Grid and geometry of a table to generate.
#[derive(Clone, Debug, PartialEq)]
pub struct TableSpec {
    /// Outer diameter at rest, D0 (mm).
    pub initial_diameter_mm: f32,
    /// Length of the expansion zone (mm).
    pub expansion_length_mm: f32,
    /// Skin thickness (mm).
    pub skin_thickness_mm: f32,
    /// Depth rows (mm), first 0.
    pub depths_mm: Vec<f32>,
    /// Diameter columns (mm), first D0.
    pub diameters_mm: Vec<f32>,
}

impl Default for TableSpec {
    /// The paper's actuator: D0 = 18.7 mm, 20 mm zone, 1.75 mm skin; depths
    /// 0–200 mm (the observation box holds 200 mm of sand); diameters from D0
    /// to 26.2 mm (the paper expands to 25 mm) every 0.25 mm.
    fn default() -> Self {
        let d0 = 18.7_f32;
        Self {
            initial_diameter_mm: d0,
            expansion_length_mm: 20.0,
            skin_thickness_mm: 1.75,
            depths_mm: vec![0.0, 20.0, 40.0, 50.0, 70.0, 100.0, 150.0, 200.0],
            // Computed in f64 from an integer index so every platform gets
            // the same f32 values.
            diameters_mm: (0..31)
                .map(|i| (f64::from(d0) + 0.25 * f64::from(i)) as f32)
                .collect(),
        }
    }
}

impl TableSpec {
    /// The grid for the actuator of `rig`: its geometry, the default's depth
    /// rows, and diameter columns from its D0 over the same relative span
    /// as the paper's (18.7 → 26.2 mm), every 0.25 mm while that stays
    /// within 48 columns, else 48 even steps (the firmware's limit is
    /// [`urechis::table::MAX_POINTS`]).
    pub fn for_rig(rig: &Rig) -> TableSpec {
        let paper = TableSpec::default();
        let a = &rig.actuator;
        let d0 = a.initial_diameter_mm;
        let span = d0 * (26.2 / 18.7 - 1.0);
        let steps = ((span / 0.25).round() as usize).clamp(1, 47);
        let step = span / steps as f64;
        TableSpec {
            initial_diameter_mm: d0 as f32,
            expansion_length_mm: a.expansion_length_mm as f32,
            skin_thickness_mm: a.skin_thickness_mm as f32,
            diameters_mm: (0..=steps).map(|i| (d0 + step * i as f64) as f32).collect(),
            ..paper
        }
    }
}

pub use model::pressure_model::PressureModel;

/// Which sand law the firmware table is generated with (the skin is the
/// same for both).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TableSand {
    /// The balloon-calibrated parametric law.
    Parametric,
    /// The FEM–DEM solver's stored results (`host-sim solver-sand`).
    Solver,
}

/// The sand of the committed firmware table: the solver's stored results.
/// The emulator's plant and the workbench's baseline fit their parametric
/// sand to the same file (`ParametricSand::fitted_to_solver`), so the
/// emulated sand pushes back as the table expects; the balloon experiment
/// is 2.6–3.0 times as strong (host-sim/data/sand/README.md). After a new data file:
/// `cargo sim tables`, `cargo sim emulate --export-replay`.
pub const TABLE_SAND: TableSand = TableSand::Solver;

impl TableSand {
    /// The skin + sand model with this sand; the solver's data are read
    /// from the repository root `repo_root`.
    pub fn model(self, repo_root: &Path) -> Result<Box<dyn PressureModel>> {
        self.model_with_skin(repo_root, None)
    }

    /// [`TableSand::model`] with the skin `skin` (a law from `--skin-fit`)
    /// instead of the default skin, when given.
    pub fn model_with_skin(
        self,
        repo_root: &Path,
        skin: Option<&skin::ChosenLaw>,
    ) -> Result<Box<dyn PressureModel>> {
        use model::pressure_model::SkinSandModel;
        Ok(match (self, skin) {
            (TableSand::Parametric, None) => Box::new(SkinSandModel::paper_default()),
            (TableSand::Parametric, Some(c)) => {
                Box::new(SkinSandModel::paper_default().with_skin(c.law.clone(), c.source.clone())?)
            }
            (TableSand::Solver, None) => Box::new(SkinSandModel::paper_solver(repo_root)?),
            // The committed file's sand was measured on the default skin:
            // a fitted skin is refused unless a file made with it is given.
            (TableSand::Solver, Some(c)) => Box::new(
                SkinSandModel::paper_solver(repo_root)?
                    .with_skin(c.law.clone(), c.source.clone())?
                    .checked_skin()?,
            ),
        })
    }
}

/// A generated table: owned data plus the checksum the firmware will verify.
#[derive(Clone, Debug, PartialEq)]
pub struct GeneratedTable {
    /// Grid and geometry.
    pub spec: TableSpec,
    /// p_i (kPa), row-major `[depth][diameter]`.
    pub pressure_kpa: Vec<f32>,
    /// Placeholder flag copied from the model.
    pub placeholder: bool,
    /// Provenance line copied from the model.
    pub provenance: String,
    /// CRC-32 computed by the firmware's own rule.
    pub checksum: u32,
    /// The command that regenerates the file (goes into its header).
    pub command: String,
}

impl GeneratedTable {
    /// Samples `model` on `spec`'s grid and checks the result with the
    /// firmware's own verification.
    pub fn sample(spec: &TableSpec, model: &dyn PressureModel) -> Result<Self> {
        let mut pressure_kpa = Vec::with_capacity(spec.depths_mm.len() * spec.diameters_mm.len());
        for &h in &spec.depths_mm {
            for &d in &spec.diameters_mm {
                pressure_kpa.push(model.internal_pressure_kpa(f64::from(d), f64::from(h)) as f32);
            }
        }
        let mut out = Self {
            spec: spec.clone(),
            pressure_kpa,
            placeholder: model.is_placeholder(),
            provenance: model.provenance(),
            checksum: 0,
            command: DEFAULT_COMMAND.to_string(),
        };
        out.checksum = out.as_table().compute_checksum();
        if let Err(e) = out.as_table().verify() {
            bail!("generated table fails the firmware's verification: {e:?}");
        }
        Ok(out)
    }

    /// A borrowed view in the firmware's format.
    pub fn as_table(&self) -> Table<'_> {
        Table {
            format_version: FORMAT_VERSION,
            placeholder: self.placeholder,
            initial_diameter_mm: self.spec.initial_diameter_mm,
            expansion_length_mm: self.spec.expansion_length_mm,
            skin_thickness_mm: self.spec.skin_thickness_mm,
            depths_mm: &self.spec.depths_mm,
            diameters_mm: &self.spec.diameters_mm,
            pressure_kpa: &self.pressure_kpa,
            checksum: self.checksum,
        }
    }

    /// The Rust source of `src/table/generated.rs`.
    pub fn to_rust_source(&self) -> String {
        let s = &self.spec;
        let mut out = String::new();
        let w = &mut out;
        // `{:?}` prints the shortest decimal that round-trips each f32, so the
        // compiled constants equal the values the checksum was taken over.
        let _ = writeln!(
            w,
            "//! GENERATED by `host-sim tables`; do not edit. Regenerate with"
        );
        let _ = writeln!(
            w,
            "//! `{}` (CI fails when this file is stale).",
            self.command
        );
        let _ = writeln!(w, "//!");
        let _ = writeln!(w, "//! Source: {}", self.provenance);
        if self.placeholder {
            let _ = writeln!(
                w,
                "//! PLACEHOLDER: not yet the project's own skin/sand physics."
            );
        }
        let _ = writeln!(
            w,
            "//! Rows: sand depth h (mm); columns: outer diameter D (mm); values:"
        );
        let _ = writeln!(
            w,
            "//! internal gauge pressure p_i (kPa) on the loading branch."
        );
        let _ = writeln!(w);
        let _ = writeln!(w, "use super::Table;");
        let _ = writeln!(w);
        let _ = writeln!(
            w,
            "const DEPTHS_MM: [f32; {}] = {};",
            s.depths_mm.len(),
            list(&s.depths_mm)
        );
        let _ = writeln!(w);
        let _ = writeln!(
            w,
            "const DIAMETERS_MM: [f32; {}] = {};",
            s.diameters_mm.len(),
            list(&s.diameters_mm)
        );
        let _ = writeln!(w);
        let _ = writeln!(w, "#[rustfmt::skip]");
        let _ = writeln!(
            w,
            "const PRESSURE_KPA: [f32; {}] = [",
            self.pressure_kpa.len()
        );
        for (row, h) in self
            .pressure_kpa
            .chunks(s.diameters_mm.len())
            .zip(&s.depths_mm)
        {
            let _ = writeln!(w, "    // h = {h:?} mm");
            for chunk in row.chunks(8) {
                let items: Vec<String> = chunk.iter().map(|v| format!("{v:?}")).collect();
                let _ = writeln!(w, "    {},", items.join(", "));
            }
        }
        let _ = writeln!(w, "];");
        let _ = writeln!(w);
        let _ = writeln!(
            w,
            "/// The compiled-in pressure→diameter table (verified at boot)."
        );
        let _ = writeln!(w, "pub const TABLE: Table<'static> = Table {{");
        let _ = writeln!(w, "    format_version: {FORMAT_VERSION},");
        let _ = writeln!(w, "    placeholder: {},", self.placeholder);
        let _ = writeln!(w, "    initial_diameter_mm: {:?},", s.initial_diameter_mm);
        let _ = writeln!(w, "    expansion_length_mm: {:?},", s.expansion_length_mm);
        let _ = writeln!(w, "    skin_thickness_mm: {:?},", s.skin_thickness_mm);
        let _ = writeln!(w, "    depths_mm: &DEPTHS_MM,");
        let _ = writeln!(w, "    diameters_mm: &DIAMETERS_MM,");
        let _ = writeln!(w, "    pressure_kpa: &PRESSURE_KPA,");
        let _ = writeln!(w, "    checksum: 0x{:08X},", self.checksum);
        let _ = writeln!(w, "}};");
        out
    }
}

fn list(values: &[f32]) -> String {
    let items: Vec<String> = values.iter().map(|v| format!("{v:?}")).collect();
    let one_line = format!("[{}]", items.join(", "));
    if one_line.len() <= 80 {
        return one_line;
    }
    let mut s = String::from("[\n");
    for chunk in items.chunks(8) {
        s.push_str("    ");
        s.push_str(&chunk.join(", "));
        s.push_str(",\n");
    }
    s.push(']');
    s
}

/// What `host-sim tables` did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TablesOutcome {
    /// The file was (re)written.
    Written,
    /// The file already held exactly these bytes.
    Unchanged,
}

/// What `host-sim tables` asks for.
#[derive(Clone, Debug, PartialEq)]
pub struct TablesSettings {
    /// Repository root (where the firmware's Cargo.toml is).
    pub repo: PathBuf,
    /// Only compare with the file; fail if it is stale.
    pub check: bool,
    /// A user's actuator (a rig.toml or an experiment folder) and the
    /// solver results for it, instead of the paper's.
    pub rig: Option<(PathBuf, PathBuf)>,
    /// A law from fit-skin's report (`--skin-fit`, `--skin-law`) that
    /// replaces the skin: the default skin's, or the rig's `[skin]`.
    pub skin_fit: Option<skin::SkinFitChoice>,
    /// File to write; default: [`GENERATED_PATH`] under `repo`.
    pub out: Option<PathBuf>,
    /// Also write the table as a binary image
    /// ([`urechis::table::image`]) for `host-sim board push-table`.
    pub image: Option<PathBuf>,
}

/// What [`generate`] did.
#[derive(Clone, Debug, PartialEq)]
pub struct Generated {
    /// The table file.
    pub path: PathBuf,
    /// Written or unchanged.
    pub outcome: TablesOutcome,
    /// Warnings of the rig file.
    pub warnings: Vec<String>,
}

/// Generates (or with `check`, checks) the table `settings` asks for: the
/// paper's actuator in [`TABLE_SAND`], or a rig's in its own solver sand.
pub fn generate(settings: &TablesSettings) -> Result<Generated> {
    let out = settings
        .out
        .clone()
        .unwrap_or_else(|| settings.repo.join(GENERATED_PATH));
    let chosen = settings
        .skin_fit
        .as_ref()
        .map(skin::SkinFitChoice::read)
        .transpose()?;
    let (model, spec, mut command, warnings): (Box<dyn PressureModel>, _, _, _) =
        match &settings.rig {
            Some((rig_path, sand_path)) => {
                let (mut rig, file, mut warnings) = Rig::read_setup(rig_path)?;
                if let Some(c) = &chosen {
                    warnings.extend(rig.use_skin_fit(c.clone(), &file));
                }
                let sand = sand::SolverSand::load(sand_path)?;
                let model = model::pressure_model::SkinSandModel::for_rig(&rig, &file, sand)?;
                let command = format!(
                    "{DEFAULT_COMMAND} --rig {} --solver-sand {}",
                    rig_path.display(),
                    sand_path.display()
                );
                (Box::new(model), TableSpec::for_rig(&rig), command, warnings)
            }
            None => (
                TABLE_SAND.model_with_skin(&settings.repo, chosen.as_ref())?,
                TableSpec::default(),
                DEFAULT_COMMAND.to_owned(),
                chosen.iter().flat_map(|c| c.warnings.clone()).collect(),
            ),
        };
    if let Some(choice) = &settings.skin_fit {
        command = format!("{command} {}", choice.args());
    }
    let (path, outcome) = regenerate_at(&out, &spec, &*model, settings.check, &command)?;
    if let Some(image) = &settings.image {
        let table = GeneratedTable::sample(&spec, &*model)?;
        write_image(&table.as_table(), image)?;
    }
    Ok(Generated {
        path,
        outcome,
        warnings,
    })
}

/// Writes `table` as a binary image (the firmware's
/// [`urechis::table::image`] format, checked by reading it back) to `path`,
/// atomically.
pub fn write_image(table: &Table<'_>, path: &Path) -> Result<()> {
    let mut bytes = Vec::new();
    urechis::table::image::write_image(table, &mut |b| bytes.extend_from_slice(b));
    urechis::table::image::TableBuf::parse(&bytes).map_err(|e| {
        anyhow::anyhow!(
            "the table does not make a valid image ({e:?}): at most {} numbers fit the board",
            urechis::table::image::MAX_IMAGE_VALUES
        )
    })?;
    datafile::write_atomic(path, &bytes)
}

/// Regenerates the table file under `repo_root`, or with `check` only
/// compares and fails when the committed file differs from a fresh run.
pub fn regenerate(
    repo_root: &Path,
    model: &dyn PressureModel,
    check: bool,
) -> Result<(PathBuf, TablesOutcome)> {
    regenerate_at(
        &repo_root.join(GENERATED_PATH),
        &TableSpec::default(),
        model,
        check,
        DEFAULT_COMMAND,
    )
}

/// [`regenerate`] for any grid `spec`, into the file `path`, naming
/// `command` as the way to regenerate it.
pub fn regenerate_at(
    path: &Path,
    spec: &TableSpec,
    model: &dyn PressureModel,
    check: bool,
    command: &str,
) -> Result<(PathBuf, TablesOutcome)> {
    let mut table = GeneratedTable::sample(spec, model)?;
    table.command = command.to_string();
    let source = table.to_rust_source();
    let path = path.to_path_buf();
    let current = std::fs::read_to_string(&path).ok();
    if current.as_deref() == Some(source.as_str()) {
        return Ok((path, TablesOutcome::Unchanged));
    }
    if check {
        bail!(
            "{} is stale: it differs from a fresh `host-sim tables`; run `cargo sim tables` and commit the result",
            path.display()
        );
    }
    datafile::write_atomic(&path, source.as_bytes())
        .with_context(|| format!("writing {}", path.display()))?;
    Ok((path, TablesOutcome::Written))
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Linear;
    impl PressureModel for Linear {
        fn internal_pressure_kpa(&self, d: f64, h: f64) -> f64 {
            (d - 18.7) * 0.5 + h * 0.01 + 0.001 * d
        }
        fn provenance(&self) -> String {
            "test".into()
        }
        fn is_placeholder(&self) -> bool {
            true
        }
    }

    #[test]
    fn generation_is_deterministic_and_verifies() {
        let a = GeneratedTable::sample(&TableSpec::default(), &Linear).unwrap();
        let b = GeneratedTable::sample(&TableSpec::default(), &Linear).unwrap();
        assert_eq!(a.to_rust_source(), b.to_rust_source());
        assert_eq!(a.as_table().verify(), Ok(()));
        assert!(a.to_rust_source().contains("PLACEHOLDER"));
    }

    #[test]
    fn printed_floats_round_trip_exactly() {
        let t = GeneratedTable::sample(&TableSpec::default(), &Linear).unwrap();
        let src = t.to_rust_source();
        // Every printed value parses back to the same f32 the checksum used.
        for v in &t.pressure_kpa {
            let printed = format!("{v:?}");
            assert_eq!(printed.parse::<f32>().unwrap(), *v);
            assert!(src.contains(&printed));
        }
    }

    #[test]
    fn non_monotone_model_is_refused() {
        struct Flat;
        impl PressureModel for Flat {
            fn internal_pressure_kpa(&self, _: f64, _: f64) -> f64 {
                1.0
            }
            fn provenance(&self) -> String {
                "flat".into()
            }
            fn is_placeholder(&self) -> bool {
                true
            }
        }
        assert!(GeneratedTable::sample(&TableSpec::default(), &Flat).is_err());
    }

    /// The repository root (this crate is host-sim/crates/tables).
    fn repo_root() -> std::path::PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../..")
    }

    #[test]
    fn solver_table_verifies_and_names_its_data_file() {
        let root = repo_root();
        let model = TableSand::Solver.model(&root).unwrap();
        let table = GeneratedTable::sample(&TableSpec::default(), &*model).unwrap();
        assert_eq!(table.as_table().verify(), Ok(()));
        let sand = sand::SolverSand::from_repo(&root).unwrap();
        let source = table.to_rust_source();
        let header = format!(
            "FEM-DEM solver sand from {} (CRC-32 0x{:08X})",
            sand::solver::DATA_PATH,
            sand.crc32()
        );
        assert!(source.contains(&header), "{}", table.provenance);
        assert!(!table.placeholder);
    }

    #[test]
    fn committed_table_matches_a_fresh_generation() {
        let root = repo_root();
        let (_, outcome) = regenerate(&root, &*TABLE_SAND.model(&root).unwrap(), true).unwrap();
        assert_eq!(outcome, TablesOutcome::Unchanged);
    }
}
