//! Telemetry captures: the raw bytes a host read from the board's virtual COM
//! port (a stream of [`urechis::protocol`] frames, possibly with line noise or
//! a cut-off frame at either end), decoded with the firmware's own decoder
//! and turned into an [experiment folder](crate).
//!
//! Conversion rules:
//! - one run per continuous recording; a new run starts at a `Hello` (the
//!   board rebooted), when `t_ms` goes back, and (without an explicit
//!   depth) at a `Params` reply with a different `depth_mm`. Runs are named
//!   `ID`, `ID_2`, `ID_3`, …;
//! - a sample with the same `t_ms` as the one before (the board ran two
//!   control steps within a millisecond, catching up after a late tick) is
//!   left out of its run, which stays one, and counted in the notes: rows
//!   of a run must be strictly later than the one before;
//! - `t_s` and `volume_ml` count from the run's first sample; `pressure_kpa`
//!   is the board's gauge reading. Samples before the first pressure reading
//!   (NaN) are dropped and counted;
//! - depth comes from the caller, else from the last `Params` reply before
//!   the run (the host should send `GetParams` after connecting);
//! - the board's diameters are estimates, not measurements, so they go to
//!   extra columns (`diameter_volume_mm`, `diameter_table_mm`) with `state`,
//!   `fault` and `cycle`; `diameter_mm` stays empty;
//! - f32 values are carried over by their shortest decimal form (0.1 stays
//!   0.1, not 0.100000001490116).

use std::path::Path;

use anyhow::{Context, Result};
use urechis::controller::Telemetry;
use urechis::protocol::{encode_device, DeviceDecoder, DeviceMessage, FrameError, MAX_FRAME};

use crate::{Experiment, Rig, Run, Sample};

/// Extra columns a converted capture carries, in this order.
pub const EXTRA_COLUMNS: [&str; 5] = [
    "state",
    "fault",
    "cycle",
    "diameter_volume_mm",
    "diameter_table_mm",
];

/// A decoded capture.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Capture {
    /// Every message decoded, in order.
    pub messages: Vec<DeviceMessage>,
    /// Every dropped frame, in order.
    pub frame_errors: Vec<FrameError>,
    /// Bytes after the last delimiter (a frame cut off by the end of the
    /// capture).
    pub unterminated_bytes: usize,
}

impl Capture {
    /// The telemetry samples, in order.
    pub fn samples(&self) -> impl Iterator<Item = &Telemetry> {
        self.messages.iter().filter_map(|m| match m {
            DeviceMessage::Sample(t) => Some(t),
            _ => None,
        })
    }

    /// One line per kind of dropped frame, e.g. "3 frames dropped: Crc".
    pub fn error_summary(&self) -> Vec<String> {
        let mut counts: Vec<(FrameError, usize)> = Vec::new();
        for e in &self.frame_errors {
            match counts.iter_mut().find(|(k, _)| k == e) {
                Some((_, n)) => *n += 1,
                None => counts.push((*e, 1)),
            }
        }
        counts
            .iter()
            .map(|(e, n)| format!("{n} frame(s) dropped: {e:?}"))
            .collect()
    }
}

/// Decodes a raw capture with the firmware's stream decoder.
pub fn decode_capture(bytes: &[u8]) -> Capture {
    let mut decoder = DeviceDecoder::new();
    let mut capture = Capture::default();
    let mut since_delimiter = 0usize;
    for &byte in bytes {
        since_delimiter = if byte == 0 { 0 } else { since_delimiter + 1 };
        match decoder.push(byte) {
            Some(Ok(msg)) => capture.messages.push(msg),
            Some(Err(e)) => capture.frame_errors.push(e),
            None => {}
        }
    }
    capture.unterminated_bytes = since_delimiter;
    capture
}

/// The bytes a board sending `messages` puts on the wire: a leading 0x00
/// (ends any noise before it) and one frame per message. Tests build
/// captures with it.
pub fn encode_capture(messages: &[DeviceMessage]) -> Result<Vec<u8>> {
    let mut bytes = vec![0u8];
    let mut buf = [0u8; MAX_FRAME];
    for msg in messages {
        let frame = encode_device(msg, &mut buf)
            .map_err(|e| anyhow::anyhow!("cannot encode {msg:?}: {e:?}"))?;
        bytes.extend_from_slice(frame);
    }
    Ok(bytes)
}

/// How to turn a capture into an experiment.
#[derive(Clone, Debug)]
pub struct ConvertOptions {
    /// Id of the first run (later ones get `_2`, `_3`, …).
    pub run_id: String,
    /// Sand cover (mm) for every run; `None` = from the `Params` replies.
    pub depth_mm: Option<f64>,
    /// The set-up the capture was recorded on.
    pub rig: Rig,
}

/// A converted capture and what the conversion noticed.
#[derive(Clone, Debug)]
pub struct Conversion {
    /// The experiment (extra columns [`EXTRA_COLUMNS`]).
    pub experiment: Experiment,
    /// Samples dropped because no pressure reading existed yet.
    pub dropped_samples: usize,
    /// Samples left out because they carried the same `t_ms` as the
    /// sample before them (two control steps within one millisecond).
    pub same_ms_samples: usize,
    /// Frames dropped, noise, reboots, placeholder tables: one line each.
    pub notes: Vec<String>,
}

/// Shortest decimal of an f32, as f64 (0.1f32 → 0.1).
fn decimal(x: f32) -> f64 {
    x.to_string().parse().unwrap_or(f64::from(x))
}

/// The run being filled.
struct OpenRun {
    run: Run,
    t0_ms: u32,
    last_ms: u32,
    v0_ml: f32,
}

/// Converts a decoded capture (see the module docs for the rules).
pub fn to_experiment(capture: &Capture, options: &ConvertOptions) -> Result<Conversion> {
    let mut runs: Vec<Run> = Vec::new();
    let mut open: Option<OpenRun> = None;
    let mut reported_depth: Option<f64> = None;
    let mut dropped = 0usize;
    // Samples at the millisecond of the one before them, left out.
    let mut same_ms = 0usize;
    let mut notes = capture.error_summary();
    if capture.unterminated_bytes > 0 {
        notes.push(format!(
            "{} byte(s) after the last frame delimiter ignored (capture cut mid-frame)",
            capture.unterminated_bytes
        ));
    }
    let close = |open: &mut Option<OpenRun>, runs: &mut Vec<Run>| {
        if let Some(o) = open.take() {
            runs.push(o.run);
        }
    };
    for msg in &capture.messages {
        match msg {
            DeviceMessage::Hello(hello) => {
                if open.is_some() {
                    notes.push("the board rebooted during the capture: new run".to_owned());
                }
                close(&mut open, &mut runs);
                let v = hello.firmware_version;
                notes.push(format!(
                    "board: firmware {}.{}.{}, protocol {}, table checksum {:#010x}{}",
                    v.major,
                    v.minor,
                    v.patch,
                    hello.protocol_version,
                    hello.table_checksum,
                    if hello.table_placeholder {
                        " (PLACEHOLDER table)"
                    } else {
                        ""
                    }
                ));
            }
            DeviceMessage::Params { params, .. } => {
                let depth = decimal(params.depth_mm);
                let changed = open.as_ref().is_some_and(|o| o.run.depth_mm != depth);
                if options.depth_mm.is_none() && changed {
                    close(&mut open, &mut runs);
                }
                reported_depth = Some(depth);
            }
            DeviceMessage::Sample(t) => {
                if !t.pressure_kpa.is_finite() || !t.volume_ml.is_finite() {
                    dropped += 1;
                    continue;
                }
                // Wrapping difference: a step later in time is 1..2^31 ms on.
                let dt = open.as_ref().map(|o| t.t_ms.wrapping_sub(o.last_ms));
                if dt == Some(0) {
                    same_ms += 1;
                    continue;
                }
                let backwards = dt.is_some_and(|dt| dt > u32::MAX / 2);
                if backwards {
                    notes.push(format!(
                        "t_ms went from {} to {}: new run",
                        open.as_ref().map_or(0, |o| o.last_ms),
                        t.t_ms
                    ));
                    close(&mut open, &mut runs);
                }
                let o = match open.as_mut() {
                    Some(o) => o,
                    None => {
                        let id = match runs.len() {
                            0 => options.run_id.clone(),
                            n => format!("{}_{}", options.run_id, n + 1),
                        };
                        let depth_mm = options.depth_mm.or(reported_depth).with_context(|| {
                            format!(
                                "no depth for run `{id}`: the capture has no Params reply \
                                 before its first sample; give the depth explicitly (--depth-mm)"
                            )
                        })?;
                        open.insert(OpenRun {
                            run: Run {
                                id,
                                depth_mm,
                                samples: Vec::new(),
                            },
                            t0_ms: t.t_ms,
                            last_ms: t.t_ms,
                            v0_ml: t.volume_ml,
                        })
                    }
                };
                o.run.samples.push(Sample {
                    t_s: f64::from(t.t_ms.wrapping_sub(o.t0_ms)) / 1000.0,
                    volume_ml: decimal(t.volume_ml - o.v0_ml),
                    pressure_kpa: decimal(t.pressure_kpa),
                    diameter_mm: None,
                    extra: vec![
                        format!("{:?}", t.state),
                        t.fault.map(|f| format!("{f:?}")).unwrap_or_default(),
                        t.cycle.to_string(),
                        decimal(t.diameter_volume_mm).to_string(),
                        decimal(t.diameter_table_mm).to_string(),
                    ],
                });
                o.last_ms = t.t_ms;
            }
            DeviceMessage::Ack { .. }
            | DeviceMessage::Nack { .. }
            | DeviceMessage::Pong { .. }
            | DeviceMessage::Info { .. } => {}
        }
    }
    close(&mut open, &mut runs);
    if same_ms > 0 {
        notes.push(format!(
            "{same_ms} sample(s) with the same t_ms as the sample before left out \
             (control steps within one millisecond)"
        ));
    }
    if dropped > 0 {
        notes.push(format!(
            "{dropped} sample(s) before the first pressure reading dropped"
        ));
    }
    anyhow::ensure!(
        !runs.is_empty(),
        "the capture holds no usable telemetry sample ({} message(s), {} dropped frame(s))",
        capture.messages.len(),
        capture.frame_errors.len()
    );
    let mut experiment = Experiment::new(options.rig.clone(), runs);
    experiment.extra_columns = EXTRA_COLUMNS.iter().map(|c| (*c).to_owned()).collect();
    Ok(Conversion {
        experiment,
        dropped_samples: dropped,
        same_ms_samples: same_ms,
        notes,
    })
}

/// `host-sim telemetry`: reads the capture file, converts it and writes the
/// experiment folder `out`. Without `rig` the paper's set-up is used (and
/// noted); without `run_id` the capture's file stem names the run.
pub fn convert_file(
    capture_path: &Path,
    out: &Path,
    rig: Option<&Path>,
    run_id: Option<&str>,
    depth_mm: Option<f64>,
) -> Result<Conversion> {
    let bytes = std::fs::read(capture_path)
        .with_context(|| format!("reading capture {}", capture_path.display()))?;
    let mut rig_notes = Vec::new();
    let rig = match rig {
        Some(path) => {
            let (rig, warnings) = Rig::read(path)?;
            rig_notes.extend(warnings);
            rig
        }
        None => {
            rig_notes.push("no rig given: using the paper's set-up (Rig::paper_default)".into());
            Rig::paper_default()
        }
    };
    let run_id = match run_id {
        Some(id) => id.to_owned(),
        None => capture_path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .filter(|s| !s.is_empty())
            .unwrap_or_else(|| "run".to_owned()),
    };
    let capture = decode_capture(&bytes);
    let options = ConvertOptions {
        run_id,
        depth_mm,
        rig,
    };
    let mut conversion = to_experiment(&capture, &options)
        .with_context(|| format!("converting {}", capture_path.display()))?;
    conversion.notes.splice(0..0, rig_notes);
    conversion
        .experiment
        .write(out)
        .with_context(|| format!("writing experiment folder {}", out.display()))?;
    Ok(conversion)
}
