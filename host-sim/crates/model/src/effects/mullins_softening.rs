//! `mullins_softening`: the skin (a filled elastomer) is softer below the
//! largest stretch it has seen (the Mullins effect), by the pseudo-elastic
//! law of Ogden & Roxburgh (1999): u = W_max − W below the run's largest W,
//! the skin's pressure is multiplied by η = 1 − (1/r)·erf(u/m); on new
//! ground (u = 0) the skin is virgin (η = 1).
//!
//! W is the tube's first invariant less 3 at the outer hoop stretch
//! λ = D/D0 in plane strain, W = λ² + λ⁻² − 2. It stands for the strain
//! energy (the two are in proportion for a neo-Hookean skin) and does not
//! depend on which skin law or baseline form the model carries.
//!
//! The law is fitted as η = 1 − s·erf(c·u)/c: s = 1/(r·m) is the initial
//! softening per unit of u, c = 1/m how soon it saturates, at 1/r = s/c.
//! A run that never stretches far past m sees only the first, nearly
//! linear part of the erf, where 1/r and m ride one ridge out to infinity;
//! s stays fixed along it, and the linear law is c = 0, inside the family.

use super::{value, Effect, EffectKind, EffectSpec, EffectState, StepContext};
use crate::params::ParamSpec;

const PARAMS: [ParamSpec; 2] = [
    ParamSpec {
        name: "rate",
        unit: "1/(I1-3)",
        lower: 0.0,
        upper: 20.0,
        default: 0.0,
        lower_is_law: false,
        description:
            "initial softening per unit of I1 − 3 below the largest, Ogden–Roxburgh's 1/(r·m)",
    },
    ParamSpec {
        name: "saturation",
        unit: "1/(I1-3)",
        lower: 0.0,
        upper: 50.0,
        default: 2.0,
        lower_is_law: true,
        description:
            "how soon the softening saturates, Ogden–Roxburgh's 1/m (0: it grows linearly)",
    },
];

/// Registry row.
pub static SPEC: EffectSpec = EffectSpec {
    name: "mullins_softening",
    description: "Stress softening of the skin below the largest stretch reached so far (Mullins effect, Ogden–Roxburgh): reloading and unloading follow a softer curve than first loading.",
    signature: "the model over-predicts pressure whenever the actuator is below its largest diameter so far (shrinking, and re-expanding in later cycles) but fits the first expansion; independent of flow rate",
    params: &PARAMS,
    kind: EffectKind::Physical,
    build: |v| {
        Box::new(MullinsSoftening {
            rate: value(v, &PARAMS, 0),
            saturation: value(v, &PARAMS, 1),
        })
    },
    not_applicable: |_| None,
    indistinct: |_, _| None,
};

/// Mullins softening. State: [largest W = I1 − 3 so far, -].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MullinsSoftening {
    /// Initial softening per unit of I1 − 3, 1/(r·m).
    pub rate: f64,
    /// Saturation, 1/m (per unit of I1 − 3).
    pub saturation: f64,
}

impl MullinsSoftening {
    /// The softening factor η at `below` = W_max − W ≥ 0.
    pub fn factor(&self, below: f64) -> f64 {
        let c = self.saturation;
        // erf(c·u)/c → 2u/√π as c → 0.
        let shape = if c * below > 1e-8 {
            libm::erf(c * below) / c
        } else {
            std::f64::consts::FRAC_2_SQRT_PI * below
        };
        // A fit may ask for more softening than the skin has: it cannot
        // carry less than nothing.
        (1.0 - self.rate * shape).max(0.0)
    }
}

impl Effect for MullinsSoftening {
    fn spec(&self) -> &'static EffectSpec {
        &SPEC
    }
    fn skin_kpa(
        &self,
        state: &mut EffectState,
        ctx: &StepContext,
        diameter_mm: f64,
        skin_kpa: f64,
    ) -> f64 {
        // Counted only while stretched: a zone drawn below its rest
        // diameter softens nothing.
        let w = if diameter_mm > ctx.initial_diameter_mm {
            ctx.hoop_invariant_excess(diameter_mm)
        } else {
            0.0
        };
        let max = state[0].max(w);
        state[0] = max;
        skin_kpa * self.factor(max - w)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::effects::free_water_context;

    #[test]
    fn virgin_on_new_ground_ogden_roxburgh_below_the_maximum() {
        let ctx = StepContext {
            dt_s: 0.02,
            initial_diameter_mm: 20.0,
            ..free_water_context()
        };
        // 1/r = 0.4, m = 0.3: s = 0.4/0.3, c = 1/0.3.
        let m = MullinsSoftening {
            rate: 0.4 / 0.3,
            saturation: 1.0 / 0.3,
        };
        let mut st = m.initial_state(&ctx);
        assert_eq!(m.skin_kpa(&mut st, &ctx, 24.0, 2.0), 2.0);
        let w_max = 1.44 + 1.0 / 1.44 - 2.0;
        assert!((st[0] - w_max).abs() < 1e-12);
        // Back at 22 mm: η = 1 − 0.4·erf((W_max − W)/0.3).
        let w = 1.21 + 1.0 / 1.21 - 2.0;
        let eta = 1.0 - 0.4 * libm::erf((w_max - w) / 0.3);
        assert!((m.skin_kpa(&mut st, &ctx, 22.0, 1.0) - eta).abs() < 1e-12);
        // Far below a large maximum the softening approaches 1/r.
        let mut st = [10.0, 0.0];
        assert!((m.skin_kpa(&mut st, &ctx, 20.0, 1.0) - 0.6).abs() < 1e-9);
    }

    #[test]
    fn linear_limit_is_continuous() {
        let lin = MullinsSoftening {
            rate: 0.5,
            saturation: 0.0,
        };
        let near = MullinsSoftening {
            rate: 0.5,
            saturation: 1e-4,
        };
        for u in [0.0, 0.1, 0.3] {
            let want = 1.0 - 0.5 * std::f64::consts::FRAC_2_SQRT_PI * u;
            assert!((lin.factor(u) - want).abs() < 1e-15);
            assert!((near.factor(u) - want).abs() < 1e-8);
        }
    }
}
