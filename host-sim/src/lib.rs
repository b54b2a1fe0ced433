//! # host-sim
//!
//! Desktop physics and tools for the urechis burrowing actuator. The CLI in
//! `main.rs` is thin; every capability is a module here:
//!
//! - [`tables`]: generates the firmware's pressure→diameter table;
//! - [`skin`]: hyperelastic skin laws, their fit to tensile tests, and the
//!   inflation of the skin tube;
//! - [`sand`]: the sand laws p_e(D, h): parametric, and from the stored
//!   FEM–DEM solver results (`host-sim solver-sand` regenerates them);
//! - [`pressure_model`]: p_i = p_membrane + p_e, the table's physics;
//! - [`experiment`]: the experiment folder (rig.toml + CSV runs), read and
//!   written by every tool;
//! - [`telemetry`]: raw serial captures of the board's telemetry → experiment
//!   folders;
//! - [`dem`]: discrete-element sand (Hertz–Mindlin spheres, walls);
//! - [`mod@bench`]: the DEM throughput benchmark (`host-sim bench dem`);
//! - [`model`]: the reduced-order rig model (pump volume → reading), shared
//!   by the workbench and the emulator;
//! - [`effects`]: the library of physical effects the model can switch on;
//! - [`workbench`]: calibration, comparison and diagnosis of a model against
//!   an experiment folder (`compare`, `diagnose`, `ledger`);
//! - [`emulate`]: the firmware's controller closed around a simulated plant
//!   (scenarios, traces, QEMU replay recordings);
//! - [`simulate`]: the paper's expansion scenario in coarse-grained DEM sand
//!   coupled to the FEM skin (`host-sim simulate`);
//! - [`demo`]: the end-to-end demo on built-in defaults (`cargo demo`);
//! - [`files`]: atomic result files.

pub mod bench;
pub mod coupling;
pub mod dem;
pub mod demo;
pub mod effects;
pub mod emulate;
pub mod experiment;
pub mod fem;
pub mod files;
pub mod model;
pub mod pressure_model;
pub mod sand;
pub mod simulate;
pub mod skin;
pub mod tables;
pub mod telemetry;
pub mod workbench;

/// The p_i(D, h) model the firmware tables are generated from: the skin
/// tube in the sand [`tables::TABLE_SAND`] names (the FEM–DEM solver's is
/// read from the data file under the repository root `repo_root`,
/// [`sand::solver::DATA_PATH`]).
pub fn physics_model(
    repo_root: &std::path::Path,
) -> anyhow::Result<Box<dyn tables::PressureModel>> {
    tables::TABLE_SAND.model(repo_root)
}

/// The repository root this crate was built in (the parent of host-sim).
pub fn repo_root() -> std::path::PathBuf {
    let crate_dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    crate_dir
        .parent()
        .map_or_else(|| crate_dir.join(".."), std::path::Path::to_path_buf)
}
