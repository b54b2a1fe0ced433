//! `host-sim board run`: start a run, show it live, record it.
//!
//! The folder is built as `DIR.partial` beside `DIR`: the rig file is
//! copied in first, every telemetry frame of the run is appended to
//! `telemetry.bin` (a capture in the board's own framing, readable by
//! `host-sim telemetry`) as it arrives, and at the end the capture is
//! converted into the experiment (`rig.toml` + `runs.csv`, the rig crate's
//! conversion) and the folder renamed to `DIR` in one step. A run that is
//! interrupted (Ctrl-C, a lost link) is converted as far as it got and
//! stays named `DIR.partial`. Ctrl-C sends `Stop` first and records the
//! shrink back to rest. A heartbeat goes out every [`HEARTBEAT_MS`].

use std::fs::{File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use anyhow::{bail, Context, Result};
use urechis::controller::{Fault, State, Telemetry};
use urechis::protocol::{encode_device, DeviceMessage, HostCommand, MAX_FRAME};

use crate::link::{Link, REPLY_TIMEOUT_MS};
use crate::{expect_ack, refusal};

/// The host's heartbeat period while a run goes on (ms of wall time):
/// twenty per default link timeout, so that a virtual board running up
/// to 10× faster than wall time still hears the host twice per timeout.
pub const HEARTBEAT_MS: u64 = 100;

/// Longest silence of the telemetry stream before the run counts as lost
/// (ms).
pub const SILENCE_MS: u64 = 2_000;

/// Longest wait for the board to come back to rest after a Stop (ms).
pub const STOP_WAIT_MS: u64 = 15_000;

/// Name of the raw capture in the folder.
pub const CAPTURE_FILE: &str = "telemetry.bin";

/// What to run and where to put it.
#[derive(Clone, Debug)]
pub struct RunOptions {
    /// Cycles to run (1 or more: the board stops by itself after them).
    pub cycles: u16,
    /// Sand cover above the actuator axis (mm): the controller's table row
    /// and the run's depth in the folder.
    pub depth_mm: f32,
    /// The set-up (a rig.toml).
    pub rig: PathBuf,
    /// The experiment folder to create.
    pub out: PathBuf,
    /// Run id in the folder.
    pub run_id: String,
}

/// How a run ended.
#[derive(Clone, Debug, PartialEq)]
pub struct RunOutcome {
    /// The folder written (`DIR`, or `DIR.partial` when interrupted).
    pub folder: PathBuf,
    /// True when the run was cut short (Ctrl-C, lost link).
    pub partial: bool,
    /// The fault the board latched, if it did.
    pub fault: Option<Fault>,
    /// Cycles the board completed.
    pub cycles: u16,
    /// Telemetry samples recorded (in the capture).
    pub samples: usize,
    /// Of them, samples written into the experiment: all but those the
    /// conversion left out or dropped (see `notes`); 0 when none was written.
    pub samples_written: usize,
    /// Board frames that failed their CRC during the run.
    pub crc_errors: u64,
    /// Notes of the conversion (dropped frames, …).
    pub notes: Vec<String>,
}

/// `DIR.partial`.
pub fn partial_path(out: &Path) -> PathBuf {
    let mut name = out.file_name().unwrap_or_default().to_os_string();
    name.push(".partial");
    out.with_file_name(name)
}

/// Runs `options.cycles` cycles and records them (see the module docs).
/// `stop` is the Ctrl-C flag; `show` gets every sample (the live line).
pub fn run(
    link: &mut Link,
    options: &RunOptions,
    stop: &AtomicBool,
    show: &mut dyn FnMut(&Telemetry),
) -> Result<RunOutcome> {
    if options.cycles == 0 {
        bail!("--cycles must be at least 1: a recorded run ends by itself");
    }
    let (rig, _warnings) = rig::Rig::read(&options.rig)?;
    let partial = partial_path(&options.out);
    for p in [&options.out, &partial] {
        if p.exists() {
            bail!("{} already exists: choose another --out", p.display());
        }
    }
    let mut params = link.params()?;
    params.cycles = options.cycles;
    params.depth_mm = options.depth_mm;
    expect_ack(link, HostCommand::SetParams(params), REPLY_TIMEOUT_MS)?;

    std::fs::create_dir_all(&partial).with_context(|| format!("creating {}", partial.display()))?;
    std::fs::copy(&options.rig, partial.join("rig.toml")).with_context(|| {
        format!(
            "copying {} into {}",
            options.rig.display(),
            partial.display()
        )
    })?;
    let capture_path = partial.join(CAPTURE_FILE);
    let mut capture = OpenOptions::new()
        .create_new(true)
        .append(true)
        .open(&capture_path)
        .with_context(|| format!("creating {}", capture_path.display()))?;
    // The capture starts with a delimiter, as a board's stream may.
    capture
        .write_all(&[0])
        .with_context(|| format!("writing {}", capture_path.display()))?;

    let crc_before = link.errors().crc;
    let mut rec = Recorder {
        capture: &mut capture,
        path: &capture_path,
        samples: 0,
    };
    // Samples before the Start's reply are the idle board's: not recorded.
    match link.request_with(HostCommand::Start, REPLY_TIMEOUT_MS, &mut |_| {})? {
        DeviceMessage::Ack { .. } => {}
        DeviceMessage::Nack { reason, .. } => {
            let _ = std::fs::remove_dir_all(&partial);
            bail!(
                "port {}: the board refused Start: {}",
                link.name(),
                refusal(&reason, None)
            );
        }
        other => bail!("port {}: unexpected reply to Start: {other:?}", link.name()),
    }

    let mut interrupted = false;
    let mut stop_sent: Option<Instant> = None;
    let mut last_heartbeat = Instant::now();
    let mut last_sample = Instant::now();
    let mut fault = None;
    let mut cycles = 0;
    let mut active_seen = false;
    let result: Result<()> = loop {
        if stop.load(Ordering::Relaxed) && stop_sent.is_none() {
            interrupted = true;
            stop_sent = Some(Instant::now());
            if let Err(e) = link.send(HostCommand::Stop) {
                break Err(e);
            }
        }
        if last_heartbeat.elapsed() >= Duration::from_millis(HEARTBEAT_MS) {
            last_heartbeat = Instant::now();
            if let Err(e) = link.send(HostCommand::Heartbeat) {
                break Err(e);
            }
        }
        let msg = match link.next(Duration::from_millis(50)) {
            Ok(m) => m,
            Err(e) => break Err(e),
        };
        let Some(msg) = msg else {
            if last_sample.elapsed() > Duration::from_millis(SILENCE_MS) {
                break Err(anyhow::anyhow!(
                    "port {}: no telemetry for {} ms: link lost",
                    link.name(),
                    SILENCE_MS
                ));
            }
            continue;
        };
        let DeviceMessage::Sample(t) = msg else {
            if let DeviceMessage::Hello(_) = msg {
                break Err(anyhow::anyhow!(
                    "port {}: the board rebooted during the run",
                    link.name()
                ));
            }
            continue;
        };
        last_sample = Instant::now();
        if let Err(e) = rec.push(&t) {
            break Err(e);
        }
        show(&t);
        cycles = t.cycle;
        if t.state != State::Idle {
            active_seen = true;
        }
        if t.state == State::Fault {
            fault = t.fault;
            break Ok(());
        }
        if active_seen && t.state == State::Idle {
            break Ok(());
        }
        if stop_sent.is_some_and(|s| s.elapsed() > Duration::from_millis(STOP_WAIT_MS)) {
            break Ok(());
        }
    };
    let samples = rec.samples;
    drop(capture);
    let crc_errors = link.errors().crc - crc_before;
    let partial_run = interrupted || result.is_err();

    // Convert what was recorded, complete or not.
    let bytes = std::fs::read(&capture_path)
        .with_context(|| format!("reading {}", capture_path.display()))?;
    let decoded = rig::telemetry::decode_capture(&bytes);
    let conversion = rig::telemetry::to_experiment(
        &decoded,
        &rig::telemetry::ConvertOptions {
            run_id: options.run_id.clone(),
            depth_mm: Some(f64::from(options.depth_mm)),
            rig,
        },
    );
    let mut notes = Vec::new();
    let mut samples_written = 0;
    match conversion {
        Ok(c) => {
            samples_written = c.experiment.runs.iter().map(|r| r.samples.len()).sum();
            c.experiment
                .write(&partial)
                .with_context(|| format!("writing the experiment into {}", partial.display()))?;
            notes = c.notes;
        }
        Err(e) => notes.push(format!("no experiment written: {e:#}")),
    }
    if crc_errors > 0 {
        notes.push(format!(
            "{crc_errors} board frame(s) failed their CRC during the run (dropped, counted)"
        ));
    }
    let folder = if partial_run {
        partial.clone()
    } else {
        std::fs::rename(&partial, &options.out).with_context(|| {
            format!(
                "renaming {} to {}",
                partial.display(),
                options.out.display()
            )
        })?;
        options.out.clone()
    };
    let outcome = RunOutcome {
        folder,
        partial: partial_run,
        fault,
        cycles,
        samples,
        samples_written,
        crc_errors,
        notes,
    };
    match result {
        Ok(()) => Ok(outcome),
        Err(e) => Err(e.context(format!(
            "the run was cut short; {} sample(s) kept in {}",
            outcome.samples,
            outcome.folder.display()
        ))),
    }
}

/// Appends each sample to the capture as a protocol frame.
struct Recorder<'a> {
    capture: &'a mut File,
    path: &'a Path,
    samples: usize,
}

impl Recorder<'_> {
    fn push(&mut self, t: &Telemetry) -> Result<()> {
        let mut buf = [0u8; MAX_FRAME];
        let frame = encode_device(&DeviceMessage::Sample(*t), &mut buf)
            .map_err(|e| anyhow::anyhow!("cannot encode a sample: {e:?}"))?;
        self.capture
            .write_all(frame)
            .with_context(|| format!("writing {}", self.path.display()))?;
        self.samples += 1;
        Ok(())
    }
}
