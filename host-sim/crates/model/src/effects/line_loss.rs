//! `line_loss`: viscous loss in the tube between pump and actuator. In
//! laminar (Poiseuille) flow the drop is linear in the flow, so a sensor on
//! the line (or the piston) reads p + R·Q while water moves, Q > 0 pushing.

use super::{value, Effect, EffectKind, EffectSpec, StepContext};
use crate::params::ParamSpec;

const PARAMS: [ParamSpec; 1] = [ParamSpec {
    name: "resistance_kpa_s_per_ml",
    unit: "kPa·s/mL",
    lower: 0.0,
    upper: 20.0,
    default: 0.0,
    lower_is_law: false,
    description: "pressure drop per unit flow between the sensor and the actuator",
}];

/// Registry row.
pub static SPEC: EffectSpec = EffectSpec {
    name: "line_loss",
    description: "Laminar flow loss in the line between pump and actuator: the reading is the internal pressure plus R times the pump flow.",
    signature: "a residual proportional to the flow rate: positive while expanding, negative while shrinking, zero during holds, twice as large at twice the flow",
    params: &PARAMS,
    kind: EffectKind::Physical,
    build: |v| Box::new(LineLoss { resistance_kpa_s_per_ml: value(v, &PARAMS, 0) }),
    not_applicable: |_| None,
    indistinct: |_, _| None,
};

/// A linear flow resistance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LineLoss {
    /// Pressure drop per flow (kPa·s/mL).
    pub resistance_kpa_s_per_ml: f64,
}

impl Effect for LineLoss {
    fn spec(&self) -> &'static EffectSpec {
        &SPEC
    }
    fn reading_kpa(&self, ctx: &StepContext, _: f64, reading_kpa: f64) -> f64 {
        reading_kpa + self.resistance_kpa_s_per_ml * ctx.pump_flow_ml_s
    }
}
