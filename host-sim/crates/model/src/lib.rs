//! The reduced-order rig model, shared by the workbench (calibration,
//! diagnosis) and the emulator's plant:
//!
//! ```text
//! pump volume ─(leak, trapped air: volume held back at pressure p)→ actuator volume
//!   ─(ExpansionZone, the firmware's own rule)→ outer diameter D
//!   → p_i = skin(D) [membrane curve × stiffness scale, Mullins, viscoelastic overstress]
//!         + sand p_e(D, h_eff) [ParametricSand, unloading branch, fresh each cycle,
//!                               Janssen depth when arching]
//!   → reading = sensor(p_i) [line loss·flow, piston friction/area·sign(flow), gain, offset]
//! ```
//!
//! Pressure and held volume depend on each other, so a step with a volume
//! effect solves p = P(pump − held(p)) by a safeguarded secant (the
//! residual is strictly decreasing in p, so the root is unique).
//!
//! Time stepping ([`RigModel::start_run`], [`RigModel::step`]) takes any
//! time steps; [`RigModel::predict`] runs a whole [`Run`].

pub mod cycles;
pub mod effects;
pub mod membrane_curve;
pub mod params;
pub mod pressure_model;

use std::sync::Arc;

use anyhow::{bail, Context, Result};
use serde::Serialize;
use urechis::controller::geometry::ExpansionZone;

use crate::effects::{Effect, EffectInstance, EffectState, StepContext};
use constants::GRAVITY_M_S2;
use rig::{Rig, Run};
use sand::{ParametricSand, SandHistory, SandLaw, SandParams};

pub use cycles::{CycleDetector, Phase, HOLD_FLOW_ML_S};
pub use membrane_curve::MembraneCurve;
pub use params::{ParamSpec, Params, BASELINE_PARAMS};

pub use constants::ATMOSPHERE_KPA;

/// What the model takes from the rig and never fits: geometry, the skin
/// curve, the sand's base law. Built once per rig and shared by every
/// parameter set a calibration tries.
#[derive(Debug)]
pub struct RigBasis {
    /// The set-up.
    pub rig: Rig,
    /// The firmware's volume ↔ diameter rule for this zone.
    pub zone: ExpansionZone,
    /// p_membrane(D) of the rig's skin (or the default skin) at scale 1.
    pub membrane: MembraneCurve,
    /// The sand law before the baseline's factors (N fitted to the solver),
    /// with this rig's densities, porosity and D0; `None` without `[sand]`.
    pub sand: Option<SandParams>,
    /// Syringe bore area (mm²).
    pub bore_area_mm2: f64,
    /// Whether the skin is known (`[skin]` in rig.toml, or `--skin-fit`):
    /// its stiffness scale is then not fitted.
    pub skin_known: bool,
}

impl RigBasis {
    /// Builds the basis of `rig`.
    pub fn new(rig: &Rig) -> Result<Arc<RigBasis>> {
        let a = &rig.actuator;
        let membrane = MembraneCurve::sample(a.tube(), rig.skin_law())
            .context("rig.toml [actuator]/[skin]: the skin tube")?;
        // The sand's base law: N fitted to the FEM–DEM solver's stored
        // results, the same file the firmware table's sand comes from, so
        // the emulated sand pushes back as the table expects.
        let solver = sand::SolverSand::committed()
            .context("the committed solver sand the model's baseline is fitted to")?;
        let paper = ParametricSand::fitted_to_solver(&solver).params;
        let sand = rig.sand.as_ref().map(|s| SandParams {
            grain_density_kg_m3: s.grain_density_kg_m3,
            fluid_density_kg_m3: rig.fluid.density_kg_m3,
            porosity: s.porosity,
            initial_diameter_mm: a.initial_diameter_mm,
            ..paper
        });
        Ok(Arc::new(RigBasis {
            rig: rig.clone(),
            zone: ExpansionZone {
                initial_diameter_mm: a.initial_diameter_mm as f32,
                expansion_length_mm: a.expansion_length_mm as f32,
            },
            membrane,
            sand,
            bore_area_mm2: std::f64::consts::PI * rig.pump.syringe_bore_mm.powi(2) / 4.0,
            skin_known: rig.skin_known(),
        }))
    }

    /// Absolute pressure at the actuator at gauge zero in a run at
    /// `depth_mm`: atmosphere + ρw·g·(water above the sand + depth) (kPa).
    pub fn absolute_rest_kpa(&self, depth_mm: f64) -> f64 {
        let f = &self.rig.fluid;
        ATMOSPHERE_KPA + f.density_kg_m3 * GRAVITY_M_S2 * 1e-6 * (f.water_above_sand_mm + depth_mm)
    }
}

/// The rig model at one parameter set with its effects.
#[derive(Debug, Clone)]
pub struct RigModel {
    basis: Arc<RigBasis>,
    params: Params,
    effects: Vec<EffectInstance>,
    built: Arc<Vec<Box<dyn Effect>>>,
    sand: Option<ParametricSand>,
    holds_volume: bool,
    /// Dead band of the phase classification (mL/s).
    pub hold_flow_ml_s: f64,
}

/// One run's state between steps.
#[derive(Clone, Debug, PartialEq)]
pub struct RunState {
    depth_mm: f64,
    sand_depth_mm: f64,
    started: bool,
    t_s: f64,
    pump_ml: f64,
    internal_kpa: f64,
    sand: Option<SandHistory>,
    effects: Vec<EffectState>,
    cycles: CycleDetector,
}

impl RunState {
    /// Sand cover of the run (mm).
    pub fn depth_mm(&self) -> f64 {
        self.depth_mm
    }
    /// Depth the sand law sees after arching (mm).
    pub fn sand_depth_mm(&self) -> f64 {
        self.sand_depth_mm
    }
    /// Cycles started after the first.
    pub fn cycle(&self) -> u32 {
        self.cycles.count
    }
}

/// The time (s) from pump volume `from_ml` at `from_s` to `to_ml` at
/// `to_s` and the pump's mean flow over it (mL/s), the backward difference
/// [`RigModel::step`] takes; `None` where time does not advance (a zero
/// step at no flow).
pub fn pump_flow(from_s: f64, from_ml: f64, to_s: f64, to_ml: f64) -> Option<(f64, f64)> {
    (to_s > from_s).then(|| {
        let dt = to_s - from_s;
        (dt, (to_ml - from_ml) / dt)
    })
}

/// The model's output at one step.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Prediction {
    /// What the sensor reads (kPa).
    pub sensor_kpa: f64,
    /// Gauge pressure inside the actuator (kPa).
    pub internal_kpa: f64,
    /// Skin's share of it (kPa).
    pub skin_kpa: f64,
    /// Sand's share of it, p_e (kPa).
    pub sand_kpa: f64,
    /// Outer diameter of the expansion zone (mm).
    pub diameter_mm: f64,
    /// Volume in the actuator past rest (mL).
    pub actuator_volume_ml: f64,
    /// Pump flow (mL/s), backward difference.
    pub pump_flow_ml_s: f64,
    /// Pump phase.
    pub phase: Phase,
    /// Cycle index within the run (0 = first).
    pub cycle: u32,
}

/// Result of one trial evaluation at a guessed pressure.
struct Trial {
    internal_kpa: f64,
    skin_kpa: f64,
    sand_kpa: f64,
    diameter_mm: f64,
    actuator_volume_ml: f64,
    sand: Option<SandHistory>,
    effects: Vec<EffectState>,
}

impl RigModel {
    /// The model of `rig` at `params` with `effects` on. Refuses an effect
    /// that cannot act in this rig, or one given twice.
    pub fn new(rig: &Rig, params: &Params, effects: &[EffectInstance]) -> Result<RigModel> {
        Self::with_basis(RigBasis::new(rig)?, params, effects)
    }

    /// Same, on an already built basis (calibration builds it once).
    pub fn with_basis(
        basis: Arc<RigBasis>,
        params: &Params,
        effects: &[EffectInstance],
    ) -> Result<RigModel> {
        let mut effects = effects.to_vec();
        effects.sort_by_key(|e| e.spec.registry_index());
        for w in effects.windows(2) {
            if std::ptr::eq(w[0].spec, w[1].spec) {
                bail!("effect `{}` is listed twice", w[0].spec.name);
            }
        }
        for e in &effects {
            if let Some(why) = (e.spec.not_applicable)(&basis.rig) {
                bail!("effect `{}` cannot act in this rig: {why}", e.spec.name);
            }
        }
        let built: Vec<Box<dyn Effect>> = effects.iter().map(EffectInstance::build).collect();
        let holds_volume = built.iter().any(|e| e.holds_volume());
        let sand = basis.sand.map(|base| {
            let at_rest = base.at_rest_coefficient * params.sand_at_rest_factor;
            let own = SandParams {
                at_rest_coefficient: at_rest,
                limit_coefficient: base.limit_coefficient * params.sand_limit_factor,
                active_coefficient: base.active_coefficient.min(at_rest),
                characteristic_diameter_increase_mm: params.sand_rise_mm.max(1e-6),
                ..base
            };
            ParametricSand {
                params: built.iter().fold(own, |p, e| e.sand(p)),
            }
        });
        Ok(RigModel {
            basis,
            params: *params,
            effects,
            built: Arc::new(built),
            sand,
            holds_volume,
            hold_flow_ml_s: HOLD_FLOW_ML_S,
        })
    }

    /// The basis (rig, skin curve, sand base).
    pub fn basis(&self) -> &Arc<RigBasis> {
        &self.basis
    }

    /// Baseline parameters.
    pub fn params(&self) -> &Params {
        &self.params
    }

    /// Effects in use, in the order they act.
    pub fn effects(&self) -> &[EffectInstance] {
        &self.effects
    }

    fn context(
        &self,
        state: &RunState,
        t_s: f64,
        dt_s: f64,
        flow: f64,
        step_flow: f64,
    ) -> StepContext {
        StepContext {
            t_s,
            dt_s,
            pump_flow_ml_s: flow,
            step_flow_ml_s: step_flow,
            depth_mm: state.depth_mm,
            absolute_rest_kpa: self.basis.absolute_rest_kpa(state.depth_mm),
            pressure_source: self.basis.rig.measurement.pressure_source,
            bore_area_mm2: self.basis.bore_area_mm2,
            initial_diameter_mm: self.basis.rig.actuator.initial_diameter_mm,
        }
    }

    /// A run at sand cover `depth_mm`, at rest.
    pub fn start_run(&self, depth_mm: f64) -> RunState {
        let sand_depth_mm = self
            .built
            .iter()
            .fold(depth_mm, |h, e| e.effective_depth_mm(&self.basis.rig, h));
        let mut state = RunState {
            depth_mm,
            sand_depth_mm,
            started: false,
            t_s: 0.0,
            pump_ml: 0.0,
            internal_kpa: 0.0,
            sand: self.sand.as_ref().map(|s| s.fresh_cycle()),
            effects: Vec::new(),
            cycles: CycleDetector::new(0.0),
        };
        let ctx = self.context(&state, 0.0, 0.0, 0.0, 0.0);
        state.effects = self.built.iter().map(|e| e.initial_state(&ctx)).collect();
        state
    }

    /// Evaluates the chain at guessed internal pressure `guess_kpa`.
    fn trial(&self, state: &RunState, ctx: &StepContext, pump_ml: f64, guess_kpa: f64) -> Trial {
        let mut effects = state.effects.clone();
        let mut held = 0.0;
        if self.holds_volume {
            for (e, st) in self.built.iter().zip(effects.iter_mut()) {
                held += e.held_volume_ml(st, ctx, guess_kpa);
            }
        }
        let volume = pump_ml - held;
        // The firmware's own geometry rule (f32 by design).
        let diameter = f64::from(self.basis.zone.diameter_mm(volume as f32));
        let mut skin =
            self.params.skin_stiffness_scale * self.basis.membrane.pressure_kpa(diameter);
        // The baseline's forms reshape the elastic law itself; the physical
        // effects (softening, a viscous overstress) act on that law's
        // pressure, so the forms go first whatever the registry order.
        for forms in [true, false] {
            let hooks = self.built.iter().zip(effects.iter_mut()).zip(&self.effects);
            for ((e, st), _) in hooks.filter(|(_, i)| i.spec.kind.is_baseline_form() == forms) {
                skin = e.skin_kpa(st, ctx, diameter, skin);
            }
        }
        let mut history = state.sand;
        let sand = match (&self.sand, history.as_mut()) {
            (Some(law), Some(h)) => law.external_pressure_kpa(h, diameter, state.sand_depth_mm),
            _ => 0.0,
        };
        Trial {
            internal_kpa: skin + sand,
            skin_kpa: skin,
            sand_kpa: sand,
            diameter_mm: diameter,
            actuator_volume_ml: volume,
            sand: history,
            effects,
        }
    }

    /// Advances `state` to time `t_s` (s since the run started) with the
    /// pump at net volume `pump_volume_ml`; returns what the rig shows.
    /// Times that do not increase count as a zero time step.
    pub fn step(&self, state: &mut RunState, t_s: f64, pump_volume_ml: f64) -> Prediction {
        self.advance(state, t_s, pump_volume_ml, None)
    }

    /// [`RigModel::step`] over a thinned copy of a recording: the pump's
    /// flow at this sample, `flow_ml_s` (mL/s), is the recording's own
    /// backward difference, not the difference to the previous step. The
    /// terms that read the flow (a line's loss, a piston's friction, the
    /// pump's phase) then see at every kept sample what they see when the
    /// whole recording is stepped through; what integrates over the step
    /// (a sensor's lag) still takes the step's mean flow.
    pub fn step_at_flow(
        &self,
        state: &mut RunState,
        t_s: f64,
        pump_volume_ml: f64,
        flow_ml_s: f64,
    ) -> Prediction {
        self.advance(state, t_s, pump_volume_ml, Some(flow_ml_s))
    }

    fn advance(
        &self,
        state: &mut RunState,
        t_s: f64,
        pump_volume_ml: f64,
        sample_flow_ml_s: Option<f64>,
    ) -> Prediction {
        let (dt, step_flow) = state
            .started
            .then(|| pump_flow(state.t_s, state.pump_ml, t_s, pump_volume_ml))
            .flatten()
            .unwrap_or((0.0, 0.0));
        let flow = sample_flow_ml_s.unwrap_or(step_flow);
        let phase = Phase::of_flow(flow, self.hold_flow_ml_s);
        if state.cycles.update(pump_volume_ml, phase) {
            if let Some(law) = &self.sand {
                state.sand = Some(law.fresh_cycle());
            }
        }
        let ctx = self.context(state, t_s, dt, flow, step_flow);
        let trial = if self.holds_volume {
            self.solve(state, &ctx, pump_volume_ml)
        } else {
            self.trial(state, &ctx, pump_volume_ml, 0.0)
        };
        let mut reading = trial.internal_kpa;
        for e in self.built.iter() {
            reading = e.reading_kpa(&ctx, trial.internal_kpa, reading);
        }
        state.started = true;
        state.t_s = t_s;
        state.pump_ml = pump_volume_ml;
        state.internal_kpa = trial.internal_kpa;
        state.sand = trial.sand;
        state.effects = trial.effects;
        Prediction {
            sensor_kpa: reading,
            internal_kpa: trial.internal_kpa,
            skin_kpa: trial.skin_kpa,
            sand_kpa: trial.sand_kpa,
            diameter_mm: trial.diameter_mm,
            actuator_volume_ml: trial.actuator_volume_ml,
            pump_flow_ml_s: flow,
            phase,
            cycle: state.cycles.count,
        }
    }

    /// Solves p = P(pump − held(p)): g(p) = P(p) − p is strictly
    /// decreasing, so secant steps kept inside a shrinking bracket
    /// converge to its single root.
    fn solve(&self, state: &RunState, ctx: &StepContext, pump_ml: f64) -> Trial {
        let g = |p: f64| {
            let t = self.trial(state, ctx, pump_ml, p);
            (t.internal_kpa - p, t)
        };
        let mut x0 = state.internal_kpa;
        let (mut g0, mut t0) = g(x0);
        if g0 == 0.0 || !g0.is_finite() {
            return t0;
        }
        // Bracket: step in the direction of g until it changes sign.
        let mut step = g0.abs().max(1e-3);
        let mut x1 = x0 + g0.signum() * step;
        let (mut g1, mut t1) = g(x1);
        let mut guard = 0;
        while g1.signum() == g0.signum() && g1.is_finite() && guard < 60 {
            x0 = x1;
            g0 = g1;
            t0 = t1;
            step *= 2.0;
            x1 = x0 + g0.signum() * step;
            (g1, t1) = g(x1);
            guard += 1;
        }
        if !g1.is_finite() || g1.signum() == g0.signum() {
            return t0;
        }
        // Illinois (regula falsi with halving): robust and superlinear.
        let (mut a, mut ga, mut b, mut gb) = (x0, g0, x1, g1);
        let mut best = if g0.abs() < g1.abs() { t0 } else { t1 };
        let mut side = 0i8;
        for _ in 0..80 {
            let c = (a * gb - b * ga) / (gb - ga);
            let (gc, tc) = g(c);
            let done = gc.abs() < 1e-10 || (b - a).abs() < 1e-12;
            best = tc;
            if done || !gc.is_finite() {
                break;
            }
            if gc.signum() == gb.signum() {
                b = c;
                gb = gc;
                if side == -1 {
                    ga *= 0.5;
                }
                side = -1;
            } else {
                a = c;
                ga = gc;
                if side == 1 {
                    gb *= 0.5;
                }
                side = 1;
            }
        }
        best
    }

    /// The reading at every sample of `run` (kPa).
    pub fn predict(&self, run: &Run) -> Vec<f64> {
        self.predict_at(run, None)
    }

    /// The full prediction at every sample of `run`.
    pub fn predict_full(&self, run: &Run) -> Vec<Prediction> {
        self.predict_full_at(run, None)
    }

    /// [`RigModel::predict`] with each sample's flow given (mL/s, one per
    /// sample; [`RigModel::step_at_flow`]) where `flows_ml_s` is `Some`.
    pub fn predict_at(&self, run: &Run, flows_ml_s: Option<&[f64]>) -> Vec<f64> {
        self.steps(run, flows_ml_s).map(|p| p.sensor_kpa).collect()
    }

    /// [`RigModel::predict_full`] with each sample's flow given, as in
    /// [`RigModel::predict_at`].
    pub fn predict_full_at(&self, run: &Run, flows_ml_s: Option<&[f64]>) -> Vec<Prediction> {
        self.steps(run, flows_ml_s).collect()
    }

    fn steps<'a>(
        &'a self,
        run: &'a Run,
        flows_ml_s: Option<&'a [f64]>,
    ) -> impl Iterator<Item = Prediction> + 'a {
        let mut state = self.start_run(run.depth_mm);
        run.samples.iter().enumerate().map(move |(i, s)| {
            let flow = flows_ml_s.and_then(|f| f.get(i).copied());
            self.advance(&mut state, s.t_s, s.volume_ml, flow)
        })
    }
}

#[cfg(test)]
mod tests;
