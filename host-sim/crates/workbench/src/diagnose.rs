//! `diagnose`: which missing physical effect explains the residual.
//!
//! For each library effect that can act in the rig, calibrate the current
//! model plus that effect and score it: ΔBIC against the current model (the
//! ranking) and, for the best few, the held-out RMSE of a
//! cross-validation (whole runs held out where every depth has several,
//! else time blocks of every run). The best candidate that pays off on
//! every count is added, round after round: ΔBIC ≤ −10, held-out error
//! down by ≥ 2 % and in every fold, at least a third of the residual's
//! excess over the noise floor explained, and none of its own refusals
//! ([`Candidate::refusals`]). Forms of the baseline compete with the
//! physical effects on the same terms; a strong physical effect that a
//! form outranks is fitted together with that form and kept beside it
//! when the data still want it ([`BesideForm`]). A structured residual
//! that remains is reported as `unexplained`, described in words, rather
//! than forced onto a wrong effect.

use anyhow::Result;
use rayon::prelude::*;
use serde::Serialize;

use super::calibrate::{calibrate, Fit, FitOptions, FitSpace, FittedParam};
use super::dataset::{Dataset, MAX_FIT_SAMPLES};
use super::residuals::{analyse, noise_floor_estimate, residual, ResidualReport};
use super::spikes::{self, Spike};
use model::effects::{EffectInstance, EffectKind, EffectSpec, REGISTRY};
use model::{Params, RigBasis, RigModel};
use rig::Experiment;

/// Selection thresholds and effort.
#[derive(Clone, Copy, Debug)]
pub struct DiagnoseOptions {
    /// Calibration settings of the candidates' full fits.
    pub fit: FitOptions,
    /// Calibration settings that refine each model the diagnosis accepts
    /// (from where its candidate fit left it), so that the next round
    /// starts, and the report ends, at the floor of the fit's valley.
    pub polish: FitOptions,
    /// Iterations of each cross-validation refit (warm started).
    pub cv_iterations: usize,
    /// Most cross-validation folds.
    pub max_folds: usize,
    /// Candidates (best by ΔBIC) that get a cross-validation each round.
    pub cv_top: usize,
    /// ΔBIC an effect must reach (negative).
    pub max_delta_bic: f64,
    /// Relative held-out improvement an effect must reach.
    pub min_heldout_gain: f64,
    /// Cross-validation folds in which an effect may predict worse than
    /// the current model: a physical effect answers the pump's history the
    /// same way everywhere, so it helps in every fold; one that soaks up a
    /// drift outside the library helps in some and hurts in others. A form
    /// of the baseline may be worse in one fold more: it is judged against
    /// a model that may still lack a physical effect, whose misfit can
    /// outweigh the form's gain where that effect is strongest.
    pub max_folds_worse: usize,
    /// Fraction of the excess variance over the noise floor it must remove.
    pub min_excess_explained: f64,
    /// The share of the excess a selected physical effect must have
    /// removed in its round when the final residual is still unexplained
    /// ([`Diagnosis::withdrawn`]): a majority. A cause named beside an
    /// unknown one should account for more of the misfit it was fitted to
    /// than it leaves; on the outside truth's drift (a 0.2 kPa, 9 s swing
    /// of the zero) a skin viscoelasticity took 39 % and was named.
    pub min_excess_explained_unexplained: f64,
    /// Most physical effects added (forms of the baseline come on top).
    pub max_effects: usize,
    /// A physical effect must change the model's reading by at least this
    /// many noise floors (RMS over the fitted samples): below that its
    /// size is not worth a name, however many samples make it significant.
    /// A quarter of the noise: on the outside truth's controls, once the
    /// baseline's forms are in (the sand's unloading floor among them),
    /// every candidate is already refused by ΔBIC, its folds or
    /// [`EffectSpec::indistinct`], while true 5 mL bubbles that the forms
    /// partly mimic change the reading by 0.34–0.56 noise floors and a
    /// true Mullins softening by 0.75.
    pub min_change_factor: f64,
    /// A physical effect that pays on every count and changes the reading
    /// by at least this many noise floors is fitted together with a form
    /// that ranks above it (see [`BesideForm`]). Twice the noise: a
    /// change near one noise floor is what the forms leave of a skin that
    /// is not the model's (on the second outside rig's `[skin]` control, a
    /// −0.027 kPa offset changed the reading by 1.05 noise floors).
    pub challenge_change_factor: f64,
    /// A selected physical effect's size counts as determined while its
    /// 95 % interval spans at most this fraction of its value either side;
    /// where it is, but no longer with a form of the baseline that was not
    /// selected set free, the two are reported as not separated
    /// ([`Confound`]). 15 %: the precision the outside truth's goal asks
    /// of a primary parameter.
    pub separable_precision: f64,
}

impl DiagnoseOptions {
    /// Whether a fit pays on the shared counts: ΔBIC `delta_bic` at most
    /// [`DiagnoseOptions::max_delta_bic`] and its held-out RMSE
    /// `heldout_kpa` down by [`DiagnoseOptions::min_heldout_gain`] from
    /// the current model's `current_heldout_kpa`.
    fn gains(&self, delta_bic: f64, heldout_kpa: f64, current_heldout_kpa: f64) -> bool {
        delta_bic <= self.max_delta_bic
            && heldout_kpa <= current_heldout_kpa * (1.0 - self.min_heldout_gain)
    }
}

impl Default for DiagnoseOptions {
    fn default() -> Self {
        Self {
            // Forward differences for the many candidate fits; the accepted
            // model is refined with central ones (`polish`).
            fit: FitOptions {
                refine_central: false,
                ..FitOptions::default()
            },
            polish: FitOptions::default(),
            cv_iterations: 6,
            max_folds: 4,
            cv_top: 3,
            max_delta_bic: -10.0,
            min_heldout_gain: 0.02,
            max_folds_worse: 0,
            min_excess_explained: 0.33,
            min_excess_explained_unexplained: 0.5,
            max_effects: 4,
            min_change_factor: 0.25,
            challenge_change_factor: 2.0,
            separable_precision: 0.15,
        }
    }
}

/// One candidate effect scored against the current model.
#[derive(Clone, Debug, Serialize)]
pub struct Candidate {
    /// Effect name.
    pub effect: String,
    /// In-sample RMSE with the effect (kPa).
    pub rmse_kpa: f64,
    /// Held-out RMSE, for the best few (kPa).
    pub heldout_rmse_kpa: Option<f64>,
    /// For the best few: in how many cross-validation folds the held-out
    /// RMSE fell against the current model's, of how many.
    pub heldout_folds_better: Option<[usize; 2]>,
    /// BIC with the effect.
    pub bic: f64,
    /// Ranking score: ΔBIC against the current model (lower is better).
    pub score: f64,
    /// Fraction of the excess variance over the noise floor removed.
    pub excess_explained: f64,
    /// Fitted parameters (the effect's and the baseline's).
    pub params: Vec<FittedParam>,
    /// The effect's own parameters that ended on a bound of their range:
    /// the data push it past what the effect can be, so it is not
    /// accepted however much it pays.
    pub at_bound: Vec<String>,
    /// Why its fitted size cannot be told apart from an uncertainty of
    /// what rig.toml states ([`EffectSpec::indistinct`]); not accepted
    /// then either.
    pub indistinct: Option<String>,
    /// RMS change of the model's reading it makes over the fitted samples
    /// (kPa); below [`DiagnoseOptions::min_change_factor`] noise floors a
    /// physical effect is not accepted. Forms of the baseline are exempt:
    /// taking up the baseline's misfit, however small, is their job.
    pub change_rms_kpa: f64,
    /// Every reason of its own that keeps it out, in words (empty when
    /// only the shared thresholds, ΔBIC, held-out gain and excess
    /// explained, decide).
    pub refusals: Vec<String>,
    /// For a physical effect that paid on every count while a form ranked
    /// above it: the two fitted together ([`BesideForm`]); null otherwise.
    pub beside_form: Option<BesideForm>,
    /// For a physical effect: how much worse its own fit gets, in BIC,
    /// with the effect switched off and everything else left as fitted.
    /// Below −[`DiagnoseOptions::max_delta_bic`] the effect does not carry
    /// its fit's gain: refitting the rest found a better optimum (a leak
    /// of 1e-4 mL/(s·kPa) with ΔBIC −528). Null for a form.
    pub carried_bic: Option<f64>,
}

/// A physical effect fitted together with a form that ranked above it (or
/// that also paid when the effect ranked first): whether the data keep the
/// effect beside the form.
#[derive(Clone, Debug, Serialize)]
pub struct BesideForm {
    /// The physical effect.
    pub effect: String,
    /// The form that ranked above it.
    pub form: String,
    /// ΔBIC of form + effect against the current model + the form alone.
    pub score: f64,
    /// Held-out RMSE of form + effect (kPa).
    pub heldout_rmse_kpa: f64,
    /// Held-out RMSE of the current model + the form alone (kPa).
    pub form_heldout_rmse_kpa: f64,
    /// In how many folds form + effect predicts better than the form
    /// alone, of how many.
    pub heldout_folds_better: [usize; 2],
    /// The effect's fitted parameters in the joint fit.
    pub params: Vec<FittedParam>,
    /// Whether the two were added together.
    pub accepted: bool,
}

impl Candidate {
    /// The reasons of its own that keep it out: a physical effect that
    /// carries less than `min_carried_bic` of its fit's BIC
    /// ([`Candidate::carried_bic`]), parameters at a bound, a size not
    /// told apart from rig.toml, held-out worse in more folds than
    /// `folds_worse` allows, a physical effect whose change of the
    /// reading is below `min_change_kpa`.
    fn own_refusals(
        &self,
        form: bool,
        min_change_kpa: f64,
        folds_worse: usize,
        min_carried_bic: f64,
    ) -> Vec<String> {
        let mut why = Vec::new();
        if let Some(carried) = self.carried_bic {
            if self.score < 0.0 && carried < min_carried_bic {
                why.push(format!(
                    "switched off in its own fit it costs only {carried:.1} in BIC: refitting the rest, not the effect, made the gain"
                ));
            }
        }
        if !self.at_bound.is_empty() {
            why.push(format!("{} at its bound", self.at_bound.join(", ")));
        }
        if let Some(reason) = &self.indistinct {
            why.push(reason.clone());
        }
        if let Some([better, folds]) = self.heldout_folds_better {
            if better + folds_worse < folds {
                why.push(format!("held-out better in {better} of {folds} folds"));
            }
        }
        if !form && self.score < 0.0 && self.change_rms_kpa < min_change_kpa {
            why.push(format!(
                "changes the reading by {:.4} kPa RMS, below {min_change_kpa:.4} kPa, too little to name",
                self.change_rms_kpa
            ));
        }
        why
    }
}

/// The fit of a model structure, summarized.
#[derive(Clone, Debug, Serialize)]
pub struct ModelScore {
    /// Effects on.
    pub effects: Vec<String>,
    /// In-sample RMSE on the fitted samples (kPa).
    pub rmse_kpa: f64,
    /// Held-out RMSE (kPa).
    pub heldout_rmse_kpa: f64,
    /// BIC.
    pub bic: f64,
    /// Fitted parameters.
    pub params: Vec<FittedParam>,
}

/// A selected effect and why.
#[derive(Clone, Debug, Serialize)]
pub struct SelectedEffect {
    /// Effect name.
    pub effect: String,
    /// Its parameters in the final model.
    pub params: Vec<FittedParam>,
    /// The residual signature that gave it away, in plain words.
    pub signature: String,
    /// For a form of the baseline ([`EffectKind::BaselineForm`]), how the
    /// model's form was wrong, from the fitted values; null for an effect.
    pub baseline_form: Option<String>,
}

/// A selected physical effect whose size rests on a form of the baseline
/// that was not selected. With that form's parameters also free (the last
/// round's fit of the form beside the final model), either the effect's
/// primary parameter is no longer determined to
/// [`DiagnoseOptions::separable_precision`] (wall arching on runs at two
/// sand depths takes up a depth law that is not the model's as well), or
/// the form pays in BIC and moves the primary by more than that precision
/// and out of its own 95 % interval
/// (the form then fell short of the held-out gain or the excess explained
/// that adding it takes, but the effect's value depends on it).
#[derive(Clone, Debug, Serialize)]
pub struct Confound {
    /// The physical effect.
    pub effect: String,
    /// Its primary parameter, as in [`Diagnosis::params`].
    pub param: String,
    /// Its value in the final model.
    pub value: f64,
    /// Its 95 % interval in the final model.
    pub interval_95: Option<[f64; 2]>,
    /// The form of the baseline it trades off against.
    pub form: String,
    /// Its value with the form also fitted.
    pub value_with_form: f64,
    /// Its 95 % interval with the form also fitted; null when the data
    /// leave it free.
    pub interval_95_with_form: Option<[f64; 2]>,
    /// ΔBIC of the fit with the form against the final model.
    pub form_score: f64,
    /// Which runs would tell the two apart, in words.
    pub tells_apart: String,
}

/// A physical effect taken out of the final model again (see
/// [`Diagnosis::withdrawn`]).
#[derive(Clone, Debug, Serialize)]
pub struct Withdrawn {
    /// Effect name.
    pub effect: String,
    /// The share of the excess over the noise floor it removed in the
    /// round it was added (0–1).
    pub excess_explained: f64,
}

/// The diagnosis (`host-sim diagnose --json` prints this).
#[derive(Clone, Debug, Serialize)]
pub struct Diagnosis {
    /// The bare model's fit.
    pub baseline: ModelScore,
    /// First round: every applicable effect against the baseline, ranked.
    pub candidates: Vec<Candidate>,
    /// Later rounds (after each selection), ranked.
    pub later_rounds: Vec<Vec<Candidate>>,
    /// Effects not tried, with the reason.
    pub not_applicable: Vec<(String, String)>,
    /// Effect names in the order added.
    pub selected: Vec<String>,
    /// Details of each selected effect.
    pub selected_details: Vec<SelectedEffect>,
    /// Parameters of the final model.
    pub params: Vec<FittedParam>,
    /// Selected physical effects whose size rests on a form of the
    /// baseline being right.
    pub confounds: Vec<Confound>,
    /// Final RMSE on every sample (kPa).
    pub final_rmse_kpa: f64,
    /// Final held-out RMSE (kPa).
    pub final_heldout_rmse_kpa: f64,
    /// Noise floor (kPa).
    pub noise_floor_kpa: f64,
    /// Where the noise floor came from.
    pub noise_floor_source: String,
    /// A structured residual no library effect explains, described; null
    /// when the remaining residual looks like noise.
    pub unexplained: Option<String>,
    /// Physical effects that paid in their round but were taken out again
    /// because the residual stays unexplained and they took less than
    /// [`DiagnoseOptions::min_excess_explained_unexplained`] of what was
    /// left in their round.
    pub withdrawn: Vec<Withdrawn>,
    /// Readings left out of every fit and score as isolated spikes
    /// ([`crate::spikes`]), with their file and line.
    pub spikes: Vec<Spike>,
    /// The final residual, analysed.
    pub residual: ResidualReport,
    /// Samples in the folder / used for fitting.
    pub samples: [usize; 2],
}

impl Diagnosis {
    /// Every candidate scored, round by round in order, each round ranked.
    pub fn every_candidate(&self) -> impl DoubleEndedIterator<Item = &Candidate> {
        std::iter::once(&self.candidates)
            .chain(&self.later_rounds)
            .flatten()
    }
}

/// Training masks of the cross-validation folds. Where every depth has
/// two runs or more, whole runs are held out, never every run of one
/// depth (leaving out the only run at a depth would test how a depth law
/// extrapolates, not whether the model generalises). Otherwise each run
/// is cut into `k` contiguous time blocks and fold f holds out block
/// (f + run) mod k of every run: every fold still trains on every depth
/// and, across runs, on every phase.
fn folds(data: &Dataset, max_folds: usize) -> Vec<Vec<bool>> {
    let k = max_folds.max(2);
    let mut by_depth: Vec<(f64, usize)> = Vec::new();
    let mut rank = Vec::with_capacity(data.runs.len());
    for run in &data.runs {
        match by_depth.iter_mut().find(|(h, _)| *h == run.depth_mm) {
            Some((_, n)) => {
                rank.push(*n);
                *n += 1;
            }
            None => {
                rank.push(0);
                by_depth.push((run.depth_mm, 1));
            }
        }
    }
    let fewest = by_depth.iter().map(|d| d.1).min().unwrap_or(0);
    if fewest >= 2 {
        let most = by_depth.iter().map(|d| d.1).max().unwrap_or(0);
        let k = k.min(most);
        return (0..k)
            .map(|f| data.run_of.iter().map(|&r| rank[r] % k != f).collect())
            .collect();
    }
    (0..k)
        .map(|f| {
            (0..data.len())
                .map(|i| {
                    let r = data.run_of[i];
                    let (start, end) = (data.offsets[r], data.offsets[r + 1]);
                    let block = (i - start) * k / (end - start).max(1);
                    (block + r) % k != f
                })
                .collect()
        })
        .collect()
}

/// Held-out RMSE of a model, overall and in each fold (kPa).
#[derive(Clone, Debug, PartialEq)]
struct Heldout {
    overall: f64,
    folds: Vec<f64>,
}

impl Heldout {
    /// Folds in which `self` predicts better than `other`.
    fn better_folds(&self, other: &Heldout) -> usize {
        self.folds
            .iter()
            .zip(&other.folds)
            .filter(|(a, b)| a < b)
            .count()
    }
}

/// Held-out RMSE of `space` (warm start from `full`).
fn heldout(full: &Fit, data: &Dataset, masks: &[Vec<bool>], opts: &DiagnoseOptions) -> Heldout {
    // Short warm refits that score held-out error: forward differences.
    let cv = FitOptions {
        max_iterations: opts.cv_iterations,
        refine_central: false,
        ..opts.fit
    };
    let parts: Vec<(f64, usize)> = masks
        .par_iter()
        .map(|mask| {
            let theta = calibrate(&full.space, data, Some(mask), cv)
                .map(|f| f.theta)
                .unwrap_or_else(|_| full.theta.clone());
            let Ok(model) = full.space.model(&theta) else {
                return (f64::INFINITY, 1);
            };
            let pred = data.predict(&model);
            let (mut s, mut n) = (0.0, 0);
            for (i, (p, m)) in pred.iter().zip(&data.measured).enumerate() {
                if !mask[i] && !data.skip[i] {
                    s += (p - m) * (p - m);
                    n += 1;
                }
            }
            (s, n)
        })
        .collect();
    let s: f64 = parts.iter().map(|p| p.0).sum();
    let n: usize = parts.iter().map(|p| p.1).sum();
    Heldout {
        overall: (s / n.max(1) as f64).sqrt(),
        folds: parts
            .iter()
            .map(|(s, n)| (s / (*n).max(1) as f64).sqrt())
            .collect(),
    }
}

fn score(fit: &Fit, heldout_rmse_kpa: f64) -> ModelScore {
    ModelScore {
        effects: fit
            .space
            .effects
            .iter()
            .map(|e| e.spec.name.to_owned())
            .collect(),
        rmse_kpa: fit.rmse_kpa,
        heldout_rmse_kpa,
        bic: fit.bic(),
        params: fit.params.clone(),
    }
}

/// `fit` refined with `opts.polish` from where it stands; `fit` itself
/// where the refinement fails or ends higher.
fn polished(fit: Fit, data: &Dataset, opts: &DiagnoseOptions) -> Fit {
    match calibrate(&fit.space, data, None, opts.polish) {
        Ok(better) if better.ssr <= fit.ssr => better,
        _ => fit,
    }
}

/// Calibrates the model with `effects` on (starting from their values).
pub fn fit_effects(
    basis: &std::sync::Arc<RigBasis>,
    data: &Dataset,
    baseline: Params,
    effects: Vec<EffectInstance>,
    options: FitOptions,
) -> Result<Fit> {
    let space = FitSpace::new(basis.clone(), data, baseline, effects);
    calibrate(&space, data, None, options)
}

/// The noise floor (kPa) and where it came from: rig.toml's
/// `pressure_noise_kpa` when given, else estimated from the second
/// differences of residual `r` over `data`.
pub fn noise_floor(experiment: &Experiment, data: &Dataset, r: &[f64]) -> (f64, String) {
    match experiment.rig.measurement.pressure_noise_kpa {
        Some(s) if s > 0.0 => (s, "rig.toml measurement.pressure_noise_kpa".to_owned()),
        _ => (
            noise_floor_estimate(data, r),
            "estimated from second differences of the baseline residual".to_owned(),
        ),
    }
}

/// BIC lost by `fit` (over `data`'s fitted samples) when its last effect,
/// a physical one, is switched off and everything else stays as fitted.
/// Off is the primary parameter at 0 where its range holds 0, else at its
/// default (a gain's 1), as `model`'s `neutral_values_do_nothing` test
/// holds for every effect.
fn carried_bic(fit: &Fit, data: &Dataset) -> Option<f64> {
    let mut space = fit.space.clone();
    let last = space.effects.last_mut()?;
    let primary = last.spec.params.first()?;
    last.values[0] = if primary.lower <= 0.0 && primary.upper >= 0.0 {
        0.0
    } else {
        primary.default
    };
    let model = space.model(&space.start()).ok()?;
    let off: f64 = data
        .predict(&model)
        .iter()
        .zip(&data.measured)
        .zip(&data.skip)
        .filter(|(_, skip)| !**skip)
        .map(|((p, m), _)| (p - m) * (p - m))
        .sum();
    let n = fit.n.max(1) as f64;
    (off.is_finite() && fit.ssr > 0.0).then(|| n * (off / fit.ssr).ln())
}

/// Fits the physical effect of `effect_fit` together with the form of
/// `form_fit` onto `current` (warm, from both fits) and judges the effect
/// beside the form: ΔBIC and held-out gain against the form alone, as for
/// any candidate, held-out better in every fold but `spare_folds` (1 where
/// the form ranked first: the pair holds a form, which may be worse in one
/// fold; 0 where the effect did: then the effect is what is judged), none
/// of the effect's parameters on a bound. The change floor is not applied
/// again: a form that can take up the effect's signature leaves only a
/// small change to the effect, whose own fit against `current` has already
/// passed it (and, where the form ranked first, changed the reading by
/// [`DiagnoseOptions::challenge_change_factor`] noise floors).
#[allow(clippy::too_many_arguments)]
fn beside_form(
    basis: &std::sync::Arc<RigBasis>,
    data: &Dataset,
    masks: &[Vec<bool>],
    opts: &DiagnoseOptions,
    current: &Fit,
    (form_fit, form_heldout): (&Fit, &Heldout),
    effect_fit: &Fit,
    spare_folds: usize,
) -> Option<(Fit, Heldout, BesideForm)> {
    let form = form_fit.space.effects.last()?;
    let effect = effect_fit.space.effects.last()?;
    let mut effects = current.space.effects.clone();
    effects.push(form.clone());
    effects.push(effect.clone());
    let fit = fit_effects(basis, data, effect_fit.space.baseline, effects, opts.fit).ok()?;
    let h = heldout(&fit, data, masks, opts);
    let own = format!("{}.", effect.spec.name);
    let params: Vec<FittedParam> = fit
        .params
        .iter()
        .filter(|p| p.name.starts_with(&own))
        .cloned()
        .collect();
    let score = fit.bic() - form_fit.bic();
    let better = h.better_folds(form_heldout);
    let accepted = opts.gains(score, h.overall, form_heldout.overall)
        && better + opts.max_folds_worse + spare_folds >= h.folds.len()
        && !params.iter().any(|p| p.at_bound);
    let test = BesideForm {
        effect: effect.spec.name.to_owned(),
        form: form.spec.name.to_owned(),
        score,
        heldout_rmse_kpa: h.overall,
        form_heldout_rmse_kpa: form_heldout.overall,
        heldout_folds_better: [better, h.folds.len()],
        params,
        accepted,
    };
    Some((fit, h, test))
}

/// Starting points of a candidate's parameters: its defaults and, for an
/// effect that starts switched off (default on the lower bound), a probe
/// at 5 % of the range: a weak, partly confounded effect (a small bubble
/// looks like softer sand) can otherwise stall in a local minimum near zero.
fn starts(spec: &EffectSpec) -> Vec<Vec<f64>> {
    let defaults: Vec<f64> = spec.params.iter().map(|p| p.default).collect();
    let mut out = vec![defaults.clone()];
    if let Some(p) = spec.params.first() {
        if p.default <= p.lower {
            let mut probe = defaults;
            probe[0] = p.lower + 0.05 * (p.upper - p.lower);
            out.push(probe);
        }
    }
    out
}

/// Diagnoses `experiment`.
pub fn diagnose(experiment: &Experiment, opts: &DiagnoseOptions) -> Result<Diagnosis> {
    let basis = RigBasis::new(&experiment.rig)?;
    let all = Dataset::new(experiment);
    anyhow::ensure!(!all.is_empty(), "the experiment has no samples");
    // Spikes are first looked for against the baseline, then confirmed
    // against the model the diagnosis ends with: a sharp feature of a
    // missing effect (friction reversing with the flow) stands out of the
    // baseline's residual but not out of the right model's, and stays in.
    let base = fit_effects(
        &basis,
        &all.thinned(MAX_FIT_SAMPLES),
        Params::default(),
        Vec::new(),
        opts.fit,
    )?;
    let (r, _) = residual(&all, &base.model()?);
    let mut skipped = spikes::find(experiment, &all, &r);
    // Without spikes, the baseline just fitted is the diagnosis' own.
    let mut prefit = skipped.is_empty().then_some(base);
    let mut tries = 0;
    loop {
        let (diagnosis, model) =
            diagnose_skipping(experiment, &basis, &all, &skipped, prefit.take(), opts)?;
        if skipped.is_empty() || tries == 1 {
            return Ok(diagnosis);
        }
        let (r, _) = residual(&all, &model);
        let confirmed = spikes::find(experiment, &all, &r);
        let at = |s: &[(usize, Spike)]| s.iter().map(|(k, _)| *k).collect::<Vec<_>>();
        if at(&confirmed) == at(&skipped) {
            return Ok(diagnosis);
        }
        skipped = confirmed;
        tries += 1;
    }
}

/// [`diagnose`] with the samples `skipped` (spikes) left out of every fit
/// and score, starting from `base_fit` when the caller has the baseline
/// fitted to these samples already; with the final model.
fn diagnose_skipping(
    experiment: &Experiment,
    basis: &std::sync::Arc<RigBasis>,
    all: &Dataset,
    skipped: &[(usize, Spike)],
    base_fit: Option<Fit>,
    opts: &DiagnoseOptions,
) -> Result<(Diagnosis, RigModel)> {
    let mut all = all.clone();
    for (k, _) in skipped {
        all.skip[*k] = true;
    }
    let data = all.thinned(MAX_FIT_SAMPLES);
    let masks = folds(&data, opts.max_folds);
    let base_fit = match base_fit {
        Some(fit) => fit,
        None => fit_effects(basis, &data, Params::default(), Vec::new(), opts.fit)?,
    };
    let spikes: Vec<Spike> = skipped.iter().map(|(_, s)| s.clone()).collect();
    let (base_r, _) = residual(&all, &base_fit.model()?);
    let kept = all.kept();
    let base_r: Vec<f64> = all.used().map(|i| base_r[i]).collect();
    let (noise, noise_source) = noise_floor(experiment, &kept, &base_r);
    let base_heldout = heldout(&base_fit, &data, &masks, opts);
    let baseline = score(&base_fit, base_heldout.overall);

    let mut not_applicable = Vec::new();
    let applicable: Vec<&'static EffectSpec> = REGISTRY
        .iter()
        .copied()
        .filter(|s| match (s.not_applicable)(&experiment.rig) {
            Some(why) => {
                not_applicable.push((s.name.to_owned(), why.to_owned()));
                false
            }
            None => true,
        })
        .collect();

    let mut current = base_fit;
    let mut current_heldout = base_heldout;
    let mut rounds: Vec<Vec<Candidate>> = Vec::new();
    let mut selected: Vec<String> = Vec::new();
    let mut physical = 0;
    // Found in the round that adds nothing: scored against the final model.
    let mut final_confounds = Vec::new();
    // Each candidate's own values where its last round's fit left them:
    // a round later it also starts there, since the fit from the effect's
    // defaults beside the round's new member can stall where that member
    // took the effect's part (a stated skin's scale taking a bubble's).
    let mut last_values: Vec<(&'static str, Vec<f64>)> = Vec::new();
    loop {
        let on: Vec<&str> = current.space.effects.iter().map(|e| e.spec.name).collect();
        let tries: Vec<&'static EffectSpec> = applicable
            .iter()
            .copied()
            .filter(|s| !on.contains(&s.name))
            .collect();
        if tries.is_empty() {
            break;
        }
        let excess = (current.rmse_kpa.powi(2) - noise * noise).max(1e-12);
        // The share of that excess a fit with RMSE `rmse` removes.
        let explained = |rmse: f64| (current.rmse_kpa.powi(2) - rmse.powi(2)) / excess;
        let current_bic = current.bic();
        let mut fits: Vec<(Fit, Candidate)> = tries
            .par_iter()
            .filter_map(|spec| {
                let mut from = starts(spec);
                if let Some((_, v)) = last_values.iter().find(|(n, _)| *n == spec.name) {
                    if !from.contains(v) {
                        from.push(v.clone());
                    }
                }
                let fit = from
                    .into_iter()
                    .filter_map(|values| {
                        let mut effects = current.space.effects.clone();
                        effects.push(EffectInstance { spec, values });
                        fit_effects(basis, &data, current.space.baseline, effects, opts.fit).ok()
                    })
                    .min_by(|a, b| a.ssr.total_cmp(&b.ssr))?;
                let own = format!("{}.", spec.name);
                let at_bound = fit
                    .params
                    .iter()
                    .filter(|p| p.at_bound && p.name.starts_with(&own))
                    .map(|p| p.name.clone())
                    .collect();
                let indistinct = fit
                    .space
                    .effects
                    .last()
                    .and_then(|e| (spec.indistinct)(&experiment.rig, &e.values))
                    .map(str::to_owned);
                // How much the effect changes the model's reading: both
                // residuals are over the same fitted samples.
                let change_sq: f64 = fit
                    .residuals_kpa
                    .iter()
                    .zip(&current.residuals_kpa)
                    .map(|(a, b)| (a - b) * (a - b))
                    .sum();
                let change_rms_kpa = (change_sq / fit.residuals_kpa.len().max(1) as f64).sqrt();
                let cand = Candidate {
                    effect: spec.name.to_owned(),
                    rmse_kpa: fit.rmse_kpa,
                    heldout_rmse_kpa: None,
                    heldout_folds_better: None,
                    bic: fit.bic(),
                    score: fit.bic() - current_bic,
                    excess_explained: explained(fit.rmse_kpa),
                    params: fit.params.clone(),
                    at_bound,
                    indistinct,
                    change_rms_kpa,
                    refusals: Vec::new(),
                    beside_form: None,
                    carried_bic: (!spec.kind.is_baseline_form())
                        .then(|| carried_bic(&fit, &data))
                        .flatten(),
                };
                Some((fit, cand))
            })
            .collect();
        fits.sort_by(|a, b| a.1.score.total_cmp(&b.1.score));
        last_values = fits
            .iter()
            .filter_map(|(f, _)| f.space.effects.last())
            .map(|e| (e.spec.name, e.values.clone()))
            .collect();
        // The best few of each kind (forms of the baseline, physical
        // effects) are cross-validated; the best admissible one by ΔBIC is
        // taken.
        let (mut forms_seen, mut effects_seen) = (0, 0);
        let mut best: Option<(Fit, Heldout)> = None;
        // The best physical effect that pays on every count and changes
        // the reading by `challenge_change_factor` noise floors, when a
        // form ranks above it.
        let mut challenger: Option<(Fit, Heldout)> = None;
        // The best form that pays on every count when a physical effect
        // ranks above it: the effect must then earn its place beside it.
        let mut rival: Option<(Fit, Heldout)> = None;
        for (fit, cand) in fits.iter_mut() {
            let form = fit
                .space
                .effects
                .last()
                .is_some_and(|e| e.spec.kind.is_baseline_form());
            // A form may be worse in one fold more than an effect.
            let folds_worse = opts.max_folds_worse + usize::from(form);
            let seen = if form {
                &mut forms_seen
            } else {
                &mut effects_seen
            };
            let mut held = None;
            if *seen < opts.cv_top {
                *seen += 1;
                let h = heldout(fit, &data, &masks, opts);
                cand.heldout_rmse_kpa = Some(h.overall);
                cand.heldout_folds_better = Some([h.better_folds(&current_heldout), h.folds.len()]);
                held = Some(h);
            }
            cand.refusals = cand.own_refusals(
                form,
                opts.min_change_factor * noise,
                folds_worse,
                -opts.max_delta_bic,
            );
            let Some(h) = held else { continue };
            let pays = opts.gains(cand.score, h.overall, current_heldout.overall)
                && cand.excess_explained >= opts.min_excess_explained
                && cand.refusals.is_empty()
                && (form || physical < opts.max_effects);
            if pays && best.is_none() {
                best = Some((fit.clone(), h));
            } else if pays && form && rival.is_none() {
                rival = Some((fit.clone(), h));
            } else if pays
                && !form
                && challenger.is_none()
                && cand.change_rms_kpa >= opts.challenge_change_factor * noise
            {
                challenger = Some((fit.clone(), h));
            }
        }
        let mut added = 1;
        // A form can take up a physical effect's signature (a skin curve
        // that stiffens sooner holds the volume a bubble would): a strong
        // effect that pays on every count but ranks below the best form
        // is fitted together with it, and the two are added when the data
        // keep the effect beside the form.
        //
        // The same question the other way round: a skin or sand that is
        // not the model's can look like an effect (a skin law that unloads
        // differently looks like stress softening). When an effect ranks
        // first and a form also pays, the effect is fitted beside the form
        // and judged as an effect, better in every fold: it is added (alone:
        // the form must then pay on its own in the next round) if it keeps
        // its gain there, else the form is added instead, and the effect may
        // come back in a later round.
        let best_is_form = best.as_ref().is_some_and(|(f, _)| {
            f.space
                .effects
                .last()
                .is_some_and(|e| e.spec.kind.is_baseline_form())
        });
        // (the form, the effect, folds the pair may lose beyond an
        // effect's, whether the form ranked first)
        let contest = match (best_is_form, &best, &challenger, &rival) {
            (true, Some(form), Some(effect), _) => Some((form, effect, 1, true)),
            (false, Some(effect), _, Some(form)) => Some((form, effect, 0, false)),
            _ => None,
        };
        if let Some(((form_fit, form_heldout), (effect_fit, _), spare, form_first)) = contest {
            if let Some((fit, h, test)) = beside_form(
                basis,
                &data,
                &masks,
                opts,
                &current,
                (form_fit, form_heldout),
                effect_fit,
                spare,
            ) {
                if let Some(c) = fits.iter_mut().find(|f| f.1.effect == test.effect) {
                    c.1.beside_form = Some(test.clone());
                }
                match (form_first, test.accepted) {
                    (true, true) => {
                        best = Some((fit, h));
                        added = 2;
                    }
                    (false, false) => best = rival.clone(),
                    _ => {}
                }
            }
        }
        // A sand and a skin that are not the model's can need several
        // forms, each taking its own part of the misfit: when no single
        // candidate pays, the two best forms that pay on every count but
        // the excess explained are judged together.
        if best.is_none() {
            let pays_but_excess = |f: &(Fit, Candidate)| {
                f.1.refusals.is_empty()
                    && f.1
                        .heldout_rmse_kpa
                        .is_some_and(|h| opts.gains(f.1.score, h, current_heldout.overall))
                    && f.0
                        .space
                        .effects
                        .last()
                        .is_some_and(|e| e.spec.kind.is_baseline_form())
            };
            let pair: Vec<&(Fit, Candidate)> =
                fits.iter().filter(|f| pays_but_excess(f)).take(2).collect();
            if let [a, b] = pair[..] {
                let mut effects = current.space.effects.clone();
                effects.extend(a.0.space.effects.last().cloned());
                effects.extend(b.0.space.effects.last().cloned());
                if let Ok(fit) =
                    fit_effects(basis, &data, current.space.baseline, effects, opts.fit)
                {
                    let h = heldout(&fit, &data, &masks, opts);
                    let own_bound = fit.params.iter().any(|p| {
                        p.at_bound
                            && [&a.1.effect, &b.1.effect]
                                .iter()
                                .any(|e| p.name.starts_with(&format!("{e}.")))
                    });
                    let pays =
                        opts.gains(fit.bic() - current_bic, h.overall, current_heldout.overall)
                            && h.better_folds(&current_heldout) + opts.max_folds_worse + 1
                                >= h.folds.len()
                            && explained(fit.rmse_kpa) >= opts.min_excess_explained
                            && !own_bound;
                    if pays {
                        best = Some((fit, h));
                        added = 2;
                    }
                }
            }
        }
        rounds.push(fits.iter().map(|f| f.1.clone()).collect());
        match best {
            Some((fit, h)) => {
                let new = &fit.space.effects[fit.space.effects.len() - added..];
                for e in new {
                    if !e.spec.kind.is_baseline_form() {
                        physical += 1;
                    }
                    selected.push(e.spec.name.to_owned());
                }
                current = polished(fit, &data, opts);
                current_heldout = h;
            }
            None => {
                // A form that pays in BIC and in the folds but fell short of
                // the held-out gain or the excess explained (near the noise
                // floor every gain is small) still goes in when a selected
                // effect's size depends on it: with it, the effect's primary
                // leaves its own 95 % interval.
                let last = rounds.last().map_or(&[][..], Vec::as_slice);
                let admissible = |c: &Candidate| {
                    c.refusals.is_empty()
                        && c.score <= opts.max_delta_bic
                        && c.heldout_folds_better
                            .is_some_and(|[b, n]| b + opts.max_folds_worse + 1 >= n)
                };
                let found = confounds(&current, last, opts.separable_precision, opts.max_delta_bic);
                let form_fit = found
                    .iter()
                    .filter(|c| c.interval_95_with_form.is_some())
                    .find_map(|c| {
                        fits.iter()
                            .find(|f| f.1.effect == c.form && admissible(&f.1))
                    });
                match form_fit {
                    Some((fit, cand)) => {
                        current_heldout = heldout(fit, &data, &masks, opts);
                        selected.push(cand.effect.clone());
                        current = polished(fit.clone(), &data, opts);
                    }
                    None => {
                        final_confounds = found;
                        break;
                    }
                }
            }
        }
    }

    let final_report = |fit: &Fit| -> Result<(RigModel, ResidualReport, Option<String>)> {
        let model = fit.model()?;
        let (r, preds) = residual(&all, &model);
        let r: Vec<f64> = all.used().map(|i| r[i]).collect();
        let preds: Vec<_> = all.used().map(|i| preds[i]).collect();
        let report = analyse(&kept, &r, &preds);
        let unexplained = unexplained(&report, noise);
        Ok((model, report, unexplained))
    };
    let (mut final_model, mut report, mut unexplained) = final_report(&current)?;
    // With the residual left unexplained, something outside the library
    // is at work, and a physical effect that took only a minority of what
    // was left in its round may be that something's partner in the fit
    // rather than a cause (a slow drift of the zero that a relaxing skin
    // follows part of the time): it is withdrawn and reported as such.
    let mut withdrawn = Vec::new();
    if unexplained.is_some() {
        let minor: Vec<Withdrawn> = current
            .space
            .effects
            .iter()
            .filter(|e| !e.spec.kind.is_baseline_form())
            .filter_map(|e| {
                // Its round is the last in which it was a candidate.
                let share = rounds
                    .iter()
                    .rev()
                    .flatten()
                    .find(|c| c.effect == e.spec.name)?
                    .excess_explained;
                (share < opts.min_excess_explained_unexplained).then(|| Withdrawn {
                    effect: e.spec.name.to_owned(),
                    excess_explained: share,
                })
            })
            .collect();
        if !minor.is_empty() {
            let out = |name: &str| minor.iter().any(|w| w.effect == name);
            let effects: Vec<EffectInstance> = current
                .space
                .effects
                .iter()
                .filter(|e| !out(e.spec.name))
                .cloned()
                .collect();
            let fit = fit_effects(basis, &data, current.space.baseline, effects, opts.fit)?;
            current_heldout = heldout(&fit, &data, &masks, opts);
            current = polished(fit, &data, opts);
            selected.retain(|s| !out(s));
            final_confounds.retain(|c: &Confound| !out(&c.effect));
            (final_model, report, unexplained) = final_report(&current)?;
            withdrawn = minor;
        }
    }
    let final_rmse = report.overall.rmse_kpa;
    let selected_details = selected
        .iter()
        .filter_map(|name| {
            let spec = EffectSpec::by_name(name).ok()?;
            let prefix = format!("{name}.");
            let params: Vec<FittedParam> = current
                .params
                .iter()
                .filter(|p| p.name.starts_with(&prefix))
                .cloned()
                .collect();
            let baseline_form = match spec.kind {
                EffectKind::BaselineForm { words, .. } => {
                    Some(words(&params.iter().map(|p| p.value).collect::<Vec<_>>()))
                }
                EffectKind::Physical => None,
            };
            Some(SelectedEffect {
                effect: name.clone(),
                params,
                signature: spec.signature.to_owned(),
                baseline_form,
            })
        })
        .collect();
    let mut rounds = rounds.into_iter();
    let diagnosis = Diagnosis {
        baseline,
        candidates: rounds.next().unwrap_or_default(),
        later_rounds: rounds.collect(),
        not_applicable,
        selected,
        selected_details,
        params: current.params.clone(),
        confounds: final_confounds,
        final_rmse_kpa: final_rmse,
        final_heldout_rmse_kpa: current_heldout.overall,
        noise_floor_kpa: noise,
        noise_floor_source: noise_source,
        unexplained,
        withdrawn,
        spikes,
        residual: report,
        samples: [all.len(), data.len()],
    };
    Ok((diagnosis, final_model))
}

/// The selected physical effects of `current` whose primary parameter is
/// determined to `precision` (a fraction of its value, either side, at
/// 95 %) in `current` but, in a fit of `last` (the round scored against
/// `current`) that adds a form of the baseline, either not determined so,
/// or moved by more than `precision` and out of that fit's 95 % interval
/// by a form that scores ΔBIC `max_delta_bic` or better.
fn confounds(
    current: &Fit,
    last: &[Candidate],
    precision: f64,
    max_delta_bic: f64,
) -> Vec<Confound> {
    let determined = |p: &FittedParam| {
        p.interval_95
            .is_some_and(|[a, b]| b - a <= 2.0 * precision * p.value.abs())
    };
    let mut out = Vec::new();
    for effect in &current.space.effects {
        let (spec, Some(primary)) = (effect.spec, effect.spec.params.first()) else {
            continue;
        };
        if spec.kind.is_baseline_form() {
            continue;
        }
        let name = format!("{}.{}", spec.name, primary.name);
        let Some(alone) = current.params.iter().find(|p| p.name == name) else {
            continue;
        };
        if !determined(alone) {
            continue;
        }
        for cand in last {
            let Ok(form) = EffectSpec::by_name(&cand.effect) else {
                continue;
            };
            let EffectKind::BaselineForm { tells_apart, .. } = form.kind else {
                continue;
            };
            let Some(with) = cand.params.iter().find(|p| p.name == name) else {
                continue;
            };
            // Moved: out of the fit's own interval and by more than the
            // precision (a precise effect moves out of its narrow interval
            // beside any form that pays a little).
            let moved = cand.score <= max_delta_bic
                && (with.value - alone.value).abs() > precision * alone.value.abs()
                && with
                    .interval_95
                    .is_some_and(|[a, b]| !(a..=b).contains(&alone.value));
            if !determined(with) || moved {
                out.push(Confound {
                    effect: spec.name.to_owned(),
                    param: name.clone(),
                    value: alone.value,
                    interval_95: alone.interval_95,
                    form: form.name.to_owned(),
                    value_with_form: with.value,
                    interval_95_with_form: with.interval_95,
                    form_score: cand.score,
                    tells_apart: tells_apart.to_owned(),
                });
            }
        }
    }
    out
}

/// A description of the remaining residual when it is structured (well
/// above the noise floor, autocorrelated, too few sign changes), else
/// `None`.
pub fn unexplained(rep: &ResidualReport, noise_kpa: f64) -> Option<String> {
    let structured = rep.overall.rmse_kpa > 1.25 * noise_kpa
        && rep.lag1_autocorrelation > 0.3
        && rep.runs_test_z < -4.0;
    if !structured {
        return None;
    }
    let c = &rep.correlations;
    let mut how = Vec::new();
    if c.time.abs() > 0.5 {
        how.push(format!(
            "{} linearly with time (correlation {:+.2})",
            if c.time > 0.0 { "grows" } else { "falls" },
            c.time
        ));
    }
    for (what, r) in [
        ("flow rate", c.flow),
        ("pumped volume", c.volume),
        ("pressure", c.pressure),
        ("depth", c.depth),
    ] {
        if r.abs() > 0.5 {
            how.push(format!("follows {what} (correlation {r:+.2})"));
        }
    }
    if how.is_empty() {
        how.push(format!(
            "varies slowly in time (lag-1 autocorrelation {:.2}) without following flow, volume, pressure, depth or time linearly (all |r| ≤ 0.5)",
            rep.lag1_autocorrelation
        ));
    }
    Some(format!(
        "unexplained residual of RMSE {:.3} kPa ({:.1}× the noise floor) that {}; runs test z = {:.1}. No library effect removes it.",
        rep.overall.rmse_kpa,
        rep.overall.rmse_kpa / noise_kpa.max(1e-12),
        how.join(" and "),
        rep.runs_test_z
    ))
}
