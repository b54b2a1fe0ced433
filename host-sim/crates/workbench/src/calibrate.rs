//! Calibration: nonlinear least squares of the model's readings against the
//! measured ones, over the baseline's free parameters and those of the
//! effects switched on. Levenberg–Marquardt ([`lsq`]) with Marquardt's
//! diagonal scaling, bounds kept by projection, a forward-difference
//! Jacobian whose columns are simulated in parallel (rayon), refined to
//! central differences where it stops making progress, and standard
//! errors from (JᵀJ)⁻¹·σ², σ² = SSR/(n − p). Never mutates its inputs:
//! returns new values.

use std::sync::Arc;

use anyhow::Result;
use lsq::Differences;
use nalgebra::DMatrix;
use rayon::prelude::*;
use serde::Serialize;

use super::dataset::Dataset;
use model::effects::{EffectInstance, EffectSpec};
use model::{ParamSpec, Params, RigBasis, RigModel, BASELINE_PARAMS};

/// Which value a fitted parameter sets.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Slot {
    /// Baseline parameter (index in [`BASELINE_PARAMS`]).
    Baseline(usize),
    /// Parameter `1` of effect `0` (index in [`FitSpace::effects`]).
    Effect(usize, usize),
}

/// A model structure to calibrate: the basis, the effects on, which
/// parameters are free.
#[derive(Clone, Debug)]
pub struct FitSpace {
    /// The rig's fixed part.
    pub basis: Arc<RigBasis>,
    /// Effects on (values are the starting point).
    pub effects: Vec<EffectInstance>,
    /// Baseline values (fixed ones stay as given).
    pub baseline: Params,
    /// Free parameters.
    pub free: Vec<(Slot, ParamSpec)>,
}

impl FitSpace {
    /// Baseline plus `effects`; the skin scale is free only when the rig
    /// does not know its skin, the sand parameters only when some run is
    /// below sand.
    pub fn new(
        basis: Arc<RigBasis>,
        data: &Dataset,
        baseline: Params,
        effects: Vec<EffectInstance>,
    ) -> FitSpace {
        let buried = basis.sand.is_some() && data.runs.iter().any(|r| r.depth_mm > 0.0);
        let mut free = Vec::new();
        for (i, spec) in BASELINE_PARAMS.iter().enumerate() {
            let on = if i == 0 { !basis.skin_known } else { buried };
            if on {
                free.push((Slot::Baseline(i), *spec));
            }
        }
        for (e, inst) in effects.iter().enumerate() {
            for (i, spec) in inst.spec.params.iter().enumerate() {
                free.push((Slot::Effect(e, i), *spec));
            }
        }
        FitSpace {
            basis,
            effects,
            baseline,
            free,
        }
    }

    /// Current values of the free parameters.
    pub fn start(&self) -> Vec<f64> {
        let base = self.baseline.to_vec();
        self.free
            .iter()
            .map(|(slot, _)| match *slot {
                Slot::Baseline(i) => base[i],
                Slot::Effect(e, i) => self.effects[e].values[i],
            })
            .collect()
    }

    /// Baseline and effects at free values `theta`.
    pub fn assign(&self, theta: &[f64]) -> (Params, Vec<EffectInstance>) {
        let mut base = self.baseline.to_vec();
        let mut effects = self.effects.clone();
        for ((slot, spec), v) in self.free.iter().zip(theta) {
            let v = spec.clamp(*v);
            match *slot {
                Slot::Baseline(i) => base[i] = v,
                Slot::Effect(e, i) => effects[e].values[i] = v,
            }
        }
        (Params::from_slice(&base), effects)
    }

    /// The model at `theta`.
    pub fn model(&self, theta: &[f64]) -> Result<RigModel> {
        let (params, effects) = self.assign(theta);
        RigModel::with_basis(self.basis.clone(), &params, &effects)
    }

    /// A copy with the starting point moved to `theta`.
    pub fn at(&self, theta: &[f64]) -> FitSpace {
        let (baseline, effects) = self.assign(theta);
        FitSpace {
            baseline,
            effects,
            ..self.clone()
        }
    }

    /// Names of the free parameters (`effect.param` for effects).
    pub fn names(&self) -> Vec<String> {
        self.free
            .iter()
            .map(|(slot, spec)| match *slot {
                Slot::Baseline(_) => spec.name.to_owned(),
                Slot::Effect(e, _) => format!("{}.{}", self.effects[e].spec.name, spec.name),
            })
            .collect()
    }
}

/// One fitted parameter with its uncertainty.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FittedParam {
    /// `name` or `effect.name`.
    pub name: String,
    /// Unit.
    pub unit: &'static str,
    /// Value.
    pub value: f64,
    /// Standard error; `None` when the data do not determine it.
    pub std_error: Option<f64>,
    /// 95 % interval (±1.96 standard errors, clipped to the bounds).
    pub interval_95: Option<[f64; 2]>,
    /// Whether it ended on a bound.
    pub at_bound: bool,
}

/// A calibration's outcome.
#[derive(Clone, Debug)]
pub struct Fit {
    /// The structure, with its starting point moved to the optimum.
    pub space: FitSpace,
    /// Free values at the optimum.
    pub theta: Vec<f64>,
    /// Fitted parameters with standard errors.
    pub params: Vec<FittedParam>,
    /// Sum of squared residuals over the fitted samples (kPa²).
    pub ssr: f64,
    /// Samples fitted.
    pub n: usize,
    /// Root mean square residual over the fitted samples (kPa).
    pub rmse_kpa: f64,
    /// Residual model − measured at every fitted sample, in the data's
    /// order (kPa).
    pub residuals_kpa: Vec<f64>,
    /// Levenberg–Marquardt iterations taken.
    pub iterations: usize,
}

impl Fit {
    /// Number of free parameters.
    pub fn k(&self) -> usize {
        self.theta.len()
    }

    /// Bayesian information criterion n·ln(SSR/n) + k·ln(n).
    pub fn bic(&self) -> f64 {
        let n = self.n.max(1) as f64;
        n * (self.ssr / n).max(1e-300).ln() + self.k() as f64 * n.ln()
    }

    /// The fitted model.
    pub fn model(&self) -> Result<RigModel> {
        self.space.model(&self.theta)
    }
}

/// Options of one calibration.
#[derive(Clone, Copy, Debug)]
pub struct FitOptions {
    /// Most LM iterations.
    pub max_iterations: usize,
    /// Stop when SSR falls by less than this fraction in an iteration.
    pub tolerance: f64,
    /// Where forward differences stop making progress, go on with central
    /// differences (twice the model evaluations an iteration).
    pub refine_central: bool,
}

impl Default for FitOptions {
    fn default() -> Self {
        Self {
            max_iterations: 40,
            tolerance: 1e-7,
            refine_central: true,
        }
    }
}

/// Residuals model − measured on the samples `mask` keeps (all when
/// `None`), or `None` when the model cannot be built or is not finite.
fn residuals(
    space: &FitSpace,
    theta: &[f64],
    data: &Dataset,
    mask: Option<&[bool]>,
) -> Option<Vec<f64>> {
    let model = space.model(theta).ok()?;
    let pred = data.predict(&model);
    let r: Vec<f64> = pred
        .iter()
        .zip(&data.measured)
        .enumerate()
        .filter(|(i, _)| !data.skip[*i])
        .filter(|(i, _)| mask.is_none_or(|m| m.get(*i).copied().unwrap_or(false)))
        .map(|(_, (p, m))| p - m)
        .collect();
    r.iter().all(|x| x.is_finite()).then_some(r)
}

/// Forward-difference step for a parameter at `value`: small against its
/// size and its range, and turned inward at the upper bound.
fn fd_step(spec: &ParamSpec, value: f64) -> f64 {
    let h = 1e-4 * value.abs().max(0.01 * (spec.upper - spec.lower)).max(1e-9);
    if value + h > spec.upper {
        -h
    } else {
        h
    }
}

/// Jacobian columns (∂r/∂θj), computed in parallel: with
/// [`Differences::First`], forward, (r(θ + h) − r(θ)) / h, one model
/// evaluation a column, error O(h); with [`Differences::Refined`],
/// central, (r(θ + h) − r(θ − h)) / 2h, two a column, error O(h²), forward
/// where θ − h leaves the range.
fn jacobian(
    space: &FitSpace,
    theta: &[f64],
    r0: &[f64],
    data: &Dataset,
    mask: Option<&[bool]>,
    differences: Differences,
) -> DMatrix<f64> {
    let cols: Vec<Vec<f64>> = (0..theta.len())
        .into_par_iter()
        .map(|j| {
            let spec = &space.free[j].1;
            let h = fd_step(spec, theta[j]);
            let mut t = theta.to_vec();
            t[j] += h;
            let Some(plus) = residuals(space, &t, data, mask) else {
                return vec![0.0; r0.len()];
            };
            t[j] = theta[j] - h;
            let minus = (differences == Differences::Refined && spec.clamp(t[j]) == t[j])
                .then(|| residuals(space, &t, data, mask))
                .flatten();
            match minus {
                Some(m) => plus
                    .iter()
                    .zip(&m)
                    .map(|(a, b)| (a - b) / (2.0 * h))
                    .collect(),
                None => plus.iter().zip(r0).map(|(a, b)| (a - b) / h).collect(),
            }
        })
        .collect();
    DMatrix::from_fn(r0.len(), theta.len(), |i, j| cols[j][i])
}

/// Calibrates `space` on `data` (samples kept by `mask`, all when `None`).
pub fn calibrate(
    space: &FitSpace,
    data: &Dataset,
    mask: Option<&[bool]>,
    options: FitOptions,
) -> Result<Fit> {
    let bounds: Vec<(f64, f64)> = space.free.iter().map(|(_, s)| (s.lower, s.upper)).collect();
    let lm = lsq::Lm {
        stop: lsq::Stop {
            max_iterations: options.max_iterations,
            tolerance: options.tolerance,
        },
        trials: 12,
        // Forward differences while they make progress; where they stop,
        // the fit may lie in a curved valley whose floor a forward
        // difference's O(h) error hides (a bubble beside the skin's
        // stiffening: 4.54 mL with forward differences, 4.68 with central
        // ones at a lower SSR, for a true 5), so it goes on with central
        // differences and stops only when those make no progress either.
        refine: options.refine_central,
    };
    let differenced =
        |theta: &[f64], r: &[f64], d: Differences| jacobian(space, theta, r, data, mask, d);
    let lsq::Minimum {
        x: theta,
        residuals: r,
        rss: s,
        jacobian: jac,
        iterations,
    } = lm
        .minimise(
            |theta| residuals(space, theta, data, mask),
            differenced,
            &space.start(),
            &bounds,
        )
        .ok_or_else(|| {
            anyhow::anyhow!("the model gives no finite prediction at its starting point")
        })?;
    let n = r.len();
    let params = uncertainties(space, &theta, &jac, s);
    Ok(Fit {
        space: space.at(&theta),
        theta,
        params,
        ssr: s,
        n,
        rmse_kpa: (s / n.max(1) as f64).sqrt(),
        residuals_kpa: r,
        iterations,
    })
}

/// Standard errors from (JᵀJ)⁻¹σ² over the parameters the data determine.
fn uncertainties(
    space: &FitSpace,
    theta: &[f64],
    jac: &DMatrix<f64>,
    ssr: f64,
) -> Vec<FittedParam> {
    let names = space.names();
    let se = lsq::standard_errors(jac, ssr);
    theta
        .iter()
        .enumerate()
        .map(|(j, &value)| {
            let spec = &space.free[j].1;
            FittedParam {
                name: names[j].clone(),
                unit: spec.unit,
                value,
                std_error: se[j],
                interval_95: se[j].map(|e| {
                    [
                        (value - 1.96 * e).max(spec.lower),
                        (value + 1.96 * e).min(spec.upper),
                    ]
                }),
                at_bound: (value <= spec.lower && !spec.lower_is_law) || value >= spec.upper,
            }
        })
        .collect()
}

/// The spec of a fitted effect parameter named `effect.param`.
pub fn effect_param<'a>(
    params: &'a [FittedParam],
    effect: &EffectSpec,
    param: &str,
) -> Option<&'a FittedParam> {
    let key = format!("{}.{}", effect.name, param);
    params.iter().find(|p| p.name == key)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::{case, typical};

    #[test]
    fn recovers_known_parameters_from_noise_free_data() {
        let mut synth = case(vec![typical("line_loss").unwrap()], 0.1, 1);
        synth.noise_kpa = 0.0;
        let exp = synth.generate().unwrap();
        let data = Dataset::new(&exp);
        let basis = RigBasis::new(&exp.rig).unwrap();
        let effects = vec![EffectInstance::with_defaults("line_loss").unwrap()];
        let space = FitSpace::new(basis, &data, Params::default(), effects);
        // Known skin: its scale is not fitted; the sand's three are.
        assert_eq!(
            space.names(),
            [
                "sand_at_rest_factor",
                "sand_limit_factor",
                "sand_rise_mm",
                "line_loss.resistance_kpa_s_per_ml"
            ]
        );
        let fit = calibrate(&space, &data, None, FitOptions::default()).unwrap();
        // Readings are rounded to 1e-5 kPa: that is the only misfit.
        assert!(fit.rmse_kpa < 1e-4, "{}", fit.rmse_kpa);
        let want = [1.15, 0.9, Params::default().sand_rise_mm, 0.25];
        for (p, w) in fit.params.iter().zip(want) {
            assert!(
                (p.value - w).abs() < 1e-3 * w,
                "{}: {} vs {w}",
                p.name,
                p.value
            );
            assert!(p.std_error.is_some_and(|e| e < 1e-3 * w), "{p:?}");
        }
        // The inputs are untouched; the fit carries its own copy.
        assert_eq!(space.start()[3], 0.0);
        assert!((fit.space.start()[3] - 0.25).abs() < 1e-3);
    }
}
