//! `mullins_softening`: the skin (a filled elastomer) is softer below the
//! largest stretch it has seen (the Mullins effect). Pseudo-elastic
//! damage: below the run's maximum diameter D_max the skin's pressure is
//! multiplied by η = 1 − r·(1 − x), x = (D − D0)/(D_max − D0) ∈ [0, 1];
//! on new ground (D ≥ D_max) the skin is virgin (η = 1).

use super::{value, Effect, EffectKind, EffectSpec, EffectState, StepContext};
use crate::params::ParamSpec;

const PARAMS: [ParamSpec; 1] = [ParamSpec {
    name: "fraction",
    unit: "-",
    lower: 0.0,
    upper: 0.95,
    default: 0.0,
    description: "largest relative softening of the skin, reached back at rest",
}];

/// Registry row.
pub static SPEC: EffectSpec = EffectSpec {
    name: "mullins_softening",
    description: "Stress softening of the skin below the largest stretch reached so far (Mullins effect): reloading and unloading follow a softer curve than first loading.",
    signature: "the model over-predicts pressure whenever the actuator is below its largest diameter so far (shrinking, and re-expanding in later cycles) but fits the first expansion; independent of flow rate",
    params: &PARAMS,
    kind: EffectKind::Physical,
    build: |v| Box::new(MullinsSoftening { fraction: value(v, &PARAMS, 0) }),
    not_applicable: |_| None,
    indistinct: |_, _| None,
};

/// Mullins softening. State: [largest diameter so far (mm), -].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MullinsSoftening {
    /// Softening at rest below a previous maximum, r.
    pub fraction: f64,
}

impl Effect for MullinsSoftening {
    fn spec(&self) -> &'static EffectSpec {
        &SPEC
    }
    fn initial_state(&self, ctx: &StepContext) -> EffectState {
        [ctx.initial_diameter_mm, 0.0]
    }
    fn skin_kpa(
        &self,
        state: &mut EffectState,
        ctx: &StepContext,
        diameter_mm: f64,
        skin_kpa: f64,
    ) -> f64 {
        let d0 = ctx.initial_diameter_mm;
        let max = state[0].max(diameter_mm);
        state[0] = max;
        if max - d0 <= 1e-9 || diameter_mm >= max {
            return skin_kpa;
        }
        let x = ((diameter_mm - d0) / (max - d0)).clamp(0.0, 1.0);
        skin_kpa * (1.0 - self.fraction * (1.0 - x))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::effects::free_water_context;

    #[test]
    fn virgin_on_new_ground_softer_below_the_maximum() {
        let ctx = StepContext {
            dt_s: 0.02,
            initial_diameter_mm: 20.0,
            ..free_water_context()
        };
        let m = MullinsSoftening { fraction: 0.4 };
        let mut st = m.initial_state(&ctx);
        assert_eq!(m.skin_kpa(&mut st, &ctx, 24.0, 2.0), 2.0);
        assert_eq!(st[0], 24.0);
        // Halfway back: η = 1 − 0.4·0.5 = 0.8.
        assert!((m.skin_kpa(&mut st, &ctx, 22.0, 1.0) - 0.8).abs() < 1e-12);
        assert_eq!(st[0], 24.0);
    }
}
