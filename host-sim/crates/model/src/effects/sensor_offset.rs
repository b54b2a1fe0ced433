//! `sensor_offset`: the reading carries a constant offset (a zero taken
//! at another level or temperature, a drifted transducer):
//! reading = p + offset.

use super::{value, Effect, EffectKind, EffectSpec};
use crate::params::ParamSpec;

const PARAMS: [ParamSpec; 1] = [ParamSpec {
    name: "offset_kpa",
    unit: "kPa",
    lower: -50.0,
    upper: 50.0,
    default: 0.0,
    lower_is_law: false,
    description: "constant added to every reading",
}];

/// Registry row.
pub static SPEC: EffectSpec = EffectSpec {
    name: "sensor_offset",
    description: "The pressure reading carries a constant offset: the zero was taken elsewhere or has drifted.",
    signature: "a constant shift of the residual in every phase, at rest as well as under load",
    params: &PARAMS,
    kind: EffectKind::Physical,
    build: |v| Box::new(SensorOffset { offset_kpa: value(v, &PARAMS, 0) }),
    not_applicable: |_| None,
    indistinct: |_, _| None,
};

/// A constant offset on the reading.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SensorOffset {
    /// Added to every reading (kPa).
    pub offset_kpa: f64,
}

impl Effect for SensorOffset {
    fn spec(&self) -> &'static EffectSpec {
        &SPEC
    }
    fn reading_kpa(&self, _: &super::StepContext, _: f64, reading_kpa: f64) -> f64 {
        reading_kpa + self.offset_kpa
    }
}
