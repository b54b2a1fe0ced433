//! `trapped_air`: a gas bubble in the line or the actuator. Isothermal
//! (Boyle): a bubble of volume V0 at the rest absolute pressure
//! P0 = atmosphere + water column shrinks to V0·P0/(P0 + p) at gauge p, so
//! V0·p/(P0 + p) of the pumped water fills the bubble's room instead of
//! the actuator.

use super::{value, Effect, EffectKind, EffectSpec, EffectState, StepContext};
use crate::params::ParamSpec;

const PARAMS: [ParamSpec; 1] = [ParamSpec {
    name: "gas_volume_ml",
    unit: "mL",
    lower: 0.0,
    upper: 20.0,
    default: 0.0,
    lower_is_law: false,
    description: "gas volume at rest (gauge zero, at the actuator's depth)",
}];

/// Registry row.
pub static SPEC: EffectSpec = EffectSpec {
    name: "trapped_air",
    description: "An air bubble compressed isothermally (Boyle, absolute pressure = atmosphere + water column + gauge) takes part of the pumped volume.",
    signature: "the model over-predicts pressure more and more as pressure rises (the rig is softer than the model), most at the deepest runs and the top of each expansion; the same at every flow rate",
    params: &PARAMS,
    kind: EffectKind::Physical,
    build: |v| Box::new(TrappedAir { gas_volume_ml: value(v, &PARAMS, 0) }),
    not_applicable: |_| None,
    indistinct: |_, _| None,
};

/// A trapped gas bubble.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrappedAir {
    /// Gas volume at gauge zero (mL).
    pub gas_volume_ml: f64,
}

impl Effect for TrappedAir {
    fn spec(&self) -> &'static EffectSpec {
        &SPEC
    }
    fn holds_volume(&self) -> bool {
        true
    }
    fn held_volume_ml(&self, _: &mut EffectState, ctx: &StepContext, gauge_kpa: f64) -> f64 {
        // Never compress past vacuum: P0 + p floored just above 0.
        let absolute = (ctx.absolute_rest_kpa + gauge_kpa).max(1e-3 * ctx.absolute_rest_kpa);
        self.gas_volume_ml * (1.0 - ctx.absolute_rest_kpa / absolute)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::effects::free_water_context;

    #[test]
    fn boyle_at_twice_the_absolute_pressure_halves_the_bubble() {
        let ctx = free_water_context();
        let air = TrappedAir { gas_volume_ml: 2.0 };
        let mut st = [0.0; 2];
        assert!((air.held_volume_ml(&mut st, &ctx, crate::ATMOSPHERE_KPA) - 1.0).abs() < 1e-12);
        assert_eq!(air.held_volume_ml(&mut st, &ctx, 0.0), 0.0);
        // Suction lets it grow: negative held volume.
        assert!(air.held_volume_ml(&mut st, &ctx, -10.0) < 0.0);
    }
}
