//! The command line: clap's definitions, and each subcommand's arguments
//! turned into the settings its library takes. No I/O here.

use std::num::NonZeroUsize;
use std::path::PathBuf;

use clap::{Args, Parser, Subcommand};

use burrow::settings::{SimulateSettings, SkinChoice};
use burrow::solver_sand::{DEFAULT_SEEDS, DEPTHS_MM};

/// host-sim's command line.
#[derive(Parser)]
#[command(
    name = "host-sim",
    version,
    about = "Physics, tables and tools for the urechis burrowing actuator"
)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands.
#[derive(Subcommand)]
pub enum Command {
    /// End-to-end demo on built-in defaults: skin fit, inflation in sand,
    /// firmware table check, the firmware's controller burrowing in the
    /// emulator, and the workbench's diagnosis of that run.
    Demo {
        /// Folder for every result.
        #[arg(long, default_value = "out/demo")]
        out: PathBuf,
    },
    /// Regenerate the firmware's pressure→diameter table (src/table/generated.rs)
    /// from the skin model and the sand of `tables::TABLE_SAND`.
    Tables(TablesArgs),
    /// Fit every skin law (neo-Hookean, Mooney–Rivlin, Yeoh, Gent, Ogden
    /// 1–3) to skin tests of any mode (uniaxial, equibiaxial, planar;
    /// shared/data-format.md), jointly, reporting R² and RMSE per mode;
    /// optionally fit some modes and predict the others, and fit a law's
    /// shape to an experiment folder's free inflation. Writes
    /// <stem>-fit.json and <stem>-fit.svg.
    FitSkin(FitSkinArgs),
    /// The paper's scenario: the zone expanding from 18.7 to 25 mm in
    /// submerged coarse-grained DEM sand at a depth, coupled to the FEM
    /// skin; or your own actuator and sand with --rig. Writes samples.csv,
    /// pressures.svg, head.svg, summary.txt and VTK frames.
    Simulate(Box<SimulateArgs>),
    /// The paper's balloon experiment reproduced: the zone inflated where
    /// it lies at each depth, its skin matched to the balloon's own
    /// pressure at h = 0, p_i and Δp_i against the measured table ± SD.
    /// Writes balloon.csv, balloon.txt, balloon.svg and one hDEPTHmm
    /// ensemble folder per depth.
    Balloon(BalloonArgs),
    /// Regenerate the stored FEM–DEM solver sand p_e(D, h) the tables use:
    /// runs `simulate` at each depth (default grain radius, no VTK), bins the
    /// sand's share of p_i over D and writes host-sim/data/sand/solver-pe.csv.
    SolverSand(SolverSandArgs),
    /// Regenerate the solver's validation table: the scenario at 40, 50,
    /// 70 and 100 mm and the balloon at its four depths over --seeds beds,
    /// each figure marked fitted, matched, imposed or predicted beside what
    /// it is compared with. Writes validation.json, validation.csv and
    /// validation.md (the docs' rows) into --out. Splits with --shard I/N
    /// and `merge`, as the ensembles do.
    Validate(ValidateArgs),
    /// Element tests of the DEM sand: drained triaxial compression (φ_peak,
    /// φ_cv, ψ) and the K0 oedometer test of the scenario's grains, over
    /// grain radii and seeds. Writes summary.json, summary.txt,
    /// triaxial.svg, oedometer.svg and one folder per test.
    SandTest(SandTestArgs),
    /// The code-to-code cavity benchmark (shared/cavity): a rigid cylinder,
    /// periodic along its axis, expanding from 18.7 to 25 mm in a settled
    /// bed. Writes pe.csv (p_e per 1 % of the expansion, the at-rest value
    /// as percent 0), pe.svg and summary.json; with --peer-avg, LAMMPS'
    /// averages of the same problem beside ours in comparison.csv.
    Cavity(CavityArgs),
    /// Gather the parts of an ensemble run split with --shard I/N (simulate
    /// --seeds, balloon, solver-sand, validate) into one folder and aggregate them:
    /// the same result files, bit for bit, as the run on one machine
    /// (only the timing files differ).
    Merge {
        /// Folder for the merged results (new, or empty).
        #[arg(long)]
        out: PathBuf,
        /// The parts' folders (each holding shard.json), every part once.
        #[arg(required = true, num_args = 1..)]
        parts: Vec<PathBuf>,
    },
    /// Benchmarks (`bench dem`: the DEM throughput problem of shared/bench).
    Bench {
        /// Which benchmark.
        #[command(subcommand)]
        what: BenchCommand,
    },
    /// Run the firmware's own controller against the emulated plant: a named
    /// scenario (`--list`), its trace written as an experiment folder with
    /// states.tsv, plot.svg and outcome.json; or record the QEMU replays.
    Emulate(EmulateArgs),
    /// Convert a raw serial capture of the board's telemetry into an
    /// experiment folder (rig.toml + runs.csv).
    Telemetry(TelemetryArgs),
    /// Calibrate the model (model.toml's effects, or the baseline) on an
    /// experiment folder and show where it fails: residual statistics by
    /// run, depth, flow rate and phase, sentences, SVG plots in EXP/workbench/.
    Compare {
        /// Experiment folder (shared/data-format.md).
        exp: PathBuf,
        /// The skin: a law from fit-skin's report instead of rig.toml's [skin].
        #[command(flatten)]
        skin: SkinFitArgs,
    },
    /// Find the missing physical effect: rank every library effect by
    /// ΔBIC and held-out error, select greedily, report parameters with
    /// uncertainties and any unexplained residual. With --add, add an effect
    /// to EXP/model.toml, refit and append EXP/ledger.json.
    Diagnose {
        /// Experiment folder.
        exp: PathBuf,
        /// Print the diagnosis as JSON (documented in host-sim/crates/workbench/README.md).
        #[arg(long)]
        json: bool,
        /// Add this effect to the folder's model, refit, record in the ledger.
        #[arg(long)]
        add: Option<String>,
        /// The skin: a law from fit-skin's report instead of rig.toml's [skin].
        #[command(flatten)]
        skin: SkinFitArgs,
    },
    /// Print the folder's model ledger and plot the error per version
    /// (EXP/workbench/ledger.svg).
    Ledger {
        /// Experiment folder.
        exp: PathBuf,
    },
    /// Drive a board over its serial link: the NUCLEO's ST-LINK virtual
    /// COM port (found by its USB ids), or a virtual board's
    /// pseudo-terminal with --port.
    Board(BoardArgs),
    /// The firmware's own board tasks on this computer, against the
    /// emulated plant, over a pseudo-terminal: prints `port: PATH` and
    /// serves until stopped (Ctrl-C).
    VirtualBoard(VirtualBoardArgs),
}

/// `host-sim board`.
#[derive(Args)]
pub struct BoardArgs {
    /// Serial port of the board; default: the ST-LINK virtual COM port.
    #[arg(long, global = true)]
    pub port: Option<String>,
    /// What to do.
    #[command(subcommand)]
    pub action: BoardAction,
}

/// `host-sim board` subcommands.
#[derive(Subcommand)]
pub enum BoardAction {
    /// Firmware, protocol and table versions, the table's CRC and where it
    /// came from, the pressure zero, state, faults, parameters.
    Info,
    /// The controller's parameter set as TOML.
    Params {
        /// Get or set.
        #[command(subcommand)]
        action: ParamsAction,
    },
    /// Start a run of N cycles and record it into an experiment folder,
    /// with a live status line; Ctrl-C stops the board first and keeps
    /// the data as DIR.partial.
    Run {
        /// Cycles to run (at least 1).
        #[arg(long)]
        cycles: u16,
        /// Sand cover above the actuator axis (mm).
        #[arg(long = "depth-mm")]
        depth_mm: f32,
        /// The set-up (rig.toml), copied into the folder.
        #[arg(long)]
        rig: PathBuf,
        /// Experiment folder to create.
        #[arg(long)]
        out: PathBuf,
        /// Run id in the folder.
        #[arg(long, default_value = "board")]
        run_id: String,
    },
    /// Stop the cycle safely (shrink back to rest, then Idle).
    Stop,
    /// Clear a latched fault (refused while its cause is present).
    Reset,
    /// Take the pressure zero now (head at rest in free water); stored on
    /// the board.
    Tare,
    /// Put a table image (`host-sim tables --image FILE`) on the board; it
    /// is used from the board's next boot.
    PushTable {
        /// The image.
        file: PathBuf,
    },
}

/// `host-sim board params`.
#[derive(Subcommand)]
pub enum ParamsAction {
    /// Print the parameters (or write them to --out).
    Get {
        /// TOML file to write.
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Replace the whole parameter set from a TOML file.
    Set {
        /// The TOML file (as `params get` writes it).
        file: PathBuf,
    },
}

/// `host-sim virtual-board`.
#[derive(Args)]
pub struct VirtualBoardArgs {
    /// An emulator scenario's plant and injected faults (`host-sim
    /// emulate --list`); default: the paper's actuator, healthy.
    #[arg(long)]
    pub scenario: Option<String>,
    /// Sand cover above the actuator axis (mm) without a scenario.
    #[arg(long = "depth-mm", default_value_t = 40.0)]
    pub depth_mm: f64,
    /// Seed of the plant's random draws.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Run the board's clock this many times faster than wall time (1 to
    /// 10; 1 = the board's real timing; 2 keeps every deadline on a loaded
    /// 2-core machine, faster ones need a faster host).
    #[arg(long, default_value_t = 1.0)]
    pub speed: f64,
}

/// `host-sim tables`.
#[derive(Args)]
pub struct TablesArgs {
    /// Repository root (where the firmware's Cargo.toml is).
    #[arg(long, default_value_os_t = crate::default_repo_root())]
    repo: PathBuf,
    /// Only compare with the committed file; fail if it is stale.
    #[arg(long)]
    check: bool,
    /// Your actuator instead of the paper's (a rig.toml or an experiment
    /// folder), in the sand of --solver-sand: the table for a firmware
    /// driving that actuator.
    #[arg(long, requires = "solver_sand")]
    rig: Option<PathBuf>,
    /// With --rig: the solver results for that rig
    /// (`solver-sand --rig ... --out FILE`).
    #[arg(long = "solver-sand", requires = "rig")]
    solver_sand: Option<PathBuf>,
    /// File to write; default: the firmware's src/table/generated.rs
    /// under --repo.
    #[arg(long)]
    out: Option<PathBuf>,
    /// The skin: a law from fit-skin's report instead of the default skin
    /// (or the rig's [skin]).
    #[command(flatten)]
    skin: SkinFitArgs,
    /// Also write the table as a binary image for `host-sim board
    /// push-table` (the board stores it in flash and uses it from its next
    /// boot).
    #[arg(long)]
    image: Option<PathBuf>,
}

impl TablesArgs {
    /// The table generator's settings.
    pub fn settings(self) -> tables::TablesSettings {
        tables::TablesSettings {
            repo: self.repo,
            check: self.check,
            rig: self.rig.zip(self.solver_sand),
            skin_fit: self.skin.choice(),
            out: self.out,
            image: self.image,
        }
    }
}

/// `host-sim simulate`: the case, then the knobs a calibration sweeps.
#[derive(Args)]
pub struct SimulateArgs {
    /// Depth of the zone's axis below the sand surface (mm).
    #[arg(long = "depth-mm", default_value_t = 40.0)]
    depth_mm: f64,
    /// Your set-up instead of the paper's: a rig.toml, or an experiment
    /// folder holding one (shared/data-format.md): actuator, skin, sand,
    /// fluid and box.
    #[arg(long)]
    rig: Option<PathBuf>,
    /// Final outer diameter of the zone (mm); default 25 mm, or with
    /// --rig the paper's stretch 25/18.7 of its initial diameter.
    #[arg(long = "final-diameter-mm")]
    final_diameter_mm: Option<f64>,
    /// Grain radius of the coarse-grained sand (mm); default 1.5 mm, or
    /// the rig's grains when coarser.
    #[arg(long = "grain-radius-mm")]
    grain_radius_mm: Option<f64>,
    /// Duration of the expansion (s); default 0.3 (0.15 with --quick).
    #[arg(long = "expansion-s")]
    expansion_s: Option<f64>,
    /// Advance the actuator this far (mm) into the settled sand before
    /// the expansion, as at the end of each burrowing cycle (0: expand
    /// from the bed at rest).
    #[arg(long = "advance-mm", default_value_t = burrow::scenario::PAPER_ADVANCE_M * 1e3)]
    advance_mm: f64,
    /// Pause after the advance (ms), the head held, before the zone
    /// inflates: how much of the face's load outlasts the head's motion.
    #[arg(long = "advance-hold-ms", default_value_t = 0.0)]
    advance_hold_ms: f64,
    /// What moves the head through the expansion: `drawn` (default:
    /// drawn back as the swelling zone's meridians would draw it if
    /// they kept their length, the body's longitudinal muscles),
    /// `free` (the skin and the sand on its face alone), `held` (a head
    /// on a rigid body), or a distance in mm (drawn back that far by
    /// the final diameter, the same square law).
    #[arg(long = "head", value_name = "SUPPORT", default_value = "drawn")]
    head: burrow::HeadSupport,
    /// The solid wall's hexahedra through the thickness (the paper's
    /// element family, rows graded to 0.35 mm at the clamped ends;
    /// default 2).
    #[arg(
        long = "solid-skin",
        value_name = "LAYERS",
        conflicts_with_all = ["membrane_skin", "shell_skin"]
    )]
    solid_skin: Option<NonZeroUsize>,
    /// The skin as the mid-surface membrane instead of the solid wall:
    /// about 40 % of the cost, no bending, a third less peak stress
    /// (host-sim/crates/burrow/README.md).
    #[arg(long = "membrane-skin", conflicts_with = "shell_skin")]
    membrane_skin: bool,
    /// Keep the solid wall's own mass while the bed settles instead of
    /// scaling it to the DEM step (slower; for checking the scaling).
    #[arg(long = "skin-mass-unscaled")]
    skin_mass_unscaled: bool,
    /// Finer grains (this radius, mm) in a block in front of the head,
    /// so more grains bear on its face; the time step follows them.
    #[arg(long = "face-grain-radius-mm")]
    face_grain_radius_mm: Option<f64>,
    /// Young's modulus of the grains during the advance and the
    /// expansion (MPa): stiffer grains overlap less and load the head
    /// harder as it advances, at a time step shorter as 1/√E.
    #[arg(long = "grain-modulus-mpa", default_value_t = burrow::scenario::GRAIN_MODULUS_PA * 1e-6)]
    grain_modulus_mpa: f64,
    /// Young's modulus of the grains while the bed settles (MPa), then
    /// stiffened to --grain-modulus-mpa; the same value: one modulus
    /// throughout.
    #[arg(long = "deposition-modulus-mpa", default_value_t = burrow::scenario::DEPOSITION_MODULUS_PA * 1e-6)]
    deposition_modulus_mpa: f64,
    /// Sand only up to this height above the axis (mm), the overburden
    /// above as a surcharge layer: cheaper, weaker (no shear strength).
    #[arg(long = "surcharge-above-mm")]
    surcharge_above_mm: Option<f64>,
    /// Seed of the grains' lattice jitter.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Run the case for this many seeds (seed, seed + 1, ...), each in
    /// its own seed-S folder, and report mean ± SD (ensemble.csv,
    /// ensemble.txt, and ensemble.svg: p_i, Δp_i, p_h against D).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u64).range(1..=1000))]
    seeds: u64,
    /// Folder for the results; default out/simulate-hDEPTH.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Run only part I of N of the seeds, into this part's own folder;
    /// `host-sim merge` gathers the parts (a Slurm job array: --shard
    /// $SLURM_ARRAY_TASK_ID/N with --array=1-N).
    #[arg(long)]
    pub shard: Option<shard::Shard>,
    /// Shorter settling and expansion (about half the steps).
    #[arg(long)]
    quick: bool,
    /// The skin: a law from fit-skin's report instead of the rig's [skin]
    /// or the paper's calibrated default skin, used as measured.
    #[command(flatten)]
    skin: SkinFitArgs,
    /// Calibration knobs: the case's defaults unless given.
    #[command(flatten)]
    knobs: CalibrationArgs,
}

/// The knobs a calibration sweep turns (`simulate`'s defaults otherwise).
#[derive(Args)]
#[command(next_help_heading = "Calibration")]
pub struct CalibrationArgs {
    /// The grains' rolling friction coefficient.
    #[arg(long = "rolling-friction")]
    rolling_friction: Option<f64>,
    /// The grains' sliding friction while the bed settles (then the
    /// sand's own).
    #[arg(long = "deposition-friction")]
    deposition_friction: Option<f64>,
    /// The grains' friction on the box's walls.
    #[arg(long = "wall-friction")]
    wall_friction: Option<f64>,
    /// The grains' friction on the skin.
    #[arg(long = "skin-friction")]
    skin_friction: Option<f64>,
    /// Every coefficient of the skin's law times this.
    #[arg(long = "skin-stiffness-scale")]
    skin_stiffness_scale: Option<f64>,
    /// The skin as a shell that resists bending (graded rows): about twice
    /// a case's cost, and outside linear shell theory where the paper's
    /// skin folds over the body's edge (host-sim/crates/burrow/README.md).
    #[arg(long = "shell-skin")]
    shell_skin: bool,
    /// The skin's mesh: nodes round and rows along, as AROUNDxALONG.
    #[arg(long = "skin-mesh", value_name = "AROUNDxALONG", value_parser = parse_mesh)]
    skin_mesh: Option<(usize, usize)>,
    /// Length of the skin's rows at the clamped ends (mm); 0: rows of
    /// equal length.
    #[arg(long = "skin-end-row-mm")]
    skin_end_row_mm: Option<f64>,
    /// Keep the zone's rings round: the sand's answer to a round expansion.
    #[arg(long = "round-zone")]
    round_zone: bool,
    /// Duration of the advance (s).
    #[arg(long = "advance-s")]
    advance_s: Option<f64>,
    /// Sand ahead of the zone's head (mm).
    #[arg(long = "ahead-mm")]
    ahead_mm: Option<f64>,
    /// The box the sand settles in.
    #[command(flatten)]
    sand_box: BoxArgs,
}

/// The box the sand settles in, where a run departs from its case's
/// (`simulate` and `balloon`).
#[derive(Args, Clone, Copy, Debug, Default)]
pub struct BoxArgs {
    /// The box's floor below the axis (mm); the settling time follows.
    #[arg(long = "below-mm")]
    pub below_mm: Option<f64>,
    /// The box's width (mm).
    #[arg(long = "box-width-mm")]
    pub box_width_mm: Option<f64>,
}

/// `AROUNDxALONG` → (around, along).
fn parse_mesh(s: &str) -> Result<(usize, usize), String> {
    let (a, b) = s
        .split_once('x')
        .ok_or_else(|| format!("`{s}`: expected AROUNDxALONG, e.g. 24x6"))?;
    let n = |v: &str| {
        v.trim()
            .parse::<usize>()
            .ok()
            .filter(|&n| n > 0)
            .ok_or_else(|| format!("`{v}` in `{s}`: expected a positive whole number"))
    };
    Ok((n(a)?, n(b)?))
}

impl SimulateArgs {
    /// The solver run's settings.
    pub fn settings(self) -> SimulateSettings {
        let k = self.knobs;
        let skin = match (self.solid_skin, self.membrane_skin, k.shell_skin) {
            (Some(layers), ..) => SkinChoice::Solid(layers),
            (None, true, _) => SkinChoice::Membrane,
            (None, false, true) => SkinChoice::Shell,
            (None, false, false) => SkinChoice::Default,
        };
        let out = self
            .out
            .unwrap_or_else(|| PathBuf::from(format!("out/simulate-h{}mm", self.depth_mm)));
        SimulateSettings {
            depth_mm: self.depth_mm,
            rig: self.rig,
            final_diameter_mm: self.final_diameter_mm,
            grain_radius_mm: self.grain_radius_mm,
            expansion_s: self.expansion_s,
            advance_mm: Some(self.advance_mm),
            advance_s: k.advance_s,
            advance_hold_ms: Some(self.advance_hold_ms),
            head: Some(self.head),
            skin,
            skin_mesh: k.skin_mesh,
            skin_end_row_mm: k.skin_end_row_mm,
            skin_mass_unscaled: self.skin_mass_unscaled,
            skin_stiffness_scale: k.skin_stiffness_scale,
            skin_friction: k.skin_friction,
            round_zone: k.round_zone,
            face_grain_radius_mm: self.face_grain_radius_mm,
            grain_modulus_mpa: Some(self.grain_modulus_mpa),
            deposition_modulus_mpa: Some(self.deposition_modulus_mpa),
            rolling_friction: k.rolling_friction,
            deposition_friction: k.deposition_friction,
            wall_friction: k.wall_friction,
            surcharge_above_mm: self.surcharge_above_mm,
            ahead_mm: k.ahead_mm,
            below_mm: k.sand_box.below_mm,
            box_width_mm: k.sand_box.box_width_mm,
            seed: self.seed,
            seeds: self.seeds,
            quick: self.quick,
            skin_fit: self.skin.choice(),
            out,
        }
    }
}

/// `host-sim balloon`.
#[derive(Args)]
pub struct BalloonArgs {
    /// Depths of the balloon's axis (mm), comma-separated; default the
    /// experiment's.
    #[arg(long = "depths-mm", value_delimiter = ',', default_values_t = DEPTHS_MM)]
    pub depths_mm: Vec<f64>,
    /// Beds per depth (seeds 1, 2, …).
    #[arg(long, default_value_t = DEFAULT_SEEDS, value_parser = clap::value_parser!(u64).range(1..=1000))]
    pub seeds: u64,
    /// The balloon's own pressure at the injected volume (kPa), its
    /// reading at h = 0; default the paper's measured 13.59.
    #[arg(long = "free-pressure-kpa", default_value_t = sand::BALLOON_FREE_PRESSURE_KPA)]
    pub free_pressure_kpa: f64,
    /// Grain radius of the coarse-grained sand (mm); default 1.5 mm, or
    /// the rig's grains when coarser.
    #[arg(long = "grain-radius-mm")]
    pub grain_radius_mm: Option<f64>,
    /// The shorter solver case (`simulate --quick`).
    #[arg(long)]
    pub quick: bool,
    /// Your balloon in your sand instead of the paper's: a rig.toml, or
    /// an experiment folder holding one (its actuator, skin, sand, fluid
    /// and box); the paper's measured table is then not beside it.
    #[arg(long)]
    pub rig: Option<PathBuf>,
    /// With --rig: final outer diameter of the zone (mm); default the
    /// paper's stretch 25/18.7 of the rig's initial diameter.
    #[arg(long = "final-diameter-mm", requires = "rig")]
    pub final_diameter_mm: Option<f64>,
    /// With --rig: the skin, a law from fit-skin's report instead of the
    /// rig's [skin] (the balloon's free pressure then scales it).
    #[command(flatten)]
    pub skin: SkinFitArgs,
    /// The box the sand settles in.
    #[command(flatten)]
    pub sand_box: BoxArgs,
    /// Nominal duration of the expansion (s): twice the default halves
    /// the injection rate.
    #[arg(long = "expansion-s")]
    pub expansion_s: Option<f64>,
    /// Folder for the results.
    #[arg(long, default_value = "out/balloon")]
    pub out: PathBuf,
    /// Run only part I of N of the cases (seeds × depths), into this
    /// part's own folder; `host-sim merge` gathers the parts (a Slurm job
    /// array: --shard $SLURM_ARRAY_TASK_ID/N with --array=1-N).
    #[arg(long)]
    pub shard: Option<shard::Shard>,
}

/// `host-sim sand-test` arguments.
#[derive(Args)]
pub struct SandTestArgs {
    /// Grain radii (mm), comma-separated.
    #[arg(long = "radii-mm", value_delimiter = ',', default_values_t = sandtest::study::Plan::default().radii_mm)]
    pub radii_mm: Vec<f64>,
    /// Seeds 1..=N of the grains' placement at each radius.
    #[arg(long, default_value_t = sandtest::study::Plan::default().seeds, value_parser = clap::value_parser!(u64).range(1..=1000))]
    pub seeds: u64,
    /// Grains in a sample.
    #[arg(long, default_value_t = sandtest::study::Plan::default().grains)]
    pub grains: usize,
    /// Confining stresses of the triaxial tests (kPa), comma-separated.
    #[arg(long = "confining-kpa", value_delimiter = ',', default_values_t = sandtest::study::Plan::default().confining_kpa)]
    pub confining_kpa: Vec<f64>,
    /// Axial strain each triaxial test ends at (−).
    #[arg(long = "axial-strain", default_value_t = sandtest::study::Plan::default().axial_strain)]
    pub axial_strain: f64,
    /// Folder for the results.
    #[arg(long, default_value = "out/sand-test")]
    pub out: PathBuf,
    /// Run only part I of N of the tests, into this part's own folder;
    /// `host-sim merge` gathers the parts.
    #[arg(long)]
    pub shard: Option<shard::Shard>,
}

/// `host-sim cavity` arguments.
#[derive(Args)]
pub struct CavityArgs {
    /// The settled bed (`id,x,y,z,radius` in m), e.g. shared/cavity/bed_h40.csv.
    #[arg(long)]
    pub bed: PathBuf,
    /// Duration of the expansion (s): 1 or 2 in the shared problem.
    #[arg(long, default_value_t = 1.0)]
    pub expansion_s: f64,
    /// Folder for the results.
    #[arg(long)]
    pub out: PathBuf,
    /// LAMMPS' `fix ave/time` output of in.expand for the same bed and
    /// duration (avg_TAG_segN.dat; every segment, in any order).
    #[arg(long, num_args = 1..)]
    pub peer_avg: Vec<PathBuf>,
    /// Add the continuum estimate (a cylindrical cavity in a Mohr–Coulomb
    /// medium, small and large strain) for this friction angle (degrees,
    /// e.g. φ measured by `sand-test`); writes theory.csv and theory.svg.
    #[arg(long, requires = "dilatancy_deg")]
    pub friction_deg: Option<f64>,
    /// The estimate's dilatancy angle ψ (degrees).
    #[arg(long, requires = "friction_deg")]
    pub dilatancy_deg: Option<f64>,
    /// The estimate's shear modulus of the bed (kPa); default: the
    /// Hertz–Mindlin effective-medium value at the run's p_e at rest.
    #[arg(long, requires = "friction_deg")]
    pub shear_modulus_kpa: Option<f64>,
    /// The estimate's Poisson's ratio of the bed.
    #[arg(long, default_value_t = 0.3)]
    pub poisson: f64,
    /// Take the DEM curve from this pe.csv of an earlier run instead of
    /// running the DEM (with --friction-deg: the estimate alone).
    #[arg(long, requires = "friction_deg")]
    pub dem_curve: Option<PathBuf>,
}

/// `host-sim solver-sand` arguments.
#[derive(Args)]
pub struct SolverSandArgs {
    /// The shorter solver case (`simulate --quick`).
    #[arg(long)]
    pub quick: bool,
    /// Data file to write; default: the repository's.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Depths of the zone's axis (mm), comma-separated.
    #[arg(long = "depths-mm", value_delimiter = ',', default_values_t = DEPTHS_MM)]
    pub depths_mm: Vec<f64>,
    /// Your set-up instead of the paper's (a rig.toml or an experiment
    /// folder); needs --out (the repository's file is the paper's).
    #[arg(long, requires = "out")]
    pub rig: Option<PathBuf>,
    /// With --rig: final outer diameter of the zone (mm); default the
    /// paper's stretch 25/18.7 of the rig's initial diameter.
    #[arg(long = "final-diameter-mm", requires = "rig")]
    pub final_diameter_mm: Option<f64>,
    /// With --rig: the skin, a law from fit-skin's report instead of the
    /// rig's [skin].
    #[command(flatten)]
    pub skin: SkinFitArgs,
    /// Beds per depth (seeds 1, 2, …), their samples pooled in the bins.
    #[arg(long, default_value_t = DEFAULT_SEEDS, value_parser = clap::value_parser!(u64).range(1..=1000))]
    pub seeds: u64,
    /// Also keep the runs' results here, one hDEPTHmm folder per depth
    /// (each seed's `simulate` output, and the mean ± SD over seeds in
    /// ensemble.csv/.txt/.svg).
    #[arg(long = "runs-out")]
    pub runs_out: Option<PathBuf>,
    /// Run only part I of N of the cases (depths × seeds) into --runs-out
    /// (needed), without the data file; `host-sim merge` gathers the parts
    /// and writes it into the merged folder.
    #[arg(long, requires = "runs_out")]
    pub shard: Option<shard::Shard>,
}

/// `host-sim validate` arguments.
#[derive(Args)]
pub struct ValidateArgs {
    /// Folder for the runs and the table.
    #[arg(long, default_value = "out/validate")]
    pub out: PathBuf,
    /// Beds per case (seeds 1, 2, …).
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u64).range(1..=1000))]
    pub seeds: u64,
    /// Only the reduced case CI pins (the scenario at 40 mm on a small,
    /// coarse bed; seconds a run).
    #[arg(long)]
    pub reduced: bool,
    /// Run only part I of N of the cases into --out; `host-sim merge`
    /// gathers the parts and writes the table into the merged folder.
    #[arg(long)]
    pub shard: Option<shard::Shard>,
}

/// What `host-sim bench` measures.
#[derive(Subcommand)]
pub enum BenchCommand {
    /// 20,000 spheres settling in a box (shared/bench); prints particle-steps/s.
    Dem {
        /// Worker threads.
        #[arg(long, default_value_t = 1)]
        workers: usize,
        /// Multiply every phase's step count (e.g. 0.05 for a smoke test).
        #[arg(long = "steps-scale", default_value_t = 1.0)]
        steps_scale: f64,
        /// Vector instructions of the contact pass: the best this CPU has
        /// (AVX2 where present), or the SSE2 baseline of every x86-64.
        /// Same results either way.
        #[arg(long, value_enum, default_value = "best")]
        simd: SimdChoice,
    },
    /// The cost per particle-step as the bed grows: the benchmark's grains
    /// settled once in a box periodic across, tiled k × k (20,000 grains
    /// per tile), every size set up first, then timed packed phases in
    /// which the sizes and worker counts take turns; prints
    /// particle-steps/s and each bed's memory per particle.
    Scaling {
        /// Tiles per side, comma-separated (1: 20,000 grains, 3: 180,000,
        /// 7: 980,000).
        #[arg(long, value_delimiter = ',', default_values_t = [1usize, 3, 7])]
        tiles: Vec<usize>,
        /// Timed steps at each size, in five rounds (the median round's
        /// rate is reported).
        #[arg(long, default_value_t = 500)]
        steps: u64,
        /// Worker thread counts, comma-separated.
        #[arg(long, value_delimiter = ',', default_values_t = [1usize, 2])]
        workers: Vec<usize>,
    },
}

/// `--skin-fit FILE [--skin-law NAME]`, shared by every command that
/// takes a skin.
#[derive(Args, Clone, Debug, Default)]
#[command(next_help_heading = "Skin")]
pub struct SkinFitArgs {
    /// fit-skin's JSON report: the skin is a law fitted there (any law:
    /// Gent, Ogden, …) instead of rig.toml's Yeoh [skin] or the default
    /// skin.
    #[arg(long = "skin-fit", value_name = "FILE")]
    pub skin_fit: Option<PathBuf>,
    /// Which law of --skin-fit: a name as fit-skin prints it, or
    /// `inflation` (the free-inflation fit); default: the inflation fit,
    /// which the report must then hold (host-sim/crates/skin/README.md).
    #[arg(long = "skin-law", value_name = "NAME", requires = "skin_fit")]
    pub skin_law: Option<String>,
}

impl SkinFitArgs {
    /// The choice, when --skin-fit is given.
    pub fn choice(self) -> Option<skin::SkinFitChoice> {
        self.skin_fit.map(|file| skin::SkinFitChoice {
            file,
            law: self.skin_law,
        })
    }
}

/// `fit-skin`'s arguments.
#[derive(clap::Args)]
pub struct FitSkinArgs {
    /// Skin-test CSV files (strain, cauchy_stress_kpa or
    /// nominal_stress_kpa, optional mode); several files or modes are
    /// fitted jointly.
    #[arg(required = true)]
    pub files: Vec<PathBuf>,
    /// Fit only these modes (comma separated: uniaxial, equibiaxial,
    /// planar) and predict the others; default: every mode given.
    #[arg(long = "fit-modes", value_delimiter = ',')]
    pub fit_modes: Option<Vec<String>>,
    /// Experiment folder whose free runs (depth 0) the law's shape is
    /// fitted to through the thick-walled tube, compared with the coupon
    /// fit of the same law.
    #[arg(long)]
    pub inflation: Option<PathBuf>,
    /// The law fitted to the inflation (a name as the fit table prints it).
    #[arg(long = "inflation-law", default_value = "Yeoh")]
    pub inflation_law: String,
    /// Folder for the JSON result and the SVG plot.
    #[arg(long, default_value = ".")]
    pub out: PathBuf,
}

/// `bench dem --simd`.
#[derive(Clone, Copy, clap::ValueEnum)]
pub enum SimdChoice {
    // No doc comments: clap would print them as each value's help.
    Best,
    Baseline,
}

impl SimdChoice {
    /// The DEM's instruction set for this choice on this CPU.
    pub fn level(self) -> dem::Simd {
        match self {
            SimdChoice::Best => dem::best_simd(),
            SimdChoice::Baseline => dem::Simd::Baseline,
        }
    }
}

/// `host-sim emulate`.
#[derive(Args)]
pub struct EmulateArgs {
    /// Scenario name (see --list).
    #[arg(long, required_unless_present_any = ["list", "export_replay"])]
    pub scenario: Option<String>,
    /// Folder for the trace; default: emulate-NAME.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Seed of the plant's noise and bus errors.
    #[arg(long, default_value_t = emulator::DEFAULT_SEED)]
    pub seed: u64,
    /// List the scenarios with what each must show.
    #[arg(long)]
    pub list: bool,
    /// Record the QEMU replays (tests/qemu/replay/*.bin and the index
    /// tests/qemu/src/replay_data.rs); with --scenario, only that one.
    #[arg(long = "export-replay")]
    pub export_replay: bool,
    /// With --export-replay: write nothing, fail if a committed
    /// recording differs from what the host produces now.
    #[arg(long, requires = "export_replay")]
    pub check: bool,
    /// Repository root (for --export-replay).
    #[arg(long, default_value_os_t = crate::default_repo_root())]
    pub repo: PathBuf,
}

/// `host-sim telemetry`.
#[derive(Args)]
pub struct TelemetryArgs {
    /// Bytes as read from the virtual COM port.
    pub capture: PathBuf,
    /// Experiment folder to write.
    #[arg(long)]
    pub out: PathBuf,
    /// The set-up (rig.toml); default: the paper's.
    #[arg(long)]
    pub rig: Option<PathBuf>,
    /// Run id; default: the capture's file stem.
    #[arg(long)]
    pub run: Option<String>,
    /// Sand cover above the actuator axis (mm); default: from the
    /// board's Params replies in the capture.
    #[arg(long = "depth-mm")]
    pub depth_mm: Option<f64>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_mesh_reads_as_around_by_along_and_bad_ones_are_named() {
        assert_eq!(parse_mesh("24x6"), Ok((24, 6)));
        assert!(parse_mesh("24").unwrap_err().contains("AROUNDxALONG"));
        assert!(parse_mesh("24x0").unwrap_err().contains("`0`"));
    }

    #[test]
    fn the_command_line_is_consistent() {
        use clap::CommandFactory;
        Cli::command().debug_assert();
    }

    #[test]
    fn simulate_flags_become_settings_in_si_free_units() {
        let cli = Cli::try_parse_from([
            "host-sim",
            "simulate",
            "--depth-mm",
            "70",
            "--solid-skin",
            "3",
            "--skin-mesh",
            "16x4",
            "--below-mm",
            "40",
        ])
        .unwrap();
        let Command::Simulate(args) = cli.command else {
            panic!("not simulate");
        };
        let s = args.settings();
        assert_eq!(s.depth_mm, 70.0);
        assert_eq!(s.skin, SkinChoice::Solid(NonZeroUsize::new(3).unwrap()));
        assert_eq!(s.skin_mesh, Some((16, 4)));
        assert_eq!(s.below_mm, Some(40.0));
        assert_eq!(s.out, PathBuf::from("out/simulate-h70mm"));
        // A solid wall and the membrane at once is refused.
        assert!(Cli::try_parse_from([
            "host-sim",
            "simulate",
            "--solid-skin",
            "2",
            "--membrane-skin"
        ])
        .is_err());
    }
}
