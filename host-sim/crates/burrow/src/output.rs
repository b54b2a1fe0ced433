//! Result files of a scenario run: the samples as CSV, the pressures and
//! the head receding distance against D as SVG plots (and an ensemble's
//! pressures as mean ± SD bands), and VTK frames
//! (grains as points with their radius, the skin mesh) with `.vtk.series`
//! indexes for ParaView. All written atomically.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::{anyhow, Context, Result};
use plotters::prelude::*;

use super::Report;
use crate::coupling::Sample;
use crate::stats::{bin_samples_indexed, mean_sd};
use ::plot::plot_err;
use datafile::write_atomic;
use dem::Particles;
use sand::{BalloonPoint, BALLOON_FINAL_DIAMETER_MM};

/// The samples as CSV: time, D, p_i, p_e, p_h, max von Mises, contacts,
/// head receding distance D_r, the sand's share of p_i, the smallest and
/// largest caliper diameters at mid-length; with a shell skin also its
/// largest surface bending strain.
pub fn samples_csv(report: &Report) -> Result<Vec<u8>> {
    let mut w = csv::Writer::from_writer(Vec::new());
    let shell = report.spec.skin_kind.is_shell();
    let mut header = vec![
        "time_s",
        "diameter_mm",
        "internal_pressure_kpa",
        "sand_pressure_kpa",
        "front_pressure_kpa",
        "max_von_mises_mpa",
        "skin_contacts",
        "head_receding_mm",
        "sand_share_kpa",
        "min_caliper_mm",
        "max_caliper_mm",
        "head_pull_n",
    ];
    if shell {
        header.push("max_bending_strain");
    }
    w.write_record(&header)?;
    for s in &report.samples {
        let mut row = vec![
            format!("{:.6}", s.time_s),
            format!("{:.4}", s.outer_diameter_m * 1e3),
            format!("{:.5}", s.internal_pressure_pa * 1e-3),
            format!("{:.5}", s.sand_pressure_pa * 1e-3),
            format!("{:.5}", s.face_pressure_pa.unwrap_or(f64::NAN) * 1e-3),
            format!("{:.6}", s.max_von_mises_pa * 1e-6),
            s.contacts.to_string(),
            format!("{:.4}", s.head_receding_m * 1e3),
            format!("{:.5}", report.sand_share_pa(s).unwrap_or(f64::NAN) * 1e-3),
            format!("{:.4}", s.calipers_m.0 * 1e3),
            format!("{:.4}", s.calipers_m.1 * 1e3),
            format!("{:.5}", s.head_pull_n),
        ];
        if shell {
            row.push(format!("{:.4}", s.max_bending_strain.unwrap_or(f64::NAN)));
        }
        w.write_record(&row)?;
    }
    w.into_inner().map_err(|e| anyhow!("CSV buffer: {e}"))
}

/// One curve of a plot against D: legend, points (D mm, value), colour.
type Curve = (&'static str, Vec<(f64, f64)>, RGBColor);

/// (D in mm, `f(s)` × `scale`) for every sample where it is finite.
fn against_d(report: &Report, scale: f64, f: &dyn Fn(&Sample) -> f64) -> Vec<(f64, f64)> {
    report
        .samples
        .iter()
        .map(|s| (s.outer_diameter_m * 1e3, f(s) * scale))
        .filter(|p| p.1.is_finite())
        .collect()
}

/// p_i, the sand's share of it Δp_i, p_e and p_h (kPa) against D (mm) as
/// SVG text.
pub fn pressure_plot_svg(report: &Report, title: &str) -> Result<String> {
    let curves = [
        (
            "p_i (internal)",
            against_d(report, 1e-3, &|s| s.internal_pressure_pa),
            BLUE,
        ),
        (
            "Δp_i = p_i − p_free(D) (the sand's share)",
            against_d(report, 1e-3, &|s| {
                report.sand_share_pa(s).unwrap_or(f64::NAN)
            }),
            MAGENTA,
        ),
        (
            "p_e (sand contact on skin)",
            against_d(report, 1e-3, &|s| s.sand_pressure_pa),
            RED,
        ),
        (
            "p_h (sand on front face)",
            against_d(report, 1e-3, &|s| s.face_pressure_pa.unwrap_or(f64::NAN)),
            GREEN,
        ),
    ];
    chart_svg(
        title,
        "pressure (kPa)",
        &curves,
        &[],
        report.spec.balloon_point(),
    )
}

/// The head receding distance D_r (mm) against D (mm) as SVG text (the
/// paper's Figure 5).
pub fn head_plot_svg(report: &Report, title: &str) -> Result<String> {
    let curves = [(
        "head receding distance D_r",
        against_d(report, 1e3, &|s| s.head_receding_m),
        BLUE,
    )];
    chart_svg(title, "D_r (mm)", &curves, &[], None)
}

/// A shaded band between two curves against D: (D mm, low, high), colour.
type Band = (Vec<(f64, f64, f64)>, RGBColor);

/// Width of the diameter bins of the ensemble plot (mm).
pub const ENSEMBLE_BIN_MM: f64 = 0.25;

/// Mean ± SD over runs of one quantity against D: each run's samples are
/// averaged in [`ENSEMBLE_BIN_MM`] bins from the smallest D of all runs,
/// then each bin's run means give the mean and the sample SD (0 where
/// only one run reached the bin). `runs[k]` holds run k's (D mm, value)
/// points; returns (mean D, mean, SD) per bin that any run reached.
pub fn mean_sd_against_d(runs: &[Vec<(f64, f64)>]) -> Vec<(f64, f64, f64)> {
    let finite = || runs.iter().flatten().filter(|p| p.0.is_finite());
    let d0 = finite().fold(f64::INFINITY, |a, p| a.min(p.0));
    let end = finite().fold(f64::NEG_INFINITY, |a, p| a.max(p.0)) + ENSEMBLE_BIN_MM;
    // bin index → each run's mean (D, value) in it
    let mut bins: std::collections::BTreeMap<usize, Vec<(f64, f64)>> = Default::default();
    for run in runs {
        for (k, b) in bin_samples_indexed(run, d0, end, ENSEMBLE_BIN_MM) {
            bins.entry(k).or_default().push((b.diameter_mm, b.p_e_kpa));
        }
    }
    bins.values()
        .map(|means| {
            let d = mean_sd(&means.iter().map(|m| m.0).collect::<Vec<_>>()).0;
            let (v, sd) = mean_sd(&means.iter().map(|m| m.1).collect::<Vec<_>>());
            (d, v, sd)
        })
        .collect()
}

/// p_i, Δp_i and p_h (kPa) against D (mm) over the runs of an ensemble:
/// the mean over the runs as a line, ± one SD as a band, as SVG text.
pub fn ensemble_plot_svg(reports: &[Report], title: &str) -> Result<String> {
    type Read = fn(&Report, &Sample) -> f64;
    let quantities: [(&'static str, Read, RGBColor); 3] = [
        (
            "p_i (internal), mean ± SD",
            |_, s| s.internal_pressure_pa,
            BLUE,
        ),
        (
            "Δp_i (the sand's share), mean ± SD",
            |r, s| r.sand_share_pa(s).unwrap_or(f64::NAN),
            MAGENTA,
        ),
        (
            "p_h (front face), mean ± SD",
            |_, s| s.face_pressure_pa.unwrap_or(f64::NAN),
            GREEN,
        ),
    ];
    let mut curves = Vec::new();
    let mut bands = Vec::new();
    for (name, read, colour) in quantities {
        let runs: Vec<Vec<(f64, f64)>> = reports
            .iter()
            .map(|r| against_d(r, 1e-3, &|s| read(r, s)))
            .collect();
        let stats = mean_sd_against_d(&runs);
        curves.push((name, stats.iter().map(|s| (s.0, s.1)).collect(), colour));
        bands.push((
            stats.iter().map(|s| (s.0, s.1 - s.2, s.1 + s.2)).collect(),
            colour,
        ));
    }
    let balloon = reports.first().and_then(|r| r.spec.balloon_point());
    chart_svg(title, "pressure (kPa)", &curves, &bands, balloon)
}

/// A line chart of `curves` over shaded `bands` against the outer
/// diameter, y from min(0, data) up, with the balloon experiment's p_e ± SD
/// at its diameter when given.
fn chart_svg(
    title: &str,
    y_desc: &str,
    curves: &[Curve],
    bands: &[Band],
    balloon: Option<BalloonPoint>,
) -> Result<String> {
    let band_points = bands
        .iter()
        .flat_map(|b| b.0.iter().flat_map(|p| [(p.0, p.1), (p.0, p.2)]));
    let all: Vec<(f64, f64)> = curves
        .iter()
        .flat_map(|c| c.1.iter().copied())
        .chain(band_points)
        .chain(balloon.iter().flat_map(|b| {
            let d = BALLOON_FINAL_DIAMETER_MM;
            [
                (d, b.external_pressure_kpa + b.sd_kpa),
                (d, b.external_pressure_kpa - b.sd_kpa),
            ]
        }))
        .filter(|p| p.0.is_finite() && p.1.is_finite())
        .collect();
    let (x0, x1) = all
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
            (a.min(p.0), b.max(p.0))
        });
    let y0 = all.iter().fold(0.0f64, |a, p| a.min(p.1)) * 1.05;
    let y1 = all.iter().fold(0.0f64, |a, p| a.max(p.1)) * 1.05 + 1e-3;
    let (x0, x1) = if x0 < x1 { (x0, x1) } else { (18.0, 26.0) };
    // Room for the error bar's caps at the right edge.
    let x1 = x1
        + if balloon.is_some() {
            0.03 * (x1 - x0)
        } else {
            0.0
        };
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (900, 560)).into_drawing_area();
        root.fill(&WHITE).map_err(plot_err)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 20))
            .margin(15)
            .x_label_area_size(45)
            .y_label_area_size(60)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(plot_err)?;
        chart
            .configure_mesh()
            .x_desc("outer diameter D (mm)")
            .y_desc(y_desc)
            .draw()
            .map_err(plot_err)?;
        for (band, colour) in bands {
            let outline: Vec<(f64, f64)> = band
                .iter()
                .map(|p| (p.0, p.2))
                .chain(band.iter().rev().map(|p| (p.0, p.1)))
                .collect();
            chart
                .draw_series(std::iter::once(Polygon::new(
                    outline,
                    colour.mix(0.2).filled(),
                )))
                .map_err(plot_err)?;
        }
        for (name, data, colour) in curves {
            let colour = *colour;
            chart
                .draw_series(LineSeries::new(data.clone(), colour.stroke_width(2)))
                .map_err(plot_err)?
                .label(*name)
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour));
        }
        if let Some(b) = balloon {
            let (d, p, sd) = (BALLOON_FINAL_DIAMETER_MM, b.external_pressure_kpa, b.sd_kpa);
            chart
                .draw_series(std::iter::once(ErrorBar::new_vertical(
                    d,
                    p - sd,
                    p,
                    p + sd,
                    BLACK.filled().stroke_width(2),
                    12,
                )))
                .map_err(plot_err)?
                .label(format!(
                    "balloon experiment at h = {:.0} mm, p_e ± SD (compare Δp_i)",
                    b.depth_mm
                ))
                .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK));
        }
        plot::draw_legend(&mut chart, SeriesLabelPosition::UpperLeft, 0.8)?;
        root.present().map_err(plot_err)?;
    }
    Ok(svg)
}

/// The grains as legacy VTK polydata: points with radius and speed.
pub fn particles_vtk(p: &Particles, time_s: f64) -> String {
    let n = p.len();
    let mut s = String::new();
    // Writing to a String cannot fail.
    let _ = writeln!(s, "# vtk DataFile Version 3.0");
    let _ = writeln!(s, "urechis grains, t = {time_s} s");
    let _ = writeln!(s, "ASCII\nDATASET POLYDATA\nPOINTS {n} double");
    for x in &p.position_m {
        let _ = writeln!(s, "{:e} {:e} {:e}", x.x, x.y, x.z);
    }
    let _ = writeln!(s, "VERTICES {n} {}", 2 * n);
    for i in 0..n {
        let _ = writeln!(s, "1 {i}");
    }
    let _ = writeln!(
        s,
        "POINT_DATA {n}\nSCALARS radius_m double 1\nLOOKUP_TABLE default"
    );
    for r in &p.radius_m {
        let _ = writeln!(s, "{r:e}");
    }
    let _ = writeln!(s, "SCALARS speed_m_s double 1\nLOOKUP_TABLE default");
    for v in &p.velocity_m_s {
        let _ = writeln!(s, "{:e}", v.norm());
    }
    s
}

/// A ParaView `.vtk.series` index: file names (relative) and times (s).
pub fn vtk_series(frames: &[(String, f64)]) -> String {
    let files: Vec<String> = frames
        .iter()
        .map(|(name, t)| format!("    {{ \"name\": \"{name}\", \"time\": {t} }}"))
        .collect();
    format!(
        "{{\n  \"file-series-version\": \"1.0\",\n  \"files\": [\n{}\n  ]\n}}\n",
        files.join(",\n")
    )
}

/// Writes `text` to `dir/name` atomically.
pub fn write_text(dir: &Path, name: &str, text: &[u8]) -> Result<()> {
    let path = dir.join(name);
    write_atomic(&path, text).with_context(|| format!("writing {}", path.display()))
}
