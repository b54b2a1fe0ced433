//! `skin_viscoelasticity`: the skin is viscoelastic (quasi-linear, one
//! Prony term). An overstress q adds to the elastic pressure p_el and
//! relaxes with time constant τ: dq/dt = −q/τ + g·dp_el/dt, so a fast step
//! reads (1 + g) times stiffer and relaxes back to the elastic curve.
//! Exact update for p_el linear within a step:
//! q ← q·e^(−Δt/τ) + g·Δp_el·(τ/Δt)(1 − e^(−Δt/τ)).

use super::{value, Effect, EffectKind, EffectSpec, EffectState, StepContext};
use crate::params::ParamSpec;

const PARAMS: [ParamSpec; 2] = [
    ParamSpec {
        name: "fraction",
        unit: "-",
        lower: 0.0,
        upper: 5.0,
        default: 0.1,
        lower_is_law: false,
        description: "Prony weight g: instantaneous over long-term skin stiffness, minus 1",
    },
    ParamSpec {
        name: "tau_s",
        unit: "s",
        lower: 0.05,
        upper: 200.0,
        default: 2.0,
        lower_is_law: false,
        description: "relaxation time of the overstress",
    },
];

/// Registry row.
pub static SPEC: EffectSpec = EffectSpec {
    name: "skin_viscoelasticity",
    description: "Viscoelastic skin, one Prony term: an overstress proportional to the recent rate of skin loading that relaxes with time constant tau.",
    signature: "the measured pressure overshoots the model while expanding and relaxes back toward it during holds with a time constant; undershoots while shrinking; grows with flow rate but less than proportionally",
    params: &PARAMS,
    kind: EffectKind::Physical,
    build: |v| Box::new(SkinViscoelasticity {
        fraction: value(v, &PARAMS, 0),
        tau_s: value(v, &PARAMS, 1),
    }),
    not_applicable: |_| None,
    indistinct: |_, _| None,
};

/// One Prony term. State: [overstress q (kPa), skin pressure at the last
/// step (kPa)].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SkinViscoelasticity {
    /// Prony weight g.
    pub fraction: f64,
    /// Relaxation time τ (s).
    pub tau_s: f64,
}

impl Effect for SkinViscoelasticity {
    fn spec(&self) -> &'static EffectSpec {
        &SPEC
    }
    fn skin_kpa(&self, state: &mut EffectState, ctx: &StepContext, _: f64, skin_kpa: f64) -> f64 {
        let [q, previous] = *state;
        let tau = self.tau_s.max(1e-9);
        let dp = skin_kpa - previous;
        let q = if ctx.dt_s > 0.0 {
            let x = ctx.dt_s / tau;
            let decay = (-x).exp();
            // (1 − e^(−x))/x, stable for small x.
            let gain = if x > 1e-8 { -(-x).exp_m1() / x } else { 1.0 };
            q * decay + self.fraction * dp * gain
        } else {
            q + self.fraction * dp
        };
        *state = [q, skin_kpa];
        skin_kpa + q
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::effects::free_water_context;

    #[test]
    fn step_then_relaxation_is_exponential() {
        let mut ctx = free_water_context();
        let v = SkinViscoelasticity {
            fraction: 0.5,
            tau_s: 2.0,
        };
        let mut st = [0.0; 2];
        // Instant step of the elastic pressure to 1 kPa: reads 1.5 kPa.
        assert!((v.skin_kpa(&mut st, &ctx, 20.0, 1.0) - 1.5).abs() < 1e-12);
        // Held: after 2 s (in 100 steps) the overstress is 0.5·e^(−1).
        ctx.dt_s = 0.02;
        let mut p = 0.0;
        for _ in 0..100 {
            p = v.skin_kpa(&mut st, &ctx, 20.0, 1.0);
        }
        assert!((p - (1.0 + 0.5 * (-1.0_f64).exp())).abs() < 1e-12, "{p}");
    }
}
