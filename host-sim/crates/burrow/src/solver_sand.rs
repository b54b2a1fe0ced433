//! `host-sim solver-sand`: runs the FEM–DEM solver ([`crate`])
//! at each depth, bins each run's p_e over the outer diameter and writes
//! the stored results [`SolverSand`] reads ([`sand::solver::DATA_PATH`]).
//! The p_e stored is the sand's share of the internal pressure,
//! Δp_i = p_i − p_free(D) ([`crate::FreeCurve`]): what the
//! balloon experiment's p_e measures, and what the tables add to the
//! skin's own pressure.
//!
//! Binning is the smoothing: the solver's samples are single DEM steps,
//! scattered by the few grains touching the skin, so each stored row is
//! the mean D and mean p_e of the samples in one [`BIN_WIDTH_MM`] bin from
//! the settled diameter to the final one; empty bins are left out. Each
//! depth runs [`DEFAULT_SEEDS`] beds (seeds 1, 2, …) and the bins pool their
//! samples: the bed's grain arrangement scatters Δp_i by 2–6 % between
//! seeds (the crate README), and the tables should not carry one bed's
//! accident.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{ensure, Context, Result};
use serde::Serialize;

use rig::Rig;
use sand::solver::{SolverSand, COLUMNS, INITIAL_DIAMETER_KEY, SKIN_LAW_KEY, UNIT_WEIGHT_KEY};
use skin::SkinLaw;

use crate::cases::Runner;
use crate::stats::mean_sd;
pub use crate::stats::{bin_samples, bin_samples_indexed, Bin};
use crate::{Ensemble, ScenarioSpec};

/// Grain radius of the solver runs (mm): the coarse-grained sand of
/// `host-sim simulate`'s default case.
pub const GRAIN_RADIUS_MM: f64 = crate::scenario::DEFAULT_GRAIN_RADIUS_M * 1e3;

/// Depths of the solver runs (mm): the paper's balloon experiment's.
pub const DEPTHS_MM: [f64; 4] = [40.0, 50.0, 70.0, 100.0];

/// Beds (seeds 1, 2, …) run at each depth by default.
pub const DEFAULT_SEEDS: u64 = 3;

/// Width of the diameter bins (mm): the firmware table's column spacing.
pub const BIN_WIDTH_MM: f64 = 0.25;

/// What to run.
#[derive(Clone, Debug, PartialEq)]
pub struct RegenerateOptions {
    /// Solver depths (mm).
    pub depths_mm: Vec<f64>,
    /// `ScenarioSpec::quick` instead of `ScenarioSpec::paper`.
    pub quick: bool,
    /// Show the solver's progress bar.
    pub progress: bool,
    /// A user's set-up instead of the paper's.
    pub rig: Option<RigSetup>,
    /// Beds per depth (seeds 1..=seeds), pooled in the bins (≥ 1).
    pub seeds: u64,
    /// Where to keep the runs' own results (`hDEPTHmm/` per depth: each
    /// seed's `simulate` folder and the ensemble's mean ± SD); `None`:
    /// nothing but the data file.
    pub runs_out: Option<PathBuf>,
}

/// A user's set-up for the solver runs ([`ScenarioSpec::with_rig`]).
#[derive(Clone, Debug, PartialEq)]
pub struct RigSetup {
    /// The rig.
    pub rig: Rig,
    /// Where it was read from (named in errors and in the data file).
    pub file: String,
    /// Final outer diameter (mm); `None`: the paper's stretch.
    pub final_diameter_mm: Option<f64>,
}

impl RegenerateOptions {
    /// The paper's set-up at `depths_mm`.
    pub fn paper(depths_mm: Vec<f64>, quick: bool) -> RegenerateOptions {
        RegenerateOptions {
            depths_mm,
            quick,
            progress: false,
            rig: None,
            seeds: DEFAULT_SEEDS,
            runs_out: None,
        }
    }

    /// The seeds run at each depth: `self.seeds` of them from `spec`'s.
    pub fn seed_list(&self, spec: &ScenarioSpec) -> Vec<u64> {
        (spec.seed..spec.seed + self.seeds).collect()
    }

    /// The skin of the table these runs are for, as the table's model
    /// (`model::pressure_model`) takes it: the rig's law
    /// ([`Rig::skin_law`]: `--skin-fit`, `[skin]` or the default skin),
    /// else the project's default skin, in both cases unscaled.
    pub fn table_skin(&self) -> SkinLaw {
        self.rig
            .as_ref()
            .map_or_else(|| skin::default_skin().into(), |r| r.rig.skin_law())
    }

    /// The solver case at `depth_mm`: [`spec`], with the rig's set-up, its
    /// skin the table's ([`RegenerateOptions::table_skin`]), so the sand's
    /// share is measured on the skin it will be added to.
    pub fn spec(&self, depth_mm: f64) -> Result<ScenarioSpec> {
        let Some(setup) = &self.rig else {
            return Ok(spec(depth_mm, self.quick).with_skin_law(self.table_skin()));
        };
        let (h, r) = (depth_mm * 1e-3, ScenarioSpec::grain_radius_for(&setup.rig));
        let base = if self.quick {
            ScenarioSpec::quick(h, r)
        } else {
            ScenarioSpec::paper(h, r)
        };
        let final_m = setup.final_diameter_mm.map(|d| d * 1e-3);
        Ok(base
            .with_rig(&setup.rig, &setup.file, final_m)?
            .0
            .with_skin_law(self.table_skin()))
    }
}

/// One depth's run.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DepthRun {
    /// Depth of the zone's axis (mm).
    pub depth_mm: f64,
    /// Outer diameter after settling, where the bins start (mm); the
    /// smallest of the seeds'.
    pub settled_diameter_mm: f64,
    /// Last sample's D (mm), mean over the seeds.
    pub final_diameter_mm: f64,
    /// Last sample's p_e (kPa), mean over the seeds.
    pub final_p_e_kpa: f64,
    /// Standard deviation of the last sample's p_e over the seeds (kPa);
    /// 0 for one seed.
    pub final_p_e_sd_kpa: f64,
    /// Grains in the run (slab and surcharge).
    pub grains: usize,
    /// The binned p_e.
    pub bins: Vec<Bin>,
    /// Wall time of the runs (s), all seeds.
    pub wall_s: f64,
}

/// The solver case at `depth_mm`.
pub fn spec(depth_mm: f64, quick: bool) -> ScenarioSpec {
    let (h, r) = (depth_mm * 1e-3, GRAIN_RADIUS_MM * 1e-3);
    if quick {
        ScenarioSpec::quick(h, r)
    } else {
        ScenarioSpec::paper(h, r)
    }
}

/// Runs the solver at `depth_mm` for each seed (writing no files but
/// under `opts.runs_out`) and bins their pooled p_e; `None` where another
/// part of a split run ([`Runner`]) runs some of the seeds.
pub fn run_depth(
    opts: &RegenerateOptions,
    depth_mm: f64,
    runner: &Runner,
) -> Result<Option<DepthRun>> {
    let base = opts.spec(depth_mm)?;
    let final_mm = base.final_diameter_m * 1e3;
    let seeds = opts.seed_list(&base);
    let dir = opts
        .runs_out
        .as_ref()
        .map(|d| d.join(format!("h{depth_mm}mm")));
    let Some(ensemble) = Ensemble::run_part(&base, &seeds, dir.as_deref(), opts.progress, runner)
        .with_context(|| format!("solver runs at h = {depth_mm} mm"))?
    else {
        return Ok(None);
    };
    let mut points: Vec<(f64, f64)> = Vec::new();
    let (mut settled_mm, mut grains) = (f64::INFINITY, 0);
    let mut finals = Vec::new();
    for (report, seed) in ensemble.reports.iter().zip(&seeds) {
        let last = report.last().with_context(|| {
            format!("the solver run at h = {depth_mm} mm, seed {seed} gave no samples")
        })?;
        let share = |s: &crate::coupling::Sample| report.sand_share_pa(s).unwrap_or(f64::NAN);
        settled_mm = settled_mm.min(report.settled.sample.outer_diameter_m * 1e3);
        grains = report.grains.0 + report.grains.1;
        finals.push((last.outer_diameter_m * 1e3, share(last) * 1e-3));
        points.extend(
            report
                .samples
                .iter()
                .map(|s| (s.outer_diameter_m * 1e3, share(s) * 1e-3)),
        );
    }
    let mean_d = mean_sd(&finals.iter().map(|f| f.0).collect::<Vec<_>>()).0;
    let (mean_p, sd_p) = mean_sd(&finals.iter().map(|f| f.1).collect::<Vec<_>>());
    Ok(Some(DepthRun {
        depth_mm,
        settled_diameter_mm: settled_mm,
        final_diameter_mm: mean_d,
        final_p_e_kpa: mean_p,
        final_p_e_sd_kpa: sd_p,
        grains,
        bins: bin_samples(&points, settled_mm, final_mm, BIN_WIDTH_MM),
        wall_s: ensemble.reports.iter().map(|r| r.wall_s).sum(),
    }))
}

/// The data file's text for `runs` made with `opts`.
pub fn csv_text(runs: &[DepthRun], opts: &RegenerateOptions) -> Result<String> {
    let quick = opts.quick;
    let first = runs.first().context("no solver runs")?;
    let probe = opts.spec(first.depth_mm)?;
    // γ' in kPa per mm of depth (N/m³ × 1e-6); the same for every depth.
    let unit_weight = probe.buoyant_unit_weight_n_m3() * 1e-6;
    for r in runs {
        let g = opts.spec(r.depth_mm)?.buoyant_unit_weight_n_m3() * 1e-6;
        ensure!(
            g == unit_weight,
            "the solver's unit weight differs between depths"
        );
    }
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# p_e(D, h) of the FEM-DEM solver (host-sim simulate): the sand's share of p_i, binned over D; see README.md here."
    );
    let rig_args = opts.rig.as_ref().map_or(String::new(), |r| {
        let d = r
            .final_diameter_mm
            .map_or(String::new(), |d| format!(" --final-diameter-mm {d}"));
        format!(" --rig {}{d} --out FILE", r.file)
    });
    let seeds_arg = if opts.seeds == DEFAULT_SEEDS {
        String::new()
    } else {
        format!(" --seeds {}", opts.seeds)
    };
    let _ = writeln!(
        s,
        "# Regenerate: cargo sim solver-sand{}{seeds_arg}{rig_args}",
        if quick { " --quick" } else { "" }
    );
    let _ = writeln!(s, "# {UNIT_WEIGHT_KEY} = {unit_weight:.10}");
    // Rounded to the nm: no binary noise in the header.
    let r_mm = (probe.grain_radius_m * 1e9).round() / 1e6;
    let _ = writeln!(s, "# grain_radius_mm = {r_mm}");
    // The grains' stiffness during the expansion, and while they settled.
    let _ = writeln!(s, "# grain_modulus_mpa = {}", probe.grain_modulus_pa * 1e-6);
    let _ = writeln!(
        s,
        "# deposition_modulus_mpa = {}",
        probe.deposition_modulus_pa * 1e-6
    );
    if opts.rig.is_some() {
        let _ = writeln!(s, "# setup = {}", probe.setup);
        let _ = writeln!(
            s,
            "# {INITIAL_DIAMETER_KEY} = {}",
            probe.tube.outer_diameter_mm
        );
        let _ = writeln!(s, "# final_diameter_mm = {}", probe.final_diameter_m * 1e3);
    }
    // The skin's law as the runs used it: the tables refuse a file made
    // with another skin than theirs.
    let _ = writeln!(s, "# {SKIN_LAW_KEY} = {}", probe.skin_law()?.describe());
    // Its wall: hexahedra through it, 0 for the mid-surface membrane.
    let _ = writeln!(s, "# skin_layers = {}", probe.skin_kind.layers());
    // What moved the head through the expansion (`simulate --head`).
    let _ = writeln!(s, "# head = {}", probe.head);
    let _ = writeln!(s, "# run = {}", if quick { "quick" } else { "full" });
    let seeds: Vec<String> = opts
        .seed_list(&probe)
        .iter()
        .map(|k| k.to_string())
        .collect();
    let _ = writeln!(s, "# seeds = {}", seeds.join(" "));
    let _ = writeln!(s, "# bin_width_mm = {BIN_WIDTH_MM}");
    let _ = writeln!(s, "{}", COLUMNS.join(","));
    for r in runs {
        for b in &r.bins {
            let _ = writeln!(
                s,
                "{},{:.4},{:.4},{}",
                r.depth_mm, b.diameter_mm, b.p_e_kpa, b.samples
            );
        }
    }
    Ok(s)
}

/// Runs every depth of `opts` in increasing order, calling `on_depth`
/// after each, and writes the data file to `out` atomically, after
/// checking that [`SolverSand`] reads it back; `None` (and no file) where
/// another part of a split run ([`Runner`]) runs some of the cases.
pub fn regenerate(
    opts: &RegenerateOptions,
    out: &Path,
    runner: &Runner,
    mut on_depth: impl FnMut(&DepthRun),
) -> Result<Option<Vec<DepthRun>>> {
    let mut depths = opts.depths_mm.clone();
    ensure!(!depths.is_empty(), "no depths given");
    ensure!(
        depths.iter().all(|d| d.is_finite() && *d > 0.0),
        "depths must be positive (mm): {depths:?}"
    );
    depths.sort_by(f64::total_cmp);
    depths.dedup();
    let mut runs = Vec::with_capacity(depths.len());
    for &h in &depths {
        if let Some(run) = run_depth(opts, h, runner)? {
            on_depth(&run);
            runs.push(run);
        }
    }
    if runs.len() < depths.len() {
        return Ok(None);
    }
    let text = csv_text(&runs, opts)?;
    SolverSand::parse(&text, &out.display().to_string())
        .context("the solver results do not make a valid data file")?;
    datafile::write_atomic(out, text.as_bytes())
        .with_context(|| format!("writing {}", out.display()))?;
    Ok(Some(runs))
}
