//! The recordings the Cortex-M4 build replays ([`replay_data`], generated
//! by `host-sim emulate --export-replay` in the firmware's own format,
//! [`urechis::replay`]).
#![no_std]
#![deny(missing_docs)]

pub mod replay_data;

/// One recorded emulator run, compiled in.
#[derive(Clone, Copy, Debug)]
pub struct Recording {
    /// Scenario name.
    pub name: &'static str,
    /// The replay file (see [`urechis::replay`] for the format).
    pub bytes: &'static [u8],
}
