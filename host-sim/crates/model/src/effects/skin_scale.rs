//! `skin_scale`, a form of the baseline rather than an effect: where
//! rig.toml states the skin's law (`[skin]`, most often a fit to a coupon
//! pulled in tension), the model takes that law at its stated scale. The
//! inflated tube is loaded biaxially, may be preconditioned or cut from
//! another sheet, and can be a few per cent softer or stiffer than the
//! coupon says; here the skin's pressure is times a factor within the
//! few per cent that a coupon law's scale is known to. Without
//! `[skin]` the baseline fits the skin's scale already, so the form does
//! not apply.

use super::sensor_gain::SKIN_LAW_SCALE_TOLERANCE;
use super::{value, Effect, EffectKind, EffectSpec, StepContext};
use crate::params::ParamSpec;

/// The factor's range: as far as a coupon law's scale is known in the
/// tube ([`SKIN_LAW_SCALE_TOLERANCE`], imposed). A skin further off than
/// that ends on a bound and is not accepted, and a sensor gain beyond it
/// is told apart from the skin (the gain's own rule, on the same
/// constant).
const PARAMS: [ParamSpec; 1] = [ParamSpec {
    name: "factor",
    unit: "-",
    lower: 1.0 - SKIN_LAW_SCALE_TOLERANCE,
    upper: 1.0 + SKIN_LAW_SCALE_TOLERANCE,
    default: 1.0,
    lower_is_law: false,
    description: "factor on the stated skin law's pressure (1: as stated)",
}];

/// Registry row.
pub static SPEC: EffectSpec = EffectSpec {
    name: "skin_scale",
    description: "Baseline form: the skin in the tube is softer or stiffer than rig.toml's [skin] law states (its pressure times a factor).",
    signature: "a residual proportional to the skin's share of the pressure: in free water as in sand, on loading as on unloading, nothing from the sand",
    params: &PARAMS,
    kind: EffectKind::BaselineForm {
        words: |v| {
            let f = value(v, &PARAMS, 0);
            format!(
                "the skin in the tube is {:.1} % {} than rig.toml's [skin] law states (its pressure × {f:.3})",
                100.0 * (f - 1.0).abs(),
                if f < 1.0 { "softer" } else { "stiffer" }
            )
        },
        tells_apart: "a free inflation in water read by a sensor of known gain, or a skin test in the tube's own (equibiaxial) loading",
    },
    build: |v| {
        Box::new(SkinScale {
            factor: value(v, &PARAMS, 0),
        })
    },
    not_applicable: |rig| {
        (!rig.skin_known())
            .then_some("rig.toml gives no [skin]: the baseline fits the skin's scale already")
    },
    indistinct: |_, _| None,
};

/// The stated skin law at another scale.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SkinScale {
    /// Factor on the law's pressure.
    pub factor: f64,
}

impl Effect for SkinScale {
    fn spec(&self) -> &'static EffectSpec {
        &SPEC
    }
    fn skin_kpa(
        &self,
        _: &mut super::EffectState,
        _: &StepContext,
        _diameter_mm: f64,
        skin_kpa: f64,
    ) -> f64 {
        self.factor * skin_kpa
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rig::Rig;

    #[test]
    fn scales_the_stated_law_and_only_where_one_is_stated() {
        let e = SkinScale { factor: 0.96 };
        let mut st = [0.0; 2];
        let ctx = super::super::free_water_context();
        assert!((e.skin_kpa(&mut st, &ctx, 22.0, 5.0) - 4.8).abs() < 1e-12);
        let mut rig = Rig::paper_default();
        assert_eq!((SPEC.not_applicable)(&rig).is_none(), rig.skin_known());
        rig.skin = None;
        rig.skin_fit = None;
        assert!((SPEC.not_applicable)(&rig).is_some());
    }
}
