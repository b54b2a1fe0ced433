//! `host-sim validate`: the solver's validation table, regenerated. Every
//! figure the docs compare with the paper or the balloon experiment comes
//! from one run of the existing ensembles (the scenario at each depth over
//! its seeds, [`Ensemble`]; the balloon, [`crate::balloon`]), split over
//! machines by the same [`Runner`] as every other ensemble command. Each
//! row says what the figure is: fitted, matched, imposed or predicted; a
//! row is "validated" only where an independent measurement or code
//! confirms a prediction, which none of these rows is (the code-to-code
//! cavity benchmark against LAMMPS is run by `scripts/cavity-lammps.sh`,
//! which needs LAMMPS).
//!
//! The reduced case ([`ValidateOptions::reduced`]) is the scenario at
//! 40 mm on a small, coarse bed: the headline figures of the full one at a
//! cost a test can pay, pinned in CI (`tests/validate.rs`).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use serde::Serialize;

use sand::BALLOON_TABLE;

use crate::balloon::{self, BalloonOptions};
use crate::cases::Runner;
use crate::ensemble::Metric;
use crate::{output, Ensemble, ScenarioSpec};

/// Depths of the full scenario (mm): the balloon experiment's.
pub const DEPTHS_MM: [f64; 4] = crate::solver_sand::DEPTHS_MM;

/// Depth of the reduced case (mm): where the paper states p_i.
pub const REDUCED_DEPTH_MM: f64 = 40.0;

/// The paper's FEM–DEM p_i at 40 mm (kPa), the figure the skin's scale
/// was fitted to ([`crate::scenario::SKIN_STIFFNESS_SCALE`]).
pub const PAPER_INTERNAL_PRESSURE_KPA: f64 = 4.06;
/// The paper's peak von Mises stress in the skin (MPa).
pub const PAPER_PEAK_STRESS_MPA: f64 = 0.042;
/// The paper's drop of the pressure ahead of the head (%): 96.4–97.7.
pub const PAPER_FACE_DROP_PCT: (f64, f64) = (96.4, 97.7);

/// What a row's figure is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Status {
    /// A parameter was chosen to reproduce it.
    Fitted,
    /// An input taken from the same data set it is compared with.
    Matched,
    /// It follows from a kinematics the case imposes.
    Imposed,
    /// Computed with nothing chosen for it.
    Predicted,
}

impl Status {
    /// The word the tables print.
    pub fn word(self) -> &'static str {
        match self {
            Status::Fitted => "fitted",
            Status::Matched => "matched",
            Status::Imposed => "imposed",
            Status::Predicted => "predicted",
        }
    }
}

/// One claim: the solver's figure beside what it is compared with.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Row {
    /// Short identifier (CSV key), e.g. `scenario_h40_p_i_kpa`.
    pub key: String,
    /// The claim in words.
    pub claim: String,
    /// Unit of the figures.
    pub unit: &'static str,
    /// The solver: mean over the runs.
    pub mean: f64,
    /// The solver: sample SD over the runs (NaN for one run).
    pub sd: f64,
    /// Runs (beds) behind the mean.
    pub runs: usize,
    /// What it is compared with, in words (empty: nothing).
    pub reference: String,
    /// The reference's value, where it is one number.
    pub reference_value: Option<f64>,
    /// The reference's SD or half-range, where it has one.
    pub reference_sd: Option<f64>,
    /// What the figure is.
    pub status: Status,
    /// Whether the mean lies within the reference ± its SD (or range).
    pub within: Option<bool>,
}

/// What to run.
#[derive(Clone, Debug, PartialEq)]
pub struct ValidateOptions {
    /// The reduced case only ([`reduced_spec`]).
    pub reduced: bool,
    /// Seeds 1..=seeds at each depth.
    pub seeds: u64,
    /// Folder for the runs and the table.
    pub out: PathBuf,
    /// Show progress bars.
    pub progress: bool,
}

/// The reduced case at `depth_m` (m): 2.5 mm grains, sand to 20 mm over
/// the axis under a surcharge, the membrane skin, a 0.4 s settling and a
/// 0.08 s expansion in 2 frames (20 samples); otherwise the scenario
/// ([`ScenarioSpec::quick`]: the skin × 2.5, the advance, the drawn head).
pub fn reduced_spec(depth_m: f64) -> ScenarioSpec {
    ScenarioSpec {
        settle_s: 0.4,
        expansion_s: 0.08,
        frames: 2,
        samples: 20,
        ..ScenarioSpec::quick(depth_m, 2.5e-3)
            .with_surcharge(20e-3, crate::scenario::SURCHARGE_ROWS)
            .with_membrane()
    }
}

/// The scenario's cases: (depth (mm), case).
pub fn scenario_cases(opts: &ValidateOptions) -> Vec<(f64, ScenarioSpec)> {
    if opts.reduced {
        return vec![(REDUCED_DEPTH_MM, reduced_spec(REDUCED_DEPTH_MM * 1e-3))];
    }
    DEPTHS_MM
        .iter()
        .map(|&h| {
            (
                h,
                ScenarioSpec::paper(h * 1e-3, crate::solver_sand::GRAIN_RADIUS_MM * 1e-3),
            )
        })
        .collect()
}

/// The table, with the ensembles it was read from.
#[derive(Clone, Debug)]
pub struct Validation {
    /// The claims.
    pub rows: Vec<Row>,
    /// The scenario's ensembles: (depth (mm), runs).
    pub scenario: Vec<(f64, Ensemble)>,
}

fn metric(e: &Ensemble, name: &str) -> Result<Metric> {
    e.metrics()
        .into_iter()
        .find(|m| m.name == name)
        .with_context(|| format!("no ensemble metric {name}"))
}

/// Runs (or, in a merge, reads back) every case of `opts` under
/// `opts.out` and writes the table there: `validation.json`,
/// `validation.csv` and `validation.md` (the docs' rows). `None` where
/// another part of a split run ([`Runner`]) runs some of the cases.
pub fn run_part(opts: &ValidateOptions, runner: &Runner) -> Result<Option<Validation>> {
    anyhow::ensure!(opts.seeds >= 1, "validate needs at least one seed");
    let seeds: Vec<u64> = (1..=opts.seeds).collect();
    let mut scenario = Vec::new();
    let mut complete = true;
    for (h, spec) in scenario_cases(opts) {
        let dir = scenario_dir(&opts.out, h);
        match Ensemble::run_part(&spec, &seeds, Some(&dir), opts.progress, runner)
            .with_context(|| format!("the scenario at h = {h} mm"))?
        {
            Some(e) => scenario.push((h, e)),
            None => complete = false,
        }
    }
    let balloon = if opts.reduced {
        None
    } else {
        let b = BalloonOptions {
            out: Some(opts.out.join("balloon")),
            progress: opts.progress,
            ..BalloonOptions::paper(opts.seeds)
        };
        match balloon::run_part(&b, runner)? {
            Some(run) => Some(run),
            None => {
                complete = false;
                None
            }
        }
    };
    if !complete {
        return Ok(None);
    }
    let mut rows = Vec::new();
    for (h, e) in &scenario {
        rows.extend(scenario_rows(*h, e, opts.reduced)?);
    }
    if let Some(b) = &balloon {
        for r in &b.rows {
            let Some(m) = r.measured else { continue };
            rows.push(Row {
                key: format!("balloon_h{}_sand_share_kpa", r.depth_mm),
                claim: format!(
                    "balloon Δp_i at h = {} mm (skin matched to the h = 0 reading of the same data set)",
                    r.depth_mm
                ),
                unit: "kPa",
                mean: r.sand_share_kpa.0,
                sd: r.sand_share_kpa.1,
                runs: opts.seeds as usize,
                reference: "experiment's p_e ± SD".into(),
                reference_value: Some(m.external_pressure_kpa),
                reference_sd: Some(m.sd_kpa),
                status: Status::Predicted,
                within: r.sand_share_within_sd(),
            });
        }
    }
    let v = Validation { rows, scenario };
    output::write_text(
        &opts.out,
        "validation.json",
        &serde_json::to_vec_pretty(&v.rows)?,
    )?;
    output::write_text(&opts.out, "validation.csv", &v.csv()?)?;
    output::write_text(&opts.out, "validation.md", v.markdown().as_bytes())?;
    Ok(Some(v))
}

/// Runs every case here ([`run_part`] on one machine).
pub fn run(opts: &ValidateOptions) -> Result<Validation> {
    run_part(opts, &Runner::whole())?.context("a run on one machine has every case")
}

fn scenario_rows(h: f64, e: &Ensemble, reduced: bool) -> Result<Vec<Row>> {
    let case = if reduced { "reduced case" } else { "scenario" };
    let row = |name: &str,
               claim: String,
               unit,
               status,
               reference: (&str, Option<f64>, Option<f64>)|
     -> Result<Row> {
        let m = metric(e, name)?;
        let (mean, sd) = (m.mean(), m.sd());
        let within = reference
            .1
            .zip(reference.2)
            .map(|(v, s)| (mean - v).abs() <= s);
        Ok(Row {
            key: format!(
                "{}_h{h}_{name}",
                if reduced { "reduced" } else { "scenario" }
            ),
            claim,
            unit,
            mean,
            sd,
            runs: m.values.len(),
            reference: reference.0.to_string(),
            reference_value: reference.1,
            reference_sd: reference.2,
            status,
            within,
        })
    };
    let at_40 = h == REDUCED_DEPTH_MM && !reduced;
    let none = ("", None, None);
    let mut rows = vec![row(
        "final_p_i_kpa",
        format!("{case}: p_i at 25 mm, h = {h} mm"),
        "kPa",
        if at_40 {
            Status::Fitted
        } else {
            Status::Predicted
        },
        if at_40 {
            (
                "paper's FEM–DEM (the skin's scale fitted to it)",
                Some(PAPER_INTERNAL_PRESSURE_KPA),
                None,
            )
        } else {
            none
        },
    )?];
    let experiment = BALLOON_TABLE.iter().find(|b| b.depth_mm == h);
    rows.push(row(
        "final_sand_share_kpa",
        format!("{case}: Δp_i = p_i − p_free at 25 mm, h = {h} mm (the worm's skin)"),
        "kPa",
        Status::Predicted,
        match (experiment, reduced) {
            (Some(b), false) => (
                "balloon experiment's p_e ± SD (a stiffer skin)",
                Some(b.external_pressure_kpa),
                Some(b.sd_kpa),
            ),
            _ => none,
        },
    )?);
    let (lo, hi) = PAPER_FACE_DROP_PCT;
    rows.push(row(
        "p_h_drop_late_pct",
        format!("{case}: drop of the pressure ahead of the head past 22 mm, h = {h} mm"),
        "%",
        Status::Imposed,
        if reduced {
            none
        } else {
            (
                "paper's range 96.4–97.7 %, as mid ± half",
                Some(0.5 * (lo + hi)),
                Some(0.5 * (hi - lo)),
            )
        },
    )?);
    rows.push(row(
        "head_receding_mm",
        format!("{case}: head drawn back D_r at 25 mm, h = {h} mm"),
        "mm",
        Status::Imposed,
        none,
    )?);
    rows.push(row(
        "max_von_mises_mpa",
        format!("{case}: peak von Mises stress in the skin, h = {h} mm"),
        "MPa",
        Status::Predicted,
        if at_40 {
            ("paper's FEM–DEM", Some(PAPER_PEAK_STRESS_MPA), None)
        } else {
            none
        },
    )?);
    Ok(rows)
}

impl Validation {
    /// One row per claim.
    pub fn csv(&self) -> Result<Vec<u8>> {
        let mut w = csv::Writer::from_writer(Vec::new());
        w.write_record([
            "key",
            "claim",
            "unit",
            "mean",
            "sd",
            "runs",
            "reference",
            "reference_value",
            "reference_sd",
            "status",
            "within",
        ])?;
        let num = |v: Option<f64>| v.map_or(String::new(), |v| format!("{v}"));
        for r in &self.rows {
            w.write_record([
                r.key.clone(),
                r.claim.clone(),
                r.unit.to_string(),
                format!("{:.5}", r.mean),
                format!("{:.5}", r.sd),
                r.runs.to_string(),
                r.reference.clone(),
                num(r.reference_value),
                num(r.reference_sd),
                r.status.word().to_string(),
                r.within.map_or(String::new(), |b| b.to_string()),
            ])?;
        }
        w.into_inner().context("writing the validation table")
    }

    /// The table's markdown rows, as the docs show them.
    pub fn markdown(&self) -> String {
        let mut s = String::from(
            "| claim | solver (mean ± SD, runs) | compared with | status |\n|---|---|---|---|\n",
        );
        for r in &self.rows {
            let reference = match (r.reference_value, r.reference_sd) {
                (Some(v), Some(sd)) => format!(
                    "{} {} ± {} {}{}",
                    r.reference,
                    short(v),
                    short(sd),
                    r.unit,
                    match r.within {
                        Some(true) => ", within",
                        Some(false) => ", outside",
                        None => "",
                    }
                ),
                (Some(v), None) => format!("{} {} {}", r.reference, short(v), r.unit),
                _ => "–".into(),
            };
            let _ = writeln!(
                s,
                "| {} | {:.3} ± {:.3} {} ({}) | {} | {} |",
                r.claim,
                r.mean,
                r.sd,
                r.unit,
                r.runs,
                reference,
                r.status.word()
            );
        }
        s
    }
}

/// The folder of the scenario's ensemble at `depth_mm` under `out`.
pub fn scenario_dir(out: &Path, depth_mm: f64) -> PathBuf {
    out.join("scenario").join(format!("h{depth_mm}mm"))
}

/// `x` to three decimals without trailing zeros (a reference's figures as
/// written: 97.05, not 97.05000000000001).
fn short(x: f64) -> String {
    let s = format!("{x:.3}");
    let s = s.trim_end_matches('0');
    s.trim_end_matches('.').to_string()
}

#[cfg(test)]
mod tests {
    use super::short;

    #[test]
    fn reference_figures_are_written_short() {
        assert_eq!(short(0.5 * (96.4 + 97.7)), "97.05");
        assert_eq!(short(0.5 * (97.7 - 96.4)), "0.65");
        assert_eq!(short(3.86), "3.86");
        assert_eq!(short(4.0), "4");
    }
}
