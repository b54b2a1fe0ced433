//! `wall_arching`: in a narrow box the container walls carry part of the
//! sand's weight by friction (Janssen 1895). With wall friction × lateral
//! ratio μk and box width B, the vertical stress at depth h is
//! σv = γ'B/(2μk)·(1 − exp(−2μk·h/B)) instead of γ'h: the sand law sees
//! the depth h_eff = h·(1 − e^(−x))/x, x = 2μk·h/B. Without a
//! `[container]` in rig.toml (a wide tank) the effect does not apply.

use super::{value, Effect, EffectKind, EffectSpec};
use crate::params::ParamSpec;
use rig::Rig;

const PARAMS: [ParamSpec; 1] = [ParamSpec {
    name: "mu_k",
    unit: "-",
    lower: 0.0,
    upper: 3.0,
    default: 0.0,
    lower_is_law: false,
    description: "wall friction coefficient times the lateral stress ratio",
}];

/// Registry row.
pub static SPEC: EffectSpec = EffectSpec {
    name: "wall_arching",
    description: "Janssen arching: the container walls carry part of the sand's weight, so the vertical stress saturates with depth (container width from rig.toml).",
    signature: "the model over-predicts the sand's share of the pressure more and more with depth (less than proportional to depth), nothing in free water; independent of flow rate",
    params: &PARAMS,
    kind: EffectKind::Physical,
    build: |v| Box::new(WallArching { mu_k: value(v, &PARAMS, 0) }),
    not_applicable: |rig| {
        if rig.container.as_ref().and_then(|c| c.width_mm).is_none() {
            Some("rig.toml gives no [container] width_mm: a wide tank has no wall arching")
        } else if rig.sand.is_none() {
            Some("rig.toml has no [sand]")
        } else {
            None
        }
    },
    indistinct: |_, _| None,
};

/// Janssen arching against the container walls.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WallArching {
    /// Wall friction × lateral stress ratio, μk.
    pub mu_k: f64,
}

impl WallArching {
    /// Janssen's depth h_eff (mm) for depth `depth_mm` in a box of width
    /// `width_mm`.
    pub fn effective_depth_mm(&self, width_mm: f64, depth_mm: f64) -> f64 {
        let x = 2.0 * self.mu_k * depth_mm / width_mm;
        // Also catches NaN (a zero width): no arching rather than garbage.
        if x.is_nan() || x <= 1e-12 {
            return depth_mm;
        }
        depth_mm * (-(-x).exp_m1() / x)
    }
}

impl Effect for WallArching {
    fn spec(&self) -> &'static EffectSpec {
        &SPEC
    }
    fn effective_depth_mm(&self, rig: &Rig, depth_mm: f64) -> f64 {
        match rig.container.as_ref().and_then(|c| c.width_mm) {
            Some(width_mm) => WallArching::effective_depth_mm(self, width_mm, depth_mm),
            // A wide tank: no wall to arch onto.
            None => depth_mm,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn janssen_closed_form() {
        let a = WallArching { mu_k: 0.2 };
        // σv/γ' = B/(2μk)(1 − e^(−2μk h/B)) = 40/0.4·(1 − e^(−0.4·100/40)).
        let want = 100.0 * (1.0 - (-1.0_f64).exp());
        assert!((a.effective_depth_mm(40.0, 100.0) - want).abs() < 1e-12);
        // Shallow limit → h; deep limit → B/(2μk).
        assert!((a.effective_depth_mm(40.0, 1e-6) / 1e-6 - 1.0).abs() < 1e-8);
        assert!((a.effective_depth_mm(40.0, 1e5) - 100.0).abs() < 1e-9);
        assert_eq!(
            WallArching { mu_k: 0.0 }.effective_depth_mm(40.0, 70.0),
            70.0
        );
    }
}
