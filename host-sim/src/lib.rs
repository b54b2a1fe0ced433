//! # host-sim
//!
//! Desktop physics and tools for the urechis burrowing actuator. The CLI in
//! `main.rs` is thin; every capability is a module here:
//!
//! - [`tables`]: generates the firmware's pressure→diameter table;
//! - [`paper_placeholder`]: the stand-in physics the table uses until the
//!   skin model and sand law land;
//! - [`files`]: atomic result files.

pub mod files;
pub mod paper_placeholder;
pub mod tables;

/// The p_i(D, h) model the firmware tables are generated from.
pub fn physics_model() -> paper_placeholder::PaperPlaceholder {
    paper_placeholder::PaperPlaceholder::default()
}
