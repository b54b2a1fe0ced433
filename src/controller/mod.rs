//! The burrowing cycle: a pure, `no_std` state machine with no HAL and no
//! async inside. The board, the host emulator and the QEMU tests all call the
//! same [`Controller::step`].

pub mod params;
pub mod types;

pub use params::{ParamError, ParamField, Params};
pub use types::*;
