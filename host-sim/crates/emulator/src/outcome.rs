//! What a run showed, measured from its [`Trace`], and whether that is what
//! its scenario expects: cycles and advance per cycle for normal runs;
//! fault, detection time against the firmware's stated bound, the time to
//! the line vented (the plant's valve in the loop) against the end-to-end
//! bound stated with the board's timing, a stopped pump and the time spent
//! above the pressure limit for faults.

use serde::Serialize;
use urechis::controller::{
    detection_bound_ms, end_to_end_bound_ms, Fault, PumpCommand, State, BOARD_TIMING,
};

use super::plant::{PlantFault, SensorBias};
use super::run::Trace;
use super::scenario::{Expectation, Reference};
use super::sensor::SensorFault;

/// How fast a fault was caught.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Detection {
    /// The fault that latched.
    pub fault: Fault,
    /// The event it is timed from (ms).
    pub reference_ms: u32,
    /// The first step in Fault (ms).
    pub detected_ms: u32,
    /// `detected_ms − reference_ms` (ms; negative = before the reference).
    pub latency_ms: i64,
    /// The firmware's stated bound ([`detection_bound_ms`]) (ms).
    pub bound_ms: u32,
    /// Added to the bound for a reference the controller sees through the
    /// sensor: its largest sample age (ms); 0 otherwise.
    pub sensor_allowance_ms: u32,
    /// The first millisecond from the fault step on with the plant's
    /// relief valve open (ms), if it opened.
    pub vented_ms: Option<u32>,
    /// The end-to-end bound stated with the board's timing
    /// ([`end_to_end_bound_ms`] with [`BOARD_TIMING`]; its valve response
    /// is the one the bound assumes, not the plant's) (ms).
    pub end_to_end_bound_ms: u32,
}

impl Detection {
    /// `vented_ms − reference_ms` (ms), if the valve opened.
    pub fn end_to_end_ms(&self) -> Option<i64> {
        self.vented_ms
            .map(|v| i64::from(v) - i64::from(self.reference_ms))
    }
}

/// The longest stretch the line pressure spent above the limit, and what
/// the firmware and the plant together promise.
///
/// "Above" means where the firmware is sure to see it: the line pressure
/// whose reading passes the limit through any sensor bias
/// (`max(limit, (limit − offset)/gain)`), plus the sensor's resolution
/// (`4·noise + 1 Pa`, over the gain: a truth within the noise of the limit
/// may read below it). The promise, with a sensor that keeps
/// delivering fresh readings: the reading that shows it arrives within the
/// sample age and latches OverPressure within its bound; random bus errors
/// can hide readings until the last one turns stale (`sensor_stale_ms` +
/// one period, when the controller faults anyway), and an injected
/// dropout or hang is caught within its own bound instead. Until then the
/// pump pushes at most `max_rate` × that time of water past the limit, the
/// relief valve opens within the response the firmware's bounds assume
/// ([`BOARD_TIMING`]), and once open vents at least `g · limit` while
/// above it.
/// A frozen sensor shows nothing while the pump stands still, so no bound
/// holds then (`allowed_ms` = `None`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct OverLimit {
    /// The controller's `max_pressure_kpa`.
    pub limit_kpa: f64,
    /// The line pressure above which the firmware must act (kPa): the
    /// limit through the sensor bias, plus the resolution margin.
    pub threshold_kpa: f64,
    /// Highest line pressure of the run (kPa).
    pub peak_kpa: f64,
    /// Longest contiguous time above the threshold (ms).
    pub longest_ms: u32,
    /// The longest time the firmware and the plant allow (ms), where a
    /// bound holds.
    pub allowed_ms: Option<u32>,
}

/// Everything measured on one run.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Outcome {
    /// Scenario name.
    pub scenario: String,
    /// Seed.
    pub seed: u64,
    /// Simulated time (ms).
    pub duration_ms: u32,
    /// State at the end.
    pub final_state: State,
    /// Latched fault at the end.
    pub fault: Option<Fault>,
    /// Completed cycles.
    pub cycles: u16,
    /// Distance the head advanced in each completed advance (mm).
    pub advance_per_cycle_mm: Vec<f64>,
    /// Largest true outer diameter of each expansion (mm).
    pub peak_diameter_mm: Vec<f64>,
    /// Why each expansion ended (`ExpandEnd`, by name).
    pub expand_ends: Vec<String>,
    /// Fault detection, when one latched.
    pub detection: Option<Detection>,
    /// Every step from the fault on commanded `Disable`.
    pub pump_disabled_in_fault: bool,
    /// Microsteps counted after the fault step's outputs took effect.
    pub steps_after_fault: i64,
    /// Time above the pressure limit.
    pub over_limit: OverLimit,
    /// Expected advance per cycle: drive speed × `advance_ms` (mm).
    pub expected_advance_mm: f64,
    /// What does not match the scenario's expectation (empty = pass).
    pub failures: Vec<String>,
}

impl Outcome {
    /// True when the run met its expectation.
    pub fn passed(&self) -> bool {
        self.failures.is_empty()
    }

    /// A few lines for the terminal.
    pub fn text(&self) -> String {
        let mut t = format!(
            "{} (seed {}): {:.2} s simulated, ended in {:?}",
            self.scenario,
            self.seed,
            f64::from(self.duration_ms) / 1000.0,
            self.final_state
        );
        if let Some(f) = self.fault {
            t.push_str(&format!(" ({f:?})"));
        }
        t.push('\n');
        if !self.advance_per_cycle_mm.is_empty() {
            let n = self.advance_per_cycle_mm.len() as f64;
            let mean = self.advance_per_cycle_mm.iter().sum::<f64>() / n;
            t.push_str(&format!(
                "  cycles completed: {}; advance per cycle {:.4} mm (expected {:.4} mm)\n",
                self.cycles, mean, self.expected_advance_mm
            ));
        }
        if !self.expand_ends.is_empty() {
            let mut counts: Vec<(&str, usize)> = Vec::new();
            for e in &self.expand_ends {
                match counts.iter_mut().find(|(n, _)| n == e) {
                    Some(c) => c.1 += 1,
                    None => counts.push((e, 1)),
                }
            }
            let list: Vec<String> = counts.iter().map(|(n, c)| format!("{n} ×{c}")).collect();
            t.push_str(&format!("  expansions ended by: {}\n", list.join(", ")));
        }
        if !self.peak_diameter_mm.is_empty() {
            let (lo, hi) = self
                .peak_diameter_mm
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), d| {
                    (lo.min(*d), hi.max(*d))
                });
            t.push_str(&format!(
                "  peak outer diameter per expansion: {lo:.3}–{hi:.3} mm\n"
            ));
        }
        if let Some(d) = &self.detection {
            t.push_str(&format!(
                "  {:?} latched at {} ms, {} ms after the reference (stated bound {} ms + sensor \
                 allowance {} ms); pump disabled: {}, microsteps after: {}\n",
                d.fault,
                d.detected_ms,
                d.latency_ms,
                d.bound_ms,
                d.sensor_allowance_ms,
                self.pump_disabled_in_fault,
                self.steps_after_fault
            ));
            let vented = d.end_to_end_ms().map_or("never".to_owned(), |e| {
                format!("{e} ms after the reference")
            });
            t.push_str(&format!(
                "  line vented {vented} (end-to-end bound {} ms)\n",
                d.end_to_end_bound_ms
            ));
        }
        let o = &self.over_limit;
        let allowed = o
            .allowed_ms
            .map_or("no bound: frozen sensor".to_owned(), |a| {
                format!("allowed {a} ms")
            });
        t.push_str(&format!(
            "  peak line pressure {:.2} kPa (limit {}); longest above the limit {} ms ({allowed})\n",
            o.peak_kpa, o.limit_kpa, o.longest_ms
        ));
        if self.passed() {
            t.push_str("  outcome: as expected\n");
        } else {
            for f in &self.failures {
                t.push_str(&format!("  NOT AS EXPECTED: {f}\n"));
            }
        }
        t
    }
}

/// Measures `trace` and checks it against its scenario's expectation.
pub fn evaluate(trace: &Trace) -> Outcome {
    let sc = &trace.scenario;
    let params = sc.params;
    let steps = &trace.steps;
    let last = steps.last();
    let final_state = last.map_or(State::Idle, |s| s.outputs.state);
    let fault_step = steps.iter().position(|s| s.outputs.state == State::Fault);
    let cycles = last.map_or(0, |s| s.outputs.telemetry.cycle);

    // Advance per completed advance, peak diameter per expansion.
    let mut advance_per_cycle_mm = Vec::new();
    let mut peak_diameter_mm = Vec::new();
    let mut expand_ends = Vec::new();
    let mut advance_from: Option<f64> = None;
    let mut peak: Option<f64> = None;
    for (i, s) in steps.iter().enumerate() {
        let state = s.outputs.state;
        let was_expanding = i > 0 && steps[i - 1].outputs.state == State::Expand;
        if was_expanding && state != State::Expand {
            if let Some(end) = s.expand_end {
                expand_ends.push(format!("{end:?}"));
            }
        }
        // Truth at step i+1 is the plant after step i's period.
        let after = steps.get(i + 1).map(|n| n.truth);
        match state {
            State::Advance => {
                advance_from.get_or_insert(s.truth.advance_mm);
            }
            _ => {
                if let Some(from) = advance_from.take() {
                    advance_per_cycle_mm.push(s.truth.advance_mm - from);
                }
            }
        }
        match (state, after) {
            (State::Expand | State::Hold, Some(a)) => {
                let p = peak.get_or_insert(a.diameter_mm);
                *p = p.max(a.diameter_mm);
            }
            _ => {
                if let Some(p) = peak.take() {
                    peak_diameter_mm.push(p);
                }
            }
        }
    }

    let fault = fault_step.and_then(|i| steps[i].outputs.telemetry.fault);
    let detected_ms = fault_step.map(|i| steps[i].inputs.now_ms);
    let pump_disabled_in_fault = fault_step.is_none_or(|i| {
        steps[i..]
            .iter()
            .all(|s| s.outputs.pump == PumpCommand::Disable)
    });
    // The fault step's outputs act from the next step on: count the steps
    // made after that.
    let steps_after_fault = fault_step
        .and_then(|i| {
            let first = steps.get(i + 1)?;
            let last = steps.last()?;
            Some(i64::from(last.truth.counted_steps) - i64::from(first.truth.counted_steps))
        })
        .unwrap_or(0);

    let over_limit = over_limit(trace);
    let expected_advance_mm =
        sc.plant.advance_speed_mm_per_s * f64::from(params.advance_ms) / 1000.0;

    let mut failures = Vec::new();
    let mut detection = None;
    match sc.expect {
        Expectation::Completes { cycles: want } => {
            if fault.is_some() || cycles != want || final_state != State::Idle {
                failures.push(format!(
                    "expected {want} completed cycles ending in Idle, got {cycles} cycles ending \
                     in {final_state:?} (fault {fault:?})"
                ));
            }
            // One sub-step of drive motion either way.
            let tol = sc.plant.advance_speed_mm_per_s * 1e-3 * 1.5;
            for (i, a) in advance_per_cycle_mm.iter().enumerate() {
                if (a - expected_advance_mm).abs() > tol {
                    failures.push(format!(
                        "cycle {}: advanced {a:.4} mm, expected {expected_advance_mm:.4} mm",
                        i + 1
                    ));
                }
            }
        }
        Expectation::Faults {
            fault: want,
            reference,
        } => {
            let reference_ms = reference_ms(trace, reference, detected_ms);
            match (fault, detected_ms, reference_ms) {
                (Some(got), Some(at), Some(r)) => {
                    let sensor_allowance_ms = match reference {
                        Reference::OverLimit | Reference::HoldDrop => {
                            sc.plant.sensor.max_sample_age_ms()
                        }
                        Reference::Injection
                        | Reference::EndStopClosed
                        | Reference::FrozenWhilePumping => 0,
                        // Suction, like over-pressure, reaches the
                        // controller through the sensor.
                        Reference::BelowRange => sc.plant.sensor.max_sample_age_ms(),
                    };
                    // Index i holds the millisecond ending at i: the valve
                    // vented from i − 1.
                    let vented_ms = trace
                        .valve_open_ms
                        .iter()
                        .enumerate()
                        .skip(at as usize + 1)
                        .find(|(_, open)| **open)
                        .map(|(i, _)| i as u32 - 1);
                    let d = Detection {
                        fault: got,
                        reference_ms: r,
                        detected_ms: at,
                        latency_ms: i64::from(at) - i64::from(r),
                        bound_ms: detection_bound_ms(got, &params),
                        sensor_allowance_ms,
                        vented_ms,
                        end_to_end_bound_ms: end_to_end_bound_ms(got, &params, &BOARD_TIMING),
                    };
                    if got != want {
                        failures.push(format!("expected fault {want:?}, got {got:?}"));
                    }
                    if d.latency_ms > i64::from(d.bound_ms + d.sensor_allowance_ms) {
                        failures.push(format!(
                            "{got:?} latched {} ms after the reference; stated bound {} ms + \
                             sensor allowance {} ms",
                            d.latency_ms, d.bound_ms, d.sensor_allowance_ms
                        ));
                    }
                    match d.end_to_end_ms() {
                        Some(e) if e <= i64::from(d.end_to_end_bound_ms) => {}
                        Some(e) => failures.push(format!(
                            "{got:?}: the line vented {e} ms after the reference; end-to-end \
                             bound {} ms (valve assumed {} ms, the plant's {} ms)",
                            d.end_to_end_bound_ms,
                            BOARD_TIMING.valve_response_ms,
                            sc.plant.valve_response_ms
                        )),
                        None => failures.push(format!("{got:?}: the relief valve never opened")),
                    }
                    detection = Some(d);
                }
                _ => failures.push(format!(
                    "expected fault {want:?}: fault {fault:?} at {detected_ms:?} ms, reference \
                     {reference:?} at {reference_ms:?} ms"
                )),
            }
            if !pump_disabled_in_fault {
                failures.push("the pump was not disabled in every Fault step".into());
            }
            if steps_after_fault != 0 {
                failures.push(format!(
                    "{steps_after_fault} microsteps after the fault took effect"
                ));
            }
            if final_state != State::Fault {
                failures.push(format!("ended in {final_state:?}, not Fault"));
            }
        }
    }
    if let Some(allowed) = over_limit.allowed_ms {
        if over_limit.longest_ms > allowed {
            failures.push(format!(
                "line pressure above {} kPa for {} ms (allowed {allowed} ms, peak {:.2} kPa)",
                over_limit.limit_kpa, over_limit.longest_ms, over_limit.peak_kpa
            ));
        }
    }

    Outcome {
        scenario: sc.name.clone(),
        seed: trace.seed,
        duration_ms: (trace.line_kpa_ms.len().saturating_sub(1)) as u32,
        final_state,
        fault,
        cycles,
        advance_per_cycle_mm,
        peak_diameter_mm,
        expand_ends,
        detection,
        pump_disabled_in_fault,
        steps_after_fault,
        over_limit,
        expected_advance_mm,
        failures,
    }
}

/// Time (ms) of the event a detection (latched at `detected_ms`) is timed
/// from.
pub fn reference_ms(trace: &Trace, reference: Reference, detected_ms: Option<u32>) -> Option<u32> {
    let params = &trace.scenario.params;
    match reference {
        Reference::Injection => trace.injected.first().map(|i| i.at_ms),
        Reference::BelowRange => trace
            .sensed_kpa_ms
            .iter()
            .position(|&p| p < params.sensor_min_kpa)
            .map(|i| i as u32),
        Reference::FrozenWhilePumping => {
            let injected = trace.injected.first()?.at_ms;
            let detected = detected_ms?;
            // The step that commanded the pump to run, the fault step's
            // stretch of running steps back to its start.
            let running = |s: &super::run::StepRecord| {
                matches!(s.outputs.pump, urechis::controller::PumpCommand::Run { .. })
            };
            let upto: Vec<_> = trace
                .steps
                .iter()
                .take_while(|s| s.inputs.now_ms < detected)
                .collect();
            let start = upto.iter().rposition(|s| !running(s)).map_or(0, |i| i + 1);
            let started = upto.get(start).map_or(detected, |s| s.inputs.now_ms);
            Some(injected.max(started))
        }
        Reference::OverLimit => trace
            .sensed_kpa_ms
            .iter()
            .position(|&p| f64::from(p) > f64::from(params.max_pressure_kpa))
            .map(|i| i as u32),
        Reference::EndStopClosed => trace.end_stop_ms.iter().position(|&c| c).map(|i| i as u32),
        Reference::HoldDrop => {
            // Holds as the controller ran them: from the step entering Hold
            // to the step leaving it; the true line pressure in between.
            let mut hold_from: Option<u32> = None;
            for s in &trace.steps {
                let t = s.inputs.now_ms;
                match (s.outputs.state, hold_from) {
                    (State::Hold, None) => hold_from = Some(t),
                    (State::Hold, Some(_)) => {}
                    (_, Some(from)) => {
                        hold_from = None;
                        if let Some(at) = hold_drop_ms(trace, from, t + 1) {
                            return Some(at);
                        }
                    }
                    (_, None) => {}
                }
            }
            let from = hold_from?;
            hold_drop_ms(trace, from, trace.sensed_kpa_ms.len() as u32)
        }
    }
}

/// First ms in `[from, to)` where the sensed pressure (noise-free) is more
/// than the controller's leak limit (`Params::leak_limit_kpa` of the
/// peak) below its peak since `from`.
fn hold_drop_ms(trace: &Trace, from: u32, to: u32) -> Option<u32> {
    let params = &trace.scenario.params;
    let mut peak = f32::NEG_INFINITY;
    for t in from..to {
        let p = *trace.sensed_kpa_ms.get(t as usize)?;
        peak = peak.max(p);
        if peak - p > params.leak_limit_kpa(peak) {
            return Some(t);
        }
    }
    None
}

/// The longest stretch above `max_pressure_kpa` and what is allowed.
fn over_limit(trace: &Trace) -> OverLimit {
    let sc = &trace.scenario;
    let params = &sc.params;
    let plant = &sc.plant;
    let limit = f64::from(params.max_pressure_kpa);
    let margin = 4.0 * plant.sensor.noise_kpa + plant.sensor.model.pa_per_count() as f64 / 1000.0;
    // The plant refused a non-positive gain; the fallback only keeps this
    // total.
    let bias = SensorBias::of(&plant.effects).unwrap_or(SensorBias {
        gain: 1.0,
        offset_kpa: 0.0,
    });
    let threshold = limit.max(bias.line_kpa(limit)) + margin / bias.gain;
    let (mut longest, mut run, mut peak) = (0u32, 0u32, f64::NEG_INFINITY);
    for &p in &trace.line_kpa_ms {
        let p = f64::from(p);
        peak = peak.max(p);
        run = if p > threshold { run + 1 } else { 0 };
        longest = longest.max(run);
    }
    let mut detect_ms = detection_bound_ms(Fault::OverPressure, params);
    if plant.sensor.bus_error_probability > 0.0 {
        // Failed periods (and the re-init after each) keep the last
        // reading published: the controller sees a new one, or the old
        // one turns stale, within the stale bound.
        detect_ms = detect_ms.max(detection_bound_ms(Fault::SensorStale, params));
    }
    let mut blind = false;
    for i in &trace.injected {
        if let PlantFault::Sensor(f) = i.fault {
            let caught_by = match f {
                SensorFault::Dropout | SensorFault::Glitch(_) | SensorFault::StuckSda => {
                    Fault::SensorBus
                }
                SensorFault::Hang => Fault::SensorStale,
                SensorFault::Frozen => {
                    blind = true;
                    Fault::SensorFrozen
                }
            };
            detect_ms = detect_ms.max(detection_bound_ms(caught_by, params));
        }
    }
    let detect_ms = detect_ms + plant.sensor.max_sample_age_ms();
    let excess_ml =
        f64::from(urechis::drivers::pump::MAX_RATE_ML_PER_S) * f64::from(detect_ms) / 1000.0;
    let vent_ms =
        (1000.0 * excess_ml / (plant.relief_conductance_ml_per_s_per_kpa * limit)).ceil() as u32;
    OverLimit {
        limit_kpa: limit,
        threshold_kpa: threshold,
        peak_kpa: peak,
        longest_ms: longest,
        allowed_ms: (!blind).then_some(detect_ms + BOARD_TIMING.valve_response_ms + vent_ms + 1),
    }
}
