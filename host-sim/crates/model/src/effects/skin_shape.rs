//! `skin_shape`, a form of the baseline rather than an effect: when
//! rig.toml gives no `[skin]`, the model takes the project's default Yeoh
//! law and fits only its scale. A skin of another shape (stiffening
//! sooner or later with stretch, another rubber) breaks that; here the
//! skin's pressure is times (D/D0)^m, m = 0 the default law's shape.

use super::{value, Effect, EffectKind, EffectSpec, StepContext};
use crate::params::ParamSpec;
use rig::Rig;

const PARAMS: [ParamSpec; 1] = [ParamSpec {
    name: "stretch_power",
    unit: "-",
    lower: -3.0,
    upper: 3.0,
    default: 0.0,
    description: "power of the stretch D/D0 on the skin's pressure (0: the default law's shape)",
}];

/// Registry row.
pub static SPEC: EffectSpec = EffectSpec {
    name: "skin_shape",
    description: "Baseline form: the skin's pressure–diameter curve has another shape than the default Yeoh law's (its pressure times (D/D0)^m); only where rig.toml gives no [skin].",
    signature: "a residual that grows with the zone's diameter in every run, in free water as in sand, the same on loading and unloading",
    params: &PARAMS,
    kind: EffectKind::BaselineForm {
        words: |v| {
            let m = value(v, &PARAMS, 0);
            format!(
                "the skin {} with stretch than the default law (its pressure times (D/D0)^{m:.2})",
                if m > 0.0 { "stiffens more" } else { "stiffens less" }
            )
        },
    },
    build: |v| Box::new(SkinShape { stretch_power: value(v, &PARAMS, 0) }),
    not_applicable: |rig: &Rig| {
        rig.skin
            .is_some()
            .then_some("rig.toml gives the skin's law ([skin])")
    },
};

/// Another shape of the skin's curve.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SkinShape {
    /// The power m on D/D0.
    pub stretch_power: f64,
}

impl Effect for SkinShape {
    fn spec(&self) -> &'static EffectSpec {
        &SPEC
    }
    fn skin_kpa(
        &self,
        _: &mut super::EffectState,
        ctx: &StepContext,
        diameter_mm: f64,
        skin_kpa: f64,
    ) -> f64 {
        skin_kpa * (diameter_mm / ctx.initial_diameter_mm).powf(self.stretch_power)
    }
}
