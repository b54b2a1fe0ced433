//! The library side of `host-sim compare`, `diagnose` and `ledger`: read
//! the folder, calibrate, analyse, write results (atomically) into the
//! folder — `model.toml`, `ledger.json`, and plots and JSON under
//! `workbench/` (a subfolder, so no result is mistaken for measurements).

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use serde::Serialize;

use super::calibrate::{Fit, FitOptions, FittedParam};
use super::dataset::{Dataset, MAX_FIT_SAMPLES};
use super::diagnose::{diagnose, fit_effects, noise_floor, DiagnoseOptions, Diagnosis};
use super::model_file::{append_ledger, read_ledger, LedgerEntry, ModelFile};
use super::plot::{chart_svg, Series};
use super::residuals::{analyse, residual, ResidualReport};
use super::spikes::{self, Spike};
use datafile::write_atomic;
use model::effects::EffectInstance;
use model::{Params, RigBasis};
use rig::Experiment;

/// Subfolder of the experiment folder for the workbench's outputs.
pub const OUTPUT_DIR: &str = "workbench";

/// What `compare` found.
#[derive(Clone, Debug, Serialize)]
pub struct Comparison {
    /// Effects in the model compared (from model.toml; none = baseline).
    pub effects: Vec<String>,
    /// Calibrated parameters.
    pub params: Vec<FittedParam>,
    /// The residual.
    pub residual: ResidualReport,
    /// Noise floor (kPa) and its source.
    pub noise_floor_kpa: f64,
    /// Where the noise floor came from.
    pub noise_floor_source: String,
    /// Readings left out of the fit as isolated spikes, with their place.
    pub spikes: Vec<Spike>,
    /// Files written.
    pub files: Vec<PathBuf>,
    /// What reading the skin found (`--skin-fit` replacing `[skin]`).
    pub warnings: Vec<String>,
}

/// The experiment folder `dir`, its skin replaced by the law of
/// `skin_fit` when given ([`rig::Rig::use_skin_fit`]); with the warnings
/// that gives.
pub fn read_experiment(
    dir: &Path,
    skin_fit: Option<&skin::SkinFitChoice>,
) -> Result<(Experiment, Vec<String>)> {
    let mut exp = Experiment::read(dir)?;
    let mut warnings = Vec::new();
    if let Some(choice) = skin_fit {
        let rig_file = dir.join("rig.toml").display().to_string();
        warnings = exp.rig.use_skin_fit(choice.read()?, &rig_file);
    }
    Ok((exp, warnings))
}

/// The model with `effects` fitted to `exp`; isolated spikes against it
/// ([`crate::spikes`]) are left out and the model refitted without them.
/// Returns the fit, every sample (spikes marked skipped) and the spikes.
fn calibrated(
    exp: &Experiment,
    effects: Vec<EffectInstance>,
) -> Result<(Fit, Dataset, Vec<Spike>)> {
    let basis = RigBasis::new(&exp.rig)?;
    let mut all = Dataset::new(exp);
    anyhow::ensure!(!all.is_empty(), "the experiment has no samples");
    let fit_on = |data: &Dataset| {
        fit_effects(
            &basis,
            &data.thinned(MAX_FIT_SAMPLES),
            Params::default(),
            effects.clone(),
            FitOptions::default(),
        )
    };
    let fit = fit_on(&all)?;
    let (r, _) = residual(&all, &fit.model()?);
    let found = spikes::find(exp, &all, &r);
    if found.is_empty() {
        return Ok((fit, all, Vec::new()));
    }
    for (k, _) in &found {
        all.skip[*k] = true;
    }
    let fit = fit_on(&all)?;
    Ok((fit, all, found.into_iter().map(|(_, s)| s).collect()))
}

fn file_safe(id: &str) -> String {
    id.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// `host-sim compare DIR`: calibrates the model of `model.toml` (the
/// baseline without one), analyses the residual, writes
/// `workbench/compare.json`, one `run-<id>.svg` per run (measured and
/// model vs time) and `residual-vs-<input>.svg` per input.
pub fn compare(dir: &Path) -> Result<Comparison> {
    compare_with(dir, None)
}

/// [`compare`] with the skin of `skin_fit` (`--skin-fit`) instead of the
/// folder's `[skin]`, when given.
pub fn compare_with(dir: &Path, skin_fit: Option<&skin::SkinFitChoice>) -> Result<Comparison> {
    let (exp, warnings) = read_experiment(dir, skin_fit)?;
    let effects = match ModelFile::read(dir)? {
        Some(m) => m.instances()?,
        None => Vec::new(),
    };
    let (fit, all, spikes) = calibrated(&exp, effects)?;
    let model = fit.model()?;
    let (r, preds) = residual(&all, &model);
    let kept = all.kept();
    let kept_r: Vec<f64> = all.used().map(|i| r[i]).collect();
    let kept_preds: Vec<_> = all.used().map(|i| preds[i]).collect();
    let report = analyse(&kept, &kept_r, &kept_preds);
    let (noise, source) = noise_floor(&exp, &kept, &kept_r);
    let out = dir.join(OUTPUT_DIR);
    let mut files = Vec::new();
    for (i, run) in all.runs.iter().enumerate() {
        let span = all.offsets[i]..all.offsets[i + 1];
        let measured: Vec<(f64, f64)> = run
            .samples
            .iter()
            .map(|s| (s.t_s, s.pressure_kpa))
            .collect();
        let modelled: Vec<(f64, f64)> = run
            .samples
            .iter()
            .zip(&preds[span])
            .map(|(s, p)| (s.t_s, p.sensor_kpa))
            .collect();
        let svg = chart_svg(
            &format!(
                "run {} (depth {} mm): measured vs model",
                run.id, run.depth_mm
            ),
            "time (s)",
            "pressure (kPa)",
            &[
                Series {
                    label: "measured",
                    points: &measured,
                    line: true,
                },
                Series {
                    label: "model",
                    points: &modelled,
                    line: true,
                },
            ],
        )?;
        let path = out.join(format!("run-{}.svg", file_safe(&run.id)));
        write_atomic(&path, svg.as_bytes())?;
        files.push(path);
    }
    let samples = || all.runs.iter().flat_map(|r| r.samples.iter());
    let inputs: [(&str, &str, Vec<f64>); 5] = [
        (
            "time",
            "time since run start (s)",
            samples().map(|s| s.t_s).collect(),
        ),
        (
            "volume",
            "pump volume (mL)",
            samples().map(|s| s.volume_ml).collect(),
        ),
        (
            "flow",
            "pump flow (mL/s)",
            preds.iter().map(|p| p.pump_flow_ml_s).collect(),
        ),
        (
            "pressure",
            "model reading (kPa)",
            preds.iter().map(|p| p.sensor_kpa).collect(),
        ),
        (
            "depth",
            "depth (mm)",
            all.run_of.iter().map(|&i| all.runs[i].depth_mm).collect(),
        ),
    ];
    for (name, label, x) in inputs {
        let pts: Vec<(f64, f64)> = x.iter().copied().zip(r.iter().copied()).collect();
        let svg = chart_svg(
            &format!("residual (measured − model) vs {name}"),
            label,
            "residual (kPa)",
            &[Series {
                label: "residual",
                points: &pts,
                line: false,
            }],
        )?;
        let path = out.join(format!("residual-vs-{name}.svg"));
        write_atomic(&path, svg.as_bytes())?;
        files.push(path);
    }
    let cmp = Comparison {
        effects: fit
            .space
            .effects
            .iter()
            .map(|e| e.spec.name.to_owned())
            .collect(),
        params: fit.params.clone(),
        residual: report,
        noise_floor_kpa: noise,
        noise_floor_source: source,
        spikes,
        files: files.clone(),
        warnings,
    };
    let path = out.join("compare.json");
    write_atomic(&path, serde_json::to_string_pretty(&cmp)?.as_bytes())?;
    let mut cmp = cmp;
    cmp.files.push(path);
    Ok(cmp)
}

/// What `diagnose` did.
#[derive(Debug)]
pub enum DiagnoseOutcome {
    /// The full diagnosis (written to `workbench/diagnosis.json`).
    Diagnosis(Box<Diagnosis>),
    /// `--add`: the refitted model and the ledger after it.
    Added {
        /// The new model file.
        model: ModelFile,
        /// The fit.
        params: Vec<FittedParam>,
        /// The whole ledger, newest last.
        ledger: Vec<LedgerEntry>,
    },
}

fn now_s() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs())
}

/// Refits `effects`, writes model.toml at the next version and appends
/// the ledger.
fn refit_and_record(
    dir: &Path,
    exp: &Experiment,
    effects: Vec<EffectInstance>,
    version: u32,
) -> Result<DiagnoseOutcome> {
    let (fit, all, _) = calibrated(exp, effects)?;
    let (r, _) = residual(&all, &fit.model()?);
    let kept = all.kept();
    let r: Vec<f64> = all.used().map(|i| r[i]).collect();
    let rmse = (r.iter().map(|x| x * x).sum::<f64>() / r.len().max(1) as f64).sqrt();
    let (noise, _) = noise_floor(exp, &kept, &r);
    let model = ModelFile::of_fit(&fit, version);
    model.write(dir)?;
    let ledger = append_ledger(
        dir,
        LedgerEntry {
            version,
            effects: model.effects.clone(),
            rmse_kpa: rmse,
            bic: fit.bic(),
            free_params: fit.k(),
            noise_floor_kpa: noise,
            unix_time_s: now_s(),
            skin: exp.rig.skin_description(),
        },
    )?;
    Ok(DiagnoseOutcome::Added {
        model,
        params: fit.params,
        ledger,
    })
}

/// `host-sim diagnose DIR [--add EFFECT]`. Without `add`: the full
/// diagnosis, written to `workbench/diagnosis.json`; a hand-edited
/// model.toml (effects unlike the ledger's last entry), or a folder with no
/// ledger yet, is refitted and recorded first. With `add`: the effect joins
/// model.toml's, the model is refitted, and the ledger gets the new version.
pub fn diagnose_folder(
    dir: &Path,
    add: Option<&str>,
    options: &DiagnoseOptions,
) -> Result<DiagnoseOutcome> {
    diagnose_folder_with(dir, add, None, options).map(|(outcome, _)| outcome)
}

/// [`diagnose_folder`] with the skin of `skin_fit` (`--skin-fit`) instead
/// of the folder's `[skin]`, when given; with the warnings that gives. The
/// ledger records each version's skin; a skin other than its last
/// entry's is warned of (versions fitted with different skins do not
/// compare).
pub fn diagnose_folder_with(
    dir: &Path,
    add: Option<&str>,
    skin_fit: Option<&skin::SkinFitChoice>,
    options: &DiagnoseOptions,
) -> Result<(DiagnoseOutcome, Vec<String>)> {
    let (exp, mut warnings) = read_experiment(dir, skin_fit)?;
    let skin = exp.rig.skin_description();
    let ledger = read_ledger(dir)?;
    if let Some(last) = ledger.last() {
        if !last.skin.is_empty() && last.skin != skin {
            warnings.push(format!(
                "the ledger's version {} was fitted with {}; this one uses {}: their errors do not compare",
                last.version, last.skin, skin
            ));
        }
    }
    let outcome = diagnose_experiment(dir, &exp, &ledger, add, options)?;
    Ok((outcome, warnings))
}

/// The diagnosis of `exp` in `dir`, whose ledger reads `ledger`.
fn diagnose_experiment(
    dir: &Path,
    exp: &Experiment,
    ledger: &[LedgerEntry],
    add: Option<&str>,
    options: &DiagnoseOptions,
) -> Result<DiagnoseOutcome> {
    let current = ModelFile::read(dir)?.unwrap_or_default();
    if let Some(name) = add {
        let mut file = current.clone();
        anyhow::ensure!(
            !file.effects.iter().any(|e| e == name),
            "effect `{name}` is already in {}",
            super::model_file::MODEL_FILE
        );
        file.effects.push(name.to_owned());
        let effects = file.instances().with_context(|| format!("--add {name}"))?;
        if let Some(why) = (effects.last().map(|e| e.spec.not_applicable)).and_then(|f| f(&exp.rig))
        {
            anyhow::bail!("effect `{name}` cannot act in this rig: {why}");
        }
        let version = ledger
            .iter()
            .map(|e| e.version)
            .max()
            .map_or(current.version, |v| v.max(current.version))
            + 1;
        return refit_and_record(dir, exp, effects, version);
    }
    let recorded = ledger.last().map(|e| e.effects.clone());
    if recorded.as_ref() != Some(&current.effects) {
        let version = ledger
            .iter()
            .map(|e| e.version + 1)
            .max()
            .unwrap_or(current.version);
        refit_and_record(dir, exp, current.instances()?, version)?;
    }
    let d = diagnose(exp, options)?;
    write_atomic(
        &dir.join(OUTPUT_DIR).join("diagnosis.json"),
        serde_json::to_string_pretty(&d)?.as_bytes(),
    )?;
    Ok(DiagnoseOutcome::Diagnosis(Box::new(d)))
}

/// `host-sim ledger DIR`: the ledger, and `workbench/ledger.svg` plotting
/// RMSE per version against the noise floor.
pub fn ledger(dir: &Path) -> Result<(Vec<LedgerEntry>, PathBuf)> {
    let entries = read_ledger(dir)?;
    anyhow::ensure!(
        !entries.is_empty(),
        "{}: no ledger yet (run `host-sim diagnose` first)",
        dir.join(super::model_file::LEDGER_FILE).display()
    );
    let rmse: Vec<(f64, f64)> = entries
        .iter()
        .map(|e| (f64::from(e.version), e.rmse_kpa))
        .collect();
    let noise: Vec<(f64, f64)> = entries
        .iter()
        .map(|e| (f64::from(e.version), e.noise_floor_kpa))
        .collect();
    let svg = chart_svg(
        "model error per version",
        "model version",
        "RMSE (kPa)",
        &[
            Series {
                label: "RMSE",
                points: &rmse,
                line: true,
            },
            Series {
                label: "noise floor",
                points: &noise,
                line: true,
            },
        ],
    )?;
    let path = dir.join(OUTPUT_DIR).join("ledger.svg");
    write_atomic(&path, svg.as_bytes())?;
    Ok((entries, path))
}

/// A number with 4 significant-ish digits, small ones in e-notation.
fn num(x: f64) -> String {
    if x != 0.0 && x.abs() < 1e-2 {
        format!("{x:.3e}")
    } else {
        format!("{x:.4}")
    }
}

fn params_text(params: &[FittedParam]) -> String {
    let mut s = String::new();
    for p in params {
        let se = match (p.std_error, p.interval_95) {
            (Some(e), Some([a, b])) => format!("± {}  (95 %: {} … {})", num(e), num(a), num(b)),
            _ => "(not determined by the data)".to_owned(),
        };
        s += &format!(
            "  {:<40} {:>12} {:<10} {se}{}\n",
            p.name,
            num(p.value),
            p.unit,
            if p.at_bound { "  [at bound]" } else { "" }
        );
    }
    s
}

fn groups_text(title: &str, groups: &[super::residuals::GroupStat]) -> String {
    let mut s = format!("  by {title}:\n");
    for g in groups {
        s += &format!(
            "    {:<24} n={:<7} mean {:+.4} kPa  rmse {:.4} kPa\n",
            g.group, g.n, g.mean_kpa, g.rmse_kpa
        );
    }
    s
}

fn residual_text(r: &ResidualReport) -> String {
    let mut s = String::new();
    s += &groups_text("run", &r.by_run);
    s += &groups_text("depth", &r.by_depth);
    s += &groups_text("flow rate", &r.by_flow);
    s += &groups_text("phase", &r.by_phase);
    for line in &r.sentences {
        s += &format!("  {line}\n");
    }
    s
}

impl Comparison {
    /// Human-readable report.
    pub fn text(&self) -> String {
        let mut s: String = self
            .warnings
            .iter()
            .map(|w| format!("warning: {w}\n"))
            .collect();
        s += &format!(
            "model: baseline{}\nparameters:\n{}residual (measured − model), noise floor {:.4} kPa ({}):\n{}",
            self.effects.iter().map(|e| format!(" + {e}")).collect::<String>(),
            params_text(&self.params),
            self.noise_floor_kpa,
            self.noise_floor_source,
            residual_text(&self.residual)
        );
        for spike in &self.spikes {
            s += &format!("spike left out of the fit: {spike}\n");
        }
        for f in &self.files {
            s += &format!("wrote {}\n", f.display());
        }
        s
    }
}

/// Human-readable diagnosis.
pub fn diagnosis_text(d: &Diagnosis) -> String {
    let mut s = format!(
        "baseline: RMSE {:.4} kPa, held-out {:.4} kPa; noise floor {:.4} kPa ({})\n",
        d.baseline.rmse_kpa, d.baseline.heldout_rmse_kpa, d.noise_floor_kpa, d.noise_floor_source
    );
    if !d.spikes.is_empty() {
        s += &format!(
            "spikes: {} isolated reading(s) left out of every fit and score:\n",
            d.spikes.len()
        );
        for spike in &d.spikes {
            s += &format!("  {spike}\n");
        }
    }
    s += "candidates (ranked by ΔBIC against the baseline):\n";
    for c in &d.candidates {
        s += &format!(
            "  {:<22} rmse {:.4}  held-out {}  ΔBIC {:>10.1}  excess explained {:>5.0} %{}\n",
            c.effect,
            c.rmse_kpa,
            c.heldout_rmse_kpa
                .map_or("   -  ".to_owned(), |h| format!("{h:.4}")),
            c.score,
            100.0 * c.excess_explained,
            if c.refusals.is_empty() {
                String::new()
            } else {
                format!("  [{}: not accepted]", c.refusals.join("; "))
            }
        );
    }
    for (name, why) in &d.not_applicable {
        s += &format!("  {name:<22} not tried: {why}\n");
    }
    let tests = d.every_candidate().filter_map(|c| c.beside_form.as_ref());
    for t in tests {
        s += &format!(
            "{} fitted beside {}, a form that also pays: ΔBIC {:.1} against the form alone, held-out {:.4} kPa against {:.4}, better in {} of {} folds: {}\n",
            t.effect,
            t.form,
            t.score,
            t.heldout_rmse_kpa,
            t.form_heldout_rmse_kpa,
            t.heldout_folds_better[0],
            t.heldout_folds_better[1],
            if t.accepted { "kept" } else { "not kept" }
        );
    }
    if d.selected.is_empty() && d.withdrawn.is_empty() {
        s += "selected: none (no effect pays off)\n";
    } else if d.selected.is_empty() {
        s += "selected: none\n";
    } else {
        s += &format!("selected: {}\n", d.selected.join(", "));
        for e in &d.selected_details {
            match &e.baseline_form {
                Some(words) => s += &format!("  {} (the baseline's form): {words}\n", e.effect),
                None => s += &format!("  {}: {}\n", e.effect, e.signature),
            }
        }
    }
    for w in &d.withdrawn {
        s += &format!(
            "withdrawn: {} paid in its round but removed only {:.0} % of the misfit left there, and the residual stays unexplained: it may be following what is missing rather than causing it, so it is not named\n",
            w.effect,
            100.0 * w.excess_explained
        );
    }
    s += &format!("final model parameters:\n{}", params_text(&d.params));
    for c in &d.confounds {
        let interval = |i: Option<[f64; 2]>| {
            i.map_or("not determined".to_owned(), |[a, b]| {
                format!("95 %: {} … {}", num(a), num(b))
            })
        };
        s += &format!(
            "{}: {} = {} ({}) holds only if the baseline is right where {} would change it; with that form also fitted (ΔBIC {:.1}) it is {} ({}). {}\n",
            if c.interval_95_with_form.is_none() { "not separated" } else { "rests on a form" },
            c.param,
            num(c.value),
            interval(c.interval_95),
            c.form,
            c.form_score,
            num(c.value_with_form),
            interval(c.interval_95_with_form),
            if c.interval_95_with_form.is_none() {
                format!(
                    "These runs cannot tell the two apart; {} would.",
                    c.tells_apart
                )
            } else {
                "The form was not added (it fell short on the other counts), but the value depends on it.".to_owned()
            }
        );
    }
    s += &format!(
        "final RMSE {:.4} kPa (held-out {:.4} kPa) vs noise floor {:.4} kPa\n",
        d.final_rmse_kpa, d.final_heldout_rmse_kpa, d.noise_floor_kpa
    );
    s += &format!(
        "unexplained: {}\n",
        d.unexplained
            .as_deref()
            .unwrap_or("none (the remaining residual looks like noise)")
    );
    s += &residual_text(&d.residual);
    s
}

impl DiagnoseOutcome {
    /// Human-readable report.
    pub fn text(&self) -> String {
        match self {
            DiagnoseOutcome::Diagnosis(d) => diagnosis_text(d),
            DiagnoseOutcome::Added {
                model,
                params,
                ledger,
            } => {
                let mut s = format!(
                    "model version {}: baseline{}\nparameters:\n{}",
                    model.version,
                    model
                        .effects
                        .iter()
                        .map(|e| format!(" + {e}"))
                        .collect::<String>(),
                    params_text(params)
                );
                s += &ledger_text(ledger);
                s
            }
        }
    }
}

/// The ledger as a table.
pub fn ledger_text(entries: &[LedgerEntry]) -> String {
    let mut s = "version  rmse_kpa  noise_kpa  free  bic          effects\n".to_owned();
    let mut skin: Option<&str> = None;
    for e in entries {
        // The skin, where it is recorded, above the first version that
        // used it.
        if !e.skin.is_empty() && skin != Some(e.skin.as_str()) {
            s += &format!("skin: {}\n", e.skin);
            skin = Some(e.skin.as_str());
        }
        s += &format!(
            "{:>7}  {:>8.4}  {:>9.4}  {:>4}  {:>11.1}  {}\n",
            e.version,
            e.rmse_kpa,
            e.noise_floor_kpa,
            e.free_params,
            e.bic,
            if e.effects.is_empty() {
                "(baseline)".to_owned()
            } else {
                e.effects.join(" + ")
            }
        );
    }
    s
}
