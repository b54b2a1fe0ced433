//! p_e over the expansion: the 1 % windows of a run (ours or the peer's),
//! `pe.csv`, the plot and the side-by-side comparison.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::{bail, Context, Result};
use plot::plot_err;
use plotters::prelude::*;
use serde::Serialize;

use super::problem::{Cavity, Schedule};

/// One output window: the mean over its samples (every 10 steps) of the
/// diameter and p_e.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Window {
    /// Last step of the window.
    pub end_step: u64,
    /// Mean cylinder diameter (mm).
    pub d_mm: f64,
    /// Mean pressure on the cylinder, ΣF_n/(π·2R·L) (kPa).
    pub pe_kpa: f64,
}

/// A run's p_e over the expansion.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Curve {
    /// p_e at rest: the mean of the windows in the last
    /// [`Cavity::rest_mean_s`] before the expansion (kPa).
    pub at_rest_kpa: f64,
    /// Diameter at rest (mm).
    pub d0_mm: f64,
    /// The expansion's windows: `expansion[p − 1]` ends at p % (p = 1..=100).
    pub expansion: Vec<Window>,
}

impl Curve {
    /// The curve from every window of a run (the rest's and the
    /// expansion's, in step order).
    pub fn new(windows: Vec<Window>, schedule: &Schedule, cavity: &Cavity) -> Result<Curve> {
        let at_rest_kpa = rest_mean_kpa(&windows, schedule, cavity)?;
        let expansion: Vec<Window> = (1..=100)
            .map(|p| {
                let end = schedule.start_step + p * schedule.window_steps;
                windows
                    .iter()
                    .find(|w| w.end_step == end)
                    .copied()
                    .with_context(|| format!("no window ends at {p} % (step {end})"))
            })
            .collect::<Result<_>>()?;
        Ok(Curve {
            at_rest_kpa,
            d0_mm: 2e3 * cavity.radius_m[0],
            expansion,
        })
    }

    /// The curve from LAMMPS' `fix ave/time` files of `in.expand` (one per
    /// segment; columns found by the header's `v_Dmm` and `v_pe`).
    pub fn from_lammps(paths: &[&Path], schedule: &Schedule, cavity: &Cavity) -> Result<Curve> {
        let mut windows: Vec<Window> = Vec::new();
        for path in paths {
            let text = std::fs::read_to_string(path)
                .with_context(|| format!("reading {}", path.display()))?;
            let file = path.display().to_string();
            let header = text
                .lines()
                .filter(|l| l.starts_with('#'))
                .find(|l| l.contains("v_pe"))
                .with_context(|| format!("{file}: no header naming v_pe"))?;
            let names: Vec<&str> = header.trim_start_matches('#').split_whitespace().collect();
            let col = |name: &str| {
                names
                    .iter()
                    .position(|n| *n == name)
                    .with_context(|| format!("{file}: no column {name} in `{header}`"))
            };
            let (c_step, c_d, c_pe) = (col("TimeStep")?, col("v_Dmm")?, col("v_pe")?);
            for (k, line) in text.lines().enumerate() {
                if line.starts_with('#') || line.trim().is_empty() {
                    continue;
                }
                let fields: Vec<&str> = line.split_whitespace().collect();
                let get = |c: usize, what: &str| -> Result<f64> {
                    let s = fields
                        .get(c)
                        .with_context(|| format!("{file}:{}: no {what}", k + 1))?;
                    let v: f64 = s
                        .parse()
                        .with_context(|| format!("{file}:{}: {what} `{s}`", k + 1))?;
                    anyhow::ensure!(v.is_finite(), "{file}:{}: {what} is {v}", k + 1);
                    Ok(v)
                };
                let step = get(c_step, "TimeStep")?;
                windows.push(Window {
                    end_step: step as u64,
                    d_mm: get(c_d, "v_Dmm")?,
                    pe_kpa: get(c_pe, "v_pe")?,
                });
            }
        }
        windows.sort_by_key(|w| w.end_step);
        windows.dedup_by_key(|w| w.end_step);
        if windows.is_empty() {
            bail!("no LAMMPS windows in {paths:?}");
        }
        Curve::new(windows, schedule, cavity)
    }

    /// Reads a `pe.csv` that [`Curve::csv`] wrote (file `name` for
    /// errors): the at-rest row and the 100 windows.
    pub fn parse_csv(name: &str, bytes: &[u8]) -> Result<Curve> {
        let mut table = datafile::Table::parse(name, bytes)?;
        let (pc, dc, ec) = (
            table.require("percent")?,
            table.require("d_mm")?,
            table.require("pe_kpa")?,
        );
        let mut rows = Vec::new();
        for row in table.rows() {
            let row = row?;
            rows.push((row.number(pc)?, row.number(dc)?, row.number(ec)?));
        }
        anyhow::ensure!(
            rows.len() == 101 && rows.iter().enumerate().all(|(k, r)| r.0 == k as f64),
            "{name}: expected the rows of percent 0, 1, …, 100"
        );
        Ok(Curve {
            at_rest_kpa: rows[0].2,
            d0_mm: rows[0].1,
            expansion: rows[1..]
                .iter()
                .map(|&(_, d_mm, pe_kpa)| Window {
                    end_step: 0,
                    d_mm,
                    pe_kpa,
                })
                .collect(),
        })
    }

    /// `pe.csv`: `percent,d_mm,pe_kpa`, the at-rest value as percent 0,
    /// then each 1 % window, `percent` its end.
    pub fn csv(&self) -> String {
        let mut s = String::from("percent,d_mm,pe_kpa\n");
        let _ = writeln!(s, "0,{:.4},{:.6}", self.d0_mm, self.at_rest_kpa);
        for (p, w) in self.expansion.iter().enumerate() {
            let _ = writeln!(s, "{},{:.4},{:.6}", p + 1, w.d_mm, w.pe_kpa);
        }
        s
    }
}

/// p_e at rest (kPa): the mean of the windows of `windows` (a run's, in
/// step order) that end in the last [`Cavity::rest_mean_s`] before the
/// expansion starts; an error when any of them is missing.
pub fn rest_mean_kpa(windows: &[Window], schedule: &Schedule, cavity: &Cavity) -> Result<f64> {
    let rest_windows =
        ((cavity.rest_mean_s / (schedule.window_steps as f64 * cavity.dt_s)).round() as u64).max(1);
    let first_rest = schedule
        .start_step
        .saturating_sub((rest_windows - 1) * schedule.window_steps);
    let rest: Vec<f64> = windows
        .iter()
        .filter(|w| w.end_step >= first_rest && w.end_step <= schedule.start_step)
        .map(|w| w.pe_kpa)
        .collect();
    anyhow::ensure!(
        rest.len() as u64 == rest_windows,
        "{} windows at rest before step {}, expected {rest_windows}",
        rest.len(),
        schedule.start_step
    );
    Ok(rest.iter().sum::<f64>() / rest.len() as f64)
}

/// One row of a comparison: both codes at one percentage.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ComparisonRow {
    /// Percent of the expansion (0 = at rest).
    pub percent: u32,
    /// Diameter (mm), ours.
    pub d_mm: f64,
    /// p_e, ours (kPa).
    pub ours_kpa: f64,
    /// p_e, the peer's (kPa).
    pub peer_kpa: f64,
    /// ours / peer − 1 (%).
    pub difference_percent: f64,
}

/// Our curve against the peer's at rest and every 10 % of the expansion.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Comparison {
    /// The rows.
    pub rows: Vec<ComparisonRow>,
    /// Largest |difference| over the expansion's rows (%).
    pub worst_percent: f64,
}

/// Sets `ours` against `peer` at rest and at every 10 % of the expansion.
pub fn compare(ours: &Curve, peer: &Curve) -> Comparison {
    let row = |percent: u32, d_mm: f64, a: f64, b: f64| ComparisonRow {
        percent,
        d_mm,
        ours_kpa: a,
        peer_kpa: b,
        difference_percent: 100.0 * (a / b - 1.0),
    };
    let mut rows = vec![row(0, ours.d0_mm, ours.at_rest_kpa, peer.at_rest_kpa)];
    for p in (10..=100).step_by(10) {
        let (a, b) = (&ours.expansion[p - 1], &peer.expansion[p - 1]);
        rows.push(row(p as u32, a.d_mm, a.pe_kpa, b.pe_kpa));
    }
    let worst_percent = rows[1..]
        .iter()
        .map(|r| r.difference_percent.abs())
        .fold(0.0, f64::max);
    Comparison {
        rows,
        worst_percent,
    }
}

impl Comparison {
    /// `comparison.csv`.
    pub fn csv(&self) -> String {
        let mut s = String::from("percent,d_mm,ours_kpa,peer_kpa,difference_percent\n");
        for r in &self.rows {
            let _ = writeln!(
                s,
                "{},{:.4},{:.6},{:.6},{:.2}",
                r.percent, r.d_mm, r.ours_kpa, r.peer_kpa, r.difference_percent
            );
        }
        s
    }
}

/// p_e against D for each named curve (SVG).
pub fn plot_svg(title: &str, curves: &[(&str, &Curve)]) -> Result<String> {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (800, 520)).into_drawing_area();
        root.fill(&WHITE).map_err(plot_err)?;
        let points = |c: &Curve| -> Vec<(f64, f64)> {
            std::iter::once((c.d0_mm, c.at_rest_kpa))
                .chain(c.expansion.iter().map(|w| (w.d_mm, w.pe_kpa)))
                .collect()
        };
        let all: Vec<(f64, f64)> = curves.iter().flat_map(|(_, c)| points(c)).collect();
        let d_hi = all.iter().map(|p| p.0).fold(f64::MIN, f64::max);
        let d_lo = all.iter().map(|p| p.0).fold(f64::MAX, f64::min);
        let p_hi = all.iter().map(|p| p.1).fold(0.0, f64::max) * 1.1;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 20))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(56)
            .build_cartesian_2d(d_lo..d_hi, 0.0..p_hi.max(1e-3))
            .map_err(plot_err)?;
        chart
            .configure_mesh()
            .x_desc("cylinder diameter D (mm)")
            .y_desc("p_e (kPa)")
            .draw()
            .map_err(plot_err)?;
        let colours = [BLUE, RED, GREEN, MAGENTA];
        for (k, (name, c)) in curves.iter().enumerate() {
            let colour = colours[k % colours.len()];
            chart
                .draw_series(LineSeries::new(points(c), colour.stroke_width(2)))
                .map_err(plot_err)?
                .label(*name)
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], colour));
        }
        plot::draw_legend(&mut chart, SeriesLabelPosition::UpperLeft, 0.8)?;
        root.present().map_err(plot_err)?;
    }
    Ok(svg)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn windows(schedule: &Schedule, pe: impl Fn(u64) -> f64) -> Vec<Window> {
        (1..=schedule.end_step() / schedule.window_steps)
            .map(|k| {
                let end = k * schedule.window_steps;
                Window {
                    end_step: end,
                    d_mm: 18.7,
                    pe_kpa: pe(end),
                }
            })
            .collect()
    }

    #[test]
    fn the_rest_is_the_mean_of_the_last_50_ms_and_percent_p_ends_at_p() {
        let c = Cavity::default();
        let s = Schedule::new(1.0, 0.1, 1.5e-5).unwrap();
        // 0.05 s / (670 steps × 15 µs) = 4.98: the 5 windows ending at
        // 4,020 … 6,700.
        let curve = Curve::new(windows(&s, |e| e as f64), &s, &c).unwrap();
        assert_eq!(
            curve.at_rest_kpa,
            (4020 + 4690 + 5360 + 6030 + 6700) as f64 / 5.0
        );
        assert_eq!(curve.expansion[0].pe_kpa, 7370.0);
        assert_eq!(curve.expansion[99].pe_kpa, 73_700.0);
        let csv = curve.csv();
        assert!(csv.starts_with("percent,d_mm,pe_kpa\n0,18.7000,5360.000000\n1,"));
        // A peer twice as high: −50 % everywhere.
        let peer = Curve::new(windows(&s, |e| 2.0 * e as f64), &s, &c).unwrap();
        let cmp = compare(&curve, &peer);
        assert_eq!(cmp.rows.len(), 11);
        assert!((cmp.worst_percent - 50.0).abs() < 1e-9);
        assert!(plot_svg("t", &[("ours", &curve), ("peer", &peer)])
            .unwrap()
            .contains("<svg"));
    }

    #[test]
    fn lammps_averages_are_read_by_their_header() {
        let c = Cavity::default();
        let s = Schedule::new(1.0, 0.1, 1.5e-5).unwrap();
        let mut text = String::from(
            "# Time-averaged data for fix avg\n# TimeStep v_rcyl v_Dmm v_Fn v_pe v_ncon\n",
        );
        for w in windows(&s, |e| e as f64 * 1e-4) {
            let _ = writeln!(
                text,
                "{} 0.00935 {} 1.0 {} 300",
                w.end_step, w.d_mm, w.pe_kpa
            );
        }
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("avg.dat");
        std::fs::write(&path, &text).unwrap();
        let curve = Curve::from_lammps(&[&path], &s, &c).unwrap();
        assert!((curve.expansion[49].pe_kpa - 4.02).abs() < 1e-12);
        std::fs::write(&path, text.replace("v_pe", "v_px")).unwrap();
        let e = Curve::from_lammps(&[&path], &s, &c)
            .unwrap_err()
            .to_string();
        assert!(e.contains("v_pe"), "{e}");
    }
}
