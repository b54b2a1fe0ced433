//! The model workbench: calibrate the rig model ([`model`]) on an
//! experiment folder, see where it fails, find the missing physical effect
//! in the library ([`model::effects`]), add it and watch the error fall.
//!
//! - [`dataset`]: the folder's runs as the fitter sees them;
//! - [`calibrate`]: Levenberg–Marquardt with bounds and standard errors;
//! - [`residuals`]: residual statistics, structure tests, sentences;
//! - [`spikes`]: isolated glitches found, named and left out of the fits;
//! - [`diagnose`]: effect ranking and greedy selection;
//! - [`model_file`]: `model.toml` (effects in use) and `ledger.json`;
//! - [`plot`]: SVG charts;
//! - [`commands`]: the library side of `compare`, `diagnose`, `ledger`;
//! - [`skin_inflation`]: the free runs as a skin test (`fit-skin --inflation`);
//! - [`synth`]: synthetic experiments with hidden effects (tests, examples).

pub mod calibrate;
pub mod commands;
pub mod dataset;
pub mod diagnose;
pub mod model_file;
pub mod plot;
pub mod residuals;
pub mod skin_inflation;
pub mod spikes;
pub mod synth;
