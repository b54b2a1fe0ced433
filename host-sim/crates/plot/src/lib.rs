//! What every host-sim plot shares. The plots themselves (plotters' SVG
//! backend) stay beside the data they show.

/// A plotters drawing error as an [`anyhow::Error`]: plotters' errors
/// carry the backend's own error type, which `?` cannot convert.
pub fn plot_err(e: impl std::fmt::Display) -> anyhow::Error {
    anyhow::anyhow!("plotting: {e}")
}
