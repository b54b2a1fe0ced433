//! `host-sim demo`: the end-to-end chain on built-in defaults, no board and
//! no input files needed. Each step calls the same library code as its own
//! subcommand and writes its results under one folder:
//!
//! 1. fit the shipped *U. unicinctus* skin data (Neo-Hookean, Mooney–Rivlin,
//!    Yeoh; `skin/`);
//! 2. inflate the skin tube in sand: p_i(D) at the paper's depths against
//!    the balloon experiment (`pressure.svg`);
//! 3. regenerate the firmware's pressure→diameter table in memory, verify it
//!    with the firmware's own check and compare with the compiled-in one;
//! 4. emulate the firmware's controller burrowing at 4 cm against the
//!    simulated actuator in sand (`emulate/`: experiment folder + plot);
//! 5. diagnose the emulated run with the model workbench.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use plotters::prelude::*;

use ::plot::plot_err;
use datafile::write_atomic;
use model::pressure_model::SkinSandModel;
use sand::{SandLaw, BALLOON_FINAL_DIAMETER_MM, BALLOON_TABLE};
use tables::{GeneratedTable, PressureModel, TableSpec};

/// Where the shipped skin data set lives, under the repository root.
pub const DEFAULT_SKIN_CSV: &str = "host-sim/data/skin/unicinctus_circumferential.csv";

/// Where the demo reads from and writes to.
struct Paths<'a> {
    /// The repository root (the shipped data, the solver's stored sand).
    repo_root: &'a Path,
    /// The folder for every result.
    out_dir: &'a Path,
}

/// What the demo produced: one line per step for the terminal.
#[derive(Debug, Default)]
pub struct DemoReport {
    /// Human-readable summary lines, in step order.
    pub lines: Vec<String>,
    /// Every file written.
    pub files: Vec<PathBuf>,
}

/// Runs the whole chain on the data under `repo_root`, writing under
/// `out_dir`.
pub fn run(repo_root: &Path, out_dir: &Path) -> Result<DemoReport> {
    let paths = Paths { repo_root, out_dir };
    let steps: [(&str, StepFn); 5] = [
        ("fit the skin", step_skin),
        ("inflate in sand", step_pressure),
        ("firmware table", step_table),
        ("emulate burrowing", step_emulate),
        ("diagnose", step_diagnose),
    ];
    let bar = ProgressBar::new(steps.len() as u64);
    bar.set_style(
        ProgressStyle::with_template("{bar:30} {pos}/{len} {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let mut report = DemoReport::default();
    for (name, step) in steps {
        bar.set_message(name);
        step(&paths, &mut report).with_context(|| format!("demo step `{name}`"))?;
        bar.inc(1);
    }
    bar.finish_and_clear();
    Ok(report)
}

type StepFn = fn(&Paths, &mut DemoReport) -> Result<()>;

fn step_skin(paths: &Paths, report: &mut DemoReport) -> Result<()> {
    let out_dir = paths.out_dir;
    let out = skin::report::fit_skin(
        &paths.repo_root.join(DEFAULT_SKIN_CSV),
        &out_dir.join("skin"),
    )?;
    let mut line = String::from("skin fit (shipped U. unicinctus data):");
    for fit in &out.report.fits {
        let _ = write!(line, " {} R²={:.4};", fit.law, fit.r_squared);
    }
    report.lines.push(line);
    report.files.extend([out.json_path, out.svg_path]);
    Ok(())
}

fn step_pressure(paths: &Paths, report: &mut DemoReport) -> Result<()> {
    let out_dir = paths.out_dir;
    // The firmware table's model: the skin and the solver's stored sand.
    let model = SkinSandModel::paper_solver(paths.repo_root)?;
    let d0 = model.tube.geometry.outer_diameter_mm;
    let depths_mm = [0.0, 40.0, 50.0, 70.0, 100.0];
    let diameters: Vec<f64> = (0..=63).map(|i| d0 + 0.1 * f64::from(i)).collect();
    let curves: Vec<(f64, Vec<(f64, f64)>)> = depths_mm
        .iter()
        .map(|&h| {
            let pts = diameters
                .iter()
                .map(|&d| (d, model.internal_pressure_kpa(d, h)))
                .collect();
            (h, pts)
        })
        .collect();
    let path = out_dir.join("pressure.svg");
    write_atomic(&path, pressure_svg(&curves)?.as_bytes())?;
    report.files.push(path);

    let membrane = model.membrane_kpa(BALLOON_FINAL_DIAMETER_MM)?;
    let mut line = format!(
        "p_membrane(25 mm) = {membrane:.2} kPa; solver p_e at 25 mm vs balloon experiment:"
    );
    for point in BALLOON_TABLE {
        let pe = model
            .sand
            .loading_pressure_kpa(BALLOON_FINAL_DIAMETER_MM, point.depth_mm);
        let _ = write!(
            line,
            " {:.0} cm {pe:.2} ({:.2} ± {:.2});",
            point.depth_mm / 10.0,
            point.external_pressure_kpa,
            point.sd_kpa
        );
    }
    report.lines.push(line);
    Ok(())
}

fn pressure_svg(curves: &[(f64, Vec<(f64, f64)>)]) -> Result<String> {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (800, 520)).into_drawing_area();
        root.fill(&WHITE).map_err(plot_err)?;
        let x_max = curves
            .iter()
            .flat_map(|(_, c)| c.iter().map(|p| p.0))
            .fold(0.0_f64, f64::max);
        let x_min = curves
            .iter()
            .flat_map(|(_, c)| c.iter().map(|p| p.0))
            .fold(f64::INFINITY, f64::min);
        let y_max = curves
            .iter()
            .flat_map(|(_, c)| c.iter().map(|p| p.1))
            .fold(0.0_f64, f64::max)
            * 1.1;
        let mut chart = ChartBuilder::on(&root)
            .caption(
                "internal pressure p_i vs outer diameter, by sand depth",
                ("sans-serif", 20),
            )
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(55)
            .build_cartesian_2d(x_min..x_max, 0.0..y_max)
            .map_err(plot_err)?;
        chart
            .configure_mesh()
            .x_desc("outer diameter D (mm)")
            .y_desc("p_i (kPa)")
            .draw()
            .map_err(plot_err)?;
        for (i, (h, pts)) in curves.iter().enumerate() {
            let color = Palette99::pick(i).to_rgba();
            chart
                .draw_series(LineSeries::new(pts.iter().copied(), color.stroke_width(2)))
                .map_err(plot_err)?
                .label(format!("h = {h:.0} mm"))
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], color));
        }
        plot::draw_legend(&mut chart, SeriesLabelPosition::MiddleRight, 0.8)?;
        root.present().map_err(plot_err)?;
    }
    Ok(svg)
}

fn step_table(paths: &Paths, report: &mut DemoReport) -> Result<()> {
    let fresh = GeneratedTable::sample(
        &TableSpec::default(),
        &*tables::TABLE_SAND.model(paths.repo_root)?,
    )?;
    let compiled = urechis::table::generated::TABLE;
    compiled
        .verify()
        .map_err(|e| anyhow::anyhow!("the compiled-in table fails the boot check: {e:?}"))?;
    let same = fresh.checksum == compiled.checksum;
    report.lines.push(format!(
        "firmware table: {} depths x {} diameters, CRC-32 {:#010x}, boot check ok, {}",
        compiled.depths_mm.len(),
        compiled.diameters_mm.len(),
        compiled.checksum,
        if same {
            "identical to a fresh generation"
        } else {
            "STALE: differs from a fresh generation (run `cargo sim tables`)"
        }
    ));
    Ok(())
}

fn step_emulate(paths: &Paths, report: &mut DemoReport) -> Result<()> {
    let out_dir = paths.out_dir;
    let name = "normal_40mm";
    let trace = emulator::run(&emulator::named(name)?, emulator::DEFAULT_SEED)?;
    let outcome = emulator::evaluate(&trace);
    let dir = out_dir.join("emulate");
    let files = emulator::trace::write(&trace, &outcome, &dir)?;
    anyhow::ensure!(
        outcome.passed(),
        "the emulated scenario `{name}` did not show its expected outcome:\n{}",
        outcome.text()
    );
    report.lines.push(format!(
        "emulation (firmware controller vs simulated actuator in sand): {}",
        outcome.text().trim_end().replace('\n', "\n  ")
    ));
    report.files.extend(files);
    Ok(())
}

fn step_diagnose(paths: &Paths, report: &mut DemoReport) -> Result<()> {
    let out_dir = paths.out_dir;
    use workbench::commands::{diagnose_folder, diagnosis_text, DiagnoseOutcome};
    let dir = out_dir.join("emulate");
    let outcome = diagnose_folder(&dir, None, &Default::default())?;
    if let DiagnoseOutcome::Diagnosis(d) = outcome {
        report.lines.push(format!(
            "workbench diagnosis of the emulated run:\n  {}",
            diagnosis_text(&d).trim_end().replace('\n', "\n  ")
        ));
    }
    report.files.push(dir.join("workbench/diagnosis.json"));
    Ok(())
}
