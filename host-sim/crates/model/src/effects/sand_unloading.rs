//! `sand_unloading`, a form of the baseline rather than an effect: as the
//! zone shrinks, the sand law lets its lateral coefficient fall back
//! along a straight unloading branch of slope s (dK/dD) down to the active
//! coefficient Ka. A sand that relaxes more softly (it follows the
//! shrinking zone less, a looser or more compressible bed) or more
//! steeply breaks that; here the slope is f·s.

use super::{value, Effect, EffectKind, EffectSpec};
use crate::params::ParamSpec;
use rig::Rig;
use sand::Unloading;

const PARAMS: [ParamSpec; 1] = [ParamSpec {
    name: "slope_factor",
    unit: "-",
    lower: 0.05,
    upper: 20.0,
    default: 1.0,
    description: "factor on the sand's unloading slope (1: the law's own)",
}];

/// Registry row.
pub static SPEC: EffectSpec = EffectSpec {
    name: "sand_unloading",
    description: "Baseline form: as the zone shrinks the sand's push falls f times as fast as the sand law's unloading branch says (f = 1).",
    signature: "misfit only in the shrink phases of buried runs, none in free water or while the zone swells, growing with depth",
    params: &PARAMS,
    kind: EffectKind::BaselineForm {
        words: |v| {
            let f = value(v, &PARAMS, 0);
            format!(
                "the sand unloads {} than the model (its push falls {f:.2} times as fast as the zone shrinks)",
                if f < 1.0 { "more softly" } else { "more steeply" }
            )
        },
    },
    build: |v| Box::new(SandUnloading { slope_factor: value(v, &PARAMS, 0) }),
    not_applicable: |rig: &Rig| rig.sand.is_none().then_some("rig.toml has no [sand]"),
};

/// Another slope of the sand's unloading branch.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SandUnloading {
    /// Factor f on the law's slope.
    pub slope_factor: f64,
}

impl Effect for SandUnloading {
    fn spec(&self) -> &'static EffectSpec {
        &SPEC
    }
    fn unloading(&self, unloading: Unloading) -> Unloading {
        Unloading {
            slope_per_mm: self.slope_factor * unloading.slope_per_mm,
            ..unloading
        }
    }
}
