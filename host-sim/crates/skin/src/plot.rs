//! SVG plot of a uniaxial test and its fits: nominal stress (what is
//! fitted) on the left, Cauchy stress (what the paper plots) on the right,
//! both against engineering strain.

use anyhow::Result;
use plotters::prelude::*;

use super::fit::LawFit;
use super::uniaxial::UniaxialTest;
use ::plot::plot_err;

/// Colours of the fitted curves, in registry order.
const COLOURS: [RGBColor; 4] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
];

/// Renders the plot as SVG text.
pub fn render_svg(test: &UniaxialTest, fits: &[LawFit]) -> Result<String> {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (1100, 480)).into_drawing_area();
        root.fill(&WHITE).map_err(plot_err)?;
        let (left, right) = root.split_horizontally(550);
        let cauchy = test.cauchy_stress_kpa();
        panel(&left, test, fits, &test.nominal_stress_kpa, false)?;
        panel(&right, test, fits, &cauchy, true)?;
        root.present().map_err(plot_err)?;
    }
    Ok(svg)
}

fn panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    test: &UniaxialTest,
    fits: &[LawFit],
    stress_kpa: &[f64],
    cauchy: bool,
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let e_max = test.strain.iter().copied().fold(0.0_f64, f64::max) * 1.1;
    let e_min = test.strain.iter().copied().fold(0.0_f64, f64::min);
    let s_max = stress_kpa.iter().copied().fold(0.0_f64, f64::max) * 1.25;
    let s_min = stress_kpa.iter().copied().fold(0.0_f64, f64::min) * 1.25;
    let (what, measure) = if cauchy {
        ("Cauchy stress σ (kPa)", "Cauchy")
    } else {
        ("nominal stress P (kPa)", "nominal (fitted)")
    };
    let mut chart = ChartBuilder::on(area)
        .caption(
            format!("{measure}: {}", file_label(test)),
            ("sans-serif", 16),
        )
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(e_min..e_max.max(1e-6), s_min..s_max.max(1e-6))
        .map_err(plot_err)?;
    chart
        .configure_mesh()
        .x_desc("engineering strain ε")
        .y_desc(what)
        .draw()
        .map_err(plot_err)?;

    let samples = 200;
    for (fit, colour) in fits.iter().zip(COLOURS.iter().cycle()) {
        let law = fit.model();
        let curve = (0..=samples).map(|i| {
            let e = e_min + (e_max - e_min) * f64::from(i) / f64::from(samples);
            let l = 1.0 + e;
            let p = law.uniaxial_nominal_kpa(l);
            (e, if cauchy { l * p } else { p })
        });
        // Clip to the panel so an unstable extrapolation stays readable.
        let curve = curve.filter(|(_, s)| *s >= s_min && *s <= s_max);
        let label = format!("{} (R² = {:.4})", fit.law, fit.r_squared);
        chart
            .draw_series(LineSeries::new(curve, colour.stroke_width(2)))
            .map_err(plot_err)?
            .label(label)
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 18, y)], colour.stroke_width(2))
            });
    }
    chart
        .draw_series(
            test.strain
                .iter()
                .zip(stress_kpa)
                .map(|(e, s)| Circle::new((*e, *s), 3, BLACK.filled())),
        )
        .map_err(plot_err)?
        .label("data")
        .legend(|(x, y)| Circle::new((x + 9, y), 3, BLACK.filled()));
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(plot_err)?;
    Ok(())
}

fn file_label(test: &UniaxialTest) -> String {
    test.source.file_name().map_or_else(
        || test.source.display().to_string(),
        |f| f.to_string_lossy().into_owned(),
    )
}
