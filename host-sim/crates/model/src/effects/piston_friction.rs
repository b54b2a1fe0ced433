//! `piston_friction`: seal friction of the syringe piston. When the
//! pressure is the piston force over the bore area
//! (`pressure_source = "piston_force"`), Coulomb friction F adds
//! F/A·sign(Q): more force to push, less to pull. A line sensor does not
//! see it.

use super::{smooth_sign, value, Effect, EffectKind, EffectSpec, StepContext};
use crate::params::ParamSpec;
use rig::PressureSource;

const PARAMS: [ParamSpec; 1] = [ParamSpec {
    name: "friction_n",
    unit: "N",
    lower: 0.0,
    upper: 200.0,
    default: 0.0,
    lower_is_law: false,
    description: "Coulomb friction force of the piston seal",
}];

/// Registry row.
pub static SPEC: EffectSpec = EffectSpec {
    name: "piston_friction",
    description: "Coulomb friction of the syringe's piston seal, seen when pressure is piston force over bore area: the reading is p + F/A·sign(flow).",
    signature: "a step in the residual that follows the sign of the flow, the same size at every flow rate: positive while expanding, negative while shrinking, near zero during holds",
    params: &PARAMS,
    kind: EffectKind::Physical,
    build: |v| Box::new(PistonFriction { friction_n: value(v, &PARAMS, 0) }),
    not_applicable: |rig| match rig.measurement.pressure_source {
        PressureSource::PistonForce => None,
        PressureSource::LineSensor => Some("pressure comes from a line sensor, which does not feel the piston's friction"),
    },
    indistinct: |_, _| None,
};

/// Seal friction on the piston.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PistonFriction {
    /// Friction force (N).
    pub friction_n: f64,
}

impl Effect for PistonFriction {
    fn spec(&self) -> &'static EffectSpec {
        &SPEC
    }
    fn reading_kpa(&self, ctx: &StepContext, _: f64, reading_kpa: f64) -> f64 {
        if ctx.pressure_source != PressureSource::PistonForce || ctx.bore_area_mm2 <= 0.0 {
            return reading_kpa;
        }
        // N/mm² = MPa = 1000 kPa.
        let kpa = 1000.0 * self.friction_n / ctx.bore_area_mm2;
        reading_kpa + kpa * smooth_sign(ctx.pump_flow_ml_s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::effects::free_water_context;

    #[test]
    fn one_newton_on_the_papers_bore() {
        // A = π·29.21²/4 = 670.1 mm²: 1 N → 1.4923 kPa.
        let area = std::f64::consts::PI * 29.21 * 29.21 / 4.0;
        let ctx = StepContext {
            dt_s: 0.02,
            pump_flow_ml_s: 2.0,
            pressure_source: PressureSource::PistonForce,
            bore_area_mm2: area,
            ..free_water_context()
        };
        let f = PistonFriction { friction_n: 1.0 };
        assert!((f.reading_kpa(&ctx, 0.0, 0.0) - 1.4923).abs() < 1e-4);
        let pull = StepContext {
            pump_flow_ml_s: -2.0,
            ..ctx
        };
        assert!((f.reading_kpa(&pull, 0.0, 0.0) + 1.4923).abs() < 1e-4);
        let line = StepContext {
            pressure_source: PressureSource::LineSensor,
            ..ctx
        };
        assert_eq!(f.reading_kpa(&line, 0.0, 0.7), 0.7);
    }
}
