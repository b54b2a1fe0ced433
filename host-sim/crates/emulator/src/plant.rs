//! The emulated plant: stepper syringe pump → line (relief valve, a
//! blockage when injected) → the workbench's rig model
//! ([`model::RigModel`]: effects, actuator volume, diameter, skin +
//! sand with its unloading branch, the reading at the line sensor) → the
//! MS5837 as the board delivers it; plus the external advance drive.
//!
//! The physics of the head is not here: it is the workbench's
//! [`RigModel`] with the same [`EffectInstance`]s the workbench fits, so an
//! effect switched on in a scenario is the very effect `host-sim diagnose`
//! looks for. What the plant adds is what sits outside the rig model:
//!
//! - the **pump** ([`StepperPump`]): microsteps and end-stops, a stall;
//! - the **line** between the pump and the head, with the relief valve on
//!   the pump side of the sensor. The water delivered into the rig model is
//!   `displaced − vented − stored`: the valve (open in Fault) vents
//!   `relief_conductance · p_line` mL/s once open, and it opens (and
//!   closes) `valve_response_ms` after it is commanded, a pure delay; a
//!   **blockage** (injected) freezes
//!   the volume reaching the head, and what the pump pushes on goes into
//!   the line's compliance, so the line reads
//!   `p_head + stored / line_compliance` (a stiff spring: a blocked line
//!   over-pressurises fast);
//! - the **advance drive**: moves the head at `advance_speed_mm_per_s`
//!   while the controller drives it, unless the head is still anchored
//!   (outer diameter more than `anchor_clearance_mm` above D0).
//!
//! Time advances in 1 ms sub-steps; [`Plant::run_period`] runs one control
//! period.

use std::collections::VecDeque;
use std::sync::{Arc, Mutex, OnceLock};

use anyhow::{ensure, Result};
use urechis::controller::{EndStops, Outputs, PressureSample, PumpCommand, BOARD_TIMING};
use urechis::drivers::pump::PumpConfig;

use super::pump::{us_from_ms, StepperPump};
use super::sensor::{Sensor, SensorConfig, SensorFault};
use model::effects::EffectInstance;
use model::{self, RigBasis, RigModel, RunState};
use rig::{Rig, Skin};

/// Length of one plant sub-step (ms).
pub const SUBSTEP_MS: u32 = 1;

/// Everything that defines a plant.
#[derive(Clone, Debug)]
pub struct PlantConfig {
    /// The physical set-up (written as the trace's rig.toml).
    pub rig: Rig,
    /// The rig model's baseline parameters.
    pub model_params: model::Params,
    /// Effects switched on in the rig model.
    pub effects: Vec<EffectInstance>,
    /// The syringe pump (its bore must be the rig's).
    pub pump: PumpConfig,
    /// Water in the barrel at power-up (mL).
    pub fill_ml: f64,
    /// The pressure sensor.
    pub sensor: SensorConfig,
    /// Compliance of the line between the pump and a blockage (mL/kPa).
    pub line_compliance_ml_per_kpa: f64,
    /// Relief valve flow per kPa of line pressure when open (mL/s/kPa).
    pub relief_conductance_ml_per_s_per_kpa: f64,
    /// Time from a command to the relief valve to the valve following it
    /// (ms), opening and closing alike.
    pub valve_response_ms: u32,
    /// Speed of the advance drive (mm/s).
    pub advance_speed_mm_per_s: f64,
    /// The head slides forward only within this of D0 (mm): wider, it is
    /// anchored in the sand.
    pub anchor_clearance_mm: f64,
}

impl PlantConfig {
    /// The paper's rig ([`Rig::paper_default`]) with the skin the firmware
    /// table was generated from ([`skin::default_skin`]), so a
    /// healthy plant matches the table; the board's pump and sensor; a
    /// half-full 50 mL syringe; a stiff line (0.02 mL/kPa: 100 kPa/s at
    /// 2 mL/s against a blockage); a relief valve venting 2 mL/s per kPa
    /// (10 ms time constant on the blocked line) with the response the
    /// firmware's end-to-end bounds assume
    /// ([`BOARD_TIMING`]`.valve_response_ms`, 50 ms); an advance drive at
    /// 1 mm/s (1 mm per default 1 s advance, the paper's advance per
    /// cycle) that cannot pull a head wider than D0 + 0.2 mm.
    pub fn paper() -> Self {
        let skin = skin::default_skin();
        let sensor = SensorConfig::default();
        let pump = PumpConfig::default();
        let mut rig = Rig::paper_default();
        rig.skin = Some(Skin {
            c10_kpa: skin.c10_kpa,
            c20_kpa: skin.c20_kpa,
            c30_kpa: skin.c30_kpa,
        });
        rig.pump.syringe_bore_mm = f64::from(pump.syringe_bore_mm);
        rig.measurement.pressure_noise_kpa = Some(sensor.noise_kpa);
        Self {
            rig,
            model_params: model::Params::default(),
            effects: Vec::new(),
            pump,
            fill_ml: 25.0,
            sensor,
            line_compliance_ml_per_kpa: 0.02,
            relief_conductance_ml_per_s_per_kpa: 2.0,
            valve_response_ms: BOARD_TIMING.valve_response_ms,
            advance_speed_mm_per_s: 1.0,
            anchor_clearance_mm: 0.2,
        }
    }
}

/// A fault put into the plant.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PlantFault {
    /// The line blocks between the sensor and the head.
    BlockLine,
    /// The motor loses its steps (the driver still counts them).
    PumpStall,
    /// A sensor failure.
    Sensor(SensorFault),
}

/// Effects that change what the sensor reports, not the pressure in the
/// line: the valve vents, and the limit protects, the line pressure without
/// them.
pub const SENSOR_BIAS_EFFECTS: [&str; 2] = ["sensor_gain", "sensor_offset"];

/// The affine sensor bias of the plant's effects: the rig model's reading
/// is `gain · line + offset` (the registry applies the physical reading
/// terms, then the gain, then the offset).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SensorBias {
    /// Factor (1 without `sensor_gain`).
    pub gain: f64,
    /// Offset (kPa; 0 without `sensor_offset`).
    pub offset_kpa: f64,
}

impl SensorBias {
    /// The bias of `effects`' `sensor_gain` and `sensor_offset`.
    pub fn of(effects: &[EffectInstance]) -> Result<Self> {
        let mut bias = Self {
            gain: 1.0,
            offset_kpa: 0.0,
        };
        for e in effects {
            match e.spec.name {
                "sensor_gain" => bias.gain = e.get("gain")?,
                "sensor_offset" => bias.offset_kpa = e.get("offset_kpa")?,
                _ => {}
            }
        }
        ensure!(
            bias.gain > 0.0,
            "sensor_gain must be > 0, got {}",
            bias.gain
        );
        Ok(bias)
    }

    /// The line pressure behind a reading (kPa).
    pub fn line_kpa(&self, reading_kpa: f64) -> f64 {
        (reading_kpa - self.offset_kpa) / self.gain
    }

    /// The reading of a line pressure (kPa).
    pub fn sensed_kpa(&self, line_kpa: f64) -> f64 {
        self.gain * line_kpa + self.offset_kpa
    }
}

/// The plant's true state at one instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Truth {
    /// Gauge pressure in the line at the sensor (kPa): what the relief
    /// valve vents and the limit protects.
    pub line_kpa: f64,
    /// What the sensor element senses before its noise and resolution
    /// (kPa): `line_kpa` through any sensor bias effect
    /// ([`SENSOR_BIAS_EFFECTS`]); equal to it without one.
    pub sensed_kpa: f64,
    /// Line pressure on the head's side of a blockage (kPa): equal to
    /// `line_kpa` unless blocked.
    pub behind_kpa: f64,
    /// Gauge pressure inside the head (kPa).
    pub internal_kpa: f64,
    /// Outer diameter of the expansion zone (mm).
    pub diameter_mm: f64,
    /// Water delivered into the rig model (mL).
    pub delivered_ml: f64,
    /// Volume in the head past rest (mL).
    pub actuator_volume_ml: f64,
    /// Net volume the plunger pushed out since power-up (mL).
    pub displaced_ml: f64,
    /// Water left in the barrel (mL).
    pub barrel_ml: f64,
    /// Microsteps the driver counted.
    pub counted_steps: i32,
    /// Volume vented by the relief valve so far (mL).
    pub vented_ml: f64,
    /// Distance the advance drive moved the head (mm).
    pub advance_mm: f64,
    /// The relief valve is open (venting), as it is, not as commanded.
    pub valve_open: bool,
    /// End-stop switches.
    pub end_stops: EndStops,
    /// The line is blocked.
    pub blocked: bool,
}

/// The plant.
#[derive(Debug)]
pub struct Plant {
    config: PlantConfig,
    model: RigModel,
    bias: SensorBias,
    run: RunState,
    pump: StepperPump,
    sensor: Sensor,
    /// Delivered volume frozen by a blockage (mL).
    blocked_at_ml: Option<f64>,
    vented_ml: f64,
    /// The valve as it is.
    valve_open: bool,
    /// The valve as last commanded.
    valve_commanded: bool,
    /// Commands on their way to the valve: (when it follows, open).
    valve_changes: VecDeque<(u32, bool)>,
    advance_on: bool,
    advance_mm: f64,
    t_ms: u32,
    truth: Truth,
}

impl Plant {
    /// A plant at rest at sand cover `depth_mm`, noise drawn from `seed`.
    pub fn new(config: &PlantConfig, depth_mm: f64, seed: u64) -> Result<Self> {
        ensure!(
            config.pump.validate().is_ok(),
            "pump configuration {:?} is invalid",
            config.pump
        );
        ensure!(
            (config.rig.pump.syringe_bore_mm - f64::from(config.pump.syringe_bore_mm)).abs() < 1e-6,
            "rig.toml syringe_bore_mm = {} differs from the pump's {} mm",
            config.rig.pump.syringe_bore_mm,
            config.pump.syringe_bore_mm
        );
        let positive = |v: f64| v.is_finite() && v > 0.0;
        ensure!(
            positive(config.line_compliance_ml_per_kpa)
                && positive(config.relief_conductance_ml_per_s_per_kpa),
            "line compliance and relief conductance must be > 0"
        );
        let model = RigModel::with_basis(
            rig_basis(&config.rig)?,
            &config.model_params,
            &config.effects,
        )?;
        let bias = SensorBias::of(&config.effects)?;
        let mut run = model.start_run(depth_mm);
        let rest = model.step(&mut run, 0.0, 0.0);
        let pump = StepperPump::new(config.pump, config.fill_ml);
        // The board tares with the head at rest in free water (the data
        // format's zero), not buried: in sand the rest reading is the
        // sand's at-rest pressure.
        let sensor = Sensor::new(config.sensor, seed, 0.0)?;
        let mut plant = Self {
            config: config.clone(),
            model,
            bias,
            run,
            pump,
            sensor,
            blocked_at_ml: None,
            vented_ml: 0.0,
            valve_open: false,
            valve_commanded: false,
            valve_changes: VecDeque::new(),
            advance_on: false,
            advance_mm: 0.0,
            t_ms: 0,
            truth: Truth {
                line_kpa: bias.line_kpa(rest.sensor_kpa),
                sensed_kpa: rest.sensor_kpa,
                behind_kpa: bias.line_kpa(rest.sensor_kpa),
                internal_kpa: rest.internal_kpa,
                diameter_mm: rest.diameter_mm,
                delivered_ml: 0.0,
                actuator_volume_ml: rest.actuator_volume_ml,
                displaced_ml: 0.0,
                barrel_ml: config.fill_ml,
                counted_steps: 0,
                vented_ml: 0.0,
                advance_mm: 0.0,
                valve_open: false,
                end_stops: EndStops::default(),
                blocked: false,
            },
        };
        plant.truth.end_stops = plant.pump.end_stops();
        plant.truth.barrel_ml = plant.pump.barrel_ml();
        Ok(plant)
    }

    /// Its configuration.
    pub fn config(&self) -> &PlantConfig {
        &self.config
    }

    /// The sensor sample the controller sees now.
    pub fn sample(&self) -> PressureSample {
        self.sensor.sample()
    }

    /// The gauge zero the sensor was tared at (absolute kPa): what the
    /// board's `Tare` stores and the controller is given.
    pub fn pressure_zero_kpa(&self) -> f32 {
        self.sensor.zero_kpa()
    }

    /// The pump volume the controller sees now (mL).
    pub fn pump_volume_ml(&self) -> f32 {
        self.pump.reported_volume_ml()
    }

    /// The end-stops the controller sees now.
    pub fn end_stops(&self) -> EndStops {
        self.pump.end_stops()
    }

    /// The true state now.
    pub fn truth(&self) -> Truth {
        self.truth
    }

    /// Injects a fault now.
    pub fn inject(&mut self, fault: PlantFault) {
        match fault {
            PlantFault::BlockLine => {
                if self.blocked_at_ml.is_none() {
                    self.blocked_at_ml = Some(self.truth.delivered_ml);
                }
            }
            PlantFault::PumpStall => self.pump.set_stalled(true),
            PlantFault::Sensor(f) => self.sensor.set_fault(Some(f)),
        }
    }

    /// Applies the controller's outputs at `now_ms` (the valve follows
    /// `valve_response_ms` later).
    pub fn apply(&mut self, outputs: &Outputs, now_ms: u32) {
        self.pump.apply(outputs.pump, us_from_ms(now_ms));
        self.command_valve(outputs.relief_valve_open, now_ms);
        self.advance_on = outputs.advance_drive;
    }

    /// Commands the relief valve at `now_ms`: it follows
    /// `valve_response_ms` later.
    fn command_valve(&mut self, open: bool, now_ms: u32) {
        if open != self.valve_commanded {
            self.valve_commanded = open;
            let at = now_ms.saturating_add(self.config.valve_response_ms);
            self.valve_changes.push_back((at, open));
        }
    }

    /// One microstep of the pump driven by its STEP pin (the virtual
    /// board; the pump's own command stays `Disable` there, so only pulses
    /// move it). False when refused at an end-stop.
    pub fn pulse(&mut self, direction: urechis::drivers::pump::Direction) -> bool {
        self.pump.pulse(direction)
    }

    /// Sets the relief valve (which follows `valve_response_ms` later)
    /// and the advance drive from their pins, at the plant's time.
    pub fn set_outputs(&mut self, valve_open: bool, advance_on: bool) {
        self.command_valve(valve_open, self.t_ms);
        self.advance_on = advance_on;
    }

    /// Runs the plant in 1 ms sub-steps up to `t_ms` (at most `max_ms`
    /// of them; later ones are skipped, as after a stalled host).
    pub fn advance_to(&mut self, t_ms: u32, max_ms: u32) {
        if t_ms.wrapping_sub(self.t_ms) > max_ms {
            self.t_ms = t_ms.wrapping_sub(max_ms);
        }
        while self.t_ms < t_ms {
            let t0 = self.t_ms;
            self.substep(t0, t0 + SUBSTEP_MS);
        }
    }

    /// The injected sensor failure in force, if any.
    pub fn sensor_fault(&self) -> Option<SensorFault> {
        self.sensor.fault()
    }

    /// The emulated sensor, for a driver that talks to it byte by byte (the
    /// virtual board's bus).
    pub fn sensor_mut(&mut self) -> &mut Sensor {
        &mut self.sensor
    }

    /// The pump command in force.
    pub fn pump_command(&self) -> PumpCommand {
        self.pump.command()
    }

    /// Runs the plant from `from_ms` for `period_ms` in 1 ms sub-steps,
    /// calling `each_ms(t_ms, truth)` at the end of every millisecond.
    pub fn run_period(
        &mut self,
        from_ms: u32,
        period_ms: u32,
        mut each_ms: impl FnMut(u32, &Truth),
    ) -> Result<()> {
        for k in 0..period_ms / SUBSTEP_MS {
            let t0 = from_ms + k * SUBSTEP_MS;
            let t1 = t0 + SUBSTEP_MS;
            self.substep(t0, t1);
            each_ms(t1, &self.truth);
        }
        Ok(())
    }

    /// Volume (mL) the open valve vents from an open line over one
    /// sub-step: `g·p_line·dt` with `p_line` taken at the END of the
    /// sub-step (implicit Euler). The line pressure falls as the valve
    /// vents, through the head's stiffness and, with `line_loss`, through
    /// the flow itself (R·Q, Q = −vent/dt); taken explicitly the vent
    /// overshoots and diverges once g·R > 1. p_line is close to affine in
    /// the vented volume over one sub-step, so one probe of the model (on a
    /// copy of its state) gives the slope and the implicit vent directly.
    fn vent_open_line_ml(&self, t1_ms: u32, displaced: f64, g: f64, dt_s: f64) -> f64 {
        let t_s = f64::from(t1_ms) / 1000.0;
        let upstream = displaced - self.vented_ml;
        let line_after = |vent_ml: f64| {
            let mut run = self.run.clone();
            let p = self.model.step(&mut run, t_s, upstream - vent_ml);
            self.bias.line_kpa(p.sensor_kpa)
        };
        let line_kpa = line_after(0.0);
        let explicit_ml = g * line_kpa * dt_s;
        if explicit_ml == 0.0 || !explicit_ml.is_finite() {
            return 0.0;
        }
        // kPa lost per mL vented; never negative (venting cannot raise it).
        let stiffness = ((line_kpa - line_after(explicit_ml)) / explicit_ml).max(0.0);
        explicit_ml / (1.0 + g * dt_s * stiffness)
    }

    /// One sub-step `[t0_ms, t1_ms)`.
    fn substep(&mut self, t0_ms: u32, t1_ms: u32) {
        let dt_s = f64::from(t1_ms - t0_ms) / 1000.0;
        while let Some(&(at, open)) = self.valve_changes.front() {
            if at > t0_ms {
                break;
            }
            self.valve_open = open;
            self.valve_changes.pop_front();
        }
        self.pump.advance(us_from_ms(t0_ms), us_from_ms(t1_ms));
        let displaced = self.pump.displaced_ml();
        // The open valve vents g·p_line. A blocked line is a linear spring
        // (p = p_head + stored/C) and vents exactly, exponentially with
        // τ = C/g towards 0 gauge; through the head, whose stiffness is a
        // few kPa/mL, the explicit rate is stable.
        if self.valve_open {
            let g = self.config.relief_conductance_ml_per_s_per_kpa;
            self.vented_ml += match self.blocked_at_ml {
                Some(frozen) => {
                    let c = self.config.line_compliance_ml_per_kpa;
                    let stored = displaced - self.vented_ml - frozen;
                    let settled = -self.truth.behind_kpa * c;
                    let after = settled + (stored - settled) * (-g * dt_s / c).exp();
                    stored - after
                }
                None => self.vent_open_line_ml(t1_ms, displaced, g, dt_s),
            };
        }
        let upstream_ml = displaced - self.vented_ml;
        let (delivered, stored) = match self.blocked_at_ml {
            Some(frozen) => (frozen, upstream_ml - frozen),
            None => (upstream_ml, 0.0),
        };
        let p = self
            .model
            .step(&mut self.run, f64::from(t1_ms) / 1000.0, delivered);
        let behind_kpa = self.bias.line_kpa(p.sensor_kpa);
        let line_kpa = behind_kpa + stored / self.config.line_compliance_ml_per_kpa;
        let sensed_kpa = self.bias.sensed_kpa(line_kpa);
        // The drive slides the head only once it is back near D0.
        let free = p.diameter_mm
            <= self.config.rig.actuator.initial_diameter_mm + self.config.anchor_clearance_mm;
        if self.advance_on && free {
            self.advance_mm += self.config.advance_speed_mm_per_s * dt_s;
        }
        self.truth = Truth {
            line_kpa,
            sensed_kpa,
            behind_kpa,
            internal_kpa: p.internal_kpa,
            diameter_mm: p.diameter_mm,
            delivered_ml: delivered,
            actuator_volume_ml: p.actuator_volume_ml,
            displaced_ml: displaced,
            barrel_ml: self.pump.barrel_ml(),
            counted_steps: self.pump.counted_steps(),
            vented_ml: self.vented_ml,
            advance_mm: self.advance_mm,
            valve_open: self.valve_open,
            end_stops: self.pump.end_stops(),
            blocked: self.blocked_at_ml.is_some(),
        };
        self.t_ms = t1_ms;
        self.sensor.tick(t1_ms, sensed_kpa);
    }
}

/// The rig model's basis for `rig` (its skin curve takes the thick-tube
/// solution at hundreds of diameters), built once per distinct rig in the
/// process: the randomized scenarios all share one.
fn rig_basis(rig: &Rig) -> Result<Arc<RigBasis>> {
    type Bases = Mutex<Vec<(Rig, Arc<RigBasis>)>>;
    static BASES: OnceLock<Bases> = OnceLock::new();
    let bases = BASES.get_or_init(|| Mutex::new(Vec::new()));
    // A poisoned lock only means another thread panicked mid-insert; the
    // list itself is still whole.
    let mut bases = bases.lock().unwrap_or_else(|e| e.into_inner());
    if let Some((_, basis)) = bases.iter().find(|(r, _)| r == rig) {
        return Ok(Arc::clone(basis));
    }
    let basis = RigBasis::new(rig)?;
    bases.push((rig.clone(), Arc::clone(&basis)));
    Ok(basis)
}
