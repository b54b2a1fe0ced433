//! `wall_arching`: in a narrow box the container walls carry part of the
//! sand's weight by friction (Janssen 1895). With wall friction × lateral
//! ratio μk and the box's hydraulic radius R = W·L/(2(W + L)) (area over
//! perimeter; W/2 for a long slot), the vertical stress at depth h is
//! σv = γ'R/μk·(1 − exp(−μk·h/R)) instead of γ'h: the sand law sees the
//! depth h_eff = h·(1 − e^(−x))/x, x = μk·h/R. Without a `[container]`
//! width in rig.toml (a wide tank) the effect does not apply.

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
    description: "Janssen arching: the container walls carry part of the sand's weight, so the vertical stress saturates with depth (container width and length from rig.toml).",
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
    /// Janssen's depth h_eff (mm) for depth `depth_mm` in a box of
    /// hydraulic radius `radius_mm`.
    pub fn effective_depth_mm(&self, radius_mm: f64, depth_mm: f64) -> f64 {
        let x = self.mu_k * depth_mm / radius_mm;
        // Also catches NaN (a zero radius): no arching rather than garbage.
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
        match rig.container.as_ref().and_then(|c| c.hydraulic_radius_mm()) {
            Some(radius_mm) => WallArching::effective_depth_mm(self, radius_mm, depth_mm),
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
        // σv/γ' = R/μk·(1 − e^(−μk h/R)) = 20/0.2·(1 − e^(−0.2·100/20)).
        let want = 100.0 * (1.0 - (-1.0_f64).exp());
        assert!((a.effective_depth_mm(20.0, 100.0) - want).abs() < 1e-12);
        // Shallow limit → h; deep limit → R/μk.
        assert!((a.effective_depth_mm(20.0, 1e-6) / 1e-6 - 1.0).abs() < 1e-8);
        assert!((a.effective_depth_mm(20.0, 1e5) - 100.0).abs() < 1e-9);
        assert_eq!(
            WallArching { mu_k: 0.0 }.effective_depth_mm(20.0, 70.0),
            70.0
        );
    }

    #[test]
    fn the_box_length_takes_its_share_of_the_weight() {
        // A 40 × 200 mm box: R = 8000/480 = 16.67 mm, not the slot's 20.
        let mut rig = Rig::paper_default();
        rig.container = Some(rig::Container {
            width_mm: Some(40.0),
            length_mm: 200.0,
        });
        let a = WallArching { mu_k: 0.2 };
        let r = 40.0 * 200.0 / (2.0 * 240.0);
        let got = Effect::effective_depth_mm(&a, &rig, 100.0);
        assert!((got - a.effective_depth_mm(r, 100.0)).abs() < 1e-12);
        assert!(got < a.effective_depth_mm(20.0, 100.0) - 1.0, "{got}");
        // A square box of side W: R = W/4, the wall all round.
        rig.container = Some(rig::Container {
            width_mm: Some(40.0),
            length_mm: 40.0,
        });
        let got = Effect::effective_depth_mm(&a, &rig, 100.0);
        assert!((got - a.effective_depth_mm(10.0, 100.0)).abs() < 1e-12);
        // A wide tank: the depth itself.
        rig.container = None;
        assert_eq!(Effect::effective_depth_mm(&a, &rig, 100.0), 100.0);
    }
}
