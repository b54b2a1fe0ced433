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
//! - [`curve`]: the 1 % windows, `pe.csv`, the plot and the comparison;
//! - [`theory`]: the continuum estimate, a cylindrical cavity in a
//!   Mohr–Coulomb medium (small and large strain).

pub mod bed;
pub mod curve;
pub mod problem;
pub mod theory;

pub use bed::{Bed, Packing};
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

/// What the continuum estimate of a run is made from: the medium's angles
/// (measured by `host-sim sand-test`), its stiffness, and the run.
#[derive(Clone, Copy, Debug)]
pub struct EstimateInput {
    /// Friction angle φ (degrees).
    pub friction_deg: f64,
    /// Dilatancy angle ψ (degrees).
    pub dilatancy_deg: f64,
    /// Shear modulus G of the bed (kPa); `None`: the Hertz–Mindlin
    /// effective-medium value at p0 ([`theory::hertz_mindlin_shear_modulus_kpa`]),
    /// an upper estimate.
    pub shear_modulus_kpa: Option<f64>,
    /// Poisson's ratio of the bed (−).
    pub poisson: f64,
}

/// The continuum estimate beside a DEM run, at rest and every 10 %.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Estimate {
    /// The medium and p0 (the run's p_e at rest) it was made for.
    pub theory: theory::CavityTheory,
    /// The packing of the far field the default G is made from.
    pub far_field: Packing,
    /// Whether G was given (else the effective-medium estimate).
    pub shear_modulus_given: bool,
    /// Rows: `[percent, D (mm), DEM p_e, large-strain p, small-strain p]`
    /// (kPa).
    pub rows: Vec<[f64; 5]>,
    /// Radius of the large-strain plastic zone at the end of the
    /// expansion (mm): where it passes the box's walls, floor or surface,
    /// the box is not the theory's infinite medium.
    pub plastic_radius_mm: f64,
}

/// The continuum estimate of the problem for the run `dem` in `bed`:
/// p0 = the run's p_e at rest, G as `input` says; writes `DIR/theory.csv`
/// (`percent,d_mm,dem_kpa,large_strain_kpa,small_strain_kpa`, at rest and
/// every 10 %) and `DIR/theory.svg` (the three curves).
pub fn write_estimate(
    dir: &Path,
    problem: &Cavity,
    bed: &Bed,
    dem: &Curve,
    input: EstimateInput,
) -> Result<Estimate> {
    // The far field beside the cylinder: 4 mm from the side wall to 6 mm
    // short of the cylinder's final radius, 5 mm above the floor to 5 mm
    // below the cylinder's axis (the bed's top is not known here).
    let far_field = bed.packing(
        nalgebra::Vector3::new(0.004, 0.0, 0.005),
        nalgebra::Vector3::new(
            problem.axis_xz_m[0] - problem.radius_m[1] - 0.006,
            problem.period_m,
            problem.axis_xz_m[1] - 0.005,
        ),
        problem.period_m,
    );
    let p0 = dem.at_rest_kpa;
    let g = match input.shear_modulus_kpa {
        Some(g) => g,
        None => {
            let m = &problem.grain;
            theory::hertz_mindlin_shear_modulus_kpa(
                m.youngs_modulus_pa / (2.0 * (1.0 + m.poisson_ratio)) / 1e3,
                m.poisson_ratio,
                far_field.coordination,
                1.0 - far_field.solid_fraction,
                p0,
            )
        }
    };
    let t = theory::CavityTheory::new(
        theory::Soil {
            friction_deg: input.friction_deg,
            dilatancy_deg: input.dilatancy_deg,
            shear_modulus_kpa: g,
            poisson: input.poisson,
        },
        p0,
    )?;
    let a_end = problem.radius_m[1] / problem.radius_m[0];
    let large = t.large_strain(a_end * 1.001, 2e-4, 100);
    let small = t.small_strain_curve(a_end * 1.001, 2000);
    // Each theory sampled at the DEM's windows, once: the plot's curves,
    // and the table's rows at every 10 %.
    let as_curve = |curve: &[theory::TheoryPoint]| Curve {
        at_rest_kpa: p0,
        d0_mm: dem.d0_mm,
        expansion: dem
            .expansion
            .iter()
            .map(|w| Window {
                end_step: 0,
                d_mm: w.d_mm,
                pe_kpa: theory::CavityTheory::pressure_at(curve, w.d_mm / dem.d0_mm)
                    .unwrap_or(f64::NAN),
            })
            .collect(),
    };
    let (l, s) = (as_curve(&large), as_curve(&small));
    let mut rows = vec![[0.0, dem.d0_mm, p0, p0, p0]];
    for p in (10..=100).step_by(10) {
        let (w, lw, sw) = (dem.expansion[p - 1], l.expansion[p - 1], s.expansion[p - 1]);
        rows.push([p as f64, w.d_mm, w.pe_kpa, lw.pe_kpa, sw.pe_kpa]);
    }
    std::fs::create_dir_all(dir)?;
    let mut csv = String::from("percent,d_mm,dem_kpa,large_strain_kpa,small_strain_kpa\n");
    for r in &rows {
        csv += &format!("{},{:.4},{:.6},{:.6},{:.6}\n", r[0], r[1], r[2], r[3], r[4]);
    }
    datafile::write_atomic(&dir.join("theory.csv"), csv.as_bytes())?;
    let title = format!(
        "DEM and cavity-expansion theory (φ {:.1}°, ψ {:.1}°, G/p0 {:.0})",
        input.friction_deg,
        input.dilatancy_deg,
        t.rigidity_index()
    );
    datafile::write_atomic(
        &dir.join("theory.svg"),
        curve::plot_svg(
            &title,
            &[
                ("this DEM", dem),
                ("large strain", &l),
                ("small strain", &s),
            ],
        )?
        .as_bytes(),
    )?;
    let plastic_radius_mm = large
        .iter()
        .find(|p| p.radius_ratio >= a_end)
        .map_or(f64::NAN, |p| {
            p.plastic_radius_ratio * 1e3 * problem.radius_m[0]
        });
    Ok(Estimate {
        theory: t,
        far_field,
        shear_modulus_given: input.shear_modulus_kpa.is_some(),
        rows,
        plastic_radius_mm,
    })
}
