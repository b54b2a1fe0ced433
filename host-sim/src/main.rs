//! `host-sim`: one command line over the library; parsing and dispatch only.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Result;
use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(
    name = "host-sim",
    version,
    about = "Physics, tables and tools for the urechis burrowing actuator"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
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
    Tables {
        /// Repository root (where the firmware's Cargo.toml is).
        #[arg(long, default_value_os_t = default_repo_root())]
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
    },
    /// Fit neo-Hookean, Mooney–Rivlin and Yeoh laws to a uniaxial test CSV
    /// (strain + cauchy_stress_kpa or nominal_stress_kpa); writes
    /// <stem>-fit.json and <stem>-fit.svg.
    FitSkin {
        /// The uniaxial test (shared/data-format.md).
        file: PathBuf,
        /// Folder for the JSON result and the SVG plot.
        #[arg(long, default_value = ".")]
        out: PathBuf,
    },
    /// The paper's scenario: the zone expanding from 18.7 to 25 mm in
    /// submerged coarse-grained DEM sand at a depth, coupled to the FEM
    /// skin; or your own actuator and sand with --rig. Writes samples.csv,
    /// pressures.svg, head.svg, summary.txt and VTK frames.
    Simulate {
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
        #[arg(long = "advance-mm", default_value_t = host_sim::simulate::scenario::PAPER_ADVANCE_M * 1e3)]
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
        head: host_sim::simulate::HeadSupport,
        /// The solid wall's hexahedra through the thickness (the paper's
        /// element family, rows graded to 0.35 mm at the clamped ends;
        /// default 2).
        #[arg(
            long = "solid-skin",
            value_name = "LAYERS",
            conflicts_with = "membrane_skin"
        )]
        solid_skin: Option<usize>,
        /// The skin as the mid-surface membrane instead of the solid wall:
        /// about 40 % of the cost, no bending, a third less peak stress
        /// (README-simulate).
        #[arg(long = "membrane-skin")]
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
        #[arg(long = "grain-modulus-mpa", default_value_t = host_sim::simulate::scenario::GRAIN_MODULUS_PA * 1e-6)]
        grain_modulus_mpa: f64,
        /// Young's modulus of the grains while the bed settles (MPa), then
        /// stiffened to --grain-modulus-mpa; the same value: one modulus
        /// throughout.
        #[arg(long = "deposition-modulus-mpa", default_value_t = host_sim::simulate::scenario::DEPOSITION_MODULUS_PA * 1e-6)]
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
        out: Option<PathBuf>,
        /// Shorter settling and expansion (about half the steps).
        #[arg(long)]
        quick: bool,
    },
    /// The paper's balloon experiment reproduced: the zone inflated where
    /// it lies at each depth, its skin matched to the balloon's own
    /// pressure at h = 0, p_i and Δp_i against the measured table ± SD.
    /// Writes balloon.csv, balloon.txt, balloon.svg and one hDEPTHmm
    /// ensemble folder per depth.
    Balloon {
        /// Depths of the balloon's axis (mm), comma-separated; default the
        /// experiment's.
        #[arg(long = "depths-mm", value_delimiter = ',', default_values_t = host_sim::sand::regenerate::DEPTHS_MM)]
        depths_mm: Vec<f64>,
        /// Beds per depth (seeds 1, 2, …).
        #[arg(long, default_value_t = host_sim::sand::regenerate::DEFAULT_SEEDS, value_parser = clap::value_parser!(u64).range(1..=1000))]
        seeds: u64,
        /// The balloon's own pressure at the injected volume (kPa), its
        /// reading at h = 0; default the paper's measured 13.59.
        #[arg(long = "free-pressure-kpa", default_value_t = host_sim::sand::BALLOON_FREE_PRESSURE_KPA)]
        free_pressure_kpa: f64,
        /// Grain radius of the coarse-grained sand (mm); default 1.5 mm, or
        /// the rig's grains when coarser.
        #[arg(long = "grain-radius-mm")]
        grain_radius_mm: Option<f64>,
        /// The shorter solver case (`simulate --quick`).
        #[arg(long)]
        quick: bool,
        /// Your balloon in your sand instead of the paper's: a rig.toml, or
        /// an experiment folder holding one (its actuator, skin, sand, fluid
        /// and box); the paper's measured table is then not beside it.
        #[arg(long)]
        rig: Option<PathBuf>,
        /// With --rig: final outer diameter of the zone (mm); default the
        /// paper's stretch 25/18.7 of the rig's initial diameter.
        #[arg(long = "final-diameter-mm", requires = "rig")]
        final_diameter_mm: Option<f64>,
        /// Folder for the results.
        #[arg(long, default_value = "out/balloon")]
        out: PathBuf,
    },
    /// Regenerate the stored FEM–DEM solver sand p_e(D, h) the tables use:
    /// runs `simulate` at each depth (default grain radius, no VTK), bins the
    /// sand's share of p_i over D and writes host-sim/data/sand/solver-pe.csv.
    SolverSand {
        /// The shorter solver case (`simulate --quick`).
        #[arg(long)]
        quick: bool,
        /// Data file to write; default: the repository's.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Depths of the zone's axis (mm), comma-separated.
        #[arg(long = "depths-mm", value_delimiter = ',', default_values_t = host_sim::sand::regenerate::DEPTHS_MM)]
        depths_mm: Vec<f64>,
        /// Your set-up instead of the paper's (a rig.toml or an experiment
        /// folder); needs --out (the repository's file is the paper's).
        #[arg(long, requires = "out")]
        rig: Option<PathBuf>,
        /// With --rig: final outer diameter of the zone (mm); default the
        /// paper's stretch 25/18.7 of the rig's initial diameter.
        #[arg(long = "final-diameter-mm", requires = "rig")]
        final_diameter_mm: Option<f64>,
        /// Beds per depth (seeds 1, 2, …), their samples pooled in the bins.
        #[arg(long, default_value_t = host_sim::sand::regenerate::DEFAULT_SEEDS, value_parser = clap::value_parser!(u64).range(1..=1000))]
        seeds: u64,
        /// Also keep the runs' results here, one hDEPTHmm folder per depth
        /// (each seed's `simulate` output, and the mean ± SD over seeds in
        /// ensemble.csv/.txt/.svg).
        #[arg(long = "runs-out")]
        runs_out: Option<PathBuf>,
    },
    /// Benchmarks (`bench dem`: the DEM throughput problem of shared/bench).
    Bench {
        #[command(subcommand)]
        what: BenchCommand,
    },
    /// Run the firmware's own controller against the emulated plant: a named
    /// scenario (`--list`), its trace written as an experiment folder with
    /// states.tsv, plot.svg and outcome.json; or record the QEMU replays.
    Emulate {
        /// Scenario name (see --list).
        #[arg(long, required_unless_present_any = ["list", "export_replay"])]
        scenario: Option<String>,
        /// Folder for the trace; default: emulate-NAME.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Seed of the plant's noise and bus errors.
        #[arg(long, default_value_t = host_sim::emulate::DEFAULT_SEED)]
        seed: u64,
        /// List the scenarios with what each must show.
        #[arg(long)]
        list: bool,
        /// Record the QEMU replays (tests/qemu/replay/*.bin and the index
        /// tests/qemu/src/replay_data.rs); with --scenario, only that one.
        #[arg(long = "export-replay")]
        export_replay: bool,
        /// With --export-replay: write nothing, fail if a committed
        /// recording differs from what the host produces now.
        #[arg(long, requires = "export_replay")]
        check: bool,
        /// Repository root (for --export-replay).
        #[arg(long, default_value_os_t = default_repo_root())]
        repo: PathBuf,
    },
    /// Convert a raw serial capture of the board's telemetry into an
    /// experiment folder (rig.toml + runs.csv).
    Telemetry {
        /// Bytes as read from the virtual COM port.
        capture: PathBuf,
        /// Experiment folder to write.
        #[arg(long)]
        out: PathBuf,
        /// The set-up (rig.toml); default: the paper's.
        #[arg(long)]
        rig: Option<PathBuf>,
        /// Run id; default: the capture's file stem.
        #[arg(long)]
        run: Option<String>,
        /// Sand cover above the actuator axis (mm); default: from the
        /// board's Params replies in the capture.
        #[arg(long = "depth-mm")]
        depth_mm: Option<f64>,
    },
    /// Calibrate the model (model.toml's effects, or the baseline) on an
    /// experiment folder and show where it fails: residual statistics by
    /// run, depth, flow rate and phase, sentences, SVG plots in EXP/workbench/.
    Compare {
        /// Experiment folder (shared/data-format.md).
        exp: PathBuf,
    },
    /// Find the missing physical effect: rank every library effect by
    /// ΔBIC and held-out error, select greedily, report parameters with
    /// uncertainties and any unexplained residual. With --add, add an effect
    /// to EXP/model.toml, refit and append EXP/ledger.json.
    Diagnose {
        /// Experiment folder.
        exp: PathBuf,
        /// Print the diagnosis as JSON (documented in host-sim/README-workbench.md).
        #[arg(long)]
        json: bool,
        /// Add this effect to the folder's model, refit, record in the ledger.
        #[arg(long)]
        add: Option<String>,
    },
    /// Print the folder's model ledger and plot the error per version
    /// (EXP/workbench/ledger.svg).
    Ledger {
        /// Experiment folder.
        exp: PathBuf,
    },
}

/// What `host-sim bench` measures.
#[derive(Subcommand)]
enum BenchCommand {
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
}

/// `bench dem --simd`.
#[derive(Clone, Copy, clap::ValueEnum)]
enum SimdChoice {
    Best,
    Baseline,
}

/// Reads the set-up `path` names: a rig.toml, or the one in an experiment
/// folder; prints its warnings. Returns the rig and the path, for errors.
fn read_rig(path: &std::path::Path) -> Result<(host_sim::experiment::Rig, String)> {
    let file = if path.is_dir() {
        path.join("rig.toml")
    } else {
        path.to_path_buf()
    };
    let (rig, warnings) = host_sim::experiment::Rig::read(&file)?;
    for w in warnings {
        eprintln!("warning: {w}");
    }
    Ok((rig, file.display().to_string()))
}

/// The rig at `path` (a rig.toml or an experiment folder) with the zone's
/// final diameter, for the commands that run the solver at several depths.
fn read_rig_setup(
    path: Option<PathBuf>,
    final_diameter_mm: Option<f64>,
) -> Result<Option<host_sim::sand::regenerate::RigSetup>> {
    path.map(|p| {
        read_rig(&p).map(|(rig, file)| host_sim::sand::regenerate::RigSetup {
            rig,
            file,
            final_diameter_mm,
        })
    })
    .transpose()
}

/// The solver's grain radius (m): `given_mm` if given, else the rig's
/// grains when coarser than the default, else the default.
fn grain_radius_m(given_mm: Option<f64>, rig: Option<&host_sim::experiment::Rig>) -> f64 {
    given_mm.map_or_else(
        || {
            rig.map_or(
                host_sim::simulate::scenario::DEFAULT_GRAIN_RADIUS_M,
                host_sim::simulate::ScenarioSpec::grain_radius_for,
            )
        },
        |r| r * 1e-3,
    )
}

fn default_repo_root() -> PathBuf {
    host_sim::repo_root()
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Demo { out } => {
            let report = host_sim::demo::run(&out)?;
            for line in &report.lines {
                println!("- {line}");
            }
            println!("results in {}:", out.display());
            for file in &report.files {
                println!("  {}", file.display());
            }
        }
        Command::Tables {
            repo,
            check,
            rig,
            solver_sand,
            out,
        } => {
            use host_sim::tables::{regenerate_at, TableSpec, DEFAULT_COMMAND, GENERATED_PATH};
            let out = out.unwrap_or_else(|| repo.join(GENERATED_PATH));
            let (path, outcome) = match (rig, solver_sand) {
                (Some(rig_path), Some(sand_path)) => {
                    let (rig, file) = read_rig(&rig_path)?;
                    let sand = host_sim::sand::SolverSand::load(&sand_path)?;
                    let model =
                        host_sim::pressure_model::SkinSandModel::for_rig(&rig, &file, sand)?;
                    let command = format!(
                        "{DEFAULT_COMMAND} --rig {} --solver-sand {}",
                        rig_path.display(),
                        sand_path.display()
                    );
                    regenerate_at(&out, &TableSpec::for_rig(&rig), &model, check, &command)?
                }
                _ => {
                    let model = host_sim::physics_model(&repo)?;
                    regenerate_at(&out, &TableSpec::default(), &*model, check, DEFAULT_COMMAND)?
                }
            };
            println!("{}: {:?}", path.display(), outcome);
        }
        Command::FitSkin { file, out } => {
            let done = host_sim::skin::report::fit_skin(&file, &out)?;
            for w in &done.report.input.warnings {
                eprintln!("warning: {w}");
            }
            print!("{}", done.report.table());
            println!(
                "wrote {} and {}",
                done.json_path.display(),
                done.svg_path.display()
            );
        }
        Command::Simulate {
            depth_mm,
            rig,
            final_diameter_mm,
            grain_radius_mm,
            expansion_s,
            advance_mm,
            advance_hold_ms,
            head,
            solid_skin,
            membrane_skin,
            skin_mass_unscaled,
            face_grain_radius_mm,
            grain_modulus_mpa,
            deposition_modulus_mpa,
            surcharge_above_mm,
            seed,
            seeds,
            out,
            quick,
        } => {
            use host_sim::simulate::{simulate, Options, ScenarioSpec};
            let rig = rig.map(|p| read_rig(&p)).transpose()?;
            let r = grain_radius_m(grain_radius_mm, rig.as_ref().map(|(rig, _)| rig));
            let h = depth_mm * 1e-3;
            let mut spec = if quick {
                ScenarioSpec::quick(h, r)
            } else {
                ScenarioSpec::paper(h, r)
            };
            let final_m = final_diameter_mm.map(|d| d * 1e-3);
            if let Some((rig, file)) = &rig {
                let (with_rig, notes) = spec.with_rig(rig, file, final_m)?;
                spec = with_rig;
                for n in notes {
                    eprintln!("note: {n}");
                }
            } else if let Some(d) = final_m {
                spec.final_diameter_m = d;
            }
            if let Some(above) = surcharge_above_mm {
                spec = spec.with_surcharge(above * 1e-3, 2);
            }
            spec.seed = seed;
            spec.face_grain_radius_m = face_grain_radius_mm.map(|f| f * 1e-3);
            spec.advance_m = advance_mm * 1e-3;
            spec.advance_hold_s = advance_hold_ms * 1e-3;
            spec.head = head;
            if let Some(layers) = solid_skin {
                anyhow::ensure!(layers >= 1, "--solid-skin: at least 1 layer");
                spec = spec.with_solid(layers);
            }
            if membrane_skin {
                spec = spec.with_membrane();
            }
            spec.skin_mass_scaling = !skin_mass_unscaled;
            spec.grain_modulus_pa = grain_modulus_mpa * 1e6;
            spec.deposition_modulus_pa = deposition_modulus_mpa * 1e6;
            if let Some(t) = expansion_s {
                spec.expansion_s = t;
            }
            let out = out.unwrap_or_else(|| PathBuf::from(format!("out/simulate-h{depth_mm}mm")));
            if seeds > 1 {
                let list: Vec<u64> = (seed..seed.saturating_add(seeds)).collect();
                let ensemble = host_sim::simulate::Ensemble::run(&spec, &list, Some(&out), true)?;
                for r in &ensemble.reports {
                    println!("seed {}:", r.spec.seed);
                    print!("{}", r.text());
                }
                print!("{}", ensemble.text());
            } else {
                let report = simulate(&Options {
                    spec,
                    out: Some(out.clone()),
                    progress: true,
                })?;
                print!("{}", report.text());
            }
            println!("wrote {}", out.display());
        }
        Command::SolverSand {
            quick,
            out,
            depths_mm,
            rig,
            final_diameter_mm,
            seeds,
            runs_out,
        } => {
            use host_sim::sand::regenerate::{regenerate, RegenerateOptions};
            let out =
                out.unwrap_or_else(|| default_repo_root().join(host_sim::sand::solver::DATA_PATH));
            let rig = read_rig_setup(rig, final_diameter_mm)?;
            let opts = RegenerateOptions {
                depths_mm,
                quick,
                progress: true,
                rig,
                seeds,
                runs_out,
            };
            regenerate(&opts, &out, |run| {
                println!(
                    "h = {} mm: final p_e (the sand's share of p_i) {:.3} ± {:.3} kPa over {seeds} seed(s) at D {:.2} mm, {} bins from D {:.2} mm, {} grains, wall {:.1} s",
                    run.depth_mm,
                    run.final_p_e_kpa,
                    run.final_p_e_sd_kpa,
                    run.final_diameter_mm,
                    run.bins.len(),
                    run.settled_diameter_mm,
                    run.grains,
                    run.wall_s
                );
            })?;
            println!("wrote {}", out.display());
        }
        Command::Balloon {
            depths_mm,
            seeds,
            free_pressure_kpa,
            grain_radius_mm,
            quick,
            rig,
            final_diameter_mm,
            out,
        } => {
            use host_sim::simulate::balloon::{run, BalloonOptions};
            let rig = read_rig_setup(rig, final_diameter_mm)?;
            let r = grain_radius_m(grain_radius_mm, rig.as_ref().map(|s| &s.rig));
            let opts = BalloonOptions {
                depths_m: depths_mm.iter().map(|h| h * 1e-3).collect(),
                grain_radius_m: r,
                free_pressure_pa: free_pressure_kpa * 1e3,
                quick,
                rig,
                out: Some(out.clone()),
                progress: true,
                ..BalloonOptions::paper(seeds)
            };
            if let Some(&h) = opts.depths_m.first() {
                for n in opts.spec(h)?.1 {
                    eprintln!("note: {n}");
                }
            }
            print!("{}", run(&opts)?.text());
            println!("wrote {}", out.display());
        }
        Command::Bench {
            what:
                BenchCommand::Dem {
                    workers,
                    steps_scale,
                    simd,
                },
        } => {
            let report = host_sim::bench::run(&host_sim::bench::BenchOptions {
                workers,
                steps_scale,
                progress: true,
                simd: match simd {
                    SimdChoice::Best => host_sim::dem::best_simd(),
                    SimdChoice::Baseline => host_sim::dem::Simd::Baseline,
                },
            })?;
            print!("{}", report.table());
        }
        Command::Emulate {
            scenario,
            out,
            seed,
            list,
            export_replay,
            check,
            repo,
        } => {
            use host_sim::emulate;
            if list {
                print!("{}", emulate::scenario::list_text()?);
            } else if export_replay {
                let done = emulate::replay::export(&repo, seed, scenario.as_deref(), check)?;
                for (name, steps) in &done.steps {
                    println!("{name}: {steps} steps");
                }
                let verb = if check { "checked" } else { "wrote" };
                println!(
                    "{verb} {} files ({} bytes of recordings)",
                    done.files.len(),
                    done.bytes
                );
            } else if let Some(name) = scenario {
                let trace = emulate::run(&emulate::named(&name)?, seed)?;
                let outcome = emulate::evaluate(&trace);
                let dir = out.unwrap_or_else(|| PathBuf::from(format!("emulate-{name}")));
                emulate::trace::write(&trace, &outcome, &dir)?;
                print!("{}", outcome.text());
                println!("wrote {}", dir.display());
                anyhow::ensure!(
                    outcome.passed(),
                    "scenario `{name}` did not show its expected outcome"
                );
            }
        }
        Command::Compare { exp } => {
            print!("{}", host_sim::workbench::commands::compare(&exp)?.text());
        }
        Command::Diagnose { exp, json, add } => {
            let outcome = host_sim::workbench::commands::diagnose_folder(
                &exp,
                add.as_deref(),
                &host_sim::workbench::diagnose::DiagnoseOptions::default(),
            )?;
            match (&outcome, json) {
                (host_sim::workbench::commands::DiagnoseOutcome::Diagnosis(d), true) => {
                    println!("{}", serde_json::to_string_pretty(d)?);
                }
                _ => print!("{}", outcome.text()),
            }
        }
        Command::Ledger { exp } => {
            let (entries, svg) = host_sim::workbench::commands::ledger(&exp)?;
            print!("{}", host_sim::workbench::commands::ledger_text(&entries));
            println!("wrote {}", svg.display());
        }
        Command::Telemetry {
            capture,
            out,
            rig,
            run,
            depth_mm,
        } => {
            let done = host_sim::telemetry::convert_file(
                &capture,
                &out,
                rig.as_deref(),
                run.as_deref(),
                depth_mm,
            )?;
            for note in &done.notes {
                eprintln!("note: {note}");
            }
            for run in &done.experiment.runs {
                println!(
                    "run {}: {} samples at depth {} mm",
                    run.id,
                    run.samples.len(),
                    run.depth_mm
                );
            }
            println!("wrote {}", out.display());
        }
    }
    Ok(())
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    // The commands run on a worker of rayon's pool, not on the main thread:
    // from outside the pool every parallel loop is handed over and waited
    // on across threads (a futex wake and sleep each way), which was an
    // eighth of a simulation's time at a few parallel loops per DEM step.
    match rayon::scope(|_| run(cli)) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
