//! `host-sim sand-test`: the element tests over grain radii, seeds and
//! confining stresses, each test one case of a [`shard::Cases`] (so a
//! cluster can split them), summarised as mean ± SD per radius and stress
//! (`summary.json`, `summary.txt`) and plotted (`triaxial.svg`,
//! `oedometer.svg`).
//!
//! Every sample is prepared as the scenario prepares its bed: the grains
//! placed loose, consolidated at the deposition's friction
//! ([`Grains::deposition_friction`]), then given the sand's own friction
//! and sheared or loaded.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{ensure, Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use plot::plot_err;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use serde::{Deserialize, Serialize};

use crate::cell::{Cell, Grains};
use crate::procedure::{consolidate, oedometer, triaxial, Oedometer, Triaxial};

/// Largest servo wall speed, as a strain rate of the cell (1/s): fast
/// enough for a loose sample to consolidate in a few thousand steps.
const SERVO_STRAIN_RATE: f64 = 2.0;

/// Where an oedometer sample is consolidated before its loading (Pa): the
/// low end of the problem's stresses.
pub const OEDOMETER_START_PA: f64 = 500.0;

/// The file each case keeps its result in.
pub const RESULT: &str = "result.json";

/// What to run.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Plan {
    /// Grain radii (mm).
    pub radii_mm: Vec<f64>,
    /// Seeds 1..=seeds of the grains' placement at each radius.
    pub seeds: u64,
    /// Grains in a sample.
    pub grains: usize,
    /// Confining stresses of the triaxial tests (kPa).
    pub confining_kpa: Vec<f64>,
    /// Axial strain each triaxial test ends at (−).
    pub axial_strain: f64,
}

impl Default for Plan {
    /// The matrix: radii 1.5, 1.0 and 0.75 mm, five seeds, 500
    /// grains, triaxial at 1 and 8 kPa to 30 % axial strain.
    fn default() -> Plan {
        Plan {
            radii_mm: vec![1.5, 1.0, 0.75],
            seeds: 5,
            grains: 500,
            confining_kpa: vec![1.0, 8.0],
            axial_strain: 0.3,
        }
    }
}

impl Plan {
    fn check(&self) -> Result<()> {
        ensure!(!self.radii_mm.is_empty(), "no grain radius given");
        for &r in &self.radii_mm {
            ensure!(
                r.is_finite() && r > 0.0 && r <= 50.0,
                "grain radius {r} mm: expected above 0 and at most 50 mm"
            );
        }
        ensure!(self.seeds >= 1, "at least one seed");
        ensure!(
            (50..=200_000).contains(&self.grains),
            "{} grains: a sample needs 50 to 200,000",
            self.grains
        );
        ensure!(!self.confining_kpa.is_empty(), "no confining stress given");
        for &p in &self.confining_kpa {
            ensure!(
                p.is_finite() && (0.05..=1000.0).contains(&p),
                "confining stress {p} kPa: expected 0.05 to 1000 kPa"
            );
        }
        ensure!(
            self.axial_strain > crate::procedure::CRITICAL_SPAN && self.axial_strain <= 0.6,
            "axial strain {}: expected above {} and at most 0.6",
            self.axial_strain,
            crate::procedure::CRITICAL_SPAN
        );
        Ok(())
    }

    fn cases(&self) -> usize {
        self.radii_mm.len() * self.seeds as usize * (self.confining_kpa.len() + 1)
    }
}

/// How a sample stood after its consolidation.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Sample {
    /// Grain radius (mm).
    pub radius_mm: f64,
    /// Seed of the placement.
    pub seed: u64,
    /// Grains.
    pub grains: usize,
    /// Solid fraction after consolidation (−).
    pub solid_fraction: f64,
    /// Mean contacts per grain after consolidation.
    pub coordination: f64,
}

/// One triaxial test.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TriaxialCase {
    /// The sample.
    pub sample: Sample,
    /// The test.
    pub test: Triaxial,
}

/// One oedometer test.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct OedometerCase {
    /// The sample (consolidated at [`OEDOMETER_START_PA`]).
    pub sample: Sample,
    /// The test.
    pub test: Oedometer,
}

/// Every test of a plan.
#[derive(Clone, Debug, PartialEq)]
pub struct Study {
    /// What was run.
    pub plan: Plan,
    /// The triaxial tests, radius by radius, seed by seed, stress by stress.
    pub triaxial: Vec<TriaxialCase>,
    /// The oedometer tests, radius by radius, seed by seed.
    pub oedometer: Vec<OedometerCase>,
}

/// A prepared sample: placed loose and consolidated at `p_pa` (Pa) with
/// the deposition's friction, then given the sand's.
fn prepare(grains: Grains, plan: &Plan, seed: u64, p_pa: f64) -> Result<(Cell, Sample)> {
    let mut cell = Cell::loose(
        grains,
        plan.grains,
        seed,
        grains.deposition_friction,
        SERVO_STRAIN_RATE,
    )?;
    consolidate(&mut cell, p_pa)?;
    cell.set_friction(grains.contacts.friction)?;
    let sample = Sample {
        radius_mm: grains.radius_m * 1e3,
        seed,
        grains: plan.grains,
        solid_fraction: cell.solid_fraction(),
        coordination: cell.coordination(),
    };
    Ok((cell, sample))
}

/// The folder of one case under `out`.
fn case_dir(out: &Path, radius_mm: f64, seed: u64, test: &str) -> PathBuf {
    out.join(format!("r{radius_mm}mm"))
        .join(format!("seed-{seed}"))
        .join(test)
}

/// Runs the plan's cases that `cases` holds (each into its folder under
/// `out`), then, when it holds them all, writes the summary and the plots
/// to `out`; `None` where another part runs some of them.
pub fn run(plan: &Plan, out: &Path, cases: &shard::Cases, progress: bool) -> Result<Option<Study>> {
    plan.check()?;
    let bar = if progress {
        let bar = ProgressBar::new(plan.cases() as u64);
        bar.set_style(
            ProgressStyle::with_template("{elapsed_precise} [{bar:30}] {pos}/{len} {msg}")
                .context("progress bar template")?,
        );
        bar
    } else {
        ProgressBar::hidden()
    };
    let mut tri = Vec::new();
    let mut oed = Vec::new();
    let mut complete = true;
    for &r_mm in &plan.radii_mm {
        let grains = Grains::scenario(r_mm * 1e-3);
        for seed in 1..=plan.seeds {
            for &p_kpa in &plan.confining_kpa {
                bar.set_message(format!("triaxial r {r_mm} mm, seed {seed}, {p_kpa} kPa"));
                let dir = case_dir(out, r_mm, seed, &format!("triaxial-{p_kpa}kpa"));
                let case = cases.case(Some(&dir), RESULT, || {
                    let (mut cell, sample) = prepare(grains, plan, seed, p_kpa * 1e3)?;
                    let test = triaxial(&mut cell, p_kpa * 1e3, plan.axial_strain)?;
                    Ok(TriaxialCase { sample, test })
                });
                let case = case.with_context(|| {
                    format!("triaxial test, r {r_mm} mm, seed {seed}, {p_kpa} kPa")
                })?;
                match case {
                    Some(c) => tri.push(c),
                    None => complete = false,
                }
                bar.inc(1);
            }
            bar.set_message(format!("oedometer r {r_mm} mm, seed {seed}"));
            let dir = case_dir(out, r_mm, seed, "oedometer");
            let case = cases
                .case(Some(&dir), RESULT, || {
                    let (mut cell, sample) = prepare(grains, plan, seed, OEDOMETER_START_PA)?;
                    let test = oedometer(&mut cell)?;
                    Ok(OedometerCase { sample, test })
                })
                .with_context(|| format!("oedometer test, r {r_mm} mm, seed {seed}"))?;
            match case {
                Some(c) => oed.push(c),
                None => complete = false,
            }
            bar.inc(1);
        }
    }
    bar.finish_and_clear();
    if !complete {
        return Ok(None);
    }
    let study = Study {
        plan: plan.clone(),
        triaxial: tri,
        oedometer: oed,
    };
    let summary = study.summary();
    let json = serde_json::to_string_pretty(&summary).context("encoding the summary")?;
    datafile::write_atomic(&out.join("summary.json"), json.as_bytes())?;
    datafile::write_atomic(&out.join("summary.txt"), summary.text().as_bytes())?;
    datafile::write_atomic(&out.join("triaxial.svg"), study.triaxial_svg()?.as_bytes())?;
    datafile::write_atomic(
        &out.join("oedometer.svg"),
        study.oedometer_svg()?.as_bytes(),
    )?;
    Ok(Some(study))
}

/// A quantity over the seeds: mean and sample SD.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Stat {
    /// Mean.
    pub mean: f64,
    /// Sample standard deviation (0 for one seed, NaN for none).
    pub sd: f64,
}

impl Stat {
    fn of(v: &[f64]) -> Stat {
        let (mean, sd) = burrow::stats::mean_sd(v);
        Stat { mean, sd }
    }
}

/// The triaxial results at one radius and confining stress.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TriaxialRow {
    /// Grain radius (mm); `None`: every radius pooled.
    pub radius_mm: Option<f64>,
    /// Confining stress (kPa).
    pub confining_kpa: f64,
    /// Tests (seeds).
    pub tests: usize,
    /// Solid fraction before shearing (−).
    pub solid_fraction: Stat,
    /// Contacts per grain before shearing.
    pub coordination: Stat,
    /// Peak friction angle (degrees).
    pub peak_deg: Stat,
    /// Critical-state friction angle (degrees).
    pub critical_deg: Stat,
    /// Largest dilatancy angle (degrees).
    pub dilatancy_deg: Stat,
}

/// K0 at one radius and vertical stress.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct OedometerRow {
    /// Grain radius (mm); `None`: every radius pooled.
    pub radius_mm: Option<f64>,
    /// Vertical stress (kPa).
    pub vertical_kpa: f64,
    /// Tests (seeds).
    pub tests: usize,
    /// K0 = σ_h/σ_v (−).
    pub k0: Stat,
}

/// The study in numbers (`summary.json`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Summary {
    /// What was run.
    pub plan: Plan,
    /// The grains' friction (−).
    pub friction: f64,
    /// Rolling resistance coefficient (−).
    pub rolling_friction: f64,
    /// Friction the samples were consolidated with (−).
    pub deposition_friction: f64,
    /// Triaxial results per radius and stress, then pooled over radii.
    pub triaxial: Vec<TriaxialRow>,
    /// K0 per radius and stress, then pooled over radii.
    pub oedometer: Vec<OedometerRow>,
    /// Jaky's K0 = 1 − sin φ for the pooled critical-state angle at each
    /// confining stress (−), beside the measured K0.
    pub jaky_k0: Vec<(f64, f64)>,
}

impl Study {
    /// Mean ± SD per radius and stress, and pooled over the radii.
    pub fn summary(&self) -> Summary {
        let radii: Vec<Option<f64>> = self
            .plan
            .radii_mm
            .iter()
            .map(|&r| Some(r))
            .chain(std::iter::once(None))
            .collect();
        let at = |want: Option<f64>, r: f64| want.is_none_or(|w| w == r);
        let mut triaxial = Vec::new();
        for &radius in &radii {
            for &p in &self.plan.confining_kpa {
                let cases: Vec<&TriaxialCase> = self
                    .triaxial
                    .iter()
                    .filter(|c| at(radius, c.sample.radius_mm) && c.test.confining_pa == p * 1e3)
                    .collect();
                let stat = |f: fn(&TriaxialCase) -> f64| {
                    Stat::of(&cases.iter().map(|c| f(c)).collect::<Vec<_>>())
                };
                triaxial.push(TriaxialRow {
                    radius_mm: radius,
                    confining_kpa: p,
                    tests: cases.len(),
                    solid_fraction: stat(|c| c.sample.solid_fraction),
                    coordination: stat(|c| c.sample.coordination),
                    peak_deg: stat(|c| c.test.peak_deg),
                    critical_deg: stat(|c| c.test.critical_deg),
                    dilatancy_deg: stat(|c| c.test.dilatancy_deg),
                });
            }
        }
        let mut oedometer = Vec::new();
        for &radius in &radii {
            for &s in &crate::procedure::OEDOMETER_STRESSES_PA {
                let k0: Vec<f64> = self
                    .oedometer
                    .iter()
                    .filter(|c| at(radius, c.sample.radius_mm))
                    .filter_map(|c| c.test.k0.iter().find(|k| k.0 == s).map(|k| k.1))
                    .collect();
                oedometer.push(OedometerRow {
                    radius_mm: radius,
                    vertical_kpa: s * 1e-3,
                    tests: k0.len(),
                    k0: Stat::of(&k0),
                });
            }
        }
        let jaky_k0 = triaxial
            .iter()
            .filter(|r| r.radius_mm.is_none())
            .map(|r| {
                (
                    r.confining_kpa,
                    1.0 - r.critical_deg.mean.to_radians().sin(),
                )
            })
            .collect();
        let g = Grains::scenario(self.plan.radii_mm[0] * 1e-3);
        Summary {
            plan: self.plan.clone(),
            friction: g.contacts.friction,
            rolling_friction: g.contacts.rolling_friction,
            deposition_friction: g.deposition_friction,
            triaxial,
            oedometer,
            jaky_k0,
        }
    }

    /// The colour of grain radius `r_mm` (mm) in every plot.
    fn radius_colour(&self, r_mm: f64) -> RGBColor {
        let colours = [BLUE, RED, GREEN, MAGENTA, CYAN];
        let k = self
            .plan
            .radii_mm
            .iter()
            .position(|&x| x == r_mm)
            .unwrap_or(0);
        colours[k % colours.len()]
    }

    /// Draws every test's curve `(radius_mm, points)` in its radius'
    /// colour, one legend entry per radius.
    fn draw_by_radius(
        &self,
        chart: &mut ChartContext<'_, SVGBackend<'_>, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
        curves: &[(f64, Vec<(f64, f64)>)],
    ) -> Result<()> {
        for &r in &self.plan.radii_mm {
            let c = self.radius_colour(r);
            for (j, (_, pts)) in curves.iter().filter(|(x, _)| *x == r).enumerate() {
                let series = chart
                    .draw_series(LineSeries::new(pts.iter().copied(), c.mix(0.6)))
                    .map_err(plot_err)?;
                if j == 0 {
                    series
                        .label(format!("r = {r} mm"))
                        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], c));
                }
            }
        }
        Ok(())
    }

    /// The mobilised friction angle and the volumetric strain against the
    /// axial strain, every test, coloured by radius (SVG).
    pub fn triaxial_svg(&self) -> Result<String> {
        let mut svg = String::new();
        {
            let root = SVGBackend::with_string(&mut svg, (900, 820)).into_drawing_area();
            root.fill(&WHITE).map_err(plot_err)?;
            let (top, bottom) = root.split_vertically(430);
            let eps = self.plan.axial_strain * 100.0;
            let mut chart = ChartBuilder::on(&top)
                .caption(
                    format!(
                        "drained triaxial, {} grains: mobilised friction angle (all tests)",
                        self.plan.grains
                    ),
                    ("sans-serif", 18),
                )
                .margin(10)
                .x_label_area_size(36)
                .y_label_area_size(50)
                .build_cartesian_2d(0.0..eps, 0.0..50.0)
                .map_err(plot_err)?;
            chart
                .configure_mesh()
                .x_desc("axial strain (%)")
                .y_desc("asin((σ1 − σ3)/(σ1 + σ3)) (°)")
                .draw()
                .map_err(plot_err)?;
            let curves: Vec<(f64, Vec<(f64, f64)>)> = self
                .triaxial
                .iter()
                .map(|t| {
                    let pts = t.test.records.iter();
                    let pts = pts.map(|x| (x.axial_strain * 100.0, x.friction_angle_deg()));
                    (t.sample.radius_mm, pts.collect())
                })
                .collect();
            self.draw_by_radius(&mut chart, &curves)?;
            plot::draw_legend(&mut chart, SeriesLabelPosition::LowerRight, 0.8)?;
            let ev: Vec<f64> = self
                .triaxial
                .iter()
                .flat_map(|t| t.test.records.iter().map(|x| -x.volumetric_strain * 100.0))
                .collect();
            let hi = ev.iter().copied().fold(1.0, f64::max);
            let lo = ev.iter().copied().fold(-1.0, f64::min);
            let mut chart = ChartBuilder::on(&bottom)
                .caption("volumetric strain (dilation positive)", ("sans-serif", 18))
                .margin(10)
                .x_label_area_size(36)
                .y_label_area_size(50)
                .build_cartesian_2d(0.0..eps, lo..hi)
                .map_err(plot_err)?;
            chart
                .configure_mesh()
                .x_desc("axial strain (%)")
                .y_desc("−ε_v (%)")
                .draw()
                .map_err(plot_err)?;
            for case in &self.triaxial {
                let pts = case
                    .test
                    .records
                    .iter()
                    .map(|x| (x.axial_strain * 100.0, -x.volumetric_strain * 100.0));
                chart
                    .draw_series(LineSeries::new(
                        pts,
                        self.radius_colour(case.sample.radius_mm).mix(0.6),
                    ))
                    .map_err(plot_err)?;
            }
            root.present().map_err(plot_err)?;
        }
        Ok(svg)
    }

    /// K0 against the vertical stress, every test, with Jaky's estimate
    /// (SVG).
    pub fn oedometer_svg(&self) -> Result<String> {
        let mut svg = String::new();
        {
            let root = SVGBackend::with_string(&mut svg, (800, 520)).into_drawing_area();
            root.fill(&WHITE).map_err(plot_err)?;
            let top = crate::procedure::OEDOMETER_STRESSES_PA
                .last()
                .copied()
                .unwrap_or(1e4)
                * 1e-3;
            let mut chart = ChartBuilder::on(&root)
                .caption(
                    "oedometer (K0) loading: σ_h/σ_v against σ_v",
                    ("sans-serif", 18),
                )
                .margin(10)
                .x_label_area_size(36)
                .y_label_area_size(50)
                .build_cartesian_2d(0.0..top * 1.05, 0.0..1.0)
                .map_err(plot_err)?;
            chart
                .configure_mesh()
                .x_desc("σ_v (kPa)")
                .y_desc("σ_h/σ_v")
                .draw()
                .map_err(plot_err)?;
            let curves: Vec<(f64, Vec<(f64, f64)>)> = self
                .oedometer
                .iter()
                .map(|t| {
                    let pts = t.test.records.iter();
                    let pts = pts
                        .filter(|x| x.axial_pa() > 0.5 * OEDOMETER_START_PA)
                        .map(|x| (x.axial_pa() * 1e-3, x.lateral_pa() / x.axial_pa()));
                    (t.sample.radius_mm, pts.collect())
                })
                .collect();
            self.draw_by_radius(&mut chart, &curves)?;
            for (p, k0) in self.summary().jaky_k0 {
                chart
                    .draw_series(LineSeries::new(
                        [(0.0, k0), (top * 1.05, k0)],
                        BLACK.stroke_width(1),
                    ))
                    .map_err(plot_err)?
                    .label(format!("Jaky 1 − sin φ_cv ({p} kPa triaxial)"))
                    .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], BLACK));
            }
            plot::draw_legend(&mut chart, SeriesLabelPosition::UpperRight, 0.8)?;
            root.present().map_err(plot_err)?;
        }
        Ok(svg)
    }
}

impl Summary {
    /// The tables in words (`summary.txt`).
    pub fn text(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "element tests of the scenario's grains (μ {}, rolling {}, prepared at μ {}), {} grains, seeds 1–{}; mean ± SD over the seeds",
            self.friction,
            self.rolling_friction,
            self.deposition_friction,
            self.plan.grains,
            self.plan.seeds
        );
        let _ = writeln!(
            s,
            "radius (mm)  σ3 (kPa)  solid fraction   contacts      φ_peak (°)     φ_cv (°)       ψ (°)"
        );
        let pm = |x: Stat, d: usize| format!("{:.d$} ± {:.d$}", x.mean, x.sd);
        for r in &self.triaxial {
            let radius = r.radius_mm.map_or("all".to_string(), |v| v.to_string());
            let _ = writeln!(
                s,
                "{radius:>11}  {:>8}  {:>14}  {:>11}  {:>12}  {:>12}  {:>12}",
                r.confining_kpa,
                pm(r.solid_fraction, 3),
                pm(r.coordination, 2),
                pm(r.peak_deg, 1),
                pm(r.critical_deg, 1),
                pm(r.dilatancy_deg, 1)
            );
        }
        let _ = writeln!(s, "K0 (oedometer from {} kPa):", OEDOMETER_START_PA * 1e-3);
        for r in &self.oedometer {
            let radius = r.radius_mm.map_or("all".to_string(), |v| v.to_string());
            let _ = writeln!(
                s,
                "{radius:>11}  σ_v {:>5} kPa  K0 {}",
                r.vertical_kpa,
                pm(r.k0, 3)
            );
        }
        for (p, k) in &self.jaky_k0 {
            let _ = writeln!(s, "Jaky 1 − sin φ_cv (σ3 {p} kPa): {k:.3}");
        }
        s
    }
}
