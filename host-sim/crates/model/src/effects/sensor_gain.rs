//! `sensor_gain`: the transducer's sensitivity differs from its datasheet
//! (a wrong calibration factor): reading = gain·p. Identifiable against
//! the skin only when the skin is known (`[skin]` in rig.toml): without
//! it the skin's fitted scale and the sand's fitted factors carry any
//! gain, so it is not tried.

use super::{value, Effect, EffectKind, EffectSpec};
use crate::params::ParamSpec;

/// How far the scale of a stated skin law (rig.toml's `[skin]`, a coupon
/// fit) may be off for the inflated tube: a reading's gain is only told
/// apart from that beyond it. Imposed: specimen-to-specimen scatter of
/// coupon fits and the uniaxial-to-biaxial step are each a few per cent.
pub const SKIN_LAW_SCALE_TOLERANCE: f64 = 0.05;

const PARAMS: [ParamSpec; 1] = [ParamSpec {
    name: "gain",
    unit: "-",
    lower: 0.5,
    upper: 2.0,
    default: 1.0,
    lower_is_law: false,
    description: "reading per unit of true gauge pressure",
}];

/// Registry row.
pub static SPEC: EffectSpec = EffectSpec {
    name: "sensor_gain",
    description: "The pressure reading is the true gauge pressure times a gain different from 1 (a wrong calibration factor).",
    signature: "a residual proportional to the pressure itself: zero at rest, largest at the highest pressures, same sign in every phase",
    params: &PARAMS,
    kind: EffectKind::Physical,
    build: |v| Box::new(SensorGain { gain: value(v, &PARAMS, 0) }),
    not_applicable: |rig| {
        (!rig.skin_known()).then_some(
            "rig.toml gives no [skin]: the skin's fitted scale and the sand's factors absorb a gain",
        )
    },
    indistinct: |rig, v| {
        let gain = value(v, &PARAMS, 0);
        (rig.skin_known() && (gain - 1.0).abs() < SKIN_LAW_SCALE_TOLERANCE).then_some(
            "closer to 1 than the scale of rig.toml's [skin] law is known in the inflated tube: not told apart from that law being off",
        )
    },
};

/// A gain on the reading.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SensorGain {
    /// Reading per kPa of true gauge pressure.
    pub gain: f64,
}

impl Effect for SensorGain {
    fn spec(&self) -> &'static EffectSpec {
        &SPEC
    }
    fn reading_kpa(&self, _: &super::StepContext, _: f64, reading_kpa: f64) -> f64 {
        self.gain * reading_kpa
    }
}
