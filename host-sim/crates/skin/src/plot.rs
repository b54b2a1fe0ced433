//! SVG plot of skin tests and their fits: one panel per test mode, nominal
//! stress (what is fitted) against engineering strain. Fitted modes' data
//! are filled circles, predicted-only modes' open circles; each curve's
//! legend gives that law's R² on the panel's mode. With a free-inflation
//! fit, one more panel: pressure against diameter, the bins, the inflation
//! fit's tube and the coupon fit's tube of the same law.

use anyhow::Result;
use plotters::prelude::*;

use super::coupon::{CouponTest, Mode};
use super::fit::LawFit;
use super::inflation::{tube_pressures_kpa, InflationPoint, InflationReport};
use super::report::r_squared_text;
use ::plot::plot_err;

/// Colours of the fitted curves, in registry order.
const COLOURS: [RGBColor; 7] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(255, 127, 14),
    RGBColor(140, 86, 75),
    RGBColor(23, 190, 207),
];

/// Width of one panel (px).
const PANEL_PX: u32 = 560;

/// Renders the plot as SVG text.
pub fn render_svg(
    tests: &[CouponTest],
    fits: &[LawFit],
    inflation: Option<&InflationReport>,
) -> Result<String> {
    let modes: Vec<Mode> = Mode::ALL
        .into_iter()
        .filter(|m| tests.iter().any(|t| t.mode == *m))
        .collect();
    let panels_n = (modes.len() + usize::from(inflation.is_some())).max(1);
    let mut svg = String::new();
    {
        let width = PANEL_PX * panels_n as u32;
        let root = SVGBackend::with_string(&mut svg, (width, 500)).into_drawing_area();
        root.fill(&WHITE).map_err(plot_err)?;
        let panels = root.split_evenly((1, panels_n));
        for (area, mode) in panels.iter().zip(&modes) {
            let of_mode: Vec<&CouponTest> = tests.iter().filter(|t| t.mode == *mode).collect();
            panel(area, *mode, &of_mode, fits)?;
        }
        if let (Some(inf), Some(area)) = (inflation, panels.get(modes.len())) {
            inflation_panel(area, inf, fits)?;
        }
        root.present().map_err(plot_err)?;
    }
    Ok(svg)
}

fn inflation_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    inf: &InflationReport,
    fits: &[LawFit],
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let d0 = inf.geometry.outer_diameter_mm;
    let d_max = inf
        .bins
        .iter()
        .map(|b| b.diameter_mm)
        .fold(d0 + 1.0, f64::max);
    let p_max = inf.bins.iter().map(|b| b.pressure_kpa).fold(1e-6, f64::max) * 1.25;
    let mut chart = ChartBuilder::on(area)
        .caption(
            format!("free inflation (depth 0): {}", inf.folder.display()),
            ("sans-serif", 15),
        )
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(64)
        .build_cartesian_2d(d0..d_max, 0.0..p_max)
        .map_err(plot_err)?;
    chart
        .configure_mesh()
        .x_desc("outer diameter D (mm)")
        .y_desc("pressure (kPa)")
        .draw()
        .map_err(plot_err)?;
    let grid: Vec<InflationPoint> = (0..=120)
        .map(|i| InflationPoint {
            diameter_mm: d0 + (d_max - d0) * f64::from(i) / 120.0,
            pressure_kpa: 0.0,
        })
        .collect();
    let coupon = fits
        .iter()
        .find(|f| f.law == inf.fit.law)
        .map(|f| (f.model(), format!("coupon {} (tube)", f.law)));
    let curves = [
        Some((
            inf.fit.model(),
            format!("inflation {} (R² = {:.4})", inf.fit.law, inf.fit.r_squared),
        )),
        coupon,
    ];
    for ((law, label), colour) in curves.into_iter().flatten().zip(COLOURS) {
        let Some(p) = tube_pressures_kpa(law, inf.geometry, &grid) else {
            continue;
        };
        let line = grid
            .iter()
            .zip(p)
            .map(|(g, p)| (g.diameter_mm, p))
            .filter(|(_, p)| p.is_finite() && *p <= p_max);
        chart
            .draw_series(LineSeries::new(line, colour.stroke_width(2)))
            .map_err(plot_err)?
            .label(label)
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 18, y)], colour.stroke_width(2))
            });
    }
    chart
        .draw_series(
            inf.bins
                .iter()
                .map(|b| Circle::new((b.diameter_mm, b.pressure_kpa), 3, BLACK.filled())),
        )
        .map_err(plot_err)?
        .label("free runs, bin means")
        .legend(|(x, y)| Circle::new((x + 9, y), 3, BLACK.filled()));
    plot::draw_legend(&mut chart, SeriesLabelPosition::UpperLeft, 0.85)?;
    Ok(())
}

fn panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    mode: Mode,
    tests: &[&CouponTest],
    fits: &[LawFit],
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let strains = || tests.iter().flat_map(|t| t.strain.iter().copied());
    let stresses = || {
        tests
            .iter()
            .flat_map(|t| t.nominal_stress_kpa.iter().copied())
    };
    let e_max = strains().fold(0.0_f64, f64::max) * 1.1;
    let e_min = strains().fold(0.0_f64, f64::min);
    let s_max = stresses().fold(0.0_f64, f64::max) * 1.25;
    let s_min = stresses().fold(0.0_f64, f64::min) * 1.25;
    let fitted = fits
        .first()
        .and_then(|f| f.mode(mode))
        .is_none_or(|m| m.fitted);
    let files: Vec<String> = tests
        .iter()
        .map(|t| {
            t.source.file_name().map_or_else(
                || t.source.display().to_string(),
                |f| f.to_string_lossy().into_owned(),
            )
        })
        .collect();
    let mut chart = ChartBuilder::on(area)
        .caption(
            format!(
                "{mode} ({}): {}",
                if fitted { "fitted" } else { "predicted" },
                files.join(", ")
            ),
            ("sans-serif", 15),
        )
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(64)
        .build_cartesian_2d(e_min..e_max.max(1e-6), s_min..s_max.max(1e-6))
        .map_err(plot_err)?;
    chart
        .configure_mesh()
        .x_desc("engineering strain ε")
        .y_desc("nominal stress P (kPa)")
        .draw()
        .map_err(plot_err)?;

    let samples = 200;
    for (fit, colour) in fits.iter().zip(COLOURS.iter().cycle()) {
        let law = fit.model();
        let curve = (0..=samples).map(|i| {
            let e = e_min + (e_max - e_min) * f64::from(i) / f64::from(samples);
            (e, mode.nominal_kpa(law.as_ref(), 1.0 + e))
        });
        // Clip to the panel so an unstable extrapolation stays readable.
        let curve = curve.filter(|(_, s)| s.is_finite() && *s >= s_min && *s <= s_max);
        let r2 = fit.mode(mode).map_or(f64::NAN, |m| m.r_squared);
        let label = format!("{} (R² = {})", fit.law, r_squared_text(r2));
        chart
            .draw_series(LineSeries::new(curve, colour.stroke_width(2)))
            .map_err(plot_err)?
            .label(label)
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 18, y)], colour.stroke_width(2))
            });
    }
    let style = if fitted {
        BLACK.filled()
    } else {
        BLACK.stroke_width(1)
    };
    chart
        .draw_series(tests.iter().flat_map(|t| {
            t.strain
                .iter()
                .zip(&t.nominal_stress_kpa)
                .map(move |(e, s)| Circle::new((*e, *s), 3, style))
        }))
        .map_err(plot_err)?
        .label(if fitted {
            "data (fitted)"
        } else {
            "data (predicted)"
        })
        .legend(move |(x, y)| Circle::new((x + 9, y), 3, style));
    plot::draw_legend(&mut chart, SeriesLabelPosition::UpperLeft, 0.85)?;
    Ok(())
}
