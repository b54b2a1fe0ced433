//! `sand_unloading`, a form of the baseline rather than an effect: as the
//! zone shrinks, the sand law lets its lateral coefficient fall back
//! along a straight unloading branch of slope s (dK/dD) down to the active
//! coefficient Ka. A sand that relaxes more softly (it follows the
//! shrinking zone less, a looser or more compressible bed) or more
//! steeply breaks that; here the slope is f·s, and the branch may bend
//! from the straight line into a curve towards its floor (a sand whose
//! push decays exponentially, or with a longer tail, as it unloads), and
//! the floor itself may lie above or below Rankine's active push (a bed
//! that keeps locked-in stress, or one that relaxes past it).

use super::{value, Effect, EffectKind, EffectSpec};
use crate::params::ParamSpec;
use rig::Rig;
use sand::SandParams;

const PARAMS: [ParamSpec; 3] = [
    ParamSpec {
        name: "slope_factor",
        unit: "-",
        lower: 0.05,
        upper: 20.0,
        default: 1.0,
        lower_is_law: false,
        description: "factor on the sand's initial unloading slope (1: the law's own)",
    },
    ParamSpec {
        name: "curvature",
        unit: "-",
        lower: -2.0,
        upper: 1.0,
        default: 1.0,
        lower_is_law: false,
        description:
            "shape towards the floor: 1 straight (the law's own), 0 exponential, < 0 a longer tail",
    },
    ParamSpec {
        name: "floor_factor",
        unit: "-",
        lower: 0.2,
        upper: 3.0,
        default: 1.0,
        lower_is_law: false,
        description: "factor on the floor the push falls to, the law's active coefficient Ka (1: the law's own; never above the at-rest coefficient)",
    },
];

/// Registry row.
pub static SPEC: EffectSpec = EffectSpec {
    name: "sand_unloading",
    description: "Baseline form: as the zone shrinks the sand's push falls f times as fast as the sand law's unloading branch says (f = 1), along a straight line or a curve to a floor that may differ from the law's active push.",
    signature: "misfit only in the shrink phases of buried runs, none in free water or while the zone swells, growing with depth",
    params: &PARAMS,
    kind: EffectKind::BaselineForm {
        words: |v| {
            let (f, c, floor) = (
                value(v, &PARAMS, 0),
                value(v, &PARAMS, 1),
                value(v, &PARAMS, 2),
            );
            let shape = if c > 0.75 {
                "along a nearly straight line to its floor".to_owned()
            } else if c > -0.25 {
                format!("along a curve that flattens towards its floor, near an exponential decay (curvature {c:.2})")
            } else {
                format!("along a curve with a long tail above its floor (curvature {c:.2})")
            };
            let floor = if (floor - 1.0).abs() < 0.05 {
                String::new()
            } else {
                format!(", which lies {floor:.2} times the law's active push")
            };
            format!(
                "the sand unloads {} than the model at first (its push falls {f:.2} times as fast as the zone starts to shrink), {shape}{floor}",
                if f < 1.0 { "more softly" } else { "more steeply" }
            )
        },
        tells_apart: "runs that shrink the zone by other amounts, or hold it part-way down",
    },
    build: |v| {
        Box::new(SandUnloading {
            slope_factor: value(v, &PARAMS, 0),
            curvature: value(v, &PARAMS, 1),
            floor_factor: value(v, &PARAMS, 2),
        })
    },
    not_applicable: |rig: &Rig| rig.sand.is_none().then_some("rig.toml has no [sand]"),
    indistinct: |_, _| None,
};

/// Another slope of the sand's unloading branch.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SandUnloading {
    /// Factor f on the law's slope.
    pub slope_factor: f64,
    /// [`sand::Unloading::curvature`] of the branch.
    pub curvature: f64,
    /// Factor on the floor, the law's active coefficient Ka (capped at the
    /// at-rest coefficient): a bed that keeps more (or less) of its push
    /// once unloaded than Rankine's active state.
    pub floor_factor: f64,
}

impl Effect for SandUnloading {
    fn spec(&self) -> &'static EffectSpec {
        &SPEC
    }
    fn sand(&self, params: SandParams) -> SandParams {
        SandParams {
            unloading_stiffness_ratio: self.slope_factor * params.unloading_stiffness_ratio,
            unloading_curvature: self.curvature,
            active_coefficient: (self.floor_factor * params.active_coefficient)
                .min(params.at_rest_coefficient),
            ..params
        }
    }
}
