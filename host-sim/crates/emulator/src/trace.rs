//! An emulated run written as an experiment folder (`shared/data-format.md`)
//! the workbench can read, produced by the very conversion the board's
//! telemetry goes through ([`rig::telemetry::to_experiment`]): every
//! control step's [`Telemetry`](urechis::controller::Telemetry) becomes one
//! row, with the converter's extra columns (`state`, `fault`, `cycle`, the
//! two diameter estimates). The emulator adds what only it knows: the true
//! outer diameter in the format's `diameter_mm` column.
//!
//! Beside `rig.toml` and `runs.csv` the folder holds:
//! - `states.tsv`: the state sequence, one line per change (`t_s`, `state`,
//!   `fault`, `cycle`); not a `.csv`, so the workbench does not read it as
//!   a run;
//! - `plot.svg`: pressure, volume and state over time ([`super::plot`]);
//! - `outcome.json`: the measured [`Outcome`].

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{ensure, Context, Result};
use urechis::controller::{Fault, State};
use urechis::protocol::DeviceMessage;

use super::outcome::Outcome;
use super::run::Trace;
use datafile::write_atomic;
use rig::telemetry::{to_experiment, Capture, ConvertOptions};
use rig::Experiment;

/// The state-sequence file.
pub const STATES_FILE: &str = "states.tsv";
/// The plot.
pub const PLOT_FILE: &str = "plot.svg";
/// The measured outcome.
pub const OUTCOME_FILE: &str = "outcome.json";

/// One change of state.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StateChange {
    /// Time of the step that changed it (ms).
    pub t_ms: u32,
    /// State after the step.
    pub state: State,
    /// Latched fault.
    pub fault: Option<Fault>,
    /// Completed cycles.
    pub cycle: u16,
}

/// The state sequence: the first step, then every step whose state differs
/// from the previous one.
pub fn state_sequence(trace: &Trace) -> Vec<StateChange> {
    let mut out: Vec<StateChange> = Vec::new();
    for s in &trace.steps {
        let t = &s.outputs.telemetry;
        if out.last().is_none_or(|c| c.state != t.state) {
            out.push(StateChange {
                t_ms: t.t_ms,
                state: t.state,
                fault: t.fault,
                cycle: t.cycle,
            });
        }
    }
    out
}

/// The state sequence as `states.tsv` text.
pub fn states_tsv(trace: &Trace) -> String {
    let mut text = String::from("t_s\tstate\tfault\tcycle\n");
    for c in state_sequence(trace) {
        let fault = c.fault.map(|f| format!("{f:?}")).unwrap_or_default();
        // Writing to a String cannot fail.
        let _ = writeln!(
            text,
            "{}\t{:?}\t{fault}\t{}",
            f64::from(c.t_ms) / 1000.0,
            c.state,
            c.cycle
        );
    }
    text
}

/// The run as an experiment (one run named after the scenario): the
/// telemetry converter's rows, plus the true diameter.
pub fn to_experiment_folder(trace: &Trace) -> Result<Experiment> {
    let capture = Capture {
        messages: trace
            .steps
            .iter()
            .map(|s| DeviceMessage::Sample(s.outputs.telemetry))
            .collect(),
        ..Capture::default()
    };
    let options = ConvertOptions {
        run_id: trace.scenario.name.clone(),
        depth_mm: Some(trace.scenario.depth_mm),
        rig: trace.scenario.plant.rig.clone(),
    };
    let mut experiment = to_experiment(&capture, &options)?.experiment;
    ensure!(
        experiment.runs.len() == 1,
        "the emulated telemetry converted into {} runs, expected one",
        experiment.runs.len()
    );
    // The converter drops the leading steps without a reading; the rest
    // map one to one.
    let kept: Vec<_> = trace
        .steps
        .iter()
        .skip_while(|s| !s.outputs.telemetry.pressure_kpa.is_finite())
        .collect();
    let run = &mut experiment.runs[0];
    ensure!(
        run.samples.len() == kept.len(),
        "{} rows for {} steps with a reading",
        run.samples.len(),
        kept.len()
    );
    for (sample, step) in run.samples.iter_mut().zip(kept) {
        sample.diameter_mm = Some(step.truth.diameter_mm);
    }
    Ok(experiment)
}

/// Writes the experiment folder, `states.tsv`, `plot.svg` and
/// `outcome.json` into `dir`; returns the paths written.
pub fn write(trace: &Trace, outcome: &Outcome, dir: &Path) -> Result<Vec<PathBuf>> {
    let experiment = to_experiment_folder(trace)?;
    experiment
        .write(dir)
        .with_context(|| format!("writing the experiment folder {}", dir.display()))?;
    let files = [
        (STATES_FILE, states_tsv(trace)),
        (PLOT_FILE, super::plot::render_svg(trace)?),
        (OUTCOME_FILE, serde_json::to_string_pretty(outcome)? + "\n"),
    ];
    let mut written = vec![dir.join(rig::RIG_FILE), dir.join(rig::RUNS_FILE)];
    for (name, text) in files {
        let path = dir.join(name);
        write_atomic(&path, text.as_bytes())?;
        written.push(path);
    }
    Ok(written)
}
