//! One case over several lattice seeds: the coarse DEM's scatter as
//! mean ± SD of each reported number, the way the balloon experiment
//! reports its own repeats. A single run's p_h, for one, follows the few
//! grains on the face (seeds 1 and 2 at 40 mm: 73 % and 53 % drop).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{ensure, Context, Result};

use super::{output, FreeCurve, Options, Report, ScenarioSpec};
use crate::cases::Runner;
use crate::stats::mean_sd;

/// One reported quantity over the ensemble's runs.
#[derive(Clone, Debug, PartialEq)]
pub struct Metric {
    /// Name (the CSV column).
    pub name: &'static str,
    /// Its value in each run, in seed order.
    pub values: Vec<f64>,
}

impl Metric {
    /// Mean over the runs (NaN for none).
    pub fn mean(&self) -> f64 {
        mean_sd(&self.values).0
    }

    /// Sample standard deviation (n − 1); NaN for fewer than two runs.
    pub fn sd(&self) -> f64 {
        if self.values.len() < 2 {
            return f64::NAN;
        }
        mean_sd(&self.values).1
    }
}

/// The runs of one case, one per seed.
#[derive(Clone, Debug)]
pub struct Ensemble {
    /// The reports, in seed order.
    pub reports: Vec<Report>,
}

/// How one number is read off a report; NaN where a run cannot give it.
type Reader = fn(&Report) -> f64;

/// The reported numbers: name (with its unit) and how to read it.
const METRICS: [(&str, Reader); 14] = [
    ("settled_p_e_kpa", |r| r.settled.sand_pressure_pa * 1e-3),
    ("settled_p_h_kpa", |r| r.settled.face_pressure_pa * 1e-3),
    ("initial_p_h_kpa", |r| r.initial_face_pressure_pa() * 1e-3),
    ("final_p_i_kpa", |r| {
        r.final_means()
            .map_or(f64::NAN, |m| m.internal_pressure_pa * 1e-3)
    }),
    ("final_sand_share_kpa", |r| {
        r.final_means().map_or(f64::NAN, |m| m.sand_share_pa * 1e-3)
    }),
    ("final_p_e_kpa", |r| {
        r.final_means()
            .map_or(f64::NAN, |m| m.sand_pressure_pa * 1e-3)
    }),
    ("final_p_h_kpa", |r| {
        r.final_means()
            .map_or(f64::NAN, |m| m.face_pressure_pa * 1e-3)
    }),
    ("p_h_drop_end_pct", |r| {
        100.0 * r.face_pressure_drop().unwrap_or(f64::NAN)
    }),
    ("p_h_drop_late_pct", |r| {
        100.0
            * r.face_pressure_drop_beyond(r.spec.face_drop_from_m())
                .unwrap_or(f64::NAN)
    }),
    ("head_receding_mm", |r| {
        r.final_means()
            .map_or(f64::NAN, |m| m.head_receding_m * 1e3)
    }),
    ("head_pull_n", |r| {
        r.final_means().map_or(f64::NAN, |m| m.head_pull_n)
    }),
    ("max_von_mises_mpa", |r| {
        r.final_means()
            .map_or(f64::NAN, |m| m.max_von_mises_pa * 1e-6)
    }),
    // The zone's shape at the end (how far from round).
    ("final_min_caliper_mm", |r| {
        r.last().map_or(f64::NAN, |s| s.calipers_m.0 * 1e3)
    }),
    ("final_max_caliper_mm", |r| {
        r.last().map_or(f64::NAN, |s| s.calipers_m.1 * 1e3)
    }),
];

impl Ensemble {
    /// Runs `spec` once per seed in `seeds` (each run's files, if `out` is
    /// given, in `out/seed-S`), then writes `ensemble.csv`, `ensemble.txt`
    /// and `ensemble.svg` (p_i, Δp_i, p_h against D, mean ± SD) to `out`.
    pub fn run(
        spec: &ScenarioSpec,
        seeds: &[u64],
        out: Option<&Path>,
        progress: bool,
    ) -> Result<Ensemble> {
        Self::run_part(spec, seeds, out, progress, &Runner::whole())?
            .context("a run on one machine has every case")
    }

    /// [`Ensemble::run`] as one part of a command split over machines
    /// ([`Runner`]): `None` where another part runs some of the seeds.
    pub fn run_part(
        spec: &ScenarioSpec,
        seeds: &[u64],
        out: Option<&Path>,
        progress: bool,
        runner: &Runner,
    ) -> Result<Option<Ensemble>> {
        ensure!(!seeds.is_empty(), "an ensemble needs at least one seed");
        // The seed moves grains only: one free-skin curve serves every run.
        Self::run_with(spec, &FreeCurve::of(spec)?, seeds, out, progress, runner)
    }

    /// [`Ensemble::run_part`] with the zone's free curve `free` already
    /// computed (it depends on the skin only, so one serves every depth
    /// too).
    pub fn run_with(
        spec: &ScenarioSpec,
        free: &FreeCurve,
        seeds: &[u64],
        out: Option<&Path>,
        progress: bool,
        runner: &Runner,
    ) -> Result<Option<Ensemble>> {
        ensure!(!seeds.is_empty(), "an ensemble needs at least one seed");
        let mut reports = Vec::with_capacity(seeds.len());
        let mut complete = true;
        for &seed in seeds {
            let opts = Options {
                spec: ScenarioSpec {
                    seed,
                    ..spec.clone()
                },
                out: out.map(|d| Self::run_dir(d, seed)),
                progress,
            };
            match runner
                .run(&opts, free)
                .with_context(|| format!("seed {seed}"))?
            {
                Some(report) => reports.push(report),
                None => complete = false,
            }
        }
        if !complete {
            return Ok(None);
        }
        let ensemble = Ensemble { reports };
        if let Some(dir) = out {
            output::write_text(dir, "ensemble.csv", &ensemble.csv()?)?;
            output::write_text(dir, "ensemble.txt", ensemble.text().as_bytes())?;
            output::write_text(dir, "timing.csv", &ensemble.timing_csv()?)?;
            let title = format!(
                "h = {:.0} mm, {} seeds: mean ± SD over the runs",
                spec.depth_m * 1e3,
                seeds.len()
            );
            let svg = output::ensemble_plot_svg(&ensemble.reports, &title)?;
            output::write_text(dir, "ensemble.svg", svg.as_bytes())?;
        }
        Ok(Some(ensemble))
    }

    /// Each reported number over the runs.
    pub fn metrics(&self) -> Vec<Metric> {
        METRICS
            .iter()
            .map(|(name, read)| Metric {
                name,
                values: self.reports.iter().map(read).collect(),
            })
            .collect()
    }

    /// One row per run (its seed first), then the mean and the SD.
    pub fn csv(&self) -> Result<Vec<u8>> {
        let metrics = self.metrics();
        let mut w = csv::Writer::from_writer(Vec::new());
        let mut header = vec!["seed"];
        header.extend(metrics.iter().map(|m| m.name));
        w.write_record(&header)?;
        for (k, r) in self.reports.iter().enumerate() {
            let mut row = vec![r.spec.seed.to_string()];
            row.extend(metrics.iter().map(|m| format!("{:.5}", m.values[k])));
            w.write_record(&row)?;
        }
        for (label, stat) in [
            ("mean", Metric::mean as fn(&Metric) -> f64),
            ("sd", Metric::sd),
        ] {
            let mut row = vec![label.to_string()];
            row.extend(metrics.iter().map(|m| format!("{:.5}", stat(m))));
            w.write_record(&row)?;
        }
        w.into_inner().context("writing the ensemble table")
    }

    /// Each run's wall time and its phases (s), one row per seed: apart
    /// from the results ([`Ensemble::csv`]), which a run repeated
    /// elsewhere reproduces bit for bit, while its times differ.
    pub fn timing_csv(&self) -> Result<Vec<u8>> {
        let mut w = csv::Writer::from_writer(Vec::new());
        w.write_record([
            "seed",
            "wall_s",
            "free_curve_s",
            "settling_s",
            "advance_s",
            "expansion_s",
        ])?;
        for r in &self.reports {
            let p = r.phases;
            w.write_record(
                std::iter::once(r.spec.seed.to_string()).chain(
                    [
                        r.wall_s,
                        p.free_curve_s,
                        p.settling_s,
                        p.advance_s,
                        p.expansion_s,
                    ]
                    .map(|t| format!("{t:.3}")),
                ),
            )?;
        }
        w.into_inner().context("writing the ensemble's timing")
    }

    /// A plain-text summary: mean ± SD of each number.
    pub fn text(&self) -> String {
        let mut s = String::new();
        let seeds: Vec<String> = self
            .reports
            .iter()
            .map(|r| r.spec.seed.to_string())
            .collect();
        let _ = writeln!(
            s,
            "ensemble of {} runs, seeds {}:",
            seeds.len(),
            seeds.join(", ")
        );
        for m in self.metrics() {
            let _ = writeln!(s, "  {:<22} {:>10.4} ± {:.4}", m.name, m.mean(), m.sd());
        }
        s
    }

    /// The folder each run wrote to under `out`.
    pub fn run_dir(out: &Path, seed: u64) -> PathBuf {
        out.join(format!("seed-{seed}"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mean_and_sample_sd_of_known_values() {
        let m = Metric {
            name: "x",
            values: vec![2.0, 4.0, 4.0, 4.0, 5.0, 5.0, 7.0, 9.0],
        };
        assert_eq!(m.mean(), 5.0);
        // Σ(x − 5)² = 32 over n − 1 = 7.
        assert!((m.sd() - (32.0f64 / 7.0).sqrt()).abs() < 1e-15);
        let one = Metric {
            name: "y",
            values: vec![3.0],
        };
        assert_eq!(one.mean(), 3.0);
        assert!(one.sd().is_nan());
        // The plain helper calls one value's spread 0 (bands, one seed).
        assert_eq!(mean_sd(&[3.0]), (3.0, 0.0));
        assert!(mean_sd(&[]).0.is_nan());
    }

    #[test]
    fn mean_and_sd_over_runs_per_diameter_bin() {
        // Run 0: two samples in the first bin (means D 19.1, value 2),
        // one in the third. Run 1: one sample in the first bin (value 4).
        let runs = vec![
            vec![(19.0, 1.0), (19.2, 3.0), (19.6, 5.0)],
            vec![(19.1, 4.0), (f64::NAN, 9.0)],
        ];
        let bins = output::mean_sd_against_d(&runs);
        assert_eq!(bins.len(), 2);
        let (d, v, sd) = bins[0];
        assert!((d - 19.1).abs() < 1e-12 && (v - 3.0).abs() < 1e-12);
        // Run means 2 and 4: sample SD √2.
        assert!((sd - 2f64.sqrt()).abs() < 1e-12);
        assert_eq!(bins[1], (19.6, 5.0, 0.0));
    }
}
