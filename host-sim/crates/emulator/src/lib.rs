//! Emulation: the firmware's own controller (the root crate's
//! [`urechis::controller::Controller`] with the compiled-in table, not a
//! copy) closed around a simulated plant, on the host and, replayed, under
//! QEMU on a Cortex-M4.
//!
//! - [`plant`]: stepper syringe pump ([`pump`]), line with relief valve
//!   and blockage, the workbench's rig model ([`model::RigModel`]
//!   with [`model::effects`] switched on), the pressure sensor as the
//!   driver delivers it ([`sensor`]), the advance drive;
//! - [`scenario`]: named scenarios with their expected outcomes;
//! - [`run`](mod@run): the deterministic loop (one controller step per
//!   `CONTROL_PERIOD_MS`, 1 ms plant sub-steps, seeded noise);
//! - [`outcome`]: what a run showed against what its scenario expects;
//! - [`trace`]: the run as an experiment folder plus its state sequence;
//!   [`plot`]: pressure, volume and state over time;
//! - [`replay`]: a run's controller inputs and decisions in a compact
//!   binary the QEMU build replays step by step.

pub mod outcome;
pub mod plant;
pub mod plot;
pub mod pump;
pub mod replay;
pub mod run;
pub mod scenario;
pub mod sensor;
pub mod trace;

pub use outcome::{evaluate, Outcome};
pub use plant::{Plant, PlantConfig, PlantFault, Truth};
pub use run::{run, StepRecord, Trace};
pub use scenario::{named, Expectation, Injection, Reference, Scenario, Trigger, NAMES};

/// The seed the CLI and the tests use unless told otherwise.
pub const DEFAULT_SEED: u64 = 1;
