//! # The paper's expansion scenario (`host-sim simulate`)
//!
//! The expansion zone (D0 18.7 mm → 25 mm over 20 mm) in submerged,
//! coarse-grained sand at a given depth: [`scenario`] builds the bed (skin,
//! sliding head with its front face, box walls, the sand column),
//! [`run`] settles it and inflates the zone by injected volume, the head
//! drawn back as it swells ([`scenario::HeadSupport`]), [`output`]
//! writes the samples (CSV), the pressures against D (SVG) and VTK frames.
//!
//! [`free_skin`] gives the zone's pressure with no sand, so a run reports
//! the sand's share of p_i as the balloon experiment measures it;
//! [`ensemble`] repeats a case over seeds for mean ± SD. The
//! calibration and the validation against the paper are in
//! `host-sim/crates/burrow/README.md`.

pub mod balloon;
pub mod cases;
pub mod coupling;
pub mod ensemble;
pub mod free_skin;
pub mod output;
pub mod run;
pub mod scenario;
pub mod settings;
pub mod solver_sand;
pub mod stats;
pub mod validate;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result};
use datafile::write_atomic;
use serde::{Deserialize, Serialize};

use crate::coupling::Sample;
pub use ensemble::Ensemble;
pub use free_skin::FreeCurve;
pub use run::Settled;
pub use scenario::{build, Bed, HeadSupport, ScenarioSpec};
use skin::membrane::TubeGeometry;

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
    /// The zone's pressure with no sand, p_free(D).
    pub free: FreeCurve,
    /// Wall time of the whole run (s).
    pub wall_s: f64,
    /// Wall time of each phase (s).
    pub phases: PhaseTimes,
    /// Skin steps per DEM step over the whole run (≥ 1; more where the
    /// skin's stable step is the shorter).
    pub skin_steps_per_dem_step: f64,
    /// The most mass the skin's mass scaling added while the bed settled,
    /// as a fraction of the wall's own; 0: none
    /// ([`ScenarioSpec::skin_mass_scaling`]).
    pub skin_added_mass: f64,
}

impl Report {
    /// The last sample (the final diameter).
    pub fn last(&self) -> Option<&Sample> {
        self.samples.last()
    }

    /// Means over the end of the expansion, the samples within
    /// [`FINAL_WINDOW_M`] of the final diameter (single DEM steps scatter
    /// by tens of per cent; the paper's quantities sit on a plateau there).
    pub fn final_means(&self) -> Option<FinalMeans> {
        let d1 = self.last()?.outer_diameter_m;
        let tail: Vec<&Sample> = self
            .samples
            .iter()
            .filter(|s| s.outer_diameter_m >= d1 - FINAL_WINDOW_M)
            .collect();
        let mean =
            |f: &dyn Fn(&Sample) -> f64| tail.iter().map(|s| f(s)).sum::<f64>() / tail.len() as f64;
        Some(FinalMeans {
            samples: tail.len(),
            internal_pressure_pa: mean(&|s| s.internal_pressure_pa),
            sand_pressure_pa: mean(&|s| s.sand_pressure_pa),
            face_pressure_pa: mean(&|s| s.face_pressure_pa.unwrap_or(f64::NAN)),
            max_von_mises_pa: tail.iter().map(|s| s.max_von_mises_pa).fold(0.0, f64::max),
            max_bending_strain: tail
                .iter()
                .filter_map(|s| s.max_bending_strain)
                .reduce(f64::max),
            head_receding_m: mean(&|s| s.head_receding_m),
            head_pull_n: mean(&|s| s.head_pull_n),
            sand_share_pa: mean(&|s| self.sand_share_pa(s).unwrap_or(f64::NAN)),
        })
    }

    /// The sand's share of the internal pressure at sample `s`,
    /// Δp_i = p_i − p_free(D) (Pa): the experiment's p_e.
    pub fn sand_share_pa(&self, s: &Sample) -> Option<f64> {
        Some(s.internal_pressure_pa - self.free.pressure_pa(s.outer_diameter_m)?)
    }

    /// The front-face pressure the expansion starts from (Pa): the first
    /// sample's, after the advance ([`ScenarioSpec::advance_m`]); the
    /// settled mean when there was none.
    pub fn initial_face_pressure_pa(&self) -> f64 {
        if self.spec.advance_m > 0.0 {
            self.samples
                .first()
                .and_then(|s| s.face_pressure_pa)
                .unwrap_or(f64::NAN)
        } else {
            self.settled.face_pressure_pa
        }
    }

    /// Drop of the front-face pressure from where the expansion started
    /// ([`Report::initial_face_pressure_pa`]) to its mean over the samples
    /// with D ≥ `from_m` (fraction of the start): the paper reads its
    /// drop as flat past D ≈ 22 mm.
    pub fn face_pressure_drop_beyond(&self, from_m: f64) -> Option<f64> {
        let p0 = self.initial_face_pressure_pa();
        let tail: Vec<f64> = self
            .samples
            .iter()
            .filter(|s| s.outer_diameter_m >= from_m)
            .filter_map(|s| s.face_pressure_pa)
            .collect();
        let p1 = tail.iter().sum::<f64>() / tail.len() as f64;
        (p0 > 0.0 && !tail.is_empty()).then(|| 1.0 - p1 / p0)
    }

    /// Drop of the front-face pressure from where the expansion started
    /// to the final mean (fraction of the start).
    pub fn face_pressure_drop(&self) -> Option<f64> {
        let p0 = self.initial_face_pressure_pa();
        let p1 = self.final_means()?.face_pressure_pa;
        (p0 > 0.0 && p1.is_finite()).then(|| 1.0 - p1 / p0)
    }

    /// A plain-text summary.
    pub fn text(&self) -> String {
        let mut s = String::new();
        let st = &self.settled;
        let skin_kind = format!(
            "skin: {}{}",
            match self.spec.skin_kind {
                fem::SkinKind::Membrane => "membrane".to_string(),
                fem::SkinKind::Shell => "shell".to_string(),
                fem::SkinKind::Solid { layers } => format!(
                    "solid wall {layers} {} thick",
                    if layers.get() == 1 {
                        "hexahedron"
                    } else {
                        "hexahedra"
                    }
                ),
            },
            if self.spec.round_zone {
                ", rings held round"
            } else {
                ""
            }
        );
        let _ = writeln!(
            s,
            "simulate ({}): depth {:.0} mm, zone {} → {:.2} mm over {} mm ({}), grain radius {:.2} mm{}, grain modulus {} MPa (settled at {} MPa), {} slab + {} surcharge grains, surcharge {:.0} Pa, dt {:.2e} s",
            self.spec.setup,
            self.spec.depth_m * 1e3,
            self.spec.tube.outer_diameter_mm,
            self.spec.final_diameter_m * 1e3,
            self.spec.tube.length_mm,
            skin_kind,
            self.spec.grain_radius_m * 1e3,
            self.spec
                .face_grain_radius_m
                .map_or(String::new(), |f| format!(" ({:.2} mm ahead of the face)", f * 1e3)),
            self.spec.grain_modulus_pa * 1e-6,
            self.spec.deposition_modulus_pa * 1e-6,
            self.grains.0,
            self.grains.1,
            self.surcharge_pa,
            self.spec.dt_s()
        );
        let _ = writeln!(
            s,
            "settled (means over its last quarter): support {:.4} N vs buoyant weight {:.4} N (floor {:.4} N), p_e {:.3} kPa, p_h {:.3} kPa; at its end: surface {:.1} mm above the axis (highest grain {:.1} mm), head pushed back {:.2} mm, D {:.2} mm, p_i {:.3} kPa, kinetic energy {:.2e} J",
            st.support_n,
            st.buoyant_weight_n,
            st.floor_force_n,
            st.sand_pressure_pa * 1e-3,
            st.face_pressure_pa * 1e-3,
            st.surface_m * 1e3,
            st.slab_top_m * 1e3,
            st.head_settling_m * 1e3,
            st.sample.outer_diameter_m * 1e3,
            st.sample.internal_pressure_pa * 1e-3,
            st.kinetic_energy_j
        );
        if let (true, Some(f)) = (self.spec.advance_m > 0.0, self.samples.first()) {
            let pause = if self.spec.advance_hold_s > 0.0 {
                format!(" and a {:.1} ms pause", self.spec.advance_hold_s * 1e3)
            } else {
                String::new()
            };
            let head = match self.spec.head {
                scenario::HeadSupport::Held => {
                    ", the head then held through the expansion".to_string()
                }
                scenario::HeadSupport::Free => ", the head then free".to_string(),
                _ => self
                    .spec
                    .expansion_head_draw()
                    .map_or_else(String::new, |d| {
                        format!(
                            ", the head then drawn back with the swelling, {:.2} mm by D = {:.2} mm",
                            d.final_receding_m * 1e3,
                            d.final_diameter_m * 1e3
                        )
                    }),
            };
            let _ = writeln!(
                s,
                "after the {:.2} mm advance{pause}{head} (the expansion's start): D {:.2} mm, p_i {:.3} kPa, p_e (contact) {:.3} kPa, p_h {:.3} kPa",
                self.spec.advance_m * 1e3,
                f.outer_diameter_m * 1e3,
                f.internal_pressure_pa * 1e-3,
                f.sand_pressure_pa * 1e-3,
                f.face_pressure_pa.unwrap_or(f64::NAN) * 1e-3,
            );
        }
        if let (Some(l), Some(m)) = (self.last(), self.final_means()) {
            let pull = match self.spec.head {
                scenario::HeadSupport::Free => String::new(),
                _ if self.spec.balloon => format!(
                    " (the held front end taking {:.3} N, + pulling back)",
                    m.head_pull_n
                ),
                _ => format!(
                    " (the body pulling the head back with {:.3} N)",
                    m.head_pull_n
                ),
            };
            let _ = writeln!(
                s,
                "final (means over D ≥ {:.2} mm, {} samples): p_i {:.3} kPa, sand's share of it Δp_i {:.3} kPa, p_e (contact) {:.3} kPa, p_h {:.3} kPa (drop {:.1} % from the expansion's start at {:.3} kPa; {:.1} % over D ≥ {:.0} mm), D_r {:.2} mm{pull}, max von Mises {:.4} MPa",
                (l.outer_diameter_m - FINAL_WINDOW_M) * 1e3,
                m.samples,
                m.internal_pressure_pa * 1e-3,
                m.sand_share_pa * 1e-3,
                m.sand_pressure_pa * 1e-3,
                m.face_pressure_pa * 1e-3,
                100.0 * self.face_pressure_drop().unwrap_or(f64::NAN),
                self.initial_face_pressure_pa() * 1e-3,
                100.0 * self.face_pressure_drop_beyond(self.spec.face_drop_from_m()).unwrap_or(f64::NAN),
                self.spec.face_drop_from_m() * 1e3,
                m.head_receding_m * 1e3,
                m.max_von_mises_pa * 1e-6,
            );
            let _ = writeln!(
                s,
                "shape at the end: caliper diameters at mid-length {:.2} to {:.2} mm (D is their mean over the ring; round: equal)",
                l.calipers_m.0 * 1e3,
                l.calipers_m.1 * 1e3,
            );
            if let Some(e) = m.max_bending_strain {
                let _ = writeln!(
                    s,
                    "skin as a shell: largest surface bending strain {e:.2}{}",
                    if e > BENDING_STRAIN_LIMIT {
                        format!(" (over {BENDING_STRAIN_LIMIT}: the skin folds tighter than linear thin-shell bending describes; its stress peak is an extrapolation)")
                    } else {
                        String::new()
                    }
                );
            }
        }
        let p_free = self.last().and_then(|l| {
            Some((
                l.outer_diameter_m,
                self.free.pressure_pa(l.outer_diameter_m)?,
            ))
        });
        if let Some((d, p)) = p_free {
            // A Yeoh skin keeps the line it has always had.
            let whose = match &self.spec.skin_coefficients {
                Some(law) if law.yeoh().is_none() => law.describe(),
                _ => "the project's default skin, or the rig's".to_owned(),
            };
            let _ = writeln!(
                s,
                "the skin alone (no sand) needs {:.3} kPa at D = {:.2} mm (its law's coefficients × {:.2}: {whose})",
                p * 1e-3,
                d * 1e3,
                self.spec.skin_stiffness_scale
            );
        }
        match (self.spec.balloon_point(), self.spec.balloon) {
            (Some(b), true) => {
                let _ = writeln!(
                    s,
                    "balloon experiment at h = {:.0} mm: p_i {:.2} ± {:.2} kPa, p_e {:.2} ± {:.2} kPa (compare p_i and Δp_i)",
                    b.depth_mm,
                    b.internal_pressure_kpa(),
                    b.sd_kpa,
                    b.external_pressure_kpa,
                    b.sd_kpa
                );
            }
            (Some(b), false) => {
                let _ = writeln!(
                    s,
                    "paper at h = {:.0} mm: p_e {:.2} ± {:.2} kPa (balloon experiment; compare Δp_i; `host-sim balloon` reproduces the experiment)",
                    b.depth_mm, b.external_pressure_kpa, b.sd_kpa
                );
            }
            _ => {}
        }
        if self.spec.tube == TubeGeometry::PAPER && !self.spec.balloon {
            let _ = writeln!(
                s,
                "paper (4 cm): p_e 3.86 ± 1.24 kPa (experiment), p_i 4.06 kPa, p_h drop 97.7 %, max von Mises 0.042 MPa"
            );
        }
        let _ = writeln!(
            s,
            "skin steps per DEM step {:.2}",
            self.skin_steps_per_dem_step
        );
        if self.skin_added_mass > 0.0 {
            let _ = writeln!(
                s,
                "skin mass scaled to the DEM step while the bed settled: at most +{:.0} % of the wall's mass (its own mass after)",
                100.0 * self.skin_added_mass
            );
        }
        s
    }
}

impl Report {
    /// Where the run's wall time went: kept apart from [`Report::text`]
    /// (and in its own file, [`cases::TIMING`]), since a run repeated elsewhere gives the same
    /// results but not the same times.
    pub fn timing_text(&self) -> String {
        format!(
            "wall time {:.1} s (free curve {:.1}, settling {:.1}, advance {:.1}, expansion {:.1})\n",
            self.wall_s,
            self.phases.free_curve_s,
            self.phases.settling_s,
            self.phases.advance_s,
            self.phases.expansion_s,
        )
    }
}

/// Surface bending strain beyond which the shell's linear bending is
/// flagged in the summary.
pub const BENDING_STRAIN_LIMIT: f64 = 0.3;

/// Width of the diameter window the final means are taken over (m).
pub const FINAL_WINDOW_M: f64 = 0.3e-3;

/// Means over the last [`FINAL_WINDOW_M`] of the expansion.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FinalMeans {
    /// Samples in the window.
    pub samples: usize,
    /// Internal pressure p_i (Pa).
    pub internal_pressure_pa: f64,
    /// Sand pressure on the skin p_e (Pa).
    pub sand_pressure_pa: f64,
    /// Sand pressure on the front face p_h (Pa); NaN without a face.
    pub face_pressure_pa: f64,
    /// Largest skin von Mises stress in the window (Pa).
    pub max_von_mises_pa: f64,
    /// Largest surface bending strain in the window (a shell skin).
    pub max_bending_strain: Option<f64>,
    /// Head receding distance D_r (m).
    pub head_receding_m: f64,
    /// Force the body takes from a drawn or held head (N, + pulling it
    /// back); 0 for a free head.
    pub head_pull_n: f64,
    /// The sand's share of the internal pressure Δp_i = p_i − p_free(D)
    /// (Pa), the experiment's p_e (see [`free_skin`]).
    pub sand_share_pa: f64,
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

/// Wall time of a run's phases (s), for finding where a case's time goes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PhaseTimes {
    /// The free skin's curve p_free(D) (0 when it was shared, as in an
    /// ensemble).
    pub free_curve_s: f64,
    /// Building and settling the bed, the stiffening included.
    pub settling_s: f64,
    /// The advance (and any hold after it).
    pub advance_s: f64,
    /// The expansion, the VTK frames included.
    pub expansion_s: f64,
}

/// Builds, settles and inflates `opts.spec`, writing samples.csv,
/// pressures.svg, summary.txt and vtk/ frames under `opts.out`.
pub fn simulate(opts: &Options) -> Result<Report> {
    let t0 = Instant::now();
    let free = FreeCurve::of(&opts.spec)?;
    simulate_with(opts, free, t0.elapsed().as_secs_f64())
}

/// [`simulate`] with the zone's free curve `free` already computed (it
/// depends on the skin only, so runs differing in the sand share it), in
/// `free_curve_s` (s; counted in the wall time, 0 when shared).
pub fn simulate_with(opts: &Options, free: FreeCurve, free_curve_s: f64) -> Result<Report> {
    let t0 = Instant::now();
    let mut phases = PhaseTimes {
        free_curve_s,
        ..PhaseTimes::default()
    };
    let bar = run::progress_bar(opts.progress)?;
    let mut bed = build(&opts.spec)?;
    let settled = run::settle(&mut bed, &bar)?;
    phases.settling_s = t0.elapsed().as_secs_f64();
    run::advance(&mut bed, &bar)?;
    phases.advance_s = t0.elapsed().as_secs_f64() - phases.settling_s;
    let mut frames: Vec<(String, String, f64)> = Vec::new();
    let samples = run::inflate(&mut bed, &bar, |b, k| {
        if let Some(dir) = &opts.out {
            frames.push(write_frame(dir, b, k)?);
        }
        Ok(())
    })?;
    bar.finish_and_clear();
    let run_s = t0.elapsed().as_secs_f64();
    phases.expansion_s = run_s - phases.settling_s - phases.advance_s;
    let report = Report {
        spec: opts.spec.clone(),
        grains: (bed.slab_grains, bed.surcharge_grains),
        surcharge_pa: opts.spec.surcharge_pa(),
        settled,
        samples,
        free,
        wall_s: free_curve_s + run_s,
        phases,
        skin_steps_per_dem_step: bed.coupling.skin_steps as f64
            / bed.state.step_count.max(1) as f64,
        skin_added_mass: bed.coupling.max_added_mass,
    };
    if let Some(dir) = &opts.out {
        output::write_text(dir, "samples.csv", &output::samples_csv(&report)?)?;
        let title = format!(
            "expansion at h = {:.0} mm, r = {:.1} mm grains",
            opts.spec.depth_m * 1e3,
            opts.spec.grain_radius_m * 1e3
        );
        let svg = output::pressure_plot_svg(&report, &title)?;
        output::write_text(dir, "pressures.svg", svg.as_bytes())?;
        let svg = output::head_plot_svg(&report, &title)?;
        output::write_text(dir, "head.svg", svg.as_bytes())?;
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
    let path = dir.join(&skin);
    let text = fem::vtk::to_vtk(&bed.coupling.skin)
        .with_context(|| format!("skin state for {}", path.display()))?;
    write_atomic(&path, text.as_bytes())?;
    Ok((grains, skin, t))
}
