//! What every host-sim plot shares. The plots themselves (plotters' SVG
//! backend) stay beside the data they show.

/// A plotters drawing error as an [`anyhow::Error`]: plotters' errors
/// carry the backend's own error type, which `?` cannot convert.
pub fn plot_err(e: impl std::fmt::Display) -> anyhow::Error {
    anyhow::anyhow!("plotting: {e}")
}

use plotters::chart::{ChartContext, SeriesLabelPosition};
use plotters::coord::CoordTranslate;
use plotters::prelude::{Color, DrawingBackend, BLACK, WHITE};

/// Draws `chart`'s legend at `at`, framed in black on white of opacity
/// `opacity` (0–1), as every host-sim plot frames it.
pub fn draw_legend<'a, DB, CT>(
    chart: &mut ChartContext<'a, DB, CT>,
    at: SeriesLabelPosition,
    opacity: f64,
) -> anyhow::Result<()>
where
    DB: DrawingBackend + 'a,
    CT: CoordTranslate,
{
    chart
        .configure_series_labels()
        .position(at)
        .background_style(WHITE.mix(opacity))
        .border_style(BLACK)
        .draw()
        .map_err(plot_err)
}
