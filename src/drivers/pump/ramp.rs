//! Trapezoidal step planning: the time to each next microstep so that the
//! plunger's rate changes at no more than [`ACCEL_ML_PER_S2`], and every
//! reversal comes to a stop first. Pure arithmetic (f32, `libm`), so the
//! pump task, any timer glue and the host tests share it.
//!
//! Within one step the acceleration is constant (`a`, `−a` or 0): from
//! speed `v` a step of volume `s` takes `t = (√(v² + 2as) − v)/a`
//! accelerating, `2s/(v + v')` with `v' = √(v² − 2as)` decelerating, and
//! `s/v` cruising; the speed never passes the target within a step (it is
//! capped there), and a step that would decelerate below zero ends at
//! zero. From standstill the first step takes `√(2s/a)`.

use super::config::{MAX_RATE_ML_PER_S, MIN_RATE_ML_PER_S};
use super::Direction;

/// Largest change of the volume rate (mL/s²): 4 mL/s is reached in 20 ms
/// (3 rev/s of a T8×2 screw in 20 ms: about 5 mN·m on a NEMA 17 rotor's
/// 54 g·cm², far below its holding torque). Stopping from 4 mL/s moves
/// 0.04 mL further; from 2 mL/s, 0.01 mL.
pub const ACCEL_ML_PER_S2: f32 = 200.0;

/// What the pump does next.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Plan {
    /// At rest, nothing to do until the target changes.
    Idle,
    /// One microstep in `direction`, `wait_us` after the previous one (or
    /// from now, from standstill).
    Step {
        /// Which way.
        direction: Direction,
        /// Time from the previous step (µs), rounded up.
        wait_us: u32,
    },
}

/// The plunger's rate and the step schedule toward a target rate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepPlanner {
    ml_per_step: f32,
    /// Signed rate (mL/s) at the last planned step.
    rate_ml_per_s: f32,
}

impl StepPlanner {
    /// At rest, for a pump moving `ml_per_step` (mL, > 0) per microstep.
    pub fn new(ml_per_step: f32) -> Self {
        Self {
            ml_per_step,
            rate_ml_per_s: 0.0,
        }
    }

    /// The signed rate reached at the last planned step (mL/s).
    pub fn rate_ml_per_s(&self) -> f32 {
        self.rate_ml_per_s
    }

    /// Stops at once (driver disabled, a step refused at an end-stop): the
    /// next motion starts from standstill.
    pub fn stop_now(&mut self) {
        self.rate_ml_per_s = 0.0;
    }

    /// Plans the next step toward `target_ml_per_s` (signed; clamped to
    /// ±[`MAX_RATE_ML_PER_S`]; NaN and anything slower than
    /// [`MIN_RATE_ML_PER_S`] count as 0, so no step is longer than the
    /// step timer gives). A target of the other
    /// sign first decelerates to exactly 0: the direction only changes
    /// from standstill.
    pub fn next(&mut self, target_ml_per_s: f32) -> Plan {
        let target = if target_ml_per_s.is_nan() || libm::fabsf(target_ml_per_s) < MIN_RATE_ML_PER_S
        {
            0.0
        } else {
            target_ml_per_s.clamp(-MAX_RATE_ML_PER_S, MAX_RATE_ML_PER_S)
        };
        let v = self.rate_ml_per_s;
        let (s, a) = (self.ml_per_step, ACCEL_ML_PER_S2);
        // The direction of motion: the current one, or the target's from
        // standstill.
        let direction = match Direction::from_rate(v).or(Direction::from_rate(target)) {
            Some(d) => d,
            None => return Plan::Idle,
        };
        let sign = direction.steps() as f32;
        let speed = libm::fabsf(v);
        // Speed to head for, along the current direction: 0 on a reversal.
        let aim = if target * sign > 0.0 {
            libm::fabsf(target)
        } else {
            0.0
        };
        let (t_s, new_speed) = if speed < aim {
            let reached = libm::sqrtf(speed * speed + 2.0 * a * s);
            if reached <= aim {
                ((reached - speed) / a, reached)
            } else {
                // The cap is reached within the step: mean of the two.
                (2.0 * s / (speed + aim), aim)
            }
        } else if speed > aim {
            let left = speed * speed - 2.0 * a * s;
            let reached = if left > aim * aim {
                libm::sqrtf(left)
            } else {
                aim
            };
            (2.0 * s / (speed + reached), reached)
        } else {
            (s / speed, speed)
        };
        self.rate_ml_per_s = sign * new_speed;
        // `as` saturates; a step never takes less than 1 µs.
        let wait_us = libm::ceilf(t_s * 1.0e6).max(1.0) as u32;
        Plan::Step { direction, wait_us }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const S: f32 = 4.19e-4; // the default pump's mL per microstep

    /// Runs the planner toward `target` for `steps` steps: (time s, signed
    /// volume mL, largest |Δrate|/Δt seen, rates after each step).
    fn run(p: &mut StepPlanner, target: f32, steps: usize) -> (f64, f64, Vec<f32>) {
        let (mut t, mut vol, mut rates) = (0.0, 0.0, Vec::new());
        for _ in 0..steps {
            match p.next(target) {
                Plan::Idle => break,
                Plan::Step { direction, wait_us } => {
                    t += f64::from(wait_us) * 1e-6;
                    vol += match direction {
                        Direction::Inject => f64::from(S),
                        Direction::Withdraw => -f64::from(S),
                    };
                    rates.push(p.rate_ml_per_s());
                }
            }
        }
        (t, vol, rates)
    }

    #[test]
    fn accelerates_at_the_limit_to_the_target_and_cruises() {
        let mut p = StepPlanner::new(S);
        // 0 → 2 mL/s at 200 mL/s²: 10 ms and v²/2a = 0.01 mL.
        let ramp_steps = (0.01 / S).ceil() as usize;
        let (t, vol, rates) = run(&mut p, 2.0, ramp_steps);
        assert!((t - 0.01).abs() < 0.0005, "{t}");
        assert!((vol - 0.01).abs() < f64::from(S), "{vol}");
        assert!(rates.iter().all(|r| *r > 0.0 && *r <= 2.0));
        // Cruising: s / v per step, 209.5 µs rounded up.
        assert_eq!(
            p.next(2.0),
            Plan::Step {
                direction: Direction::Inject,
                wait_us: 210
            }
        );
        // Rates above the pump's limit are clamped.
        let (_, _, rates) = run(&mut p, 10.0, 400);
        assert_eq!(*rates.last().unwrap(), MAX_RATE_ML_PER_S);
    }

    #[test]
    fn a_reversal_stops_first_and_never_jumps() {
        let mut p = StepPlanner::new(S);
        run(&mut p, 2.0, 200);
        assert_eq!(p.rate_ml_per_s(), 2.0);
        // Stop during Expand: +2 → −4 mL/s.
        let (t, _, rates) = run(&mut p, -4.0, 2000);
        // Every rate on the way, and exactly 0 once, between the signs.
        let zero = rates.iter().position(|r| *r == 0.0).unwrap();
        assert!(rates[..zero].iter().all(|r| *r > 0.0));
        assert!(rates[zero + 1..].iter().all(|r| *r < 0.0));
        assert_eq!(*rates.last().unwrap(), -4.0);
        // The rate changes by at most a·Δt between steps (tolerance of the
        // µs rounding and f32): check through the step times.
        let mut q = StepPlanner::new(S);
        run(&mut q, 2.0, 200);
        let mut prev = q.rate_ml_per_s();
        for _ in 0..2000 {
            let Plan::Step { wait_us, .. } = q.next(-4.0) else {
                panic!("idle while reversing")
            };
            let dv = (q.rate_ml_per_s() - prev).abs();
            assert!(
                dv <= ACCEL_ML_PER_S2 * wait_us as f32 * 1e-6 * 1.01 + 1e-4,
                "{dv}"
            );
            prev = q.rate_ml_per_s();
        }
        // 2/200 + 4/200 s of ramps plus cruising: at least 30 ms.
        assert!(t > 0.03, "{t}");
    }

    #[test]
    fn hold_decelerates_to_rest_then_idles() {
        let mut p = StepPlanner::new(S);
        run(&mut p, 4.0, 500);
        // 4 mL/s to 0: v²/2a = 0.04 mL further.
        let (_, vol, rates) = run(&mut p, 0.0, 1000);
        assert!((vol - 0.04).abs() < 2.0 * f64::from(S), "{vol}");
        assert_eq!(*rates.last().unwrap(), 0.0);
        assert_eq!(p.next(0.0), Plan::Idle);
        assert_eq!(p.next(f32::NAN), Plan::Idle);
        // Slower than the pump's slowest rate: no motion (a step would
        // outlast the step timer).
        assert_eq!(p.next(0.049), Plan::Idle);
        assert_eq!(p.next(-0.049), Plan::Idle);
        // From standstill the first step takes √(2s/a) = 2.047 ms.
        assert_eq!(
            p.next(-1.0),
            Plan::Step {
                direction: Direction::Withdraw,
                wait_us: 2047
            }
        );
        p.stop_now();
        assert_eq!(p.rate_ml_per_s(), 0.0);
    }
}
