//! # The paper's balloon experiment, reproduced (`host-sim balloon`)
//!
//! The experiment's p_e is a latex balloon's reading: 9.8 mL of water
//! injected into a balloon buried at depth h, the internal pressure at
//! each depth minus the pressure at h = 0 (paper-figures.md). The balloon
//! is far stiffer than the worm's skin: its own skin needs 13.59 kPa at
//! that volume, against the ≈ 2.2 kPa of the scenario's skin fitted to the
//! worm's p_i. The stiffness decides what the sand gives: a skin whose
//! tension is large against the sand's pressure stays round and pushes the
//! sand all round; a soft one swells towards the weakest sand (upward, in
//! the paper's 40 mm box) and reads a smaller share (the crate README).
//!
//! So the experiment is reproduced with the scenario's zone, sand, box and
//! depths, the zone inflated where it lies ([`ScenarioSpec::as_balloon`]),
//! and the zone's skin given the balloon's stiffness: the default skin's
//! law scaled so that with no sand it needs the balloon's own pressure at
//! the zone's final diameter ([`FreeCurve::matched`]; the zone at 25 mm
//! holds the 9.8 mL, the paper's "expansion zone similar in volume"). That
//! pressure, the h = 0 row, is the one number taken from the experiment;
//! the four depths' p_i and Δp_i are then predictions, compared with the
//! measured rows ± SD.
//!
//! Not the balloon's geometry: it starts 6.1 mm across in a 30 cm tube,
//! the zone 18.7 mm in a 20 mm clamped length. The shape matters: a zone
//! of the same length from 12 mm (rounder, less volume) reads a third less
//! at 40 mm (the crate README, "Limits").

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use plotters::prelude::*;

use super::ensemble::Ensemble;
use super::{output, FreeCurve, ScenarioSpec};
use crate::cases::Runner;
use crate::solver_sand::RigSetup;
use sand::{BalloonPoint, BALLOON_FREE_PRESSURE_KPA, BALLOON_FREE_SD_KPA, BALLOON_TABLE};

/// What to run.
#[derive(Clone, Debug)]
pub struct BalloonOptions {
    /// Depths of the balloon's axis below the sand surface (m).
    pub depths_m: Vec<f64>,
    /// Lattice seeds: one bed per seed at each depth.
    pub seeds: Vec<u64>,
    /// Grain radius of the coarse-grained sand (m).
    pub grain_radius_m: f64,
    /// The balloon's own pressure at the injected volume, its h = 0
    /// reading (Pa): the skin is matched to it.
    pub free_pressure_pa: f64,
    /// The shorter case ([`ScenarioSpec::quick`]).
    pub quick: bool,
    /// A user's set-up (actuator, skin, sand, water, box) instead of the
    /// paper's ([`ScenarioSpec::with_rig`]); its rows are predictions with
    /// nothing measured beside them unless it is the paper's set-up.
    pub rig: Option<RigSetup>,
    /// Folder for the results (one `hDEPTHmm` ensemble folder per depth
    /// and the comparison); `None`: write nothing.
    pub out: Option<PathBuf>,
    /// Show progress bars.
    pub progress: bool,
    /// The box's floor below the axis (m); `None`: the case's.
    pub below_m: Option<f64>,
    /// The box's width (m); `None`: the case's.
    pub box_width_m: Option<f64>,
    /// Nominal duration of the expansion (s); `None`: the case's.
    pub expansion_s: Option<f64>,
}

impl BalloonOptions {
    /// The paper's experiment: its four depths, seeds 1–`seeds`, the
    /// scenario's grains and the balloon's measured 13.59 kPa at h = 0.
    pub fn paper(seeds: u64) -> BalloonOptions {
        BalloonOptions {
            depths_m: BALLOON_TABLE.iter().map(|b| b.depth_mm * 1e-3).collect(),
            seeds: (1..=seeds).collect(),
            grain_radius_m: super::scenario::DEFAULT_GRAIN_RADIUS_M,
            free_pressure_pa: BALLOON_FREE_PRESSURE_KPA * 1e3,
            quick: false,
            rig: None,
            out: None,
            progress: false,
            below_m: None,
            box_width_m: None,
            expansion_s: None,
        }
    }

    /// The case at depth `depth_m` (m), the skin not yet matched, with
    /// the notes on what a rig says that the solver does not take as
    /// given ([`ScenarioSpec::with_rig`]).
    pub fn spec(&self, depth_m: f64) -> Result<(ScenarioSpec, Vec<String>)> {
        let base = if self.quick {
            ScenarioSpec::quick(depth_m, self.grain_radius_m)
        } else {
            ScenarioSpec::paper(depth_m, self.grain_radius_m)
        };
        let (spec, notes) = match &self.rig {
            Some(setup) => base.with_rig(
                &setup.rig,
                &setup.file,
                setup.final_diameter_mm.map(|d| d * 1e-3),
            )?,
            None => (base, Vec::new()),
        };
        let mut spec = match self.below_m {
            Some(below) => spec.with_floor_below(below),
            None => spec,
        };
        if let Some(w) = self.box_width_m {
            spec.box_width_m = w;
        }
        if let Some(t) = self.expansion_s {
            spec.expansion_s = t;
        }
        Ok((spec.as_balloon(), notes))
    }
}

/// Mean and sample SD over the beds (kPa, or mm for the calipers).
pub type MeanSd = (f64, f64);

/// One depth: the simulated balloon against the measured one.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    /// Depth h (mm).
    pub depth_mm: f64,
    /// Final internal pressure p_i (kPa).
    pub internal_kpa: MeanSd,
    /// Final sand's share Δp_i = p_i − p_free (kPa): the experiment's p_e.
    pub sand_share_kpa: MeanSd,
    /// Final contact pressure of the grains on the skin (kPa).
    pub contact_kpa: MeanSd,
    /// Smallest and largest caliper diameter at mid-length at the end
    /// (mm, means over the beds): how round the zone stayed.
    pub calipers_mm: (f64, f64),
    /// The experiment at this depth, if it measured there.
    pub measured: Option<BalloonPoint>,
}

impl Row {
    /// Whether the simulated Δp_i lies within the measured p_e ± SD.
    pub fn sand_share_within_sd(&self) -> Option<bool> {
        self.measured
            .map(|b| (self.sand_share_kpa.0 - b.external_pressure_kpa).abs() <= b.sd_kpa)
    }

    /// Whether the simulated p_i lies within the measured internal
    /// pressure ± SD.
    pub fn internal_within_sd(&self) -> Option<bool> {
        self.measured
            .map(|b| (self.internal_kpa.0 - b.internal_pressure_kpa()).abs() <= b.sd_kpa)
    }
}

/// The experiment reproduced.
#[derive(Clone, Debug)]
pub struct BalloonRun {
    /// Factor on the default skin's law that matches the balloon (−).
    pub skin_stiffness_scale: f64,
    /// The matched skin's pressure with no sand at the final diameter (Pa).
    pub free_pressure_pa: f64,
    /// The zone's final diameter (m).
    pub final_diameter_m: f64,
    /// One row per depth, in the order run.
    pub rows: Vec<Row>,
    /// Each depth's beds.
    pub ensembles: Vec<Ensemble>,
}

/// Matches the skin to the balloon, then runs every depth over every seed
/// (one free curve for all), writing each depth's ensemble under
/// `out/hDEPTHmm` and the comparison (`balloon.csv`, `balloon.txt`,
/// `balloon.svg`) under `out`.
pub fn run(opts: &BalloonOptions) -> Result<BalloonRun> {
    run_part(opts, &Runner::whole())?.context("a run on one machine has every case")
}

/// [`run`] as one part of the experiment split over machines
/// ([`Runner`]): `None` where another part runs some of the beds.
pub fn run_part(opts: &BalloonOptions, runner: &Runner) -> Result<Option<BalloonRun>> {
    let cases = opts
        .depths_m
        .iter()
        .map(|&h| Ok(opts.spec(h)?.0))
        .collect::<Result<Vec<ScenarioSpec>>>()?;
    run_cases(
        &cases,
        &opts.seeds,
        opts.free_pressure_pa,
        opts.out.as_deref(),
        opts.progress,
        runner,
    )
}

/// [`run`] over prepared cases (one per depth, each
/// [`ScenarioSpec::as_balloon`], all with the same skin and zone: the
/// first case's is matched to `free_pressure_pa` (Pa) and given to all);
/// `None` where another part of a split run ([`Runner`]) runs some beds.
pub fn run_cases(
    cases: &[ScenarioSpec],
    seeds: &[u64],
    free_pressure_pa: f64,
    out: Option<&Path>,
    progress: bool,
    runner: &Runner,
) -> Result<Option<BalloonRun>> {
    let first = cases
        .first()
        .context("the balloon experiment needs at least one depth")?;
    let (matched, free) = FreeCurve::matched(first, free_pressure_pa)
        .context("matching the skin to the balloon's pressure at h = 0")?;
    let scale = matched.skin_stiffness_scale;
    let free_pressure_pa = free
        .pressure_pa(matched.final_diameter_m)
        .context("the matched skin's curve misses the final diameter")?;
    let mut rows = Vec::new();
    let mut ensembles = Vec::new();
    for case in cases {
        // One free curve serves every case only if they share the skin.
        let same_skin = case.tube == first.tube
            && case.skin_coefficients == first.skin_coefficients
            && case.skin_stiffness_scale == first.skin_stiffness_scale
            && case.final_diameter_m == first.final_diameter_m
            && (case.skin_kind, case.skin_mesh, case.skin_end_row_m)
                == (first.skin_kind, first.skin_mesh, first.skin_end_row_m);
        anyhow::ensure!(
            same_skin,
            "the balloon's cases must share one skin and zone (the case at h = {:.0} mm differs from the first's)",
            case.depth_m * 1e3
        );
        let spec = ScenarioSpec {
            skin_stiffness_scale: scale,
            ..case.clone()
        };
        let dir = out.map(|d| depth_dir(d, spec.depth_m));
        let ensemble = Ensemble::run_with(&spec, &free, seeds, dir.as_deref(), progress, runner)
            .with_context(|| format!("the balloon at h = {:.0} mm", spec.depth_m * 1e3))?;
        if let Some(ensemble) = ensemble {
            rows.push(row(&ensemble, &spec));
            ensembles.push(ensemble);
        }
    }
    if ensembles.len() < cases.len() {
        return Ok(None);
    }
    let result = BalloonRun {
        skin_stiffness_scale: scale,
        free_pressure_pa,
        final_diameter_m: matched.final_diameter_m,
        rows,
        ensembles,
    };
    if let Some(dir) = out {
        output::write_text(dir, "balloon.csv", &result.csv()?)?;
        output::write_text(dir, "balloon.txt", result.text().as_bytes())?;
        output::write_text(dir, "balloon.svg", result.plot_svg()?.as_bytes())?;
    }
    Ok(Some(result))
}

/// The depth's row from its beds.
fn row(ensemble: &Ensemble, spec: &ScenarioSpec) -> Row {
    let metrics = ensemble.metrics();
    let metric = |name: &str| {
        metrics
            .iter()
            .find(|m| m.name == name)
            .map_or((f64::NAN, f64::NAN), |m| crate::stats::mean_sd(&m.values))
    };
    Row {
        depth_mm: spec.depth_m * 1e3,
        internal_kpa: metric("final_p_i_kpa"),
        sand_share_kpa: metric("final_sand_share_kpa"),
        contact_kpa: metric("final_p_e_kpa"),
        calipers_mm: (
            metric("final_min_caliper_mm").0,
            metric("final_max_caliper_mm").0,
        ),
        measured: spec.balloon_point(),
    }
}

/// "yes"/"no" for a check, "–" where nothing was measured.
fn verdict(v: Option<bool>) -> &'static str {
    match v {
        Some(true) => "yes",
        Some(false) => "no",
        None => "–",
    }
}

impl BalloonRun {
    /// One row per depth: simulated mean and SD, measured value and SD,
    /// whether within.
    pub fn csv(&self) -> Result<Vec<u8>> {
        let mut w = csv::Writer::from_writer(Vec::new());
        w.write_record([
            "depth_mm",
            "p_i_kpa",
            "p_i_sd_kpa",
            "measured_p_i_kpa",
            "p_i_within_sd",
            "sand_share_kpa",
            "sand_share_sd_kpa",
            "measured_p_e_kpa",
            "measured_sd_kpa",
            "sand_share_within_sd",
            "contact_p_e_kpa",
            "min_caliper_mm",
            "max_caliper_mm",
        ])?;
        let nan = f64::NAN;
        for r in &self.rows {
            let m = r.measured;
            w.write_record([
                format!("{:.0}", r.depth_mm),
                format!("{:.4}", r.internal_kpa.0),
                format!("{:.4}", r.internal_kpa.1),
                format!("{:.2}", m.map_or(nan, |b| b.internal_pressure_kpa())),
                verdict(r.internal_within_sd()).to_string(),
                format!("{:.4}", r.sand_share_kpa.0),
                format!("{:.4}", r.sand_share_kpa.1),
                format!("{:.2}", m.map_or(nan, |b| b.external_pressure_kpa)),
                format!("{:.2}", m.map_or(nan, |b| b.sd_kpa)),
                verdict(r.sand_share_within_sd()).to_string(),
                format!("{:.4}", r.contact_kpa.0),
                format!("{:.3}", r.calipers_mm.0),
                format!("{:.3}", r.calipers_mm.1),
            ])?;
        }
        w.into_inner().context("writing the balloon table")
    }

    /// A plain-text comparison with the measured table.
    pub fn text(&self) -> String {
        let mut s = String::new();
        let beds = self.ensembles.first().map_or(0, |e| e.reports.len());
        let paper = if self.rows.iter().any(|r| r.measured.is_some()) {
            format!(
                " (the paper's balloon read {BALLOON_FREE_PRESSURE_KPA:.2} ± {BALLOON_FREE_SD_KPA:.2} kPa at h = 0)"
            )
        } else {
            String::new()
        };
        let _ = writeln!(
            s,
            "balloon experiment reproduced: the skin law's coefficients × {:.2}, matched to {:.3} kPa with no sand at D = {:.2} mm{paper}; {beds} bed{} per depth, means ± SD over the beds",
            self.skin_stiffness_scale,
            self.free_pressure_pa * 1e-3,
            self.final_diameter_m * 1e3,
            if beds == 1 { "" } else { "s" },
        );
        let _ = writeln!(
            s,
            "{:>6}  {:>17}  {:>15}  {:>6}  {:>17}  {:>15}  {:>6}  {:>13}",
            "h (mm)",
            "p_i (kPa)",
            "measured",
            "within",
            "Δp_i (kPa)",
            "measured p_e",
            "within",
            "calipers (mm)"
        );
        for r in &self.rows {
            let measured = |v: Option<f64>| {
                r.measured.zip(v).map_or("–".to_string(), |(b, v)| {
                    format!("{v:.2} ± {:.2}", b.sd_kpa)
                })
            };
            let _ = writeln!(
                s,
                "{:>6.0}  {:>8.3} ± {:<6.3}  {:>15}  {:>6}  {:>8.3} ± {:<6.3}  {:>15}  {:>6}  {:>5.2}–{:<5.2}",
                r.depth_mm,
                r.internal_kpa.0,
                r.internal_kpa.1,
                measured(r.measured.map(|b| b.internal_pressure_kpa())),
                verdict(r.internal_within_sd()),
                r.sand_share_kpa.0,
                r.sand_share_kpa.1,
                measured(r.measured.map(|b| b.external_pressure_kpa)),
                verdict(r.sand_share_within_sd()),
                r.calipers_mm.0,
                r.calipers_mm.1,
            );
        }
        s
    }

    /// p_i and Δp_i against depth, simulated (mean ± SD over the beds)
    /// beside the measured (± SD), as SVG text.
    pub fn plot_svg(&self) -> Result<String> {
        let err = |e: &dyn std::fmt::Display| anyhow::anyhow!("plotting the balloon: {e}");
        let hi = self
            .rows
            .iter()
            .flat_map(|r| {
                let m = r.measured.map_or(0.0, |b| b.internal_pressure_kpa() + b.sd_kpa);
                [r.internal_kpa.0 + r.internal_kpa.1, m]
            })
            .chain([
                BALLOON_FREE_PRESSURE_KPA + BALLOON_FREE_SD_KPA,
                self.free_pressure_pa * 1e-3,
            ])
            .filter(|v| v.is_finite())
            .fold(1.0f64, f64::max)
            // Room above the points for the legend.
            * 1.4;
        let (h0, h1) = self.rows.iter().fold((0.0f64, 10.0f64), |(a, b), r| {
            (a.min(r.depth_mm), b.max(r.depth_mm))
        });
        let pad = 0.08 * (h1 - h0);
        let mut svg = String::new();
        {
            let root = SVGBackend::with_string(&mut svg, (900, 560)).into_drawing_area();
            root.fill(&WHITE).map_err(|e| err(&e))?;
            let mut chart = ChartBuilder::on(&root)
                .caption(
                    format!(
                        "balloon experiment: measured and simulated (skin law × {:.2})",
                        self.skin_stiffness_scale
                    ),
                    ("sans-serif", 20),
                )
                .margin(15)
                .x_label_area_size(45)
                .y_label_area_size(60)
                .build_cartesian_2d((h0 - pad)..(h1 + pad), 0.0..hi)
                .map_err(|e| err(&e))?;
            chart
                .configure_mesh()
                .x_desc("depth h (mm)")
                .y_desc("pressure (kPa)")
                .draw()
                .map_err(|e| err(&e))?;
            // Measured points left of each depth, simulated right of it.
            let shift = 0.012 * (h1 - h0 + 2.0 * pad);
            type Pick = fn(&Row) -> Option<(f64, f64)>;
            let series: [(&str, Pick, RGBColor, f64); 4] = [
                (
                    "measured p_i ± SD (h = 0: the balloon alone)",
                    |r| r.measured.map(|b| (b.internal_pressure_kpa(), b.sd_kpa)),
                    BLACK,
                    -shift,
                ),
                (
                    "simulated p_i, mean ± SD (h = 0: the matched skin alone)",
                    |r| Some(r.internal_kpa),
                    BLUE,
                    shift,
                ),
                (
                    "measured p_e (p_i − p_i at h = 0) ± SD",
                    |r| r.measured.map(|b| (b.external_pressure_kpa, b.sd_kpa)),
                    RGBColor(90, 90, 90),
                    -shift,
                ),
                (
                    "simulated Δp_i (p_i − p_free), mean ± SD",
                    |r| Some(r.sand_share_kpa),
                    MAGENTA,
                    shift,
                ),
            ];
            // At h = 0 the balloon's own pressure, measured and matched
            // (the one number taken from the experiment).
            let at_rest = [
                Some((BALLOON_FREE_PRESSURE_KPA, BALLOON_FREE_SD_KPA)),
                Some((self.free_pressure_pa * 1e-3, 0.0)),
                None,
                None,
            ];
            for ((name, pick, colour, dx), rest) in series.into_iter().zip(at_rest) {
                let points: Vec<(f64, f64, f64)> = rest
                    .map(|(m, sd)| (dx, m, sd))
                    .into_iter()
                    .chain(
                        self.rows
                            .iter()
                            .filter_map(|r| pick(r).map(|(m, sd)| (r.depth_mm + dx, m, sd))),
                    )
                    .filter(|p| p.1.is_finite())
                    .collect();
                chart
                    .draw_series(points.iter().map(|&(x, m, sd)| {
                        let sd = if sd.is_finite() { sd } else { 0.0 };
                        ErrorBar::new_vertical(x, m - sd, m, m + sd, colour.filled(), 10)
                    }))
                    .map_err(|e| err(&e))?
                    .label(name)
                    .legend(move |(x, y)| Circle::new((x + 10, y), 4, colour.filled()));
            }
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.8))
                .border_style(BLACK)
                .position(SeriesLabelPosition::UpperLeft)
                .draw()
                .map_err(|e| err(&e))?;
            root.present().map_err(|e| err(&e))?;
        }
        Ok(svg)
    }
}

/// The folder `run` writes depth `depth_m`'s beds to under `out`.
pub fn depth_dir(out: &Path, depth_m: f64) -> PathBuf {
    out.join(format!("h{:.0}mm", depth_m * 1e3))
}
