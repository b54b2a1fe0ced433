//! SVG charts of the workbench: lines (measured vs model over time, the
//! ledger's error per version) and scatters (residual vs an input).

use ::plot::plot_err;
use anyhow::Result;
use plotters::prelude::*;

/// A named series.
pub struct Series<'a> {
    /// Legend label.
    pub label: &'a str,
    /// Points (x, y).
    pub points: &'a [(f64, f64)],
    /// Drawn as a line (else as dots).
    pub line: bool,
}

const COLOURS: [RGBColor; 4] = [
    RGBColor(0, 0, 0),
    RGBColor(214, 39, 40),
    RGBColor(31, 119, 180),
    RGBColor(44, 160, 44),
];

/// Most points drawn per series (evenly thinned beyond; SVGs stay small).
const MAX_POINTS: usize = 4000;

/// Renders `series` as an SVG chart.
pub fn chart_svg(
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series<'_>],
) -> Result<String> {
    let all = || {
        series
            .iter()
            .flat_map(|s| s.points.iter())
            .filter(|p| p.0.is_finite() && p.1.is_finite())
    };
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &(x, y) in all() {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    if x0 > x1 {
        (x0, x1, y0, y1) = (0.0, 1.0, 0.0, 1.0);
    }
    let pad = 0.05 * (y1 - y0).max(1e-6);
    let (y0, y1) = (y0 - pad, y1 + pad);
    let x1 = if x1 > x0 { x1 } else { x0 + 1.0 };
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (900, 420)).into_drawing_area();
        root.fill(&WHITE).map_err(plot_err)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 16))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(plot_err)?;
        chart
            .configure_mesh()
            .x_desc(x_label)
            .y_desc(y_label)
            .draw()
            .map_err(plot_err)?;
        for (s, colour) in series.iter().zip(COLOURS.iter().cycle()) {
            let step = s.points.len().div_ceil(MAX_POINTS).max(1);
            let pts: Vec<(f64, f64)> = s
                .points
                .iter()
                .step_by(step)
                .copied()
                .filter(|p| p.0.is_finite() && p.1.is_finite())
                .collect();
            let colour = *colour;
            if s.line {
                chart
                    .draw_series(LineSeries::new(pts, colour.stroke_width(1)))
                    .map_err(plot_err)?
                    .label(s.label)
                    .legend(move |(x, y)| {
                        PathElement::new(vec![(x, y), (x + 18, y)], colour.stroke_width(2))
                    });
            } else {
                chart
                    .draw_series(pts.into_iter().map(|p| Circle::new(p, 1, colour.filled())))
                    .map_err(plot_err)?
                    .label(s.label)
                    .legend(move |(x, y)| Circle::new((x + 9, y), 3, colour.filled()));
            }
        }
        plot::draw_legend(&mut chart, SeriesLabelPosition::UpperLeft, 0.85)?;
        root.present().map_err(plot_err)?;
    }
    Ok(svg)
}
