//! SVG plot of an emulated run: three panels over time, sharing the time
//! axis: pressure (the reading the controller had, the true line pressure
//! and the limit), volume (what the pump reported, what reached the head)
//! and the controller's state.

use anyhow::Result;
use plotters::prelude::*;
use urechis::controller::State;

use super::run::Trace;
use ::plot::plot_err;

/// Most points drawn per series (longer runs are thinned evenly).
const MAX_POINTS: usize = 4000;

/// A labelled, coloured line.
type Series<'a> = (&'a str, &'a [(f64, f64)], RGBColor);

const READING: RGBColor = RGBColor(31, 119, 180);
const TRUE_LINE: RGBColor = RGBColor(255, 127, 14);
const LIMIT: RGBColor = RGBColor(214, 39, 40);
const PUMP: RGBColor = RGBColor(44, 160, 44);
const HEAD: RGBColor = RGBColor(148, 103, 189);

fn level(state: State) -> f64 {
    State::ALL.iter().position(|s| *s == state).unwrap_or(0) as f64
}

/// One time-series panel: labelled lines over `0..t_end` with a legend.
fn line_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    t_end: f64,
    y_range: std::ops::Range<f64>,
    y_desc: &str,
    series: &[Series<'_>],
) -> Result<()> {
    let mut chart = ChartBuilder::on(area)
        .margin(10)
        .x_label_area_size(30)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..t_end, y_range)
        .map_err(plot_err)?;
    chart
        .configure_mesh()
        .y_desc(y_desc)
        .draw()
        .map_err(plot_err)?;
    for &(label, pts, colour) in series {
        chart
            .draw_series(LineSeries::new(pts.iter().copied(), colour.stroke_width(1)))
            .map_err(plot_err)?
            .label(label)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], colour));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(plot_err)?;
    Ok(())
}

/// Renders the plot as SVG text.
pub fn render_svg(trace: &Trace) -> Result<String> {
    let stride = trace.steps.len().div_ceil(MAX_POINTS).max(1);
    let steps: Vec<_> = trace.steps.iter().step_by(stride).collect();
    let t = |ms: u32| f64::from(ms) / 1000.0;
    let t_end = steps.last().map_or(1.0, |s| t(s.inputs.now_ms)).max(0.01);
    let limit = f64::from(trace.scenario.params.max_pressure_kpa);

    let reading: Vec<(f64, f64)> = steps
        .iter()
        .filter(|s| s.outputs.telemetry.pressure_kpa.is_finite())
        .map(|s| {
            (
                t(s.inputs.now_ms),
                f64::from(s.outputs.telemetry.pressure_kpa),
            )
        })
        .collect();
    let line: Vec<(f64, f64)> = steps
        .iter()
        .map(|s| (t(s.inputs.now_ms), s.truth.line_kpa))
        .collect();
    let pump: Vec<(f64, f64)> = steps
        .iter()
        .map(|s| (t(s.inputs.now_ms), f64::from(s.inputs.pump_volume_ml)))
        .collect();
    let head: Vec<(f64, f64)> = steps
        .iter()
        .map(|s| (t(s.inputs.now_ms), s.truth.actuator_volume_ml))
        .collect();
    // A step line: hold each state until the next step.
    let mut state: Vec<(f64, f64)> = Vec::new();
    for s in &trace.steps {
        let (x, y) = (t(s.inputs.now_ms), level(s.outputs.state));
        if let Some(&(_, prev)) = state.last() {
            if prev != y {
                state.push((x, prev));
                state.push((x, y));
            }
        } else {
            state.push((x, y));
        }
    }
    state.push((t_end, state.last().map_or(0.0, |p| p.1)));

    let range = |pts: &[(f64, f64)], extra: &[f64]| {
        let (lo, hi) = pts
            .iter()
            .map(|p| p.1)
            .chain(extra.iter().copied())
            .filter(|v| v.is_finite())
            .fold((0.0_f64, 0.0_f64), |(lo, hi), v| (lo.min(v), hi.max(v)));
        let pad = 0.05 * (hi - lo).max(1e-3);
        (lo - pad)..(hi + pad)
    };
    let p_range = range(&[reading.as_slice(), line.as_slice()].concat(), &[limit]);
    let v_range = range(&[pump.as_slice(), head.as_slice()].concat(), &[]);

    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (1200, 900)).into_drawing_area();
        root.fill(&WHITE).map_err(plot_err)?;
        let root = root
            .titled(
                &format!(
                    "emulated {} (seed {}, sand cover {} mm)",
                    trace.scenario.name, trace.seed, trace.scenario.depth_mm
                ),
                ("sans-serif", 16),
            )
            .map_err(plot_err)?;
        let panels = root.split_evenly((3, 1));

        line_panel(
            &panels[0],
            t_end,
            p_range,
            "pressure (kPa)",
            &[
                ("reading (controller)", &reading, READING),
                ("true line pressure", &line, TRUE_LINE),
                ("max_pressure_kpa", &[(0.0, limit), (t_end, limit)], LIMIT),
            ],
        )?;
        line_panel(
            &panels[1],
            t_end,
            v_range,
            "volume (mL)",
            &[
                ("pump (reported)", &pump, PUMP),
                ("in the head (true)", &head, HEAD),
            ],
        )?;

        let mut chart = ChartBuilder::on(&panels[2])
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(0.0..t_end, -0.5..(State::ALL.len() as f64 - 0.5))
            .map_err(plot_err)?;
        chart
            .configure_mesh()
            .x_desc("time (s)")
            .y_labels(State::ALL.len())
            .y_label_formatter(&|y| {
                let i = y.round();
                if (y - i).abs() < 1e-6 && i >= 0.0 {
                    State::ALL
                        .get(i as usize)
                        .map(|s| format!("{s:?}"))
                        .unwrap_or_default()
                } else {
                    String::new()
                }
            })
            .draw()
            .map_err(plot_err)?;
        chart
            .draw_series(LineSeries::new(state, BLACK.stroke_width(2)))
            .map_err(plot_err)?;
        root.present().map_err(plot_err)?;
    }
    Ok(svg)
}
