//! # The paper's expansion scenario (`host-sim simulate`)
//!
//! The expansion zone (D0 18.7 mm → 25 mm over 20 mm) in submerged,
//! coarse-grained sand at a given depth: [`scenario`] builds the bed (skin,
//! front face, box walls, grains, surcharge layer for the overburden),
//! [`run`] settles it and inflates the zone by injected volume, [`output`]
//! writes the samples (CSV), the pressures against D (SVG) and VTK frames.
//!
//! Not yet: the head receding distance D_r (the front face is fixed), and
//! any calibration against the paper (see `host-sim/README-simulate.md`).

pub mod output;
pub mod run;
pub mod scenario;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Result;

use crate::coupling::Sample;
use crate::fem::vtk::write_vtk;
pub use run::Settled;
pub use scenario::{build, Bed, ScenarioSpec};

/// What a run produced.
#[derive(Clone, Debug)]
pub struct Report {
    /// The case.
    pub spec: ScenarioSpec,
    /// Grains in the slab and in the surcharge layer.
    pub grains: (usize, usize),
    /// The surcharge's vertical stress on the slab top (Pa).
    pub surcharge_pa: f64,
    /// The settled state.
    pub settled: Settled,
    /// The expansion's samples.
    pub samples: Vec<Sample>,
    /// Wall time of the whole run (s).
    pub wall_s: f64,
}

impl Report {
    /// The last sample (the final diameter).
    pub fn last(&self) -> Option<&Sample> {
        self.samples.last()
    }

    /// Drop of the front-face pressure from the settled mean to the end
    /// (fraction of the settled value).
    pub fn face_pressure_drop(&self) -> Option<f64> {
        let p0 = self.settled.face_pressure_pa;
        let p1 = self.last()?.face_pressure_pa?;
        (p0 > 0.0).then(|| 1.0 - p1 / p0)
    }

    /// A plain-text summary.
    pub fn text(&self) -> String {
        let mut s = String::new();
        let st = &self.settled;
        let _ = writeln!(
            s,
            "simulate: depth {:.0} mm, grain radius {:.2} mm, {} slab + {} surcharge grains, surcharge {:.0} Pa, dt {:.2e} s",
            self.spec.depth_m * 1e3,
            self.spec.grain_radius_m * 1e3,
            self.grains.0,
            self.grains.1,
            self.surcharge_pa,
            self.spec.dt_s()
        );
        let _ = writeln!(
            s,
            "settled (means over its last quarter): support {:.4} N vs buoyant weight {:.4} N (floor {:.4} N), p_e {:.3} kPa, p_h {:.3} kPa; at its end: slab top {:.1} mm above the axis, D {:.2} mm, p_i {:.3} kPa, kinetic energy {:.2e} J",
            st.support_n,
            st.buoyant_weight_n,
            st.floor_force_n,
            st.sand_pressure_pa * 1e-3,
            st.face_pressure_pa * 1e-3,
            st.slab_top_m * 1e3,
            st.sample.outer_diameter_m * 1e3,
            st.sample.internal_pressure_pa * 1e-3,
            st.kinetic_energy_j
        );
        if let Some(l) = self.last() {
            let _ = writeln!(
                s,
                "final: D {:.2} mm, p_i {:.3} kPa, p_e {:.3} kPa, p_h {:.3} kPa (drop {:.1} %), max von Mises {:.4} MPa, {} samples",
                l.outer_diameter_m * 1e3,
                l.internal_pressure_pa * 1e-3,
                l.sand_pressure_pa * 1e-3,
                l.face_pressure_pa.unwrap_or(f64::NAN) * 1e-3,
                100.0 * self.face_pressure_drop().unwrap_or(f64::NAN),
                l.max_von_mises_pa * 1e-6,
                self.samples.len()
            );
        }
        let _ = writeln!(
            s,
            "paper (4 cm): p_e 3.86 ± 1.24 kPa (experiment), p_i 4.06 kPa, p_h drop 97.7 %, max von Mises 0.042 MPa"
        );
        let _ = writeln!(s, "wall time {:.1} s", self.wall_s);
        s
    }
}

/// Options of a command-line run.
#[derive(Clone, Debug)]
pub struct Options {
    /// The case.
    pub spec: ScenarioSpec,
    /// Folder for the results (`None`: write nothing).
    pub out: Option<PathBuf>,
    /// Show a progress bar.
    pub progress: bool,
}

/// Builds, settles and inflates `opts.spec`, writing samples.csv,
/// pressures.svg, summary.txt and vtk/ frames under `opts.out`.
pub fn simulate(opts: &Options) -> Result<Report> {
    let t0 = Instant::now();
    let bar = run::progress_bar(opts.progress)?;
    let mut bed = build(&opts.spec)?;
    let settled = run::settle(&mut bed, &bar)?;
    let mut frames: Vec<(String, String, f64)> = Vec::new();
    let samples = run::inflate(&mut bed, &bar, |b, k| {
        if let Some(dir) = &opts.out {
            frames.push(write_frame(dir, b, k)?);
        }
        Ok(())
    })?;
    bar.finish_and_clear();
    let report = Report {
        spec: opts.spec.clone(),
        grains: (bed.slab_grains, bed.surcharge_grains),
        surcharge_pa: opts.spec.surcharge_pa(),
        settled,
        samples,
        wall_s: t0.elapsed().as_secs_f64(),
    };
    if let Some(dir) = &opts.out {
        output::write_text(dir, "samples.csv", &output::samples_csv(&report.samples)?)?;
        let title = format!(
            "expansion at h = {:.0} mm, r = {:.1} mm grains",
            opts.spec.depth_m * 1e3,
            opts.spec.grain_radius_m * 1e3
        );
        let svg = output::pressure_plot_svg(&report.samples, &title)?;
        output::write_text(dir, "pressures.svg", svg.as_bytes())?;
        let grains: Vec<(String, f64)> = frames.iter().map(|f| (f.0.clone(), f.2)).collect();
        let skin: Vec<(String, f64)> = frames.iter().map(|f| (f.1.clone(), f.2)).collect();
        output::write_text(
            dir,
            "grains.vtk.series",
            output::vtk_series(&grains).as_bytes(),
        )?;
        output::write_text(dir, "skin.vtk.series", output::vtk_series(&skin).as_bytes())?;
        output::write_text(dir, "summary.txt", report.text().as_bytes())?;
    }
    Ok(report)
}

/// Writes frame `k` (grains and skin) under `dir/vtk/`; returns the two
/// relative names and the time.
fn write_frame(dir: &Path, bed: &Bed, k: usize) -> Result<(String, String, f64)> {
    let t = bed.state.time_s;
    let grains = format!("vtk/grains_{k:04}.vtk");
    let skin = format!("vtk/skin_{k:04}.vtk");
    output::write_text(
        dir,
        &grains,
        output::particles_vtk(&bed.state.particles, t).as_bytes(),
    )?;
    write_vtk(&bed.coupling.skin, &dir.join(&skin))?;
    Ok((grains, skin, t))
}
