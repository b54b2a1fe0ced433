//! Host link: framed, checksummed commands and telemetry over the virtual
//! COM port.
