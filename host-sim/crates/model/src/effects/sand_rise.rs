//! `sand_rise`, a form of the baseline rather than an effect: the sand
//! law's push rises from at rest to its limit along tanh(ΔD/ΔDc). A sand
//! that approaches its limit more gradually (an exponential approach, as
//! cavity-expansion and hyperbolic p–y laws give) or more abruptly breaks
//! that; here the rise is the family of [`sand::SandParams::rise_shape`],
//! with the same initial slope and limit.

use super::{value, Effect, EffectKind, EffectSpec};
use crate::params::ParamSpec;
use rig::Rig;
use sand::SandParams;

const PARAMS: [ParamSpec; 1] = [ParamSpec {
    name: "shape",
    unit: "-",
    lower: -0.9,
    upper: 10.0,
    default: 1.0,
    lower_is_law: false,
    description: "shape of the sand's rise: 1 tanh (the law's own), 0 exponential approach, < 0 more gradual, > 1 more abrupt",
}];

/// Registry row.
pub static SPEC: EffectSpec = EffectSpec {
    name: "sand_rise",
    description: "Baseline form: the sand's push rises from at rest towards its limit along another curve than the law's tanh (same initial slope, same limit).",
    signature: "misfit only in buried runs while the zone swells past its earlier peak, of one sign early in the swelling and the other late, growing with depth",
    params: &PARAMS,
    kind: EffectKind::BaselineForm {
        words: |v| {
            let c = value(v, &PARAMS, 0);
            format!(
                "the sand's push approaches its limit {} than the model's tanh law (shape {c:.2}: 1 is tanh, 0 an exponential approach)",
                if c < 1.0 { "more gradually" } else { "more abruptly" }
            )
        },
        tells_apart: "runs that expand the zone by other amounts",
    },
    build: |v| Box::new(SandRise { shape: value(v, &PARAMS, 0) }),
    not_applicable: |rig: &Rig| rig.sand.is_none().then_some("rig.toml has no [sand]"),
    indistinct: |_, _| None,
};

/// Another shape of the sand's rise.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SandRise {
    /// [`SandParams::rise_shape`].
    pub shape: f64,
}

impl Effect for SandRise {
    fn spec(&self) -> &'static EffectSpec {
        &SPEC
    }
    fn sand(&self, params: SandParams) -> SandParams {
        SandParams {
            rise_shape: self.shape,
            ..params
        }
    }
}
