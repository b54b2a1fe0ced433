//! Controller scenario checks shared by the host tests and the Cortex-M4
//! build run under QEMU: the same test bodies on both.
//!
//! Every scenario drives a real [`Controller`] against a tiny deterministic
//! plant written here (no heap, no std): the head's internal pressure is a
//! closed-form skin-plus-sand law of the outer diameter, which follows the
//! water that actually reached the head; the controller's table is sampled
//! from the same law ([`LawTable`]). Faults are injected into that plant
//! (sensor failures, a stalled motor, air in the line, a torn skin, …).
//! The real physics lives in `host-sim`; this plant only has to be simple
//! enough that each scenario's expectation follows from its law by hand.
//!
//! The law (D in mm, h in mm, x = max(D − D0, 0)):
//! `p_i = 0.03·x + k·h·(c0 + (1 − c0)·(1 − exp(−x/λ)))` kPa, with the
//! paper's `k = 0.097 kPa/mm` (0.97 kPa/cm), at-rest share `c0 = 0.09`, and
//! a rise length λ of 5 mm (sand still stiffening at 25 mm: no plateau
//! before the target) or 1.2 mm (the paper's collapse by D ≈ 22 mm).
//! The plant adds a deterministic ±2 Pa dither, as any real sensor would
//! show, so a healthy reading is never bit-identical twice while pumping.

use crate::controller::{
    detection_bound_ms, Command, CommandError, Controller, EndStops, ExpandEnd, ExpansionZone,
    Fault, Inputs, Outputs, ParamField, Params, PressureSample, PumpCommand, State,
    CONTROL_OVERRUN_LIMIT_MS, CONTROL_PERIOD_MS, PLATEAU_CONFIRM_SAMPLES, PLATEAU_WINDOW_SAMPLES,
    PRESSURE_ZERO_RANGE_KPA, RANGES, SENSOR_SPECIFIED_KPA,
};
use crate::table::{Table, TableError, CHECKSUM_ALGORITHM, FORMAT_VERSION};

/// One named self-test; `run` returns why it failed.
pub struct Scenario {
    /// Name printed by the runners (the host test has the same name).
    pub name: &'static str,
    /// The body; `Err` names the first failed expectation.
    pub run: fn() -> Result<(), &'static str>,
}

/// Every scenario, in the order the QEMU runner prints them.
pub const SCENARIOS: &[Scenario] = &[
    Scenario {
        name: "normal_cycles_40mm",
        run: normal_cycles_40mm,
    },
    Scenario {
        name: "normal_cycles_100mm",
        run: normal_cycles_100mm,
    },
    Scenario {
        name: "plateau_stops_expansion_early",
        run: plateau_stops_expansion_early,
    },
    Scenario {
        name: "stop_shrinks_then_idles",
        run: stop_shrinks_then_idles,
    },
    Scenario {
        name: "set_params_rejected_whole",
        run: set_params_rejected_whole,
    },
    Scenario {
        name: "bad_table_refuses_start",
        run: bad_table_refuses_start,
    },
    Scenario {
        name: "fault_over_pressure",
        run: fault_over_pressure,
    },
    Scenario {
        name: "fault_sensor_bus",
        run: fault_sensor_bus,
    },
    Scenario {
        name: "fault_sensor_out_of_range",
        run: fault_sensor_out_of_range,
    },
    Scenario {
        name: "fault_sensor_frozen",
        run: fault_sensor_frozen,
    },
    Scenario {
        name: "fault_sensor_stale",
        run: fault_sensor_stale,
    },
    Scenario {
        name: "fault_end_stop",
        run: fault_end_stop,
    },
    Scenario {
        name: "fault_pump_stall",
        run: fault_pump_stall,
    },
    Scenario {
        name: "fault_leak",
        run: fault_leak,
    },
    Scenario {
        name: "fault_volume_limit",
        run: fault_volume_limit,
    },
    Scenario {
        name: "fault_diameter_mismatch",
        run: fault_diameter_mismatch,
    },
    Scenario {
        name: "fault_control_overrun",
        run: fault_control_overrun,
    },
    Scenario {
        name: "fault_link_loss",
        run: fault_link_loss,
    },
    Scenario {
        name: "pressure_zero_gates_start",
        run: pressure_zero_gates_start,
    },
];

/// The bench's host sends a `Heartbeat` this often when it has no other
/// command (ms): four per default link timeout.
pub const HEARTBEAT_MS: u32 = 500;

/// The gauge zero the bench's sensor was tared at (absolute kPa).
pub const BENCH_ZERO_KPA: f32 = 101.325;

/// D0 of the test actuator (mm), the paper's body diameter.
pub const D0_MM: f32 = 18.7;
/// Expansion zone length (mm), the paper's 2 cm.
pub const ZONE_LENGTH_MM: f32 = 20.0;
/// Skin stiffness of the law (kPa per mm of diameter).
const SKIN_KPA_PER_MM: f32 = 0.03;
/// Sand plateau per mm of depth (kPa/mm): the paper's 0.97 kPa/cm.
const SAND_KPA_PER_MM: f32 = 0.097;
/// At-rest share of the plateau (K0·σ'v / k·h).
const AT_REST_SHARE: f32 = 0.09;
/// Rise length of a sand that is still stiffening at 25 mm (mm).
pub const SLOW_RISE_MM: f32 = 5.0;
/// Rise length of the paper-like sand that collapses by D ≈ 22 mm (mm).
pub const FAST_RISE_MM: f32 = 1.2;
/// Amplitude of the plant's reading dither (kPa).
const DITHER_KPA: f32 = 0.002;

const DEPTHS_MM: [f32; 7] = [0.0, 20.0, 40.0, 70.0, 100.0, 150.0, 200.0];
const N_DIAMETERS: usize = 64;
const DIAMETER_STEP_MM: f32 = 0.14;
const N_PRESSURES: usize = 7 * N_DIAMETERS;

/// Skin-plus-sand pressure law of the test plant (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SandLaw {
    /// Rise length λ of the sand pressure (mm).
    pub rise_mm: f32,
}

impl SandLaw {
    /// Internal pressure p_i (kPa) at outer diameter `diameter_mm`, depth
    /// `depth_mm`.
    pub fn internal_kpa(&self, diameter_mm: f32, depth_mm: f32) -> f32 {
        let x = if diameter_mm > D0_MM {
            diameter_mm - D0_MM
        } else {
            0.0
        };
        SKIN_KPA_PER_MM * x + self.sand_kpa(x, depth_mm)
    }

    fn sand_kpa(&self, x_mm: f32, depth_mm: f32) -> f32 {
        let rise = 1.0 - libm::expf(-x_mm / self.rise_mm);
        SAND_KPA_PER_MM * depth_mm * (AT_REST_SHARE + (1.0 - AT_REST_SHARE) * rise)
    }

    /// dp_e/dV at `diameter_mm` relative to its value at D0 (closed form):
    /// `exp(−x/λ)·D0/D`, since dV/dD = π·L·D/2.
    pub fn sand_slope_ratio(&self, diameter_mm: f32) -> f32 {
        libm::expf(-(diameter_mm - D0_MM) / self.rise_mm) * D0_MM / diameter_mm
    }
}

/// A table sampled from a [`SandLaw`] on 7 depths × 64 diameters
/// (18.7–27.52 mm every 0.14 mm), held in fixed arrays.
pub struct LawTable {
    diameters_mm: [f32; N_DIAMETERS],
    pressure_kpa: [f32; N_PRESSURES],
}

impl LawTable {
    /// Samples `law`.
    pub fn new(law: SandLaw) -> Self {
        let mut diameters_mm = [0.0; N_DIAMETERS];
        for (i, d) in diameters_mm.iter_mut().enumerate() {
            *d = D0_MM + DIAMETER_STEP_MM * i as f32;
        }
        let mut pressure_kpa = [0.0; N_PRESSURES];
        for (row, h) in pressure_kpa.chunks_exact_mut(N_DIAMETERS).zip(DEPTHS_MM) {
            for (p, d) in row.iter_mut().zip(diameters_mm) {
                *p = law.internal_kpa(d, h);
            }
        }
        Self {
            diameters_mm,
            pressure_kpa,
        }
    }

    /// The table, with a valid checksum.
    pub fn table(&self) -> Table<'_> {
        let mut t = Table {
            format_version: FORMAT_VERSION,
            placeholder: true,
            initial_diameter_mm: D0_MM,
            expansion_length_mm: ZONE_LENGTH_MM,
            skin_thickness_mm: 1.75,
            depths_mm: &DEPTHS_MM,
            diameters_mm: &self.diameters_mm,
            pressure_kpa: &self.pressure_kpa,
            checksum: 0,
        };
        t.checksum = t.compute_checksum();
        t
    }
}

/// The test plant: syringe pump, hydraulic line, head in sand, sensor,
/// with fault injections. All volumes in mL.
#[derive(Clone, Debug)]
pub struct Plant {
    law: SandLaw,
    depth_mm: f32,
    zone: ExpansionZone,
    /// Net volume the pump was commanded to move (what it reports).
    pub pump_ml: f32,
    /// Water in the head past rest.
    pub head_ml: f32,
    dither_state: u32,
    /// Added to every reading (kPa).
    pub offset_kpa: f32,
    /// Delivered instead of a reading.
    pub sample_override: Option<PressureSample>,
    /// The sensor repeats this value (with fresh timestamps).
    pub frozen_kpa: Option<f32>,
    /// Readings keep this old timestamp.
    pub stale_taken_ms: Option<u32>,
    /// End-stop switches.
    pub end_stops: EndStops,
    /// The motor does not turn (its step count still grows).
    pub stalled: bool,
    /// Share of pumped water that reaches the head (air in the line < 1).
    pub compliance: f32,
    /// Head leak while the pump holds (mL/s).
    pub leak_ml_per_s: f32,
    /// Reported pump volume replaced by this (a garbage count).
    pub volume_override: Option<f32>,
    last_reading_kpa: f32,
}

impl Plant {
    /// A healthy plant at rest at `depth_mm`.
    pub fn new(law: SandLaw, depth_mm: f32) -> Self {
        Self {
            law,
            depth_mm,
            zone: ExpansionZone {
                initial_diameter_mm: D0_MM,
                expansion_length_mm: ZONE_LENGTH_MM,
            },
            pump_ml: 0.0,
            head_ml: 0.0,
            dither_state: 0x1234_5678,
            offset_kpa: 0.0,
            sample_override: None,
            frozen_kpa: None,
            stale_taken_ms: None,
            end_stops: EndStops::default(),
            stalled: false,
            compliance: 1.0,
            leak_ml_per_s: 0.0,
            volume_override: None,
            last_reading_kpa: 0.0,
        }
    }

    /// True outer diameter of the head (mm).
    pub fn diameter_mm(&self) -> f32 {
        self.zone.diameter_mm(self.head_ml)
    }

    /// True internal pressure (kPa), before dither and injections.
    pub fn pressure_kpa(&self) -> f32 {
        self.law.internal_kpa(self.diameter_mm(), self.depth_mm)
    }

    /// Deterministic dither in [−2, 2] Pa (xorshift32).
    fn dither_kpa(&mut self) -> f32 {
        let mut x = self.dither_state;
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        self.dither_state = x;
        ((x >> 8) as f32 / (1u32 << 24) as f32 * 2.0 - 1.0) * DITHER_KPA
    }

    /// What the sensor task delivers at `now_ms`.
    pub fn sample(&mut self, now_ms: u32) -> PressureSample {
        let dither = self.dither_kpa();
        if let Some(s) = self.sample_override {
            return s;
        }
        let pressure_kpa = match self.frozen_kpa {
            Some(p) => p,
            None => self.pressure_kpa() + self.offset_kpa + dither,
        };
        self.last_reading_kpa = pressure_kpa;
        PressureSample::Reading {
            pressure_kpa,
            taken_ms: self.stale_taken_ms.unwrap_or(now_ms),
        }
    }

    /// The last value the sensor delivered (kPa).
    pub fn last_reading_kpa(&self) -> f32 {
        self.last_reading_kpa
    }

    /// Applies `outputs` for `dt_ms`.
    pub fn apply(&mut self, outputs: &Outputs, dt_ms: u32) {
        let dt_s = dt_ms as f32 / 1000.0;
        match outputs.pump {
            PumpCommand::Run { rate_ml_per_s } => {
                let dv = rate_ml_per_s * dt_s;
                self.pump_ml += dv;
                if !self.stalled {
                    self.head_ml += self.compliance * dv;
                }
            }
            PumpCommand::Hold => self.head_ml -= self.leak_ml_per_s * dt_s,
            PumpCommand::Disable => {}
        }
        if outputs.relief_valve_open {
            // The valve vents the head back to rest.
            self.head_ml = 0.0;
        }
    }
}

/// A controller wired to a plant, stepping every control period.
pub struct Bench<'t> {
    /// The controller under test.
    pub ctrl: Controller<'t>,
    /// Its plant.
    pub plant: Plant,
    /// Time of the next step (ms).
    pub now_ms: u32,
    /// Outputs of the last step.
    pub last: Option<Outputs>,
    /// The host is connected: a step without a command sends a
    /// `Heartbeat` every [`HEARTBEAT_MS`].
    pub heartbeat: bool,
    /// Time of the host's last frame (ms).
    last_host_ms: u32,
}

impl<'t> Bench<'t> {
    /// A bench at t = 1000 ms with a fresh controller, tared at
    /// [`BENCH_ZERO_KPA`], and a connected host; invalid `params` are
    /// refused as the controller refuses them.
    pub fn new(params: Params, table: Table<'t>, plant: Plant) -> Result<Self, &'static str> {
        let mut ctrl = Controller::new(params, table).map_err(|_| "bench params refused")?;
        ctrl.set_pressure_zero(Some(BENCH_ZERO_KPA));
        Ok(Self {
            ctrl,
            plant,
            now_ms: 1000,
            last: None,
            heartbeat: true,
            last_host_ms: 1000,
        })
    }

    /// One control step with an optional command (a `Heartbeat` every
    /// [`HEARTBEAT_MS`] when there is none and the host is connected); the
    /// plant then runs one period under the outputs.
    pub fn step(&mut self, command: Option<Command>) -> Outputs {
        let due = self.now_ms.wrapping_sub(self.last_host_ms) >= HEARTBEAT_MS;
        let command = command.or((self.heartbeat && due).then_some(Command::Heartbeat));
        if command.is_some() {
            self.last_host_ms = self.now_ms;
        }
        let inputs = Inputs {
            now_ms: self.now_ms,
            pressure: self.plant.sample(self.now_ms),
            pump_volume_ml: self.plant.volume_override.unwrap_or(self.plant.pump_ml),
            end_stops: self.plant.end_stops,
            command,
        };
        let out = self.ctrl.step(&inputs);
        self.plant.apply(&out, CONTROL_PERIOD_MS);
        self.now_ms = self.now_ms.wrapping_add(CONTROL_PERIOD_MS);
        self.last = Some(out);
        out
    }

    /// Steps until `done` holds for the outputs (returned), at most
    /// `max_steps` steps.
    pub fn run_until(
        &mut self,
        max_steps: u32,
        mut done: impl FnMut(&Outputs, &Plant) -> bool,
        why: &'static str,
    ) -> Result<Outputs, &'static str> {
        for _ in 0..max_steps {
            let out = self.step(None);
            if done(&out, &self.plant) {
                return Ok(out);
            }
        }
        Err(why)
    }

    /// A few idle steps so the sensor has delivered, then `Start`.
    pub fn start(&mut self) -> Result<(), &'static str> {
        for _ in 0..3 {
            self.step(None);
        }
        let out = self.step(Some(Command::Start));
        ensure(out.command_result == Some(Ok(())), "Start refused")?;
        ensure(out.state == State::Expand, "Start did not enter Expand")
    }

    /// Time (ms) of the last step taken.
    pub fn last_step_ms(&self) -> u32 {
        self.now_ms.wrapping_sub(CONTROL_PERIOD_MS)
    }
}

fn ensure(condition: bool, why: &'static str) -> Result<(), &'static str> {
    if condition {
        Ok(())
    } else {
        Err(why)
    }
}

fn is_safe(out: &Outputs) -> bool {
    out.state == State::Fault
        && out.pump == PumpCommand::Disable
        && out.relief_valve_open
        && !out.advance_drive
}

/// Volume past rest (mL) of one control period at `rate_ml_per_s`.
fn per_step_ml(rate_ml_per_s: f32) -> f32 {
    rate_ml_per_s * CONTROL_PERIOD_MS as f32 / 1000.0
}

fn zone() -> ExpansionZone {
    ExpansionZone {
        initial_diameter_mm: D0_MM,
        expansion_length_mm: ZONE_LENGTH_MM,
    }
}

fn abs(x: f32) -> f32 {
    libm::fabsf(x)
}

// ---------------------------------------------------------------------------
// Normal operation
// ---------------------------------------------------------------------------

fn normal_cycles_40mm() -> Result<(), &'static str> {
    normal_cycles(40.0)
}

fn normal_cycles_100mm() -> Result<(), &'static str> {
    normal_cycles(100.0)
}

/// Three cycles at `depth_mm` in the slowly stiffening sand: every
/// expansion ends at the target from below (within one period of pumping),
/// the head never passes it, each shrink returns to the rest volume, each
/// cycle lasts what the rates and times add up to, then Idle.
fn normal_cycles(depth_mm: f32) -> Result<(), &'static str> {
    const CYCLES: u16 = 3;
    let law = SandLaw {
        rise_mm: SLOW_RISE_MM,
    };
    let store = LawTable::new(law);
    let params = Params {
        depth_mm,
        cycles: CYCLES,
        ..Params::DEFAULT
    };
    let mut bench = Bench::new(params, store.table(), Plant::new(law, depth_mm))?;
    bench.start()?;
    let rest_ml = bench.ctrl.rest_volume_ml();
    let start_ms = bench.last_step_ms();
    let target = params.target_diameter_mm;
    let target_ml = zone().volume_ml(target);
    // Diameter gained by one period of pumping at the target.
    let step_mm = target - zone().diameter_mm(target_ml - per_step_ml(params.expand_rate_ml_per_s));
    // Closed-form cycle time: pump the target volume in and out, hold, advance.
    let cycle_ms = 1000.0 * target_ml / params.expand_rate_ml_per_s
        + 1000.0 * target_ml / params.shrink_rate_ml_per_s
        + (params.hold_ms + params.advance_ms) as f32;

    let mut prev = State::Expand;
    let mut cycle_start_ms = start_ms;
    let mut expansions = 0;
    let mut max_head_mm = 0.0_f32;
    let max_steps = (cycle_ms as u32 / CONTROL_PERIOD_MS + 100) * u32::from(CYCLES);
    for _ in 0..max_steps {
        let out = bench.step(None);
        let t = &out.telemetry;
        max_head_mm = max_head_mm.max(bench.plant.diameter_mm());
        ensure(out.state != State::Fault, "fault during a normal cycle")?;
        ensure(out.feed_watchdog, "watchdog not fed on time")?;
        ensure(
            out.advance_drive == (out.state == State::Advance),
            "advance drive outside Advance",
        )?;
        ensure(!out.relief_valve_open, "valve open outside Fault")?;
        if prev == State::Expand && out.state == State::Hold {
            expansions += 1;
            let end = bench.ctrl.last_expand_end();
            ensure(
                matches!(end, Some(ExpandEnd::VolumeTarget | ExpandEnd::TableTarget)),
                "expansion ended before the target",
            )?;
            ensure(
                t.diameter_volume_mm <= target,
                "volume estimate passed the target",
            )?;
            ensure(
                t.diameter_volume_mm >= target - 2.0 * step_mm,
                "expansion stopped more than two periods short of the target",
            )?;
            ensure(
                abs(t.diameter_table_mm - t.diameter_volume_mm) < 0.05,
                "table and volume estimates disagree",
            )?;
        }
        if prev == State::Shrink && out.state != State::Shrink {
            ensure(
                abs(t.volume_ml - rest_ml)
                    <= params.rest_tolerance_ml + per_step_ml(params.shrink_rate_ml_per_s),
                "shrink did not return to the rest volume",
            )?;
        }
        if prev == State::Advance && out.state != State::Advance {
            let took = out.telemetry.t_ms.wrapping_sub(cycle_start_ms) as f32;
            // One period of rounding at each of the four phase ends, plus
            // the rest tolerance: a shrink may stop that much short of rest
            // and the next expansion starts there.
            let slack_ms = 4.0 * CONTROL_PERIOD_MS as f32
                + 1000.0 * params.rest_tolerance_ml / params.expand_rate_ml_per_s
                + 1000.0 * params.rest_tolerance_ml / params.shrink_rate_ml_per_s;
            ensure(
                abs(took - cycle_ms) <= slack_ms,
                "cycle time differs from the closed form",
            )?;
            cycle_start_ms = out.telemetry.t_ms;
        }
        prev = out.state;
        if out.state == State::Idle {
            break;
        }
    }
    ensure(bench.ctrl.state() == State::Idle, "did not return to Idle")?;
    ensure(
        expansions == u32::from(CYCLES),
        "wrong number of expansions",
    )?;
    ensure(bench.ctrl.cycle() == CYCLES, "cycle counter wrong")?;
    ensure(max_head_mm < target, "the head passed the target diameter")?;
    ensure(
        abs(bench.plant.pump_ml - rest_ml)
            <= params.rest_tolerance_ml + per_step_ml(params.shrink_rate_ml_per_s),
        "not back at the rest volume",
    )?;
    // Idle holds.
    let out = bench.step(None);
    ensure(
        out.pump == PumpCommand::Hold && !out.advance_drive,
        "Idle does not hold",
    )
}

/// In the paper-like sand (λ = 1.2 mm), the sand pressure flattens long
/// before 25 mm: the expansion stops on the plateau. The stop must lie
/// where the true slope ratio `exp(−x/λ)·D0/D` is already below the
/// fraction (the windowed estimate lags, never leads), and at most one
/// window's diameter span later (half a window of lag at the stop plus the
/// half window by which the first window underestimates the initial slope)
/// plus the confirmation's span.
fn plateau_stops_expansion_early() -> Result<(), &'static str> {
    let law = SandLaw {
        rise_mm: FAST_RISE_MM,
    };
    let store = LawTable::new(law);
    let params = Params {
        cycles: 1,
        ..Params::DEFAULT
    };
    let mut bench = Bench::new(params, store.table(), Plant::new(law, params.depth_mm))?;
    bench.start()?;
    let out = bench.run_until(
        400,
        |o, _| o.state != State::Expand,
        "expansion never ended",
    )?;
    ensure(out.state == State::Hold, "expansion did not end in Hold")?;
    ensure(
        bench.ctrl.last_expand_end() == Some(ExpandEnd::Plateau),
        "did not stop on the plateau",
    )?;
    let stop_mm = out.telemetry.diameter_volume_mm;
    ensure(
        stop_mm < params.target_diameter_mm - 2.0,
        "plateau stop not well before the target",
    )?;

    // D_f: where the closed-form slope ratio equals the fraction (bisection;
    // the ratio falls monotonically with D).
    let f = params.plateau_slope_fraction;
    let (mut lo, mut hi) = (D0_MM, params.target_diameter_mm);
    for _ in 0..40 {
        let mid = 0.5 * (lo + hi);
        if law.sand_slope_ratio(mid) > f {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let d_f = 0.5 * (lo + hi);
    // Diameter spans (largest: at D0) of one window and of the confirmation.
    let span_mm = |samples: f32| {
        zone().diameter_mm(samples * per_step_ml(params.expand_rate_ml_per_s)) - D0_MM
    };
    let window_mm = span_mm(PLATEAU_WINDOW_SAMPLES as f32);
    let confirm_mm = span_mm(f32::from(PLATEAU_CONFIRM_SAMPLES));
    ensure(
        stop_mm >= d_f,
        "stopped before the true slope fell below the fraction",
    )?;
    ensure(
        stop_mm <= d_f + window_mm + confirm_mm,
        "stopped more than a window after the plateau",
    )?;
    // The rest of the cycle is normal.
    let out = bench.run_until(
        600,
        |o, _| o.state == State::Idle || o.state == State::Fault,
        "cycle never ended",
    )?;
    ensure(
        out.state == State::Idle,
        "cycle after the plateau stop did not end in Idle",
    )?;
    ensure(bench.ctrl.cycle() == 1, "cycle counter wrong")
}

/// `Stop` in the middle of an expansion: straight to Shrink, back to the
/// rest volume, Idle, no advance and no further cycle.
fn stop_shrinks_then_idles() -> Result<(), &'static str> {
    let law = SandLaw {
        rise_mm: SLOW_RISE_MM,
    };
    let store = LawTable::new(law);
    let params = Params::DEFAULT;
    let mut bench = Bench::new(params, store.table(), Plant::new(law, params.depth_mm))?;
    bench.start()?;
    let rest_ml = bench.ctrl.rest_volume_ml();
    bench.run_until(
        300,
        |o, _| o.telemetry.diameter_volume_mm >= 22.0,
        "never reached 22 mm",
    )?;
    let out = bench.step(Some(Command::Stop));
    ensure(out.command_result == Some(Ok(())), "Stop refused")?;
    ensure(out.state == State::Shrink, "Stop did not shrink")?;
    ensure(
        bench.ctrl.last_expand_end() == Some(ExpandEnd::Stopped),
        "expansion end not recorded as Stopped",
    )?;
    let out = bench.run_until(
        400,
        |o, _| o.advance_drive || o.state != State::Shrink,
        "shrink never ended",
    )?;
    ensure(
        out.state == State::Idle && !out.advance_drive,
        "Stop did not end in Idle",
    )?;
    ensure(
        abs(bench.plant.pump_ml - rest_ml)
            <= params.rest_tolerance_ml + per_step_ml(params.shrink_rate_ml_per_s),
        "not back at the rest volume",
    )?;
    ensure(
        bench.ctrl.cycle() == 0,
        "a stopped cycle counted as complete",
    )?;
    for _ in 0..200 {
        ensure(
            bench.step(None).state == State::Idle,
            "left Idle after Stop",
        )?;
    }
    Ok(())
}

/// A parameter set with one field out of its range, or NaN, changes
/// nothing; a valid set is taken whole; no set is taken outside Idle.
fn set_params_rejected_whole() -> Result<(), &'static str> {
    let law = SandLaw {
        rise_mm: SLOW_RISE_MM,
    };
    let store = LawTable::new(law);
    let mut bench = Bench::new(Params::DEFAULT, store.table(), Plant::new(law, 40.0))?;
    bench.step(None);
    // A valid set, different in every field, except one field broken.
    let mut good = Params::DEFAULT;
    good.depth_mm = 100.0;
    good.hold_ms = 700;
    good.expand_rate_ml_per_s = 1.5;
    ensure(good.validate().is_ok(), "test set invalid")?;
    for r in RANGES {
        let span = r.max - r.min;
        for bad in [
            r.max + 1.0 + 0.01 * span,
            r.min - 1.0 - 0.01 * span,
            f32::NAN,
        ] {
            let mut p = good;
            p.set(r.field, bad);
            // Integer fields saturate: a value that did not stick is not a test.
            let stored = p.get(r.field);
            if stored >= r.min && stored <= r.max {
                continue;
            }
            let out = bench.step(Some(Command::SetParams(p)));
            ensure(
                out.command_result
                    == Some(Err(CommandError::InvalidParams(
                        crate::controller::ParamError { field: r.field },
                    ))),
                "bad field not named",
            )?;
            ensure(
                *bench.ctrl.params() == Params::DEFAULT,
                "a rejected set changed the parameters",
            )?;
        }
    }
    // The cross-field rule: a limit the sensor cannot measure.
    let mut p = good;
    p.max_pressure_kpa = p.sensor_max_kpa;
    let out = bench.step(Some(Command::SetParams(p)));
    ensure(
        out.command_result
            == Some(Err(CommandError::InvalidParams(
                crate::controller::ParamError {
                    field: ParamField::MaxPressureKpa,
                },
            ))),
        "limit above the sensor range accepted",
    )?;
    ensure(
        *bench.ctrl.params() == Params::DEFAULT,
        "a rejected set changed the parameters",
    )?;
    let out = bench.step(Some(Command::SetParams(good)));
    ensure(out.command_result == Some(Ok(())), "valid set refused")?;
    ensure(*bench.ctrl.params() == good, "valid set not taken whole")?;
    // Not while a cycle runs.
    bench.start()?;
    let out = bench.step(Some(Command::SetParams(Params::DEFAULT)));
    ensure(
        out.command_result == Some(Err(CommandError::Busy)),
        "SetParams accepted while active",
    )?;
    ensure(
        *bench.ctrl.params() == good,
        "SetParams while active changed the parameters",
    )
}

/// A table that fails verification: `Start` is refused with the table's
/// error and nothing moves; the table-independent over-pressure monitor
/// still works.
fn bad_table_refuses_start() -> Result<(), &'static str> {
    let law = SandLaw {
        rise_mm: SLOW_RISE_MM,
    };
    let store = LawTable::new(law);
    let mut table = store.table();
    table.checksum ^= 1;
    let mut bench = Bench::new(Params::DEFAULT, table, Plant::new(law, 40.0))?;
    for _ in 0..3 {
        bench.step(None);
    }
    let out = bench.step(Some(Command::Start));
    ensure(
        out.command_result == Some(Err(CommandError::BadTable(TableError::Checksum))),
        "Start not refused with BadTable",
    )?;
    ensure(
        out.state == State::Idle && out.pump == PumpCommand::Hold,
        "a bad table moved the pump",
    )?;
    ensure(
        out.telemetry.diameter_table_mm.is_nan(),
        "diameter read from a bad table",
    )?;
    let mut short = store.table();
    short.pressure_kpa = &[1.0, 2.0];
    let mut other = Controller::with_default_params(short);
    let out = other.step(&Inputs {
        now_ms: 0,
        pressure: PressureSample::Reading {
            pressure_kpa: 1.0,
            taken_ms: 0,
        },
        pump_volume_ml: 0.0,
        end_stops: EndStops::default(),
        command: Some(Command::Start),
    });
    ensure(
        out.command_result == Some(Err(CommandError::BadTable(TableError::Shape))),
        "malformed table not refused",
    )?;
    for _ in 0..100 {
        ensure(
            bench.step(Some(Command::Start)).state == State::Idle,
            "started on a bad table",
        )?;
    }
    bench.plant.offset_kpa = 40.0;
    let out = bench.step(None);
    ensure(
        is_safe(&out) && out.telemetry.fault == Some(Fault::OverPressure),
        "over-pressure not caught",
    )
}

// ---------------------------------------------------------------------------
// Faults
// ---------------------------------------------------------------------------

/// A bench mid-expansion (volume-based diameter ≥ `at_mm`) at 40 mm in the
/// slowly stiffening sand, with `params`.
fn expanding<'t>(
    store: &'t LawTable,
    params: Params,
    at_mm: f32,
) -> Result<Bench<'t>, &'static str> {
    let law = SandLaw {
        rise_mm: SLOW_RISE_MM,
    };
    let mut bench = Bench::new(params, store.table(), Plant::new(law, params.depth_mm))?;
    bench.start()?;
    bench.run_until(
        300,
        |o, _| o.telemetry.diameter_volume_mm >= at_mm,
        "never reached the injection point",
    )?;
    ensure(
        bench.ctrl.state() == State::Expand,
        "not expanding at the injection point",
    )?;
    Ok(bench)
}

fn slow_store() -> LawTable {
    LawTable::new(SandLaw {
        rise_mm: SLOW_RISE_MM,
    })
}

/// Steps until Fault (at most `max_steps`), then checks the kind, that the
/// outputs are safe, and that it came within the stated bound after
/// `healthy_ms`, the last step whose inputs were healthy.
fn expect_fault(
    bench: &mut Bench<'_>,
    fault: Fault,
    healthy_ms: u32,
    max_steps: u32,
) -> Result<Outputs, &'static str> {
    let out = bench.run_until(
        max_steps,
        |o, _| o.state == State::Fault,
        "fault never detected",
    )?;
    ensure(out.telemetry.fault == Some(fault), "wrong fault kind")?;
    ensure(is_safe(&out), "fault outputs not safe")?;
    let took = out.telemetry.t_ms.wrapping_sub(healthy_ms);
    ensure(
        took <= detection_bound_ms(fault, bench.ctrl.params()),
        "detected later than the stated bound",
    )?;
    Ok(out)
}

/// The fault latches: commands other than Reset are refused, the outputs
/// stay safe for 2 s whatever happens; with `cause_active`, Reset is refused
/// until `clear` removes the cause; then Reset returns to Idle.
fn expect_latched(
    bench: &mut Bench<'_>,
    cause_active: bool,
    clear: fn(&mut Plant),
) -> Result<(), &'static str> {
    for cmd in [
        Command::Start,
        Command::Stop,
        Command::SetParams(Params::DEFAULT),
    ] {
        let out = bench.step(Some(cmd));
        ensure(
            out.command_result == Some(Err(CommandError::Faulted)),
            "command accepted in Fault",
        )?;
        ensure(is_safe(&out), "fault outputs not safe")?;
    }
    if cause_active {
        let out = bench.step(Some(Command::Reset));
        ensure(
            out.command_result == Some(Err(CommandError::CauseActive)),
            "Reset accepted with the cause present",
        )?;
        ensure(is_safe(&out), "fault outputs not safe")?;
    }
    clear(&mut bench.plant);
    for _ in 0..200 {
        let out = bench.step(None);
        ensure(is_safe(&out), "fault did not latch")?;
        ensure(
            out.feed_watchdog,
            "watchdog not fed in a healthy Fault loop",
        )?;
    }
    let out = bench.step(Some(Command::Reset));
    ensure(
        out.command_result == Some(Ok(())),
        "Reset refused after the cause cleared",
    )?;
    ensure(
        out.state == State::Idle && out.pump == PumpCommand::Hold && !out.relief_valve_open,
        "Reset did not return to Idle",
    )?;
    ensure(
        bench.ctrl.fault().is_none(),
        "fault still latched after Reset",
    )
}

fn fault_over_pressure() -> Result<(), &'static str> {
    let store = slow_store();
    let mut bench = expanding(&store, Params::DEFAULT, 21.0)?;
    let healthy_ms = bench.last_step_ms();
    bench.plant.offset_kpa = 40.0;
    expect_fault(&mut bench, Fault::OverPressure, healthy_ms, 1)?;
    expect_latched(&mut bench, true, |p| p.offset_kpa = 0.0)?;
    // At rest too.
    bench.plant.offset_kpa = 31.0;
    let healthy_ms = bench.last_step_ms();
    expect_fault(&mut bench, Fault::OverPressure, healthy_ms, 1).map(|_| ())
}

fn fault_sensor_bus() -> Result<(), &'static str> {
    let store = slow_store();
    let mut bench = expanding(&store, Params::DEFAULT, 21.0)?;
    let healthy_ms = bench.last_step_ms();
    bench.plant.sample_override = Some(PressureSample::BusError);
    expect_fault(&mut bench, Fault::SensorBus, healthy_ms, 10)?;
    expect_latched(&mut bench, true, |p| p.sample_override = None)
}

fn fault_sensor_out_of_range() -> Result<(), &'static str> {
    let store = slow_store();
    let mut bench = expanding(&store, Params::DEFAULT, 21.0)?;
    let healthy_ms = bench.last_step_ms();
    bench.plant.sample_override = Some(PressureSample::Reading {
        pressure_kpa: f32::NAN,
        taken_ms: healthy_ms,
    });
    expect_fault(&mut bench, Fault::SensorOutOfRange, healthy_ms, 1)?;
    expect_latched(&mut bench, true, |p| p.sample_override = None)
}

fn fault_sensor_frozen() -> Result<(), &'static str> {
    let store = slow_store();
    let mut bench = expanding(&store, Params::DEFAULT, 20.0)?;
    // The last healthy step's value is repeated from now on.
    let healthy_ms = bench.last_step_ms();
    bench.plant.frozen_kpa = Some(bench.plant.last_reading_kpa());
    expect_fault(&mut bench, Fault::SensorFrozen, healthy_ms, 100)?;
    // A steady reading with the pump stopped is no cause: Reset may proceed.
    expect_latched(&mut bench, false, |p| p.frozen_kpa = None)
}

fn fault_sensor_stale() -> Result<(), &'static str> {
    let store = slow_store();
    let mut bench = expanding(&store, Params::DEFAULT, 21.0)?;
    let healthy_ms = bench.last_step_ms();
    bench.plant.stale_taken_ms = Some(healthy_ms);
    expect_fault(&mut bench, Fault::SensorStale, healthy_ms, 20)?;
    expect_latched(&mut bench, true, |p| p.stale_taken_ms = None)
}

fn fault_end_stop() -> Result<(), &'static str> {
    let store = slow_store();
    let mut bench = expanding(&store, Params::DEFAULT, 21.0)?;
    let healthy_ms = bench.last_step_ms();
    bench.plant.end_stops.empty = true;
    expect_fault(&mut bench, Fault::EndStop, healthy_ms, 1)?;
    expect_latched(&mut bench, true, |p| p.end_stops.empty = false)
}

fn fault_pump_stall() -> Result<(), &'static str> {
    let store = slow_store();
    let mut bench = expanding(&store, Params::DEFAULT, 20.5)?;
    let healthy_ms = bench.last_step_ms();
    bench.plant.stalled = true;
    expect_fault(&mut bench, Fault::PumpStall, healthy_ms, 200)?;
    expect_latched(&mut bench, false, |p| p.stalled = false)
}

fn fault_leak() -> Result<(), &'static str> {
    let store = slow_store();
    // A long hold, so the torn skin has time to show.
    let params = Params {
        hold_ms: 3000,
        ..Params::DEFAULT
    };
    let law = SandLaw {
        rise_mm: SLOW_RISE_MM,
    };
    let mut bench = Bench::new(params, store.table(), Plant::new(law, params.depth_mm))?;
    bench.start()?;
    let out = bench.run_until(400, |o, _| o.state == State::Hold, "never reached Hold")?;
    let mut peak_kpa = out.telemetry.pressure_kpa;
    bench.plant.leak_ml_per_s = 10.0;
    let mut healthy_ms = bench.last_step_ms();
    for _ in 0..300 {
        let out = bench.step(None);
        if out.state == State::Fault {
            ensure(out.telemetry.fault == Some(Fault::Leak), "wrong fault kind")?;
            ensure(is_safe(&out), "fault outputs not safe")?;
            ensure(
                out.telemetry.t_ms.wrapping_sub(healthy_ms)
                    <= detection_bound_ms(Fault::Leak, &params),
                "leak detected later than the stated bound",
            )?;
            ensure(
                peak_kpa - out.telemetry.pressure_kpa > params.leak_limit_kpa(peak_kpa),
                "leak fault without the drop",
            )?;
            return expect_latched(&mut bench, false, |p| p.leak_ml_per_s = 0.0);
        }
        ensure(out.state == State::Hold, "left Hold while leaking")?;
        peak_kpa = peak_kpa.max(out.telemetry.pressure_kpa);
        if peak_kpa - out.telemetry.pressure_kpa <= params.leak_limit_kpa(peak_kpa) {
            healthy_ms = out.telemetry.t_ms;
        }
    }
    Err("leak never detected")
}

fn fault_volume_limit() -> Result<(), &'static str> {
    let store = slow_store();
    // A stroke shorter than the target needs (4.32 mL).
    let params = Params {
        max_volume_ml: 3.0,
        ..Params::DEFAULT
    };
    let law = SandLaw {
        rise_mm: SLOW_RISE_MM,
    };
    let mut bench = Bench::new(params, store.table(), Plant::new(law, params.depth_mm))?;
    bench.start()?;
    bench.run_until(300, |_, p| p.pump_ml > 2.9, "never pumped 2.9 mL")?;
    let mut healthy_ms = bench.last_step_ms();
    let out = bench.run_until(
        20,
        |o, _| {
            if o.telemetry.volume_ml <= params.max_volume_ml && o.state != State::Fault {
                healthy_ms = o.telemetry.t_ms;
            }
            o.state == State::Fault
        },
        "volume limit never detected",
    )?;
    ensure(
        out.telemetry.fault == Some(Fault::VolumeLimit),
        "wrong fault kind",
    )?;
    ensure(is_safe(&out), "fault outputs not safe")?;
    ensure(
        out.telemetry.volume_ml > params.max_volume_ml,
        "fault before the limit",
    )?;
    ensure(
        out.telemetry.t_ms.wrapping_sub(healthy_ms)
            <= detection_bound_ms(Fault::VolumeLimit, &params),
        "detected later than the stated bound",
    )?;
    // The stroke stays beyond the limit until the pump is re-homed.
    expect_latched(&mut bench, true, |p| p.pump_ml = 0.0)?;
    // A garbage count (NaN) is the same fault, even at rest.
    bench.plant.volume_override = Some(f32::NAN);
    let out = bench.step(None);
    ensure(
        is_safe(&out) && out.telemetry.fault == Some(Fault::VolumeLimit),
        "NaN volume not caught",
    )?;
    expect_latched(&mut bench, true, |p| p.volume_override = None)
}

fn fault_diameter_mismatch() -> Result<(), &'static str> {
    let store = slow_store();
    let params = Params::DEFAULT;
    let law = SandLaw {
        rise_mm: SLOW_RISE_MM,
    };
    let mut plant = Plant::new(law, params.depth_mm);
    // Air in the line: only 30 % of the pumped water swells the head.
    plant.compliance = 0.3;
    let mut bench = Bench::new(params, store.table(), plant)?;
    bench.start()?;
    let mut healthy_ms = bench.last_step_ms();
    let out = bench.run_until(
        400,
        |o, _| {
            let t = &o.telemetry;
            if abs(t.diameter_table_mm - t.diameter_volume_mm) <= params.diameter_mismatch_mm
                && o.state != State::Fault
            {
                healthy_ms = t.t_ms;
            }
            o.state != State::Expand
        },
        "expansion never ended",
    )?;
    ensure(
        out.state == State::Fault,
        "mismatch not detected during the expansion",
    )?;
    ensure(
        out.telemetry.fault == Some(Fault::DiameterMismatch),
        "wrong fault kind",
    )?;
    ensure(is_safe(&out), "fault outputs not safe")?;
    ensure(
        out.telemetry.t_ms.wrapping_sub(healthy_ms)
            <= detection_bound_ms(Fault::DiameterMismatch, &params),
        "detected later than the stated bound",
    )?;
    ensure(
        out.telemetry.t_ms.wrapping_sub(healthy_ms) >= params.diameter_mismatch_ms,
        "a short disagreement tripped the fault",
    )?;
    expect_latched(&mut bench, false, |p| p.compliance = 1.0)
}

fn fault_control_overrun() -> Result<(), &'static str> {
    let store = slow_store();
    let mut bench = expanding(&store, Params::DEFAULT, 21.0)?;
    // Exactly at the limit: still on time.
    bench.now_ms = bench.last_step_ms().wrapping_add(CONTROL_OVERRUN_LIMIT_MS);
    let out = bench.step(None);
    ensure(
        out.state == State::Expand && out.feed_watchdog,
        "a step at the overrun limit tripped",
    )?;
    // One millisecond later: an overrun, latched in that very step.
    let healthy_ms = bench.last_step_ms();
    bench.now_ms = healthy_ms.wrapping_add(CONTROL_OVERRUN_LIMIT_MS + 1);
    let out = bench.step(None);
    ensure(!out.feed_watchdog, "watchdog fed on a late step")?;
    ensure(
        out.telemetry.fault == Some(Fault::ControlOverrun) && is_safe(&out),
        "overrun not latched",
    )?;
    // Time going backwards is just as late.
    bench.now_ms = bench.last_step_ms().wrapping_sub(5);
    ensure(
        !bench.step(None).feed_watchdog,
        "watchdog fed when time went backwards",
    )?;
    bench.now_ms = bench.last_step_ms().wrapping_add(CONTROL_PERIOD_MS);
    expect_latched(&mut bench, false, |_| {})
}

fn fault_link_loss() -> Result<(), &'static str> {
    let store = slow_store();
    let mut bench = expanding(&store, Params::DEFAULT, 21.0)?;
    // The host's last frame: a heartbeat now, then silence.
    let out = bench.step(Some(Command::Heartbeat));
    ensure(out.command_result == Some(Ok(())), "Heartbeat refused")?;
    let healthy_ms = bench.last_step_ms();
    bench.heartbeat = false;
    let steps = Params::DEFAULT.link_timeout_ms / CONTROL_PERIOD_MS + 2;
    let out = expect_fault(&mut bench, Fault::LinkLoss, healthy_ms, steps)?;
    ensure(
        out.telemetry.t_ms.wrapping_sub(healthy_ms) > Params::DEFAULT.link_timeout_ms,
        "link loss before its timeout",
    )?;
    ensure(
        bench.ctrl.last_fault().map(|(f, _)| f) == Some(Fault::LinkLoss),
        "last fault not kept",
    )?;
    // The host comes back: a heartbeat is accepted in Fault, and the
    // fault latches until Reset, which clears it (the cause is gone).
    bench.heartbeat = true;
    expect_latched(&mut bench, false, |_| {})?;
    ensure(
        bench.ctrl.last_fault().map(|(f, _)| f) == Some(Fault::LinkLoss),
        "last fault forgotten by Reset",
    )?;
    // A cycle without a limit needs the watch; with a limit it may go
    // without a host, and then runs its cycles to the end unfed.
    let unwatched = Params {
        link_timeout_ms: 0,
        ..Params::DEFAULT
    };
    let out = bench.step(Some(Command::SetParams(unwatched)));
    ensure(
        out.command_result
            == Some(Err(CommandError::InvalidParams(
                crate::controller::ParamError {
                    field: ParamField::LinkTimeoutMs,
                },
            ))),
        "a cycle without limit or link watch was accepted",
    )?;
    let bounded = Params {
        cycles: 1,
        ..unwatched
    };
    let out = bench.step(Some(Command::SetParams(bounded)));
    ensure(out.command_result == Some(Ok(())), "bounded run refused")?;
    bench.heartbeat = false;
    bench.start()?;
    let out = bench.run_until(
        2_000,
        |o, _| o.state == State::Idle || o.state == State::Fault,
        "bounded run never ended",
    )?;
    ensure(
        out.state == State::Idle && bench.ctrl.cycle() == 1,
        "bounded run without host did not complete",
    )
}

fn pressure_zero_gates_start() -> Result<(), &'static str> {
    let store = slow_store();
    let law = SandLaw {
        rise_mm: SLOW_RISE_MM,
    };
    let mut bench = Bench::new(Params::DEFAULT, store.table(), Plant::new(law, 40.0))?;
    for _ in 0..3 {
        bench.step(None);
    }
    let (lo, hi) = PRESSURE_ZERO_RANGE_KPA;
    for zero in [None, Some(lo - 0.5), Some(hi + 0.5), Some(f32::NAN)] {
        bench.ctrl.set_pressure_zero(zero);
        let out = bench.step(Some(Command::Start));
        ensure(
            out.command_result == Some(Err(CommandError::NoPressureZero)),
            "Start accepted without a zero in range",
        )?;
        ensure(out.state == State::Idle, "refused Start left Idle")?;
        ensure(
            out.telemetry.pressure_zero_kpa.to_bits() == zero.unwrap_or(f32::NAN).to_bits(),
            "telemetry does not carry the zero in force",
        )?;
    }
    // A zero in range with which the fitted sensor cannot see a limit: the
    // trip above its specified maximum, the floor below its minimum.
    let (spec_lo, spec_hi) = SENSOR_SPECIFIED_KPA;
    let p = *bench.ctrl.params();
    let low_floor = Params {
        sensor_min_kpa: spec_lo - lo - 1.0,
        ..p
    };
    for (zero, params, field) in [
        (
            spec_hi - p.max_pressure_kpa + 0.5,
            p,
            ParamField::MaxPressureKpa,
        ),
        (lo, low_floor, ParamField::SensorMinKpa),
    ] {
        if !(lo..=hi).contains(&zero) || params.validate().is_err() {
            // Not reachable with this sensor model's ranges.
            continue;
        }
        let out = bench.step(Some(Command::SetParams(params)));
        ensure(out.command_result == Some(Ok(())), "SetParams refused")?;
        bench.ctrl.set_pressure_zero(Some(zero));
        let out = bench.step(Some(Command::Start));
        ensure(
            out.command_result == Some(Err(CommandError::SensorRange(field))),
            "Start accepted with a limit the sensor cannot see",
        )?;
        ensure(out.state == State::Idle, "refused Start left Idle")?;
    }
    let out = bench.step(Some(Command::SetParams(p)));
    ensure(out.command_result == Some(Ok(())), "SetParams refused")?;
    let highest = spec_hi - p.max_pressure_kpa;
    for zero in [lo, BENCH_ZERO_KPA, highest.min(hi)] {
        bench.ctrl.set_pressure_zero(Some(zero));
        let out = bench.step(Some(Command::Start));
        ensure(
            out.command_result == Some(Ok(())),
            "Start refused with a zero in range",
        )?;
        ensure(
            out.telemetry.pressure_zero_kpa == zero,
            "telemetry does not carry the zero",
        )?;
        bench.step(Some(Command::Stop));
        bench.run_until(500, |o, _| o.state == State::Idle, "stop never idled")?;
    }
    Ok(())
}

/// CRC-32 over every output of a three-cycle run at 40 mm (all fields,
/// floats by their bits). Host and Cortex-M4 must print the same number:
/// the controller's arithmetic is the same IEEE f32 and `libm` on both.
pub fn normal_cycle_trace_crc32() -> Result<u32, &'static str> {
    let law = SandLaw {
        rise_mm: SLOW_RISE_MM,
    };
    let store = LawTable::new(law);
    let params = Params {
        cycles: 3,
        ..Params::DEFAULT
    };
    let mut bench = Bench::new(params, store.table(), Plant::new(law, params.depth_mm))?;
    let mut digest = CHECKSUM_ALGORITHM.digest();
    for k in 0..2000u32 {
        let command = (k == 3).then_some(Command::Start);
        let out = bench.step(command);
        let t = &out.telemetry;
        let (pump_code, rate) = match out.pump {
            PumpCommand::Disable => (0u8, 0.0),
            PumpCommand::Hold => (1, 0.0),
            PumpCommand::Run { rate_ml_per_s } => (2, rate_ml_per_s),
        };
        digest.update(&[
            pump_code,
            u8::from(out.relief_valve_open),
            u8::from(out.advance_drive),
            out.state as u8,
            t.fault.map_or(0xFF, |f| f as u8),
            u8::from(out.feed_watchdog),
        ]);
        for v in [
            rate,
            t.volume_ml,
            t.pressure_kpa,
            t.diameter_volume_mm,
            t.diameter_table_mm,
        ] {
            digest.update(&v.to_bits().to_le_bytes());
        }
        digest.update(&t.t_ms.to_le_bytes());
        digest.update(&t.cycle.to_le_bytes());
    }
    Ok(digest.finalize())
}
