//! The project's own generator of synthetic experiments, for testing the
//! workbench on effects it has to find: its truth is the rig model with
//! hidden effects from the library, optionally one effect *outside* the
//! library ([`Outside`]), and seeded Gaussian noise, over several runs at
//! different depths and flow rates, each a series of expand / hold /
//! shrink / rest cycles, with optionally jittered (irregular) time steps.

use anyhow::{Context, Result};
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, Normal};
use rand_pcg::Pcg64Mcg;

use model::effects::EffectInstance;
use model::{Params, RigModel};
use rig::{Experiment, Rig, Run, Sample};

/// An effect the library does not have.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Outside {
    /// The transducer's zero wanders with the lab's temperature:
    /// a·sin(2πt/T + φ), φ different per run.
    TemperatureDrift {
        /// Amplitude (kPa).
        amplitude_kpa: f64,
        /// Period (s).
        period_s: f64,
    },
}

/// One run's schedule.
#[derive(Clone, Debug, PartialEq)]
pub struct RunPlan {
    /// Run id.
    pub id: String,
    /// Sand cover (mm).
    pub depth_mm: f64,
    /// Pump flow of each cycle (mL/s): one cycle per entry.
    pub flows_ml_s: Vec<f64>,
    /// Volume at the top of each expansion (mL).
    pub peak_ml: f64,
    /// Hold at the top (s).
    pub hold_s: f64,
    /// Rest at the bottom (s).
    pub rest_s: f64,
    /// Sample interval (s).
    pub dt_s: f64,
    /// Relative jitter of the sample interval (0 = regular).
    pub jitter: f64,
}

/// A synthetic experiment's truth.
#[derive(Clone, Debug)]
pub struct Synth {
    /// The set-up written to rig.toml.
    pub rig: Rig,
    /// Baseline truth.
    pub params: Params,
    /// Hidden library effects.
    pub effects: Vec<EffectInstance>,
    /// Hidden effect outside the library.
    pub outside: Option<Outside>,
    /// Runs.
    pub runs: Vec<RunPlan>,
    /// Standard deviation of the reading noise (kPa).
    pub noise_kpa: f64,
    /// Seed of the noise and jitter.
    pub seed: u64,
}

/// Three runs (free water, 40 mm, 100 mm) of two cycles each at 1 and
/// 2.5 mL/s to 4 mL, sampled every `dt_s` (about 1,000 samples per run at
/// 0.02 s).
pub fn standard_runs(dt_s: f64) -> Vec<RunPlan> {
    [(0.0, [1.0, 2.5]), (40.0, [2.5, 1.0]), (100.0, [1.0, 2.5])]
        .iter()
        .enumerate()
        .map(|(i, (depth, flows))| RunPlan {
            id: format!("run{}_h{}", i + 1, depth),
            depth_mm: *depth,
            flows_ml_s: flows.to_vec(),
            peak_ml: 4.0,
            hold_s: 2.0,
            rest_s: 1.0,
            dt_s,
            jitter: 0.2,
        })
        .collect()
}

/// Pump volume (mL) at time `t_s` of `plan`, or `None` past its end.
fn volume_at(plan: &RunPlan, t_s: f64) -> Option<f64> {
    let mut t0 = 0.0;
    for &q in &plan.flows_ml_s {
        let ramp = plan.peak_ml / q;
        let period = 2.0 * ramp + plan.hold_s + plan.rest_s;
        let tc = t_s - t0;
        if tc < period {
            return Some(if tc < ramp {
                q * tc
            } else if tc < ramp + plan.hold_s {
                plan.peak_ml
            } else if tc < 2.0 * ramp + plan.hold_s {
                plan.peak_ml - q * (tc - ramp - plan.hold_s)
            } else {
                0.0
            });
        }
        t0 += period;
    }
    None
}

impl Synth {
    /// The noise-free truth model.
    pub fn truth(&self) -> Result<RigModel> {
        RigModel::new(&self.rig, &self.params, &self.effects)
    }

    /// Generates the experiment.
    pub fn generate(&self) -> Result<Experiment> {
        let model = self.truth().context("synthetic truth model")?;
        let mut rng = Pcg64Mcg::seed_from_u64(self.seed);
        let noise = Normal::new(0.0, self.noise_kpa.max(0.0)).context("noise level")?;
        let mut runs = Vec::new();
        for (k, plan) in self.runs.iter().enumerate() {
            let phase = 1.3 + 2.1 * k as f64;
            let mut state = model.start_run(plan.depth_mm);
            let mut samples = Vec::new();
            let mut t = 0.0;
            while let Some(v) = volume_at(plan, t) {
                // Volumes as a lab logs them: 1 µL resolution.
                let v = (v * 1e3).round() / 1e3;
                let p = model.step(&mut state, t, v);
                let mut reading = p.sensor_kpa + noise.sample(&mut rng);
                if let Some(Outside::TemperatureDrift {
                    amplitude_kpa,
                    period_s,
                }) = self.outside
                {
                    reading += amplitude_kpa * (std::f64::consts::TAU * t / period_s + phase).sin();
                }
                samples.push(Sample {
                    t_s: (t * 1e6).round() / 1e6,
                    volume_ml: v,
                    pressure_kpa: (reading * 1e5).round() / 1e5,
                    diameter_mm: None,
                    extra: Vec::new(),
                });
                let jitter = if plan.jitter > 0.0 {
                    rng.random_range(-plan.jitter..plan.jitter)
                } else {
                    0.0
                };
                t += plan.dt_s * (1.0 + jitter);
            }
            runs.push(Run {
                id: plan.id.clone(),
                depth_mm: plan.depth_mm,
                samples,
            });
        }
        Ok(Experiment::new(self.rig.clone(), runs))
    }
}

/// A synthetic case with the paper's rig, slightly-off baseline truth,
/// `effects` hidden, the standard runs at `dt_s`, noise 0.03 kPa.
pub fn case(effects: Vec<EffectInstance>, dt_s: f64, seed: u64) -> Synth {
    Synth {
        rig: Rig::paper_default(),
        params: Params {
            sand_at_rest_factor: 1.15,
            sand_limit_factor: 0.9,
            ..Params::default()
        },
        effects,
        outside: None,
        runs: standard_runs(dt_s),
        noise_kpa: 0.03,
        seed,
    }
}

/// The hidden value of each library effect used by the tests and the
/// confusion-matrix example: large enough to matter, physically plausible.
pub fn typical(name: &str) -> Result<EffectInstance> {
    let values: &[(&str, f64)] = match name {
        "sensor_offset" => &[("offset_kpa", 0.4)],
        "sensor_gain" => &[("gain", 1.12)],
        "line_loss" => &[("resistance_kpa_s_per_ml", 0.25)],
        "piston_friction" => &[("friction_n", 1.0)],
        "trapped_air" => &[("gas_volume_ml", 8.0)],
        "leak" => &[("ml_per_s_per_kpa", 0.005)],
        "skin_viscoelasticity" => &[("fraction", 0.8), ("tau_s", 1.5)],
        "mullins_softening" => &[("rate", 1.33), ("saturation", 3.33)],
        "wall_arching" => &[("mu_k", 0.25)],
        "sensor_lag" => &[("lag_s", 0.04)],
        "sand_depth_power" => &[("exponent", 0.7)],
        "skin_shape" => &[("stiffening_linear", 0.6), ("stiffening_quadratic", 0.3)],
        "sand_unloading" => &[("slope_factor", 0.3), ("curvature", 0.3)],
        "sand_rise" => &[("shape", 0.0)],
        "skin_scale" => &[("factor", 0.96)],
        // Unknown names fail in `new`; other effects start at defaults.
        _ => &[],
    };
    EffectInstance::new(name, values)
}
