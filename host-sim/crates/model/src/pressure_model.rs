//! The project's p_i(D, h): the skin tube's own pressure plus the sand's,
//! p_i = p_membrane(D) + p_e(D, h) (exact for an incompressible wall; see
//! [`skin::membrane`]). The firmware tables sample it with the
//! FEM–DEM solver's sand ([`SkinSandModel::paper_solver`]); the demo and the
//! skin tests use the parametric sand ([`SkinSandModel::paper_default`]).

use std::path::Path;

use anyhow::{ensure, Context, Result};

use rig::Rig;

use sand::{ParametricSand, SandLaw, SolverSand};
use skin::membrane::{Ends, InflationState, Tube};
use skin::SkinLaw;

/// The physics a table is sampled from: loading-branch internal pressure
/// p_i(D, h) in kPa for outer diameter D (mm) and sand depth h (mm).
pub trait PressureModel {
    /// p_i (kPa) at outer diameter `diameter_mm` and depth `depth_mm`.
    fn internal_pressure_kpa(&self, diameter_mm: f64, depth_mm: f64) -> f64;
    /// One line saying where the numbers come from (goes into the file).
    fn provenance(&self) -> String;
    /// True while the model is a stand-in, not the project's physics.
    fn is_placeholder(&self) -> bool;
}

/// Skin tube plus a sand law.
#[derive(Clone, Debug)]
pub struct SkinSandModel<S = ParametricSand> {
    /// The skin tube of the expansion zone.
    pub tube: Tube<SkinLaw>,
    /// Where the skin's law comes from (the file's provenance line).
    pub skin_source: String,
    /// The sand around it.
    pub sand: S,
}

/// The paper's zone (D0 18.7 mm, 1.75 mm skin, 20 mm,
/// [`TubeGeometry::PAPER`](skin::membrane::TubeGeometry::PAPER)) of
/// the default Yeoh skin with closed ends: the zone is part of a closed,
/// pressurised body, so its wall carries the pressure on the cross-section.
fn paper_tube() -> Tube<SkinLaw> {
    Tube::paper(skin::default_skin().into(), Ends::Closed)
}

/// Where the default skin comes from.
const DEFAULT_SKIN_SOURCE: &str = "fit to data/skin/unicinctus_circumferential.csv";

impl SkinSandModel<ParametricSand> {
    /// The paper's zone in the balloon-calibrated parametric sand.
    pub fn paper_default() -> Self {
        Self {
            tube: paper_tube(),
            skin_source: DEFAULT_SKIN_SOURCE.to_owned(),
            sand: ParametricSand::calibrated_to_balloon(),
        }
    }
}

impl SkinSandModel<SolverSand> {
    /// The paper's zone in the FEM–DEM solver's sand, read from the data
    /// file stored under the repository root `repo_root`.
    pub fn paper_solver(repo_root: &Path) -> Result<Self> {
        Self {
            tube: paper_tube(),
            skin_source: DEFAULT_SKIN_SOURCE.to_owned(),
            sand: SolverSand::from_repo(repo_root)?,
        }
        .checked_skin()
    }

    /// This model, if its sand was measured on its skin: the solver file's
    /// `skin_law` ([`sand::solver::SKIN_LAW_KEY`]) must be this tube's law.
    /// The sand's share of p_i depends on the skin it meets (a softer skin
    /// bulges into the sand less and meets less of it), so a share
    /// measured on one skin added to another's own pressure is not the
    /// p_i of either.
    pub fn checked_skin(self) -> Result<Self> {
        let want = self.tube.skin.describe();
        let redo = "run `host-sim solver-sand` for this skin (paper: `cargo sim solver-sand`; \
                    a rig or --skin-fit: `solver-sand --rig ... --out FILE`) and generate from that file";
        match self.sand.skin_law() {
            Some(got) if got == want => Ok(self),
            Some(got) => anyhow::bail!(
                "{}: {} = {got}, but the table's skin is {want} ({}): the sand's share was measured on another skin; {redo}",
                self.sand.source(),
                sand::solver::SKIN_LAW_KEY,
                self.skin_source
            ),
            None => anyhow::bail!(
                "{}: no `# {} = ...` header line: the file does not say which skin the sand's share was measured on (the table's is {want}); {redo}",
                self.sand.source(),
                sand::solver::SKIN_LAW_KEY,
            ),
        }
    }
}

impl SkinSandModel<SolverSand> {
    /// The actuator of `rig` (its tube; its skin law, [`Rig::skin_law`];
    /// closed ends, as the paper's) in the solver sand
    /// `sand`, which must have been run for that actuator (same D0, from
    /// `solver-sand --rig`); `rig_file` names the rig in errors.
    pub fn for_rig(rig: &Rig, rig_file: &str, sand: SolverSand) -> Result<Self> {
        let a = &rig.actuator;
        ensure!(
            (sand.initial_diameter_mm() - a.initial_diameter_mm).abs() < 0.01,
            "the solver runs were made for D0 = {} mm, but {rig_file} [actuator] initial_diameter_mm = {} mm (run `host-sim solver-sand --rig` for this rig)",
            sand.initial_diameter_mm(),
            a.initial_diameter_mm
        );
        let tube = Tube::new(a.tube(), rig.skin_law(), Ends::Closed)
            .with_context(|| format!("{rig_file}: [actuator]/[skin]: the skin tube"))?;
        let skin_source = match (&rig.skin_fit, &rig.skin) {
            (Some(fit), _) => fit.source.clone(),
            (None, Some(_)) => "the rig's [skin]".to_owned(),
            (None, None) => DEFAULT_SKIN_SOURCE.to_owned(),
        };
        Self {
            tube,
            skin_source,
            sand,
        }
        .checked_skin()
    }
}

impl<S> SkinSandModel<S> {
    /// This model with the skin `law` (from `source`, for the provenance
    /// line) on the same tube and ends.
    pub fn with_skin(self, law: SkinLaw, source: String) -> Result<Self> {
        let tube = Tube::new(self.tube.geometry, law, self.tube.ends)
            .context("the skin tube of the fitted law")?;
        Ok(Self {
            tube,
            skin_source: source,
            sand: self.sand,
        })
    }

    /// The skin's pressure p_membrane (kPa) at outer diameter `diameter_mm`.
    pub fn membrane_kpa(&self, diameter_mm: f64) -> Result<f64> {
        Ok(self.tube.pressure_kpa(diameter_mm)?)
    }

    /// The skin's full state (stretches, von Mises) at `diameter_mm`.
    pub fn skin_state(&self, diameter_mm: f64) -> Result<InflationState> {
        Ok(self.tube.state(diameter_mm)?)
    }
}

impl<S: SandLaw> PressureModel for SkinSandModel<S> {
    fn internal_pressure_kpa(&self, diameter_mm: f64, depth_mm: f64) -> f64 {
        // NaN for a diameter the tube cannot reach; the table generator's
        // verification refuses non-finite values.
        self.tube.pressure_kpa(diameter_mm).unwrap_or(f64::NAN)
            + self.sand.loading_pressure_kpa(diameter_mm, depth_mm)
    }

    fn provenance(&self) -> String {
        let g = &self.tube.geometry;
        let law = match self.tube.skin.yeoh() {
            // The Yeoh line as it has always read (the committed table's).
            Some(y) => format!(
                "Yeoh C10={:.4} C20={:.5} C30={:.6} kPa",
                y.c10_kpa, y.c20_kpa, y.c30_kpa
            ),
            None => self.tube.skin.describe(),
        };
        format!(
            "host-sim skin + sand (issue 3): {law} \
             ({}), {} thick tube \
             D0={} mm wall={} mm; {}",
            self.skin_source,
            self.tube.ends.label(),
            g.outer_diameter_mm,
            g.wall_thickness_mm,
            self.sand.describe(),
        )
    }

    fn is_placeholder(&self) -> bool {
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn internal_pressure_is_membrane_plus_sand() {
        let m = SkinSandModel::paper_default();
        for (d, h) in [(18.7, 0.0), (21.0, 40.0), (25.0, 100.0)] {
            let want = m.membrane_kpa(d).unwrap() + m.sand.loading_pressure_kpa(d, h);
            assert_eq!(m.internal_pressure_kpa(d, h), want);
        }
        // Free water at rest reads zero (the sensor's zero).
        assert!(m.internal_pressure_kpa(18.7, 0.0).abs() < 1e-12);
        // A diameter that closes the bore is NaN, not a panic.
        assert!(m.internal_pressure_kpa(5.0, 0.0).is_nan());
        assert!(!m.is_placeholder());
    }

    #[test]
    fn solver_model_is_membrane_plus_the_stored_sand() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../..");
        let m = SkinSandModel::paper_solver(&root).unwrap();
        for (d, h) in [(18.7, 0.0), (21.0, 40.0), (25.0, 100.0), (26.2, 200.0)] {
            let want = m.membrane_kpa(d).unwrap() + m.sand.loading_pressure_kpa(d, h);
            assert_eq!(m.internal_pressure_kpa(d, h), want);
        }
        assert!(m.internal_pressure_kpa(18.7, 0.0).abs() < 1e-12);
        let line = m.provenance();
        assert!(line.contains(sand::solver::DATA_PATH), "{line}");
        assert!(
            line.contains(&format!("0x{:08X}", m.sand.crc32())),
            "{line}"
        );
    }
}
