//! The effect library: physical effects the baseline rig model
//! ([`crate`]) leaves out, each one file implementing [`Effect`] and
//! one row of [`REGISTRY`]. The workbench tries every row on the data; the
//! emulator switches rows on in its plant; a test walks the whole list.
//!
//! Effects act through fixed hooks of one time step, called in this order
//! (LAMMPS-style: laws interact only through the order):
//!
//! 0. [`Effect::sand`]: the sand law's coefficients (another form of its
//!    rise or of its unloading branch), once when the model is built.
//! 1. [`Effect::held_volume_ml`]: pumped volume that does not reach the
//!    actuator at gauge pressure p (a leak's lost volume, a gas bubble's
//!    compression). The step solves p = P(pump − Σ held(p)) implicitly.
//! 2. [`Effect::effective_depth_mm`]: the depth whose σ'v = γ'·h the sand
//!    law sees (arching against the container walls), once per run.
//! 3. [`Effect::skin_kpa`]: the skin's pressure, from its elastic value;
//!    the baseline's forms first (they reshape the elastic law), then the
//!    physical effects, which act on the reshaped law's pressure.
//! 4. [`Effect::reading_kpa`]: what the sensor reads, from the internal
//!    pressure.
//!
//! Effects with state (leaked volume, maximum stretch, overstress) get an
//! [`EffectState`] per run; hooks receive a trial copy the model commits
//! once the step is solved.

use std::fmt;

use anyhow::{bail, Result};
use serde::Serialize;

use crate::params::ParamSpec;
use rig::{PressureSource, Rig};
use sand::SandParams;

pub mod leak;
pub mod line_loss;
pub mod mullins_softening;
pub mod piston_friction;
pub mod sand_depth_power;
pub mod sand_rise;
pub mod sand_unloading;
pub mod sensor_gain;
pub mod sensor_lag;
pub mod sensor_offset;
pub mod skin_scale;
pub mod skin_shape;
pub mod skin_viscoelasticity;
pub mod trapped_air;
pub mod wall_arching;

/// Every effect the workbench knows, in the order the model applies them
/// within a hook (volume, depth, skin: mullins before viscoelasticity;
/// sensor: physical terms, then gain, then offset). A new effect is one
/// file and one row here.
pub static REGISTRY: [&EffectSpec; 15] = [
    &leak::SPEC,
    &trapped_air::SPEC,
    &wall_arching::SPEC,
    &mullins_softening::SPEC,
    &skin_viscoelasticity::SPEC,
    &line_loss::SPEC,
    &piston_friction::SPEC,
    &sensor_gain::SPEC,
    &sensor_offset::SPEC,
    // Last so that the rows before keep their indices (stored proptest
    // cases pick effects by index); it acts only through the held volume,
    // a sum, so its place in the order does not matter.
    &sensor_lag::SPEC,
    // Forms of the baseline, competing with the effects on the same terms.
    &sand_depth_power::SPEC,
    &skin_shape::SPEC,
    &sand_unloading::SPEC,
    &sand_rise::SPEC,
    &skin_scale::SPEC,
];

/// Per-run memory of one effect (meaning is the effect's own).
pub type EffectState = [f64; 2];

/// What one time step knows before it is solved.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepContext {
    /// Time since the start of the run (s).
    pub t_s: f64,
    /// Time since the previous step (s); 0 on the first.
    pub dt_s: f64,
    /// Pump flow into the line at this sample (mL/s), > 0 pushing: the
    /// backward difference to the recording's previous sample, which is
    /// the previous step unless the model steps over a thinned copy.
    pub pump_flow_ml_s: f64,
    /// Mean pump flow over this step (mL/s): the volume pumped since the
    /// previous step over `dt_s`. What an integrator over the step needs;
    /// equal to `pump_flow_ml_s` when every sample is stepped through.
    pub step_flow_ml_s: f64,
    /// Sand cover of the run (mm).
    pub depth_mm: f64,
    /// Absolute pressure at the actuator at gauge zero: atmosphere plus the
    /// water column above it (kPa).
    pub absolute_rest_kpa: f64,
    /// Where the reading comes from.
    pub pressure_source: PressureSource,
    /// Syringe bore area (mm²).
    pub bore_area_mm2: f64,
    /// Outer diameter at rest, D0 (mm).
    pub initial_diameter_mm: f64,
}

impl StepContext {
    /// I1 − 3 of a plane-strain tube at outer diameter `diameter_mm`, hoop
    /// stretch λ = D/D0: λ² + λ⁻² − 2 (0 at rest, positive either side).
    pub fn hoop_invariant_excess(&self, diameter_mm: f64) -> f64 {
        let l2 = (diameter_mm / self.initial_diameter_mm).powi(2);
        l2 + 1.0 / l2 - 2.0
    }
}

/// The step the effects' unit tests start from: free water, at rest, a
/// line sensor, the paper's bore (670 mm²) and D0 (18.7 mm), t = dt = 0.
#[cfg(test)]
pub(crate) fn free_water_context() -> StepContext {
    StepContext {
        t_s: 0.0,
        dt_s: 0.0,
        pump_flow_ml_s: 0.0,
        step_flow_ml_s: 0.0,
        depth_mm: 0.0,
        absolute_rest_kpa: crate::ATMOSPHERE_KPA,
        pressure_source: PressureSource::LineSensor,
        bore_area_mm2: 670.0,
        initial_diameter_mm: 18.7,
    }
}

/// One physical effect with its parameter values (built by
/// [`EffectSpec::build`]). Every hook defaults to "no effect".
pub trait Effect: Send + Sync + fmt::Debug {
    /// Its registry row.
    fn spec(&self) -> &'static EffectSpec;

    /// Whether [`Effect::held_volume_ml`] can be nonzero (the step then
    /// solves for pressure implicitly).
    fn holds_volume(&self) -> bool {
        false
    }

    /// State at the start of a run.
    fn initial_state(&self, ctx: &StepContext) -> EffectState {
        let _ = ctx;
        [0.0; 2]
    }

    /// Volume (mL) pumped but not in the actuator at gauge pressure
    /// `gauge_kpa` at the end of this step.
    fn held_volume_ml(&self, state: &mut EffectState, ctx: &StepContext, gauge_kpa: f64) -> f64 {
        let _ = (state, ctx, gauge_kpa);
        0.0
    }

    /// The depth (mm) whose geostatic σ'v the sand law should see, for a
    /// run at `depth_mm` in this rig.
    fn effective_depth_mm(&self, rig: &Rig, depth_mm: f64) -> f64 {
        let _ = rig;
        depth_mm
    }

    /// The sand law's coefficients, given them so far (the baseline's, or
    /// an earlier effect's); applied once when the model is built.
    fn sand(&self, params: SandParams) -> SandParams {
        params
    }

    /// The skin's pressure (kPa) at outer diameter `diameter_mm`, given the
    /// value `skin_kpa` so far (the elastic one, or an earlier effect's).
    fn skin_kpa(
        &self,
        state: &mut EffectState,
        ctx: &StepContext,
        diameter_mm: f64,
        skin_kpa: f64,
    ) -> f64 {
        let _ = (state, ctx, diameter_mm);
        skin_kpa
    }

    /// The reading (kPa), given the internal pressure and the reading so
    /// far (starts as the internal pressure).
    fn reading_kpa(&self, ctx: &StepContext, internal_kpa: f64, reading_kpa: f64) -> f64 {
        let _ = (ctx, internal_kpa);
        reading_kpa
    }
}

/// A registry row: what an effect is, its parameters (the first is the
/// primary one) and how to build it.
#[derive(Serialize)]
pub struct EffectSpec {
    /// Name (the key in `model.toml`, the JSON and `--add`).
    pub name: &'static str,
    /// The physics, in a sentence or two.
    pub description: &'static str,
    /// The residual it leaves when missing, in plain words.
    pub signature: &'static str,
    /// Its parameters; the first is the primary one.
    pub params: &'static [ParamSpec],
    /// A physical effect, or another form of a part of the baseline.
    #[serde(skip)]
    pub kind: EffectKind,
    /// Builds the effect from values in [`EffectSpec::params`] order.
    #[serde(skip)]
    pub build: fn(&[f64]) -> Box<dyn Effect>,
    /// Why it cannot act in `rig` (`None`: it can).
    #[serde(skip)]
    pub not_applicable: fn(&Rig) -> Option<&'static str>,
    /// Why a fit at these values (in `params` order) cannot be told apart
    /// from an uncertainty of what rig.toml states (`None`: it can).
    #[serde(skip)]
    pub indistinct: fn(&Rig, &[f64]) -> Option<&'static str>,
}

/// What a registry row stands for.
#[derive(Clone, Copy, Debug)]
pub enum EffectKind {
    /// Something the rig does that the baseline leaves out.
    Physical,
    /// Another form of a part of the baseline whose shape is assumed (the
    /// sand's depth dependence, the skin law's shape): it competes with
    /// the effects on the same terms, and when selected says in words how
    /// the baseline's form was wrong.
    BaselineForm {
        /// That sentence, from the fitted values (in `params` order).
        words: fn(&[f64]) -> String,
        /// Which runs would tell this form apart from an effect that the
        /// data cannot separate from it, in words ("runs at a third sand
        /// depth").
        tells_apart: &'static str,
    },
}

impl EffectKind {
    /// Whether it is a form of the baseline.
    pub fn is_baseline_form(&self) -> bool {
        matches!(self, EffectKind::BaselineForm { .. })
    }
}

impl fmt::Debug for EffectSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("EffectSpec")
            .field("name", &self.name)
            .finish_non_exhaustive()
    }
}

impl EffectSpec {
    /// Looks an effect up in [`REGISTRY`] by name.
    pub fn by_name(name: &str) -> Result<&'static EffectSpec> {
        match REGISTRY.iter().find(|s| s.name == name) {
            Some(spec) => Ok(spec),
            None => bail!(
                "unknown effect `{name}`; the library has: {}",
                REGISTRY.map(|s| s.name).join(", ")
            ),
        }
    }

    /// Position in [`REGISTRY`] (the order effects are applied in).
    pub fn registry_index(&self) -> usize {
        REGISTRY
            .iter()
            .position(|s| std::ptr::eq(*s, self))
            .unwrap_or(REGISTRY.len())
    }

    /// Index of the parameter named `name`.
    pub fn param_index(&self, name: &str) -> Result<usize> {
        match self.params.iter().position(|p| p.name == name) {
            Some(i) => Ok(i),
            None => bail!(
                "effect `{}` has no parameter `{name}` (it has: {})",
                self.name,
                self.params
                    .iter()
                    .map(|p| p.name)
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        }
    }
}

/// An effect switched on, with parameter values in
/// [`EffectSpec::params`] order.
#[derive(Clone, Debug)]
pub struct EffectInstance {
    /// Its registry row.
    pub spec: &'static EffectSpec,
    /// Parameter values.
    pub values: Vec<f64>,
}

impl PartialEq for EffectInstance {
    fn eq(&self, other: &Self) -> bool {
        std::ptr::eq(self.spec, other.spec) && self.values == other.values
    }
}

impl EffectInstance {
    /// The effect `name` with its default parameters.
    pub fn with_defaults(name: &str) -> Result<Self> {
        let spec = EffectSpec::by_name(name)?;
        Ok(Self {
            spec,
            values: spec.params.iter().map(|p| p.default).collect(),
        })
    }

    /// The effect `name` with the named values set (others default).
    pub fn new(name: &str, values: &[(&str, f64)]) -> Result<Self> {
        let mut e = Self::with_defaults(name)?;
        for (k, v) in values {
            e.set(k, *v)?;
        }
        Ok(e)
    }

    /// Sets parameter `name`; refuses a value outside its bounds.
    pub fn set(&mut self, name: &str, value: f64) -> Result<()> {
        let i = self.spec.param_index(name)?;
        let p = &self.spec.params[i];
        if !(value.is_finite() && value >= p.lower && value <= p.upper) {
            bail!(
                "effect `{}`: {name} = {value} {} is outside [{}, {}]",
                self.spec.name,
                p.unit,
                p.lower,
                p.upper
            );
        }
        self.values[i] = value;
        Ok(())
    }

    /// Value of parameter `name`.
    pub fn get(&self, name: &str) -> Result<f64> {
        Ok(self.values[self.spec.param_index(name)?])
    }

    /// The effect object.
    pub fn build(&self) -> Box<dyn Effect> {
        (self.spec.build)(&self.values)
    }
}

/// Value `i` of `values`, or the parameter's default (builders never index
/// out of range).
pub(crate) fn value(values: &[f64], params: &[ParamSpec], i: usize) -> f64 {
    values
        .get(i)
        .copied()
        .or_else(|| params.get(i).map(|p| p.default))
        .unwrap_or(0.0)
}

/// A smooth sign of a flow (mL/s): ±1 beyond a few [`FLOW_SIGN_WIDTH_ML_S`],
/// so friction reverses without a jump the fitter cannot follow.
pub fn smooth_sign(flow_ml_s: f64) -> f64 {
    (flow_ml_s / FLOW_SIGN_WIDTH_ML_S).tanh()
}

/// Width of [`smooth_sign`]'s transition (mL/s).
pub const FLOW_SIGN_WIDTH_ML_S: f64 = 0.02;

#[cfg(test)]
mod tests {
    use super::*;

    fn ctx() -> StepContext {
        StepContext {
            t_s: 1.0,
            dt_s: 0.02,
            pump_flow_ml_s: 1.0,
            step_flow_ml_s: 1.0,
            depth_mm: 40.0,
            absolute_rest_kpa: 103.5,
            pressure_source: PressureSource::PistonForce,
            ..free_water_context()
        }
    }

    #[test]
    fn registry_rows_are_consistent() {
        let mut names: Vec<&str> = REGISTRY.iter().map(|s| s.name).collect();
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), REGISTRY.len(), "duplicate names");
        for (i, spec) in REGISTRY.iter().enumerate() {
            assert_eq!(spec.registry_index(), i);
            assert!(!spec.params.is_empty(), "{}: no parameters", spec.name);
            assert!(!spec.description.is_empty() && !spec.signature.is_empty());
            for p in spec.params {
                assert!(
                    p.lower <= p.default && p.default <= p.upper,
                    "{}.{}",
                    spec.name,
                    p.name
                );
            }
            let e = EffectInstance::with_defaults(spec.name).unwrap().build();
            assert_eq!(e.spec().name, spec.name);
            assert!(EffectSpec::by_name(spec.name).is_ok());
        }
        assert!(EffectSpec::by_name("flux_capacitor").is_err());
    }

    #[test]
    fn primary_parameters_are_the_interface() {
        let want = [
            ("sensor_offset", "offset_kpa"),
            ("sensor_gain", "gain"),
            ("line_loss", "resistance_kpa_s_per_ml"),
            ("piston_friction", "friction_n"),
            ("trapped_air", "gas_volume_ml"),
            ("leak", "ml_per_s_per_kpa"),
            ("skin_viscoelasticity", "fraction"),
            ("mullins_softening", "rate"),
            ("wall_arching", "mu_k"),
            ("sensor_lag", "lag_s"),
            ("sand_depth_power", "exponent"),
            ("skin_shape", "stiffening_linear"),
            ("sand_unloading", "slope_factor"),
            ("sand_rise", "shape"),
            ("skin_scale", "factor"),
        ];
        for (name, primary) in want {
            assert_eq!(EffectSpec::by_name(name).unwrap().params[0].name, primary);
        }
        assert_eq!(
            EffectSpec::by_name("skin_viscoelasticity").unwrap().params[1].name,
            "tau_s"
        );
    }

    #[test]
    fn neutral_values_do_nothing() {
        // Every effect at its "absent" value (0, or gain 1) leaves each
        // hook's input unchanged: the baseline is the library's zero.
        let c = ctx();
        for spec in REGISTRY {
            let values: Vec<f64> = spec
                .params
                .iter()
                .enumerate()
                .map(|(i, p)| match (spec.name, i) {
                    (
                        "sensor_gain" | "sand_depth_power" | "sand_unloading" | "sand_rise"
                        | "skin_scale",
                        0,
                    ) => 1.0,
                    (_, 0) => 0.0,
                    _ => p.default,
                })
                .collect();
            let e = (spec.build)(&values);
            let mut st = e.initial_state(&c);
            assert_eq!(e.held_volume_ml(&mut st, &c, 5.0), 0.0, "{}", spec.name);
            assert_eq!(e.skin_kpa(&mut st, &c, 22.0, 1.5), 1.5, "{}", spec.name);
            assert_eq!(e.reading_kpa(&c, 3.0, 3.25), 3.25, "{}", spec.name);
        }
    }

    #[test]
    fn instances_refuse_out_of_bounds_and_unknown_names() {
        let mut e = EffectInstance::with_defaults("leak").unwrap();
        assert!(e.set("ml_per_s_per_kpa", -1.0).is_err());
        assert!(e.set("nope", 1.0).is_err());
        e.set("ml_per_s_per_kpa", 0.01).unwrap();
        assert_eq!(e.get("ml_per_s_per_kpa").unwrap(), 0.01);
    }
}
