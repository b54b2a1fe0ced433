//! The model in use for an experiment folder, and its history:
//!
//! - `model.toml`: the effects in use (edit it by hand, or let
//!   `host-sim diagnose EXP --add EFFECT` do it) and the values of the last
//!   fit (informational; every command refits);
//! - `ledger.json`: one entry per model version fitted, appended, so
//!   `host-sim ledger EXP` can show the error falling. JSON, not CSV: every
//!   `*.csv` in the folder is read as measurements.

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::{Context, Result};
use serde::{Deserialize, Serialize};

use super::calibrate::Fit;
use datafile::write_atomic;
use model::effects::{EffectInstance, EffectSpec};

/// File name of the model inside the experiment folder.
pub const MODEL_FILE: &str = "model.toml";

/// File name of the ledger inside the experiment folder.
pub const LEDGER_FILE: &str = "ledger.json";

/// `model.toml`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ModelFile {
    /// Model version (1 = first written).
    #[serde(default)]
    pub version: u32,
    /// Effect names in use.
    #[serde(default)]
    pub effects: Vec<String>,
    /// Values of the last fit, `name` or `effect.name` (informational).
    #[serde(default)]
    pub fitted: BTreeMap<String, f64>,
}

impl ModelFile {
    /// Reads `dir/model.toml`; `None` when absent.
    pub fn read(dir: &Path) -> Result<Option<ModelFile>> {
        let path = dir.join(MODEL_FILE);
        if !path.exists() {
            return Ok(None);
        }
        let text = std::fs::read_to_string(&path)
            .with_context(|| format!("reading {}", path.display()))?;
        let file: ModelFile = toml::from_str(&text)
            .with_context(|| format!("{}: not a model file", path.display()))?;
        for name in &file.effects {
            EffectSpec::by_name(name)
                .with_context(|| format!("{}: key `effects`", path.display()))?;
        }
        Ok(Some(file))
    }

    /// The effects with their default (starting) values, or the last fitted
    /// values where the file has them.
    pub fn instances(&self) -> Result<Vec<EffectInstance>> {
        self.effects
            .iter()
            .map(|name| {
                let mut e = EffectInstance::with_defaults(name)?;
                for p in e.spec.params {
                    if let Some(v) = self.fitted.get(&format!("{name}.{}", p.name)) {
                        if v.is_finite() && *v >= p.lower && *v <= p.upper {
                            e.set(p.name, *v)?;
                        }
                    }
                }
                Ok(e)
            })
            .collect()
    }

    /// Writes `dir/model.toml` atomically.
    pub fn write(&self, dir: &Path) -> Result<()> {
        let text = format!(
            "# Model in use for this experiment folder (host-sim workbench).\n\
             # Edit `effects` to change it; `fitted` is informational, every command refits.\n{}",
            toml::to_string_pretty(self).context("serializing model.toml")?
        );
        write_atomic(&dir.join(MODEL_FILE), text.as_bytes())
    }

    /// The file for `fit`, at `version`.
    pub fn of_fit(fit: &Fit, version: u32) -> ModelFile {
        ModelFile {
            version,
            effects: fit
                .space
                .effects
                .iter()
                .map(|e| e.spec.name.to_owned())
                .collect(),
            fitted: fit
                .params
                .iter()
                .map(|p| (p.name.clone(), p.value))
                .collect(),
        }
    }
}

/// One ledger entry: a model version and its error.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LedgerEntry {
    /// Model version.
    pub version: u32,
    /// Effects in use.
    pub effects: Vec<String>,
    /// RMSE over every sample (kPa).
    pub rmse_kpa: f64,
    /// BIC of the calibration.
    pub bic: f64,
    /// Free parameters.
    pub free_params: usize,
    /// Noise floor at the time (kPa).
    pub noise_floor_kpa: f64,
    /// Seconds since the Unix epoch.
    pub unix_time_s: u64,
    /// The skin the model was fitted with ([`rig::Rig::skin_description`]);
    /// empty in ledgers written before it was recorded.
    #[serde(default)]
    pub skin: String,
}

/// Reads `dir/ledger.json` (empty when absent).
pub fn read_ledger(dir: &Path) -> Result<Vec<LedgerEntry>> {
    let path = dir.join(LEDGER_FILE);
    if !path.exists() {
        return Ok(Vec::new());
    }
    let text =
        std::fs::read_to_string(&path).with_context(|| format!("reading {}", path.display()))?;
    serde_json::from_str(&text).with_context(|| format!("{}: not a ledger", path.display()))
}

/// Appends `entry` to `dir/ledger.json` (atomically rewritten).
pub fn append_ledger(dir: &Path, entry: LedgerEntry) -> Result<Vec<LedgerEntry>> {
    let mut all = read_ledger(dir)?;
    all.push(entry);
    let text = serde_json::to_string_pretty(&all)?;
    write_atomic(&dir.join(LEDGER_FILE), text.as_bytes())?;
    Ok(all)
}
