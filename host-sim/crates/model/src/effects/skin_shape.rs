//! `skin_shape`, a form of the baseline rather than an effect: the skin's
//! law is taken as given (rig.toml's `[skin]`, a coupon fit) or as the
//! project's default Yeoh law with only its scale fitted. A skin that
//! stiffens sooner or later with stretch than that law (another rubber, a
//! coupon law that does not carry over to the inflated tube) breaks it;
//! here the skin's pressure is times 1 + a·x + b·x², x = λ² + λ⁻² − 2 the
//! first invariant's excess I1 − 3 of a tube stretched by λ = D/D0 — the
//! shape that adding Yeoh's c20 (a ≈ 2·c20/c10) and c30 (b ≈ 3·c30/c10)
//! terms to a neo-Hookean thin tube gives.

use super::{value, Effect, EffectKind, EffectSpec, StepContext};
use crate::params::ParamSpec;

const PARAMS: [ParamSpec; 2] = [
    ParamSpec {
        name: "stiffening_linear",
        unit: "-",
        lower: -5.0,
        upper: 20.0,
        default: 0.0,
        lower_is_law: false,
        description: "a in 1 + a·x + b·x² on the skin's pressure, x = I1 − 3 (0: the law's shape)",
    },
    ParamSpec {
        name: "stiffening_quadratic",
        unit: "-",
        lower: -20.0,
        upper: 50.0,
        default: 0.0,
        lower_is_law: false,
        description: "b in 1 + a·x + b·x² on the skin's pressure (0: the law's shape)",
    },
];

/// Smallest factor on the skin's pressure: a skin never pushes outwards.
const MIN_FACTOR: f64 = 0.05;

/// Registry row.
pub static SPEC: EffectSpec = EffectSpec {
    name: "skin_shape",
    description: "Baseline form: the skin's pressure–diameter curve has another shape than its law's (pressure times 1 + a·x + b·x², x = I1 − 3 at stretch D/D0).",
    signature: "a residual that grows with the zone's diameter in every run, in free water as in sand, the same on loading and unloading",
    params: &PARAMS,
    kind: EffectKind::BaselineForm {
        words: |v| {
            let (a, b) = (value(v, &PARAMS, 0), value(v, &PARAMS, 1));
            // The factor at a 40 % stretch, a typical working diameter.
            let x = 1.4f64.powi(2) + 1.4f64.powi(-2) - 2.0;
            let f = 1.0 + a * x + b * x * x;
            format!(
                "the skin stiffens {} with stretch than its law (pressure × {f:.2} at D = 1.4·D0; a = {a:.3}, b = {b:.3}, as if Yeoh's c20/c10 ≈ {:.3} and c30/c10 ≈ {:.3} were added)",
                if f >= 1.0 { "more" } else { "less" },
                a / 2.0,
                b / 3.0
            )
        },
        tells_apart: "a free inflation in water over the whole stroke, or runs to other peak diameters",
    },
    build: |v| {
        Box::new(SkinShape {
            linear: value(v, &PARAMS, 0),
            quadratic: value(v, &PARAMS, 1),
        })
    },
    not_applicable: |_| None,
    indistinct: |_, _| None,
};

/// Another shape of the skin's curve.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SkinShape {
    /// a, on x = I1 − 3.
    pub linear: f64,
    /// b, on x².
    pub quadratic: f64,
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
        let x = ctx.hoop_invariant_excess(diameter_mm);
        skin_kpa * (1.0 + self.linear * x + self.quadratic * x * x).max(MIN_FACTOR)
    }
}
