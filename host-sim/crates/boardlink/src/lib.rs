//! `host-sim board`: drive a board (the NUCLEO over its ST-LINK virtual COM
//! port, or the virtual board over a pseudo-terminal) from the desktop,
//! with the firmware's own protocol code ([`urechis::protocol`]).
//!
//! - [`link`]: the port, framing, replies, dropped-frame counts and the
//!   errors that name the port;
//! - [`info_text`], [`params_to_toml`] / [`params_from_toml`],
//!   [`refusal`]: what the subcommands print and read;
//! - [`push_table`]: a table image (`host-sim tables --image`) onto the
//!   board's flash;
//! - [`run()`]: a recorded run into an experiment folder.

pub mod link;
pub mod run;

use std::path::Path;

use anyhow::{bail, Context, Result};
use datafile::DataError;
use urechis::controller::{CommandError, ParamField, Params, RANGES};
use urechis::protocol::{
    ChunkData, HostCommand, Info, NackReason, StoredTable, TableSource, TareError, UploadError,
    TABLE_CHUNK_BYTES,
};
use urechis::table::image::TableBuf;
use urechis::table::CHECKSUM_ALGORITHM;

pub use link::{find_stlink_port, Link};
pub use run::{run, RunOptions, RunOutcome};

/// `snake_case` name of a parameter field, as in the TOML file.
pub fn field_name(field: ParamField) -> String {
    let camel = format!("{field:?}");
    let mut out = String::new();
    for (i, c) in camel.chars().enumerate() {
        if c.is_ascii_uppercase() {
            if i > 0 {
                out.push('_');
            }
            out.push(c.to_ascii_lowercase());
        } else {
            out.push(c);
        }
    }
    out
}

/// Every parameter's TOML name, in declaration order.
pub fn field_names() -> Vec<String> {
    RANGES.iter().map(|r| field_name(r.field)).collect()
}

/// The parameter set as a TOML file (one line per field, with its unit in
/// its name).
pub fn params_to_toml(params: &Params) -> Result<String> {
    let body = toml::to_string(params).context("writing the parameters as TOML")?;
    Ok(format!(
        "# The controller's parameters (host-sim board params get); every field is\n\
         # required, units in the names. Ranges: the firmware's controller/params.rs.\n{body}"
    ))
}

/// Reads a whole parameter set from TOML `text` of file `file`: every field
/// present, no unknown key; errors name the file, line and key.
pub fn params_from_toml(file: &str, text: &str) -> Result<Params> {
    let doc = datafile::TomlDoc::parse(file, text)?;
    let known = field_names();
    for key in doc.values().keys() {
        if !known.iter().any(|k| k == key) {
            return Err(doc
                .error(
                    &[key.as_str()],
                    "unknown parameter (see `params get` for the names)",
                )
                .into());
        }
    }
    for key in &known {
        if !doc.values().contains_key(key) {
            return Err(DataError::new(
                file,
                format!("parameter `{key}` is missing: a set is replaced whole"),
            )
            .into());
        }
    }
    toml::from_str::<Params>(text).map_err(|e| {
        let line = e
            .span()
            .map(|s| text[..s.start.min(text.len())].lines().count().max(1) as u64);
        let mut err = DataError::new(file, e.message().to_owned());
        if let Some(l) = line {
            err = err.with_line(l);
        }
        err.into()
    })
}

/// A board's refusal, in words (the field and its range for a parameter).
pub fn refusal(reason: &NackReason, params: Option<&Params>) -> String {
    match reason {
        NackReason::Command(CommandError::InvalidParams(e)) => {
            let r = e.field.range();
            let value = params.map(|p| p.get(e.field));
            format!(
                "field `{}`{} is refused: its range is {}..={}{}",
                field_name(e.field),
                value.map(|v| format!(" = {v}")).unwrap_or_default(),
                r.min,
                r.max,
                if e.field == ParamField::LinkTimeoutMs {
                    " (0 only with cycles > 0, else at least 100)"
                } else if e.field == ParamField::MaxPressureKpa {
                    " (and below sensor_max_kpa)"
                } else {
                    ""
                }
            )
        }
        NackReason::Command(CommandError::SensorRange(field)) => format!(
            "field `{}` is refused at start: with the zero in force the sensor ({:?}, specified \
             {:?} kPa absolute) could not see it; lower it, or tare where the atmosphere is lower",
            field_name(*field),
            urechis::controller::SENSOR_MODEL,
            urechis::controller::SENSOR_SPECIFIED_KPA
        ),
        NackReason::Tare(TareError::SensorRange(field)) => format!(
            "tare refused: with this zero the sensor ({:?}, specified {:?} kPa absolute) could \
             not see field `{}`; lower it first",
            urechis::controller::SENSOR_MODEL,
            urechis::controller::SENSOR_SPECIFIED_KPA,
            field_name(*field)
        ),
        NackReason::Command(CommandError::NoPressureZero) => {
            "no pressure zero in range: run `host-sim board tare` with the head at rest in free \
             water first"
                .to_owned()
        }
        NackReason::Command(CommandError::CauseActive) => {
            "a monitored cause is present (sensor, end-stop or volume): see `info`".to_owned()
        }
        NackReason::Command(CommandError::Busy) => "the board is busy (not in Idle)".to_owned(),
        NackReason::Command(CommandError::Faulted) => {
            "a fault is latched: `host-sim board reset` first".to_owned()
        }
        NackReason::Command(CommandError::BadTable(e)) => {
            format!("the board's table failed its check ({e:?})")
        }
        NackReason::Tare(TareError::OutOfRange { measured_kpa }) => format!(
            "the zero measured, {measured_kpa:.3} kPa absolute, is outside {:?} kPa: is the \
             head at rest, unburied, in free water?",
            urechis::controller::PRESSURE_ZERO_RANGE_KPA
        ),
        NackReason::Tare(e) => format!("tare refused: {e:?}"),
        NackReason::Upload(UploadError::Image(e)) => {
            format!("the board refused the table: {e:?}")
        }
        NackReason::Upload(e) => format!("table upload refused: {e:?}"),
        NackReason::Frame(e) => format!("the board could not read the frame ({e:?})"),
    }
}

/// `info`: what the board runs, one item a line.
pub fn info_text(port: &str, info: &Info, params: &Params, errors: link::RxErrors) -> String {
    let v = info.firmware_version;
    let source = match info.table_source {
        TableSource::CompiledIn => "compiled in",
        TableSource::Uploaded => "uploaded (flash)",
    };
    let stored = match info.stored_table {
        StoredTable::Absent => "none".to_owned(),
        StoredTable::Valid => "valid, in use".to_owned(),
        StoredTable::Rejected(e) => format!("REFUSED at boot ({e:?}): compiled-in table in use"),
    };
    let zero = if info.pressure_zero_kpa.is_nan() {
        "none: run `host-sim board tare` before a run".to_owned()
    } else {
        format!("{:.3} kPa absolute", info.pressure_zero_kpa)
    };
    let mut out = format!(
        "port: {port}\n\
         firmware: {}.{}.{}\n\
         protocol: {}\n\
         table: format {}, CRC {:#010x}, {source}{}\n\
         stored table: {stored}\n\
         pressure zero: {zero}\n\
         state: {:?}\n\
         fault: {}\n\
         alarm now: {}\n\
         last fault: {}\n\
         uptime: {:.1} s\n\
         host frames the board rejected: {}\n\
         telemetry samples the board dropped: {}\n\
         board frames that failed their CRC here: {} (other damaged frames: {})\n\
         parameters:\n",
        v.major,
        v.minor,
        v.patch,
        info.protocol_version,
        info.table_format_version,
        info.table_checksum,
        if info.table_placeholder {
            " (PLACEHOLDER law)"
        } else {
            ""
        },
        info.state,
        info.fault
            .map(|f| format!("{f:?}"))
            .unwrap_or_else(|| "none".into()),
        info.alarm
            .map(|f| format!("{f:?}"))
            .unwrap_or_else(|| "none".into()),
        info.last_fault
            .map(|f| format!("{f:?} at {:.2} s", f64::from(info.last_fault_ms) / 1000.0))
            .unwrap_or_else(|| "none since boot".into()),
        f64::from(info.uptime_ms) / 1000.0,
        info.frame_errors,
        info.telemetry_dropped,
        errors.crc,
        errors.other,
    );
    for r in RANGES {
        out.push_str(&format!(
            "  {} = {}\n",
            field_name(r.field),
            params.get(r.field)
        ));
    }
    out
}

/// Sends `command` and fails with the board's refusal in words.
pub fn expect_ack(link: &mut Link, command: HostCommand, timeout_ms: u64) -> Result<()> {
    let what = link::command_name(&command);
    let params = match &command {
        HostCommand::SetParams(p) => Some(*p),
        _ => None,
    };
    match link.command(command, timeout_ms)? {
        Ok(()) => Ok(()),
        Err(reason) => bail!(
            "port {}: the board refused {what}: {}",
            link.name(),
            refusal(&reason, params.as_ref())
        ),
    }
}

/// Reads a table image file and checks it as the board will; returns the
/// bytes and the table's checksum.
pub fn read_table_image(path: &Path) -> Result<(Vec<u8>, u32)> {
    let bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
    let buf = TableBuf::parse(&bytes).map_err(|e| {
        anyhow::anyhow!(
            "{}: not a valid table image ({e:?}); make one with `host-sim tables --image FILE`",
            path.display()
        )
    })?;
    Ok((bytes, buf.table().checksum))
}

/// Uploads table image `bytes` (chunk by chunk, each acknowledged); the
/// board checks it whole at the end and uses it from its next boot.
/// `progress(sent, total)` is called after each chunk.
pub fn push_table(
    link: &mut Link,
    bytes: &[u8],
    progress: &mut dyn FnMut(usize, usize),
) -> Result<()> {
    let len_bytes = u32::try_from(bytes.len()).context("table image too large")?;
    let crc32 = CHECKSUM_ALGORITHM.checksum(bytes);
    expect_ack(
        link,
        HostCommand::TableBegin { len_bytes, crc32 },
        link::ERASE_TIMEOUT_MS,
    )?;
    for (k, piece) in bytes.chunks(TABLE_CHUNK_BYTES).enumerate() {
        let data = ChunkData::from_slice(piece)
            .map_err(|_| anyhow::anyhow!("a chunk longer than {TABLE_CHUNK_BYTES} bytes"))?;
        let offset = (k * TABLE_CHUNK_BYTES) as u32;
        expect_ack(
            link,
            HostCommand::TableChunk { offset, data },
            link::REPLY_TIMEOUT_MS,
        )?;
        progress(
            (offset as usize + piece.len()).min(bytes.len()),
            bytes.len(),
        );
    }
    expect_ack(link, HostCommand::TableCommit, link::ERASE_TIMEOUT_MS)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn field_names_are_snake_case_and_round_trip() {
        assert_eq!(field_name(ParamField::LinkTimeoutMs), "link_timeout_ms");
        assert_eq!(field_name(ParamField::DepthMm), "depth_mm");
        let text = params_to_toml(&Params::DEFAULT).unwrap();
        assert_eq!(params_from_toml("p.toml", &text).unwrap(), Params::DEFAULT);
    }

    #[test]
    fn bad_files_name_the_key_and_line() {
        let text = params_to_toml(&Params::DEFAULT).unwrap();
        let unknown = format!("{text}depth_cm = 4.0\n");
        let e = params_from_toml("p.toml", &unknown)
            .unwrap_err()
            .to_string();
        assert!(e.contains("p.toml") && e.contains("depth_cm"), "{e}");
        let missing: String = text
            .lines()
            .filter(|l| !l.starts_with("hold_ms"))
            .map(|l| format!("{l}\n"))
            .collect();
        let e = params_from_toml("p.toml", &missing)
            .unwrap_err()
            .to_string();
        assert!(e.contains("hold_ms") && e.contains("missing"), "{e}");
        let wrong = text.replace("hold_ms = 500", "hold_ms = \"long\"");
        let e = params_from_toml("p.toml", &wrong).unwrap_err().to_string();
        assert!(e.contains("p.toml"), "{e}");
    }
}
