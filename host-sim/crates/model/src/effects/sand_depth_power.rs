//! `sand_depth_power`, a form of the baseline rather than an effect: the
//! sand law takes its push as proportional to the vertical stress γ'h.
//! A sand whose lateral push grows faster or slower with depth (a
//! stress-dependent friction angle or stiffness, a crust, a looser bed
//! below) breaks that; here the law sees the depth
//! h_eff = h·(h/h_ref)^(n−1), so the push goes as hⁿ and is unchanged at
//! h_ref.

use super::{value, Effect, EffectKind, EffectSpec};
use crate::params::ParamSpec;
use rig::Rig;

/// Depth at which the form leaves the push unchanged (mm): the middle of
/// the paper's depths, where the baseline's K factors are best fixed.
pub const REFERENCE_DEPTH_MM: f64 = 60.0;

const PARAMS: [ParamSpec; 1] = [ParamSpec {
    name: "exponent",
    unit: "-",
    lower: 0.3,
    upper: 2.5,
    default: 1.0,
    lower_is_law: false,
    description: "power of depth the sand's push follows (1: in proportion to depth)",
}];

/// Registry row.
pub static SPEC: EffectSpec = EffectSpec {
    name: "sand_depth_power",
    description: "Baseline form: the sand's push on the zone grows as a power n of the depth instead of in proportion to it (n = 1).",
    signature: "the sand's share misfits with opposite signs at the shallow and the deep runs, nothing in free water; independent of flow rate",
    params: &PARAMS,
    kind: EffectKind::BaselineForm {
        words: |v| {
            let n = value(v, &PARAMS, 0);
            format!(
                "the sand's push grows as depth^{n:.2}, {} than in proportion to depth as the model assumes",
                if n < 1.0 { "less" } else { "more" }
            )
        },
        tells_apart: "runs at more sand depths, or in a box of another width",
    },
    build: |v| Box::new(SandDepthPower { exponent: value(v, &PARAMS, 0) }),
    not_applicable: |rig: &Rig| rig.sand.is_none().then_some("rig.toml has no [sand]"),
    indistinct: |_, _| None,
};

/// The sand's push as a power of depth.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SandDepthPower {
    /// The power n.
    pub exponent: f64,
}

impl Effect for SandDepthPower {
    fn spec(&self) -> &'static EffectSpec {
        &SPEC
    }
    fn effective_depth_mm(&self, _: &Rig, depth_mm: f64) -> f64 {
        if depth_mm <= 0.0 {
            return depth_mm;
        }
        depth_mm * (depth_mm / REFERENCE_DEPTH_MM).powf(self.exponent - 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_push_goes_as_the_power_and_is_unchanged_at_the_reference() {
        let rig = Rig::paper_default();
        let e = SandDepthPower { exponent: 0.5 };
        assert_eq!(
            e.effective_depth_mm(&rig, REFERENCE_DEPTH_MM),
            REFERENCE_DEPTH_MM
        );
        // Four times deeper: twice the push, not four times.
        let ratio = e.effective_depth_mm(&rig, 4.0 * REFERENCE_DEPTH_MM) / REFERENCE_DEPTH_MM;
        assert!((ratio - 2.0).abs() < 1e-12, "{ratio}");
        assert_eq!(
            SandDepthPower { exponent: 1.0 }.effective_depth_mm(&rig, 37.0),
            37.0
        );
    }
}
