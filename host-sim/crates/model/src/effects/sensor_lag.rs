//! `sensor_lag`: the reading is the line pressure of a moment ago. A digital
//! transducer such as the MS5837 samples the pressure, converts it (ΣΔ, a
//! few ms), is read over the bus at its own phase, and the logger pairs the
//! newest published value with the pump volume of *its* step: the reading
//! is p(t − δ) while the volume is V(t).
//!
//! A pure delay, not a first-order lag: nothing in that chain low-passes the
//! pressure (the conversion averages over ~2 ms, much shorter than the age
//! of the sample), it only hands over an older value. The model has no
//! pressure history, but between two samples the pump volume is a straight
//! line, so the pressure δ ago is the model at the volume δ ago: the effect
//! holds back h = V(t) − V(t − δ), the volume pumped during the last δ.
//! For δ up to the step, h = Q·δ (Q the pump flow over the step): exact,
//! linear interpolation of the volume log. For a longer δ the log before
//! the step is gone, so h is carried from step to step, assuming the
//! window δ it spans was pumped at a uniform rate h/δ: h ← h·(1 − dt/δ) +
//! Q·dt. That is Q·δ again at constant flow (its fixed point), meets the
//! exact rule at dt = δ, and stays smooth on a stepper's jerky 1 ms
//! flow, where Q·δ would jump. The whole chain is evaluated at the
//! earlier volume, so the prediction's internal pressure and diameter are
//! the delayed ones too; the flow terms of the reading (line loss, piston
//! friction) stay at the current flow. An emulator plant must not switch it
//! on: its sensor delays the reading itself.
//!
//! Bounds 0–50 ms: a digital sensor's conversion and read-out (the MS5837
//! at its slowest, OSR 8192, takes two 18 ms conversions). Longer lags
//! come from plumbing (a snubber, a long soft line), a low-pass, not a
//! delay. In an emulator plant, where the held volume delays the line's
//! physics too, the safety property test (`tests/emulate_props.rs`,
//! effects up to their bound) found over-limit times beyond its bound with
//! lags of 61–100 ms, none in 5,000 cases at 31–50 ms.

use super::{value, Effect, EffectKind, EffectSpec, EffectState, StepContext};
use crate::params::ParamSpec;

const PARAMS: [ParamSpec; 1] = [ParamSpec {
    name: "lag_s",
    unit: "s",
    lower: 0.0,
    upper: 0.05,
    default: 0.0,
    lower_is_law: false,
    description: "age of the pressure reading when it is logged with the pump volume",
}];

/// Registry row.
pub static SPEC: EffectSpec = EffectSpec {
    name: "sensor_lag",
    description: "The reading lags the line pressure by the sensor's conversion, sampling and read-out time: it is the pressure at the pump volume δ earlier, V − Q·δ.",
    signature: "a residual against the flow and proportional to the local slope dp/dV: the reading below the model while expanding, above it while shrinking, largest where the curve is steepest (the sand's unloading branch), zero during holds, twice as large at twice the flow",
    params: &PARAMS,
    kind: EffectKind::Physical,
    build: |v| Box::new(SensorLag { lag_s: value(v, &PARAMS, 0) }),
    not_applicable: |_| None,
    indistinct: |_, _| None,
};

/// A pure delay of the reading. State: [volume pumped during the last δ
/// (mL), -].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SensorLag {
    /// Age of the reading (s).
    pub lag_s: f64,
}

impl Effect for SensorLag {
    fn spec(&self) -> &'static EffectSpec {
        &SPEC
    }
    fn holds_volume(&self) -> bool {
        true
    }
    fn held_volume_ml(&self, state: &mut EffectState, ctx: &StepContext, _: f64) -> f64 {
        // `state` is a trial copy of the committed value (negative while
        // shrinking).
        state[0] = if ctx.dt_s >= self.lag_s {
            ctx.step_flow_ml_s * self.lag_s
        } else {
            state[0] * (1.0 - ctx.dt_s / self.lag_s) + ctx.step_flow_ml_s * ctx.dt_s
        };
        state[0]
    }
}

#[cfg(test)]
mod tests {
    use super::SensorLag;
    use crate::effects::{free_water_context, Effect, EffectInstance, EffectState, StepContext};
    use crate::{Params, RigModel};
    use rig::Rig;

    /// Pump volume (mL) of a triangle: up at 2.5 mL/s to 4 mL, then down.
    fn triangle_ml(t_s: f64) -> f64 {
        let (q, top) = (2.5, 4.0);
        let t_top = top / q;
        if t_s <= t_top {
            q * t_s
        } else {
            (top - q * (t_s - t_top)).max(0.0)
        }
    }

    /// The defining property, p_read(t) = p(t − δ): the lagged model fed
    /// V(t) reads what the bare model reads fed V(t − δ), linearly
    /// interpolated in the volume log (the way the emulator's 10 ms log
    /// meets its 9 ms old samples), through expansion, the reversal and the
    /// sand's unloading branch.
    #[test]
    fn reading_is_the_pressure_a_lag_ago() {
        let rig = Rig::paper_default();
        let (dt, lag) = (0.01, 0.009);
        let lagged = RigModel::new(
            &rig,
            &Params::default(),
            &[EffectInstance::new("sensor_lag", &[("lag_s", lag)]).unwrap()],
        )
        .unwrap();
        let bare = RigModel::new(&rig, &Params::default(), &[]).unwrap();
        let mut a = lagged.start_run(100.0);
        let (mut b, mut c) = (bare.start_run(100.0), bare.start_run(100.0));
        let mut largest_shift_kpa: f64 = 0.0;
        for n in 0..320 {
            let t = n as f64 * dt;
            let (v, v_prev) = (triangle_ml(t), triangle_ml((t - dt).max(0.0)));
            // Linear interpolation of the log between t − dt and t.
            let v_then = v - (v - v_prev) * lag / dt;
            let got = lagged.step(&mut a, t, v).sensor_kpa;
            let want = bare.step(&mut b, t, v_then).sensor_kpa;
            assert!((got - want).abs() < 1e-9, "t = {t}: {got} vs {want}");
            let unlagged = bare.step(&mut c, t, v).sensor_kpa;
            largest_shift_kpa = largest_shift_kpa.max((unlagged - got).abs());
        }
        // And the delay matters: ≥ 0.05 kPa somewhere on this curve.
        assert!(largest_shift_kpa > 0.05, "{largest_shift_kpa}");
    }

    fn ctx(dt_s: f64, flow_ml_s: f64) -> StepContext {
        StepContext {
            t_s: 1.0,
            dt_s,
            pump_flow_ml_s: flow_ml_s,
            step_flow_ml_s: flow_ml_s,
            ..free_water_context()
        }
    }

    /// δ longer than the step: from rest at constant Q the held volume is
    /// Q·δ·(1 − (1 − dt/δ)^n) after n steps (the recursion's closed form),
    /// tending to the pure delay's Q·δ.
    #[test]
    fn long_lag_tends_to_flow_times_lag() {
        let lag = SensorLag { lag_s: 0.05 };
        let (dt, q) = (0.002, 2.0);
        let mut st: EffectState = [0.0; 2];
        for n in 1..=200 {
            let h = lag.held_volume_ml(&mut st, &ctx(dt, q), 0.0);
            let want = q * 0.05 * (1.0 - (1.0 - dt / 0.05f64).powi(n));
            assert!((h - want).abs() < 1e-12, "n = {n}: {h} vs {want}");
        }
        assert!((st[0] - q * 0.05).abs() < 1e-3 * q * 0.05, "{}", st[0]);
    }

    /// A stepper seen every 1 ms: one 0.5 µL microstep every 2.5 ms
    /// (0.2 mL/s on average) makes the 1 ms flow jump between 0 and
    /// 0.5 mL/s. Q·δ would jump between 0 and 0.025 mL at δ = 0.05 s; the
    /// carried window settles to the mean flow times δ, 0.01 mL, within
    /// half a microstep (0.25 µL).
    #[test]
    fn jerky_flow_is_smoothed_over_the_window() {
        let lag = SensorLag { lag_s: 0.05 };
        let mut st: EffectState = [0.0; 2];
        let mut held = Vec::new();
        for ms in 1..=3000u32 {
            let stepped = |t: u32| f64::from(t * 2 / 5) * 0.5e-3;
            let q = (stepped(ms) - stepped(ms - 1)) / 1e-3;
            held.push(lag.held_volume_ml(&mut st, &ctx(1e-3, q), 0.0));
        }
        for h in &held[2000..] {
            assert!((h - 0.01).abs() < 0.25e-3, "{h}");
        }
    }
}
