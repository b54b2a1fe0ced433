//! # The cavity benchmark
//!
//! A code-to-code problem for the DEM (`shared/cavity/README.md`): a rigid
//! cylinder, axis horizontal and the bed periodic along it, grows from
//! 18.7 to 25 mm in a settled, submerged bed between two side walls on a
//! floor; the pressure on it, p_e = ΣF_n / (π·2R·L), is averaged over each
//! 1 % of the expansion. The same beds, contact law and schedule run in
//! LAMMPS (`shared/cavity/in.expand`); [`compare`] reads its averages and
//! sets the two curves side by side.
//!
//! - [`bed`]: the shared beds (`id,x,y,z,radius`, m);
//! - [`problem`]: the box, the grains, the contact law and the schedule,
//!   as the DEM's parameters;
//! - [`curve`]: the 1 % windows, `pe.csv`, the plot and the comparison.

pub mod bed;
pub mod curve;
pub mod problem;

pub use bed::Bed;
pub use curve::{compare, Comparison, Curve, Window};
pub use problem::{at_rest_kpa, run, Cavity, Schedule};

use std::path::Path;

use anyhow::Result;

/// What a run took, for `summary.json`.
#[derive(Clone, Debug, serde::Serialize)]
pub struct RunInfo {
    /// The bed file.
    pub bed: String,
    /// Spheres in it.
    pub spheres: usize,
    /// Expansion asked for (s).
    pub expansion_s: f64,
    /// The schedule in steps.
    pub window_steps: u64,
    /// See [`Schedule::start_step`].
    pub start_step: u64,
    /// Last step.
    pub end_step: u64,
    /// Wall-clock time of the run (s).
    pub wall_s: f64,
    /// Rayon workers.
    pub workers: usize,
}

/// Writes `DIR/pe.csv`, `DIR/pe.svg` and `DIR/summary.json` for `ours`,
/// and with a `peer` curve also `DIR/comparison.csv` (at rest and every
/// 10 %) with both curves in the plot; returns the comparison. Every file
/// is written atomically.
pub fn write_report(
    dir: &Path,
    info: &RunInfo,
    ours: &Curve,
    peer: Option<&Curve>,
) -> Result<Option<Comparison>> {
    std::fs::create_dir_all(dir)?;
    datafile::write_atomic(&dir.join("pe.csv"), ours.csv().as_bytes())?;
    let comparison = peer.map(|p| compare(ours, p));
    let title = format!(
        "cavity expansion, {} ({} spheres, {} s)",
        info.bed, info.spheres, info.expansion_s
    );
    let mut curves = vec![("this DEM", ours)];
    if let Some(p) = peer {
        curves.push(("LAMMPS", p));
    }
    datafile::write_atomic(
        &dir.join("pe.svg"),
        curve::plot_svg(&title, &curves)?.as_bytes(),
    )?;
    if let Some(c) = &comparison {
        datafile::write_atomic(&dir.join("comparison.csv"), c.csv().as_bytes())?;
    }
    let summary = serde_json::json!({
        "run": info,
        "at_rest_kpa": ours.at_rest_kpa,
        "pe_at_100_percent_kpa": ours.expansion.last().map(|w| w.pe_kpa),
        "comparison": comparison,
    });
    datafile::write_atomic(
        &dir.join("summary.json"),
        serde_json::to_string_pretty(&summary)?.as_bytes(),
    )?;
    Ok(comparison)
}

/// [`run`] with a progress bar on the terminal (steps, rate, time left).
pub fn run_with_progress(cavity: &Cavity, bed: &Bed, expansion_s: f64) -> Result<Curve> {
    let bar = indicatif::ProgressBar::new(0);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{elapsed_precise} [{bar:40}] step {pos}/{len} ({per_sec}, {eta} left)",
        )?
        .progress_chars("=> "),
    );
    let curve = run(cavity, bed, expansion_s, |k, end| {
        if k == 1 {
            bar.set_length(end);
        }
        if k % 100 == 0 || k == end {
            bar.set_position(k);
        }
    })?;
    bar.finish_and_clear();
    Ok(curve)
}
