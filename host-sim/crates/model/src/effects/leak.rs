//! `leak`: water escapes through a seal or a pin-hole in proportion to the
//! gauge pressure (laminar leak path): dV_lost/dt = k·p. The lost volume
//! accumulates over the run (implicit Euler in p).

use super::{value, Effect, EffectKind, EffectSpec, EffectState, StepContext};
use crate::params::ParamSpec;

const PARAMS: [ParamSpec; 1] = [ParamSpec {
    name: "ml_per_s_per_kpa",
    unit: "mL/(s·kPa)",
    lower: 0.0,
    upper: 1.0,
    default: 0.0,
    lower_is_law: false,
    description: "leak flow per kPa of gauge pressure",
}];

/// Registry row.
pub static SPEC: EffectSpec = EffectSpec {
    name: "leak",
    description: "Water leaks out in proportion to the gauge pressure (a laminar leak path); the lost volume accumulates over the run.",
    signature: "the measured pressure decays during holds while the model's stays flat, and the deficit grows from cycle to cycle (pressure below the model's, even negative, by the end of each shrink)",
    params: &PARAMS,
    kind: EffectKind::Physical,
    build: |v| Box::new(Leak { ml_per_s_per_kpa: value(v, &PARAMS, 0) }),
    not_applicable: |_| None,
    indistinct: |_, _| None,
};

/// A pressure-driven leak. State: [lost volume so far (mL), -].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Leak {
    /// Leak conductance (mL/s per kPa).
    pub ml_per_s_per_kpa: f64,
}

impl Effect for Leak {
    fn spec(&self) -> &'static EffectSpec {
        &SPEC
    }
    fn holds_volume(&self) -> bool {
        true
    }
    fn held_volume_ml(&self, state: &mut EffectState, ctx: &StepContext, gauge_kpa: f64) -> f64 {
        // `state` is a trial copy of the committed total (the model commits
        // the copy of the solved evaluation).
        state[0] += self.ml_per_s_per_kpa * gauge_kpa * ctx.dt_s;
        state[0]
    }
}
