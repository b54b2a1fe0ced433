//! A solver run as a user asks for it: settings in the user's units (mm,
//! MPa, ms), every knob optional but the depth, turned into a
//! [`ScenarioSpec`] and run once or over several seeds. `host-sim
//! simulate` fills these from its flags; nothing here parses arguments.

use std::fmt::Write as _;
use std::num::NonZeroUsize;
use std::path::{Path, PathBuf};

use anyhow::{ensure, Context, Result};
use rig::Rig;

use crate::cases::{Part, Runner};
use crate::ensemble::Ensemble;
use crate::scenario::{self, HeadSupport, ScenarioSpec, SURCHARGE_ROWS};
use crate::solver_sand::RigSetup;
use crate::{simulate, Options, Report};

/// The skin's wall model, as asked for; `Default` keeps the case's own
/// (the solid wall, or the membrane for a thin-walled rig).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SkinChoice {
    /// The case's own.
    #[default]
    Default,
    /// The mid-surface membrane ([`ScenarioSpec::with_membrane`]).
    Membrane,
    /// The bending shell ([`ScenarioSpec::with_shell`]).
    Shell,
    /// A solid wall this many hexahedra thick ([`ScenarioSpec::with_solid`]).
    Solid(NonZeroUsize),
}

/// Everything `host-sim simulate` can set. `None` and `false` keep the
/// case's default ([`ScenarioSpec::paper`] or [`ScenarioSpec::quick`],
/// with a rig's set-up when one is given).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SimulateSettings {
    /// Depth of the zone's axis below the sand surface (mm).
    pub depth_mm: f64,
    /// A rig.toml or an experiment folder holding one: the user's
    /// actuator, skin, sand, fluid and box instead of the paper's.
    pub rig: Option<PathBuf>,
    /// Final outer diameter of the zone (mm).
    pub final_diameter_mm: Option<f64>,
    /// Grain radius (mm); default 1.5 mm, or the rig's grains when coarser.
    pub grain_radius_mm: Option<f64>,
    /// Duration of the expansion (s).
    pub expansion_s: Option<f64>,
    /// Advance into the settled sand before the expansion (mm).
    pub advance_mm: Option<f64>,
    /// Duration of the advance (s).
    pub advance_s: Option<f64>,
    /// Pause after the advance, the head held, before the expansion (ms).
    pub advance_hold_ms: Option<f64>,
    /// What moves the head through the expansion.
    pub head: Option<HeadSupport>,
    /// The skin's wall model.
    pub skin: SkinChoice,
    /// The skin's mesh: nodes round and rows along.
    pub skin_mesh: Option<(usize, usize)>,
    /// Length of the skin's rows at the clamped ends (mm); 0: equal rows.
    pub skin_end_row_mm: Option<f64>,
    /// Keep a solid wall's own mass while the bed settles.
    pub skin_mass_unscaled: bool,
    /// Every coefficient of the skin's law times this.
    pub skin_stiffness_scale: Option<f64>,
    /// The grains' friction on the skin.
    pub skin_friction: Option<f64>,
    /// Keep the zone's rings round.
    pub round_zone: bool,
    /// Finer grains of this radius (mm) in a block in front of the head.
    pub face_grain_radius_mm: Option<f64>,
    /// Young's modulus of the grains during the advance and expansion (MPa).
    pub grain_modulus_mpa: Option<f64>,
    /// Young's modulus of the grains while the bed settles (MPa).
    pub deposition_modulus_mpa: Option<f64>,
    /// The grains' rolling friction coefficient.
    pub rolling_friction: Option<f64>,
    /// The grains' sliding friction while the bed settles.
    pub deposition_friction: Option<f64>,
    /// The grains' friction on the box's walls.
    pub wall_friction: Option<f64>,
    /// Sand only up to this height above the axis (mm), the overburden
    /// above as a surcharge layer.
    pub surcharge_above_mm: Option<f64>,
    /// Sand ahead of the zone's head (mm).
    pub ahead_mm: Option<f64>,
    /// The box's floor below the axis (mm).
    pub below_mm: Option<f64>,
    /// The box's width (mm).
    pub box_width_mm: Option<f64>,
    /// Seed of the grains' lattice jitter (the first, with several seeds).
    pub seed: u64,
    /// Beds run: seeds `seed`, `seed + 1`, …; more than one gives the
    /// ensemble's mean ± SD.
    pub seeds: u64,
    /// The shorter case ([`ScenarioSpec::quick`]).
    pub quick: bool,
    /// A law from fit-skin's report (`--skin-fit`, `--skin-law`) that
    /// replaces the skin (the rig's `[skin]`, or the paper's calibrated
    /// default skin), used as measured (stiffness scale 1).
    pub skin_fit: Option<skin::SkinFitChoice>,
    /// Folder for the results.
    pub out: PathBuf,
}

/// A case ready to run, with what the user should know about it.
#[derive(Debug)]
pub struct Plan {
    /// The case.
    pub spec: ScenarioSpec,
    /// Sentences about how the user's set-up was read (a thin wall run as
    /// the membrane, grains coarsened, …).
    pub notes: Vec<String>,
    /// Warnings of the rig file.
    pub warnings: Vec<String>,
    seeds: u64,
    out: PathBuf,
}

/// What a plan's run produced.
#[derive(Debug)]
pub enum Outcome {
    /// One bed.
    Single(Box<Report>),
    /// Several beds and their mean ± SD.
    Ensemble(Ensemble),
}

impl SimulateSettings {
    /// The case these settings describe, checked.
    pub fn plan(&self) -> Result<Plan> {
        let mut setup = self.rig.as_deref().map(Rig::read_setup).transpose()?;
        let chosen = self
            .skin_fit
            .as_ref()
            .map(skin::SkinFitChoice::read)
            .transpose()?;
        if let (Some(c), Some((rig, file, w))) = (&chosen, &mut setup) {
            w.extend(rig.use_skin_fit(c.clone(), file));
        }
        let r = grain_radius_m(self.grain_radius_mm, setup.as_ref().map(|(rig, ..)| rig));
        let h = self.depth_mm * 1e-3;
        let mut spec = if self.quick {
            ScenarioSpec::quick(h, r)
        } else {
            ScenarioSpec::paper(h, r)
        };
        let final_m = self.final_diameter_mm.map(|d| d * 1e-3);
        let mut notes = Vec::new();
        let mut warnings = Vec::new();
        if let Some((rig, file, w)) = &setup {
            let (with_rig, n) = spec.with_rig(rig, file, final_m)?;
            spec = with_rig;
            notes = n;
            warnings.clone_from(w);
        } else {
            if let Some(d) = final_m {
                spec.final_diameter_m = d;
            }
            if let Some(c) = &chosen {
                notes.push(format!(
                    "the skin is {}, {}, used as measured (scale 1, not the paper's calibrated {})",
                    c.source,
                    c.law.describe(),
                    spec.skin_stiffness_scale
                ));
                warnings.extend(c.warnings.iter().cloned());
                spec = spec.with_skin_law(c.law.clone());
            }
        }
        // mm → m and ms → s.
        let milli = |v: f64| v * 1e-3;
        set(&mut spec.rolling_friction, self.rolling_friction);
        set(&mut spec.deposition_friction, self.deposition_friction);
        set(&mut spec.wall_friction, self.wall_friction);
        set(&mut spec.skin_friction, self.skin_friction);
        set(&mut spec.skin_stiffness_scale, self.skin_stiffness_scale);
        set(&mut spec.ahead_m, self.ahead_mm.map(milli));
        set(&mut spec.box_width_m, self.box_width_mm.map(milli));
        if let Some(below) = self.below_mm {
            spec = spec.with_floor_below(milli(below));
        }
        if let Some(above) = self.surcharge_above_mm {
            spec = spec.with_surcharge(milli(above), SURCHARGE_ROWS);
        }
        spec.seed = self.seed;
        spec.face_grain_radius_m = self.face_grain_radius_mm.map(milli);
        set(&mut spec.advance_m, self.advance_mm.map(milli));
        set(&mut spec.advance_s, self.advance_s);
        set(&mut spec.advance_hold_s, self.advance_hold_ms.map(milli));
        set(&mut spec.head, self.head);
        spec = match self.skin {
            SkinChoice::Default => spec,
            SkinChoice::Membrane => spec.with_membrane(),
            SkinChoice::Shell => spec.with_shell(),
            SkinChoice::Solid(layers) => spec.with_solid(layers),
        };
        set(&mut spec.skin_mesh, self.skin_mesh);
        if let Some(end_row) = self.skin_end_row_mm {
            spec.skin_end_row_m = (end_row > 0.0).then_some(milli(end_row));
        }
        spec.skin_mass_scaling = !self.skin_mass_unscaled;
        spec.round_zone |= self.round_zone;
        set(
            &mut spec.grain_modulus_pa,
            self.grain_modulus_mpa.map(|e| e * 1e6),
        );
        set(
            &mut spec.deposition_modulus_pa,
            self.deposition_modulus_mpa.map(|e| e * 1e6),
        );
        set(&mut spec.expansion_s, self.expansion_s);
        ensure!(self.seeds >= 1, "at least one seed");
        Ok(Plan {
            spec,
            notes,
            warnings,
            seeds: self.seeds,
            out: self.out.clone(),
        })
    }
}

impl Plan {
    /// Runs the case (with a progress bar), writing its results.
    pub fn run(self) -> Result<Outcome> {
        self.run_part(&Runner::whole())?
            .context("a run on one machine has every case")
    }

    /// [`Plan::run`] as one part of a split ensemble ([`Runner`]; every
    /// split run is an ensemble, one seed or more): `None` where another
    /// part runs some of the seeds.
    pub fn run_part(self, runner: &Runner) -> Result<Option<Outcome>> {
        if self.seeds > 1 || runner.part() != Part::Whole {
            let list: Vec<u64> =
                (self.spec.seed..self.spec.seed.saturating_add(self.seeds)).collect();
            Ok(
                Ensemble::run_part(&self.spec, &list, Some(&self.out), true, runner)?
                    .map(Outcome::Ensemble),
            )
        } else {
            Ok(Some(Outcome::Single(Box::new(simulate(&Options {
                spec: self.spec,
                out: Some(self.out),
                progress: true,
            })?))))
        }
    }

    /// Where the results go.
    pub fn out(&self) -> &Path {
        &self.out
    }
}

impl Outcome {
    /// The summary: each bed's, then the ensemble's.
    pub fn text(&self) -> String {
        match self {
            Outcome::Single(report) => report.text() + &report.timing_text(),
            Outcome::Ensemble(ensemble) => {
                let mut s = String::new();
                for r in &ensemble.reports {
                    let _ = writeln!(s, "seed {}:", r.spec.seed);
                    s.push_str(&r.text());
                    s.push_str(&r.timing_text());
                }
                s.push_str(&ensemble.text());
                s
            }
        }
    }
}

/// The solver's grain radius (m): `given_mm` if given, else the rig's
/// grains when coarser than the default, else the default.
pub fn grain_radius_m(given_mm: Option<f64>, rig: Option<&Rig>) -> f64 {
    given_mm.map_or_else(
        || {
            rig.map_or(
                scenario::DEFAULT_GRAIN_RADIUS_M,
                ScenarioSpec::grain_radius_for,
            )
        },
        |r| r * 1e-3,
    )
}

/// The rig at `path` (a rig.toml or an experiment folder) with the zone's
/// final diameter, for the commands that run the solver at several
/// depths, its skin replaced by `skin_fit`'s law when given (which needs
/// the rig); with the rig file's warnings.
pub fn rig_setup(
    path: Option<&Path>,
    final_diameter_mm: Option<f64>,
    skin_fit: Option<&skin::SkinFitChoice>,
) -> Result<(Option<RigSetup>, Vec<String>)> {
    let Some(path) = path else {
        ensure!(
            skin_fit.is_none(),
            "--skin-fit needs --rig here: the paper's case keeps its calibrated skin"
        );
        return Ok((None, Vec::new()));
    };
    let (mut rig, file, mut warnings) = Rig::read_setup(path)?;
    if let Some(choice) = skin_fit {
        warnings.extend(rig.use_skin_fit(choice.read()?, &file));
    }
    Ok((
        Some(RigSetup {
            rig,
            file,
            final_diameter_mm,
        }),
        warnings,
    ))
}

/// Overwrites `field` with `value` when one is given.
fn set<T>(field: &mut T, value: Option<T>) {
    if let Some(v) = value {
        *field = v;
    }
}
