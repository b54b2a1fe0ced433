//! The actuator's own free inflation as a skin test: an experiment
//! folder's runs at depth 0 (free in water) give pressure against diameter,
//! and a skin law's shape is fitted to it through the thick-walled tube
//! (`skin::inflation`). `fit-skin --inflation EXP` is this.
//!
//! The diameter comes from the pumped volume by the firmware's own rule
//! (the zone is a cylinder of the rig's expansion length), as in the rig
//! model; the gauge pressure at depth 0 is taken as the skin's alone (the
//! model's baseline: no sand, no line loss, no air).

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use rig::Experiment;
use skin::coupon::CouponTest;
use skin::fit::LawFit;
use skin::inflation::{bin, compare, fit_inflation, InflationPoint, InflationReport};
use skin::membrane::TubeGeometry;
use skin::LawSpec;
use urechis::controller::geometry::ExpansionZone;

/// The free runs of a folder as inflation points.
#[derive(Clone, Debug)]
pub struct FreeInflation {
    /// The folder.
    pub folder: PathBuf,
    /// Ids of the runs at depth 0.
    pub runs: Vec<String>,
    /// Rest geometry of the zone's tube.
    pub geometry: TubeGeometry,
    /// Every sample of those runs: diameter from the volume, pressure.
    pub samples: Vec<InflationPoint>,
    /// What reading the folder found odd but accepted.
    pub warnings: Vec<String>,
    /// What the fit should say with its result (a pressure that is not
    /// the skin's alone).
    pub fit_warnings: Vec<String>,
}

impl FreeInflation {
    /// Reads `dir` (the workbench's reader) and keeps its depth-0 runs; an
    /// error naming the folder when it has none.
    pub fn read(dir: &Path) -> Result<FreeInflation> {
        let exp = Experiment::read(dir)?;
        Self::of(dir, &exp)
    }

    /// The free runs of an experiment already read from `dir`.
    pub fn of(dir: &Path, exp: &Experiment) -> Result<FreeInflation> {
        let a = &exp.rig.actuator;
        let zone = ExpansionZone {
            initial_diameter_mm: a.initial_diameter_mm as f32,
            expansion_length_mm: a.expansion_length_mm as f32,
        };
        let free: Vec<&rig::Run> = exp.runs.iter().filter(|r| r.depth_mm == 0.0).collect();
        if free.is_empty() {
            let depths: Vec<String> = exp
                .runs
                .iter()
                .map(|r| format!("{} at {} mm", r.id, r.depth_mm))
                .collect();
            bail!(
                "{}: no free run (depth_mm = 0) to fit the skin to; runs: {}",
                dir.display(),
                depths.join(", ")
            );
        }
        let samples = free
            .iter()
            .flat_map(|r| &r.samples)
            .map(|s| InflationPoint {
                diameter_mm: f64::from(zone.diameter_mm(s.volume_ml as f32)),
                pressure_kpa: s.pressure_kpa,
            })
            .collect();
        let mut fit_warnings = Vec::new();
        if exp.rig.measurement.pressure_source == rig::PressureSource::PistonForce {
            fit_warnings.push(format!(
                "{}/rig.toml: pressure_source = \"piston_force\": the piston's friction is read as skin stiffness by the inflation fit",
                dir.display()
            ));
        }
        Ok(FreeInflation {
            fit_warnings,
            folder: dir.to_path_buf(),
            runs: free.iter().map(|r| r.id.clone()).collect(),
            geometry: a.tube(),
            samples,
            warnings: exp.warnings.clone(),
        })
    }

    /// Fits `spec` to the binned inflated samples and, when `coupon` (a
    /// coupon fit of the same law and its tests) is given, compares the two.
    pub fn fit(
        &self,
        spec: &'static LawSpec,
        coupon: Option<(&LawFit, &[CouponTest])>,
    ) -> Result<InflationReport> {
        let d0 = self.geometry.outer_diameter_mm;
        let bins = bin(&self.samples, d0);
        let samples = self.samples.iter().filter(|p| p.diameter_mm >= d0).count();
        let hint = coupon
            .filter(|(f, _)| f.law == spec.name)
            .map(|(f, _)| f.parameters.as_slice());
        let fit = fit_inflation(spec, self.geometry, &bins, hint).with_context(|| {
            format!(
                "fitting {} to the free runs of {}",
                spec.name,
                self.folder.display()
            )
        })?;
        let coupon = coupon
            .filter(|(f, _)| f.law == spec.name)
            .and_then(|(f, tests)| compare(&fit, f, self.geometry, &bins, tests));
        Ok(InflationReport {
            folder: self.folder.clone(),
            runs: self.runs.clone(),
            samples,
            geometry: self.geometry,
            warnings: self.fit_warnings.clone(),
            bins,
            fit,
            coupon,
        })
    }
}
