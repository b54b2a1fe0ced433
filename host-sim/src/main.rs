//! `host-sim`: one command line over the host-sim crates. Arguments become
//! settings ([`args`]); each subcommand is one library call and the
//! printing of what it returns.

mod args;
mod board;

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, Result};
use burrow::cases::{Part, Runner};
use clap::Parser;

use args::{BenchCommand, Cli, Command};

fn main() -> ExitCode {
    let cli = Cli::parse();
    // The command line as given: a shard's manifest keeps it, so that the
    // merge can run the same command over the parts' records.
    let argv: Vec<String> = std::env::args().skip(1).collect();
    // The commands run on a worker of rayon's pool, not on the main thread:
    // from outside the pool every parallel loop is handed over and waited
    // on across threads (a futex wake and sleep each way), which was an
    // eighth of a simulation's time at a few parallel loops per DEM step.
    match rayon::scope(|_| run(cli, argv)) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn run(cli: Cli, argv: Vec<String>) -> Result<()> {
    match cli.command {
        Command::Demo { out } => demo(&out),
        Command::Tables(a) => tables(a.settings()),
        Command::FitSkin(a) => fit_skin(&a),
        Command::Simulate(a) => {
            let part = shard_part(a.shard);
            simulate(a.settings(), part, part_command(&argv, &["--out"]))
        }
        Command::Balloon(a) => {
            let part = shard_part(a.shard);
            balloon(a, part, part_command(&argv, &["--out"]))
        }
        Command::Merge { out, parts } => merge(&out, &parts),
        Command::SolverSand(a) => {
            let part = shard_part(a.shard);
            let command = part_command(&argv, &["--out", "--runs-out"]);
            solver_sand(a, part, command)
        }
        Command::SandTest(a) => {
            let part = shard_part(a.shard);
            sand_test(a, part, part_command(&argv, &["--out"]))
        }
        Command::Validate(a) => {
            let part = shard_part(a.shard);
            validate(a, part, part_command(&argv, &["--out"]))
        }
        Command::Cavity(a) => cavity(a),
        Command::Bench {
            what:
                BenchCommand::Dem {
                    workers,
                    steps_scale,
                    simd,
                },
        } => {
            let report = dem::benchmark::run(&dem::benchmark::BenchOptions {
                workers,
                steps_scale,
                progress: true,
                simd: simd.level(),
            })?;
            print!("{}", report.table());
            Ok(())
        }
        Command::Bench {
            what:
                BenchCommand::Scaling {
                    tiles,
                    steps,
                    workers,
                },
        } => {
            let opts = dem::scaling::ScalingOptions {
                tiles,
                steps,
                workers,
            };
            let rows = dem::scaling::run(&opts, |what| eprintln!("{what}"))?;
            print!("{}", dem::scaling::table(&rows));
            Ok(())
        }
        Command::Emulate(a) => emulate(a),
        Command::Telemetry(a) => telemetry(a),
        Command::Compare { exp, skin } => {
            let choice = skin.choice();
            print!(
                "{}",
                workbench::commands::compare_with(&exp, choice.as_ref())?.text()
            );
            Ok(())
        }
        Command::Diagnose {
            exp,
            json,
            add,
            skin,
        } => diagnose(&exp, json, add.as_deref(), skin.choice()),
        Command::Board(a) => board::board(a),
        Command::VirtualBoard(a) => board::virtual_board(a),
        Command::Ledger { exp } => {
            let (entries, svg) = workbench::commands::ledger(&exp)?;
            print!("{}", workbench::commands::ledger_text(&entries));
            println!("wrote {}", svg.display());
            Ok(())
        }
    }
}

/// The repository root this binary was built in (the parent of host-sim).
fn default_repo_root() -> PathBuf {
    let crate_dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    crate_dir
        .parent()
        .map_or_else(|| crate_dir.join(".."), std::path::Path::to_path_buf)
}

fn warn(warnings: &[String]) {
    for w in warnings {
        eprintln!("warning: {w}");
    }
}

fn note(notes: &[String]) {
    for n in notes {
        eprintln!("note: {n}");
    }
}

fn demo(out: &std::path::Path) -> Result<()> {
    let report = demo::run(&default_repo_root(), out)?;
    for line in &report.lines {
        println!("- {line}");
    }
    println!("results in {}:", out.display());
    for file in &report.files {
        println!("  {}", file.display());
    }
    Ok(())
}

fn tables(settings: tables::TablesSettings) -> Result<()> {
    let done = tables::generate(&settings)?;
    warn(&done.warnings);
    println!("{}: {:?}", done.path.display(), done.outcome);
    Ok(())
}

fn fit_skin(a: &args::FitSkinArgs) -> Result<()> {
    let fit_modes = a
        .fit_modes
        .as_deref()
        .map(skin::choice::parse_fit_modes)
        .transpose()?;
    let spec = skin::choice::parse_inflation_law(&a.inflation_law)?;
    let tests = skin::report::read_tests(&a.files)?;
    let mut report = skin::report::FitSkinReport::from_tests(&tests, fit_modes.as_deref())?;
    if let Some(dir) = &a.inflation {
        let free = workbench::skin_inflation::FreeInflation::read(dir)?;
        warn(&free.warnings);
        let coupon = report.fit(spec.name).map(|f| (f, tests.as_slice()));
        report.inflation = Some(free.fit(spec, coupon)?);
    }
    warn(&report.warnings);
    let stem = skin::report::output_stem(&a.files);
    let done = skin::report::write_report(report, &tests, &stem, &a.out)?;
    print!("{}", done.report.table());
    println!(
        "wrote {} and {}",
        done.json_path.display(),
        done.svg_path.display()
    );
    Ok(())
}

/// The part of an ensemble a command line asks for.
fn shard_part(shard: Option<burrow::cases::Shard>) -> Part {
    shard.map_or(Part::Whole, Part::Shard)
}

/// The command line every part of an ensemble shares: `argv` without the
/// part (`--shard`) and the options naming the part's own folder.
fn part_command(argv: &[String], folders: &[&str]) -> Vec<String> {
    let names: Vec<&str> = std::iter::once("--shard")
        .chain(folders.iter().copied())
        .collect();
    shard::without_options(argv, &names)
}

/// After a command's cases: a shard says what it ran (and wrote its
/// manifest), the others print the command's results.
fn finish<T>(shard_line: Option<String>, done: Option<T>, print: impl FnOnce(T)) -> Result<()> {
    match (shard_line, done) {
        (Some(line), _) => println!("{line}"),
        (None, Some(done)) => print(done),
        (None, None) => anyhow::bail!("the command ran only some of its cases"),
    }
    Ok(())
}

fn simulate(
    settings: burrow::settings::SimulateSettings,
    part: Part,
    argv: Vec<String>,
) -> Result<()> {
    let plan = settings.plan()?;
    warn(&plan.warnings);
    note(&plan.notes);
    let out = plan.out().to_path_buf();
    let runner = Runner::new(part, Some(&out), argv)?;
    let done = plan.run_part(&runner)?;
    finish(runner.finish()?, done, |outcome| {
        print!("{}", outcome.text());
        println!("wrote {}", out.display());
    })
}

/// `host-sim merge`: the parts gathered into `out`, then their command run
/// over the records there.
fn merge(out: &std::path::Path, parts: &[PathBuf]) -> Result<()> {
    let command = shard::assemble(parts, out)?;
    let cli = Cli::try_parse_from(std::iter::once("host-sim".to_string()).chain(command.clone()))
        .map_err(|e| {
        anyhow::anyhow!("merge: the parts' command `{}`: {e}", command.join(" "))
    })?;
    match cli.command {
        Command::Simulate(mut a) => {
            a.out = Some(out.to_path_buf());
            simulate(a.settings(), Part::Merge, command)
        }
        Command::Balloon(mut a) => {
            a.out = out.to_path_buf();
            balloon(a, Part::Merge, command)
        }
        Command::SandTest(mut a) => {
            a.out = out.to_path_buf();
            sand_test(a, Part::Merge, command)
        }
        Command::Validate(mut a) => {
            a.out = out.to_path_buf();
            validate(a, Part::Merge, command)
        }
        Command::SolverSand(mut a) => {
            // The data file beside the runs, under the repository's name.
            let name = std::path::Path::new(sand::solver::DATA_PATH)
                .file_name()
                .context("the solver data path has a file name")?;
            a.runs_out = Some(out.to_path_buf());
            a.out = Some(out.join(name));
            solver_sand(a, Part::Merge, command)
        }
        _ => anyhow::bail!(
            "merge: the parts ran `{}`, which is not a command that splits",
            command.join(" ")
        ),
    }
}

fn balloon(a: args::BalloonArgs, part: Part, argv: Vec<String>) -> Result<()> {
    use burrow::balloon::{run_part, BalloonOptions};
    let (rig, warnings) = burrow::settings::rig_setup(
        a.rig.as_deref(),
        a.final_diameter_mm,
        a.skin.clone().choice().as_ref(),
    )?;
    warn(&warnings);
    let opts = BalloonOptions {
        depths_m: a.depths_mm.iter().map(|h| h * 1e-3).collect(),
        grain_radius_m: burrow::settings::grain_radius_m(
            a.grain_radius_mm,
            rig.as_ref().map(|s| &s.rig),
        ),
        free_pressure_pa: a.free_pressure_kpa * 1e3,
        quick: a.quick,
        rig,
        out: Some(a.out.clone()),
        progress: true,
        below_m: a.sand_box.below_mm.map(|v| v * 1e-3),
        box_width_m: a.sand_box.box_width_mm.map(|v| v * 1e-3),
        expansion_s: a.expansion_s,
        ..BalloonOptions::paper(a.seeds)
    };
    if let Some(&h) = opts.depths_m.first() {
        note(&opts.spec(h)?.1);
    }
    let runner = Runner::new(part, Some(&a.out), argv)?;
    let done = run_part(&opts, &runner)?;
    finish(runner.finish()?, done, |run| {
        print!("{}", run.text());
        println!("wrote {}", a.out.display());
    })
}

fn validate(a: args::ValidateArgs, part: Part, argv: Vec<String>) -> Result<()> {
    use burrow::validate::{run_part, ValidateOptions};
    let opts = ValidateOptions {
        reduced: a.reduced,
        seeds: a.seeds,
        out: a.out.clone(),
        progress: true,
    };
    let runner = Runner::new(part, Some(&a.out), argv)?;
    let done = run_part(&opts, &runner)?;
    finish(runner.finish()?, done, |v| {
        print!("{}", v.markdown());
        println!("wrote {}", a.out.join("validation.md").display());
    })
}

fn sand_test(a: args::SandTestArgs, part: Part, command: Vec<String>) -> Result<()> {
    let plan = sandtest::study::Plan {
        radii_mm: a.radii_mm,
        seeds: a.seeds,
        grains: a.grains,
        confining_kpa: a.confining_kpa,
        axial_strain: a.axial_strain,
    };
    let cases = shard::Cases::new(part, Some(&a.out), command)?;
    let done = sandtest::study::run(&plan, &a.out, &cases, part != Part::Merge)?;
    finish(cases.finish()?, done, |study| {
        print!("{}", study.summary().text());
        println!("wrote {}", a.out.display());
    })
}

fn cavity(a: args::CavityArgs) -> Result<()> {
    let problem = cavity::Cavity::default();
    let bed = cavity::Bed::read(&a.bed)?;
    if let Some(path) = &a.dem_curve {
        let bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
        let dem = cavity::Curve::parse_csv(&path.display().to_string(), &bytes)?;
        return cavity_estimate(&a, &problem, &bed, &dem);
    }
    let schedule = cavity::Schedule::new(a.expansion_s, problem.relax_s, problem.dt_s)?;
    let peer = if a.peer_avg.is_empty() {
        None
    } else {
        let paths: Vec<&std::path::Path> = a.peer_avg.iter().map(|p| p.as_path()).collect();
        Some(cavity::Curve::from_lammps(&paths, &schedule, &problem)?)
    };
    let started = std::time::Instant::now();
    let ours = cavity::run_with_progress(&problem, &bed, a.expansion_s)?;
    let info = cavity::RunInfo {
        bed: a.bed.display().to_string(),
        spheres: bed.len(),
        expansion_s: a.expansion_s,
        window_steps: schedule.window_steps,
        start_step: schedule.start_step,
        end_step: schedule.end_step(),
        wall_s: started.elapsed().as_secs_f64(),
        workers: rayon::current_num_threads(),
    };
    let comparison = cavity::write_report(&a.out, &info, &ours, peer.as_ref())?;
    println!(
        "{} spheres, {} steps in {:.1} s ({:.2} M particle-steps/s); p_e at rest {:.4} kPa, at 100 % {:.4} kPa",
        bed.len(),
        schedule.end_step(),
        info.wall_s,
        bed.len() as f64 * schedule.end_step() as f64 / info.wall_s / 1e6,
        ours.at_rest_kpa,
        ours.expansion.last().map_or(f64::NAN, |w| w.pe_kpa)
    );
    if let Some(c) = comparison {
        println!("percent  D (mm)  ours (kPa)  LAMMPS (kPa)  difference");
        for r in &c.rows {
            println!(
                "{:>7}  {:>6.3}  {:>10.4}  {:>12.4}  {:>+9.1} %",
                r.percent, r.d_mm, r.ours_kpa, r.peer_kpa, r.difference_percent
            );
        }
        println!(
            "largest difference over the expansion: {:.1} %",
            c.worst_percent
        );
    }
    if a.friction_deg.is_some() {
        return cavity_estimate(&a, &problem, &bed, &ours);
    }
    println!("wrote {}", a.out.display());
    Ok(())
}

/// `cavity --friction-deg …`: the continuum estimate beside the DEM curve.
fn cavity_estimate(
    a: &args::CavityArgs,
    problem: &cavity::Cavity,
    bed: &cavity::Bed,
    dem: &cavity::Curve,
) -> Result<()> {
    let (Some(friction_deg), Some(dilatancy_deg)) = (a.friction_deg, a.dilatancy_deg) else {
        anyhow::bail!("--dem-curve needs --friction-deg and --dilatancy-deg");
    };
    let e = cavity::write_estimate(
        &a.out,
        problem,
        bed,
        dem,
        cavity::EstimateInput {
            friction_deg,
            dilatancy_deg,
            shear_modulus_kpa: a.shear_modulus_kpa,
            poisson: a.poisson,
        },
    )?;
    println!(
        "continuum estimate: φ {friction_deg}°, ψ {dilatancy_deg}°, ν {}, p0 {:.4} kPa (the run's at rest), G {:.1} kPa ({}; far field: solid fraction {:.3}, {:.2} contacts per sphere), G/p0 {:.0}",
        a.poisson,
        e.theory.in_situ_kpa,
        e.theory.soil.shear_modulus_kpa,
        if e.shear_modulus_given { "given" } else { "Hertz–Mindlin effective medium, an upper estimate" },
        e.far_field.solid_fraction,
        e.far_field.coordination,
        e.theory.rigidity_index()
    );
    println!(
        "plastic zone at the end (large strain): radius {:.0} mm; the box's side walls are {:.0} mm from the axis, its floor {:.0} mm",
        e.plastic_radius_mm,
        1e3 * (problem.width_m - problem.axis_xz_m[0]),
        1e3 * problem.axis_xz_m[1]
    );
    println!("percent  D (mm)  DEM (kPa)  large strain (kPa)  small strain (kPa)");
    for r in &e.rows {
        println!(
            "{:>7}  {:>6.3}  {:>9.4}  {:>18.4}  {:>18.4}",
            r[0], r[1], r[2], r[3], r[4]
        );
    }
    println!("wrote {}", a.out.display());
    Ok(())
}

fn solver_sand(a: args::SolverSandArgs, part: Part, argv: Vec<String>) -> Result<()> {
    use burrow::solver_sand::{regenerate, RegenerateOptions};
    let out = a
        .out
        .unwrap_or_else(|| default_repo_root().join(sand::solver::DATA_PATH));
    let (rig, warnings) = burrow::settings::rig_setup(
        a.rig.as_deref(),
        a.final_diameter_mm,
        a.skin.clone().choice().as_ref(),
    )?;
    warn(&warnings);
    let seeds = a.seeds;
    let opts = RegenerateOptions {
        depths_mm: a.depths_mm,
        quick: a.quick,
        progress: true,
        rig,
        seeds,
        runs_out: a.runs_out,
    };
    let runner = Runner::new(part, opts.runs_out.as_deref(), argv)?;
    let done = regenerate(&opts, &out, &runner, |run| {
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
    finish(runner.finish()?, done, |_| {
        println!("wrote {}", out.display())
    })
}

fn emulate(a: args::EmulateArgs) -> Result<()> {
    if a.list {
        print!("{}", emulator::scenario::list_text()?);
    } else if a.export_replay {
        let done = emulator::replay::export(&a.repo, a.seed, a.scenario.as_deref(), a.check)?;
        for (name, steps) in &done.steps {
            println!("{name}: {steps} steps");
        }
        let verb = if a.check { "checked" } else { "wrote" };
        println!(
            "{verb} {} files ({} bytes of recordings)",
            done.files.len(),
            done.bytes
        );
    } else if let Some(name) = a.scenario {
        let trace = emulator::run(&emulator::named(&name)?, a.seed)?;
        let outcome = emulator::evaluate(&trace);
        let dir = a
            .out
            .unwrap_or_else(|| PathBuf::from(format!("emulate-{name}")));
        emulator::trace::write(&trace, &outcome, &dir)?;
        print!("{}", outcome.text());
        println!("wrote {}", dir.display());
        anyhow::ensure!(
            outcome.passed(),
            "scenario `{name}` did not show its expected outcome"
        );
    }
    Ok(())
}

fn telemetry(a: args::TelemetryArgs) -> Result<()> {
    let done = rig::telemetry::convert_file(
        &a.capture,
        &a.out,
        a.rig.as_deref(),
        a.run.as_deref(),
        a.depth_mm,
    )?;
    note(&done.notes);
    for run in &done.experiment.runs {
        println!(
            "run {}: {} samples at depth {} mm",
            run.id,
            run.samples.len(),
            run.depth_mm
        );
    }
    println!("wrote {}", a.out.display());
    Ok(())
}

fn diagnose(
    exp: &std::path::Path,
    json: bool,
    add: Option<&str>,
    skin: Option<skin::SkinFitChoice>,
) -> Result<()> {
    use workbench::commands::{diagnose_folder_with, DiagnoseOutcome};
    let (outcome, warnings) = diagnose_folder_with(
        exp,
        add,
        skin.as_ref(),
        &workbench::diagnose::DiagnoseOptions::default(),
    )?;
    warn(&warnings);
    match (&outcome, json) {
        (DiagnoseOutcome::Diagnosis(d), true) => println!("{}", serde_json::to_string_pretty(d)?),
        _ => print!("{}", outcome.text()),
    }
    Ok(())
}
