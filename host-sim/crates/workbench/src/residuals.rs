//! What the residual (measured − model) looks like: statistics overall
//! and by run, depth, flow rate and phase; its correlation with each
//! input; whether it is structured (runs test, lag-1 autocorrelation);
//! and a few generated sentences saying where the model fails worst.

use std::collections::BTreeMap;

use serde::Serialize;

use super::dataset::Dataset;
use model::{Phase, Prediction, RigModel};

/// Residual statistics of one group of samples.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct GroupStat {
    /// Group label.
    pub group: String,
    /// Samples.
    pub n: usize,
    /// Mean residual, measured − model (kPa): > 0 where the model
    /// under-predicts.
    pub mean_kpa: f64,
    /// Root mean square residual (kPa).
    pub rmse_kpa: f64,
}

/// Pearson correlation of the residual with each input.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Correlations {
    /// With time since the start of the run.
    pub time: f64,
    /// With pump flow (signed).
    pub flow: f64,
    /// With pump volume.
    pub volume: f64,
    /// With the model's reading.
    pub pressure: f64,
    /// With the sand cover.
    pub depth: f64,
}

/// Everything said about one residual.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ResidualReport {
    /// All samples.
    pub overall: GroupStat,
    /// Per run.
    pub by_run: Vec<GroupStat>,
    /// Per depth.
    pub by_depth: Vec<GroupStat>,
    /// Per flow rate (|flow| rounded; holds apart).
    pub by_flow: Vec<GroupStat>,
    /// Per phase.
    pub by_phase: Vec<GroupStat>,
    /// Correlations with the inputs.
    pub correlations: Correlations,
    /// Lag-1 autocorrelation within runs (white noise: ≈ 0).
    pub lag1_autocorrelation: f64,
    /// Wald–Wolfowitz runs test on the residual's signs, z score (white
    /// noise: |z| < 3; a smooth, structured residual: strongly negative).
    pub runs_test_z: f64,
    /// Plain-words summary.
    pub sentences: Vec<String>,
}

/// Residual (measured − model) and the model's predictions at every sample.
pub fn residual(data: &Dataset, model: &RigModel) -> (Vec<f64>, Vec<Prediction>) {
    let preds = data.predict_full(model);
    let r = data
        .measured
        .iter()
        .zip(&preds)
        .map(|(m, p)| m - p.sensor_kpa)
        .collect();
    (r, preds)
}

fn stat(group: String, values: &[f64]) -> GroupStat {
    let n = values.len();
    let nf = n.max(1) as f64;
    GroupStat {
        group,
        n,
        mean_kpa: values.iter().sum::<f64>() / nf,
        rmse_kpa: (values.iter().map(|x| x * x).sum::<f64>() / nf).sqrt(),
    }
}

fn grouped<K: Ord>(
    keys: impl Iterator<Item = K>,
    r: &[f64],
    label: impl Fn(&K) -> String,
) -> Vec<GroupStat> {
    let mut map: BTreeMap<K, Vec<f64>> = BTreeMap::new();
    for (k, x) in keys.zip(r) {
        map.entry(k).or_default().push(*x);
    }
    map.iter().map(|(k, v)| stat(label(k), v)).collect()
}

/// Pearson correlation (0 when either side is constant).
pub fn correlation(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len()) as f64;
    if n < 2.0 {
        return 0.0;
    }
    let ma = a.iter().sum::<f64>() / n;
    let mb = b.iter().sum::<f64>() / n;
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        sab += (x - ma) * (y - mb);
        saa += (x - ma) * (x - ma);
        sbb += (y - mb) * (y - mb);
    }
    if saa <= 0.0 || sbb <= 0.0 {
        0.0
    } else {
        sab / (saa * sbb).sqrt()
    }
}

/// Flow bucket (mL/s ×10, rounded to 0.5 mL/s above 0.25 mL/s).
fn flow_bucket(p: &Prediction) -> i64 {
    if p.phase == Phase::Hold {
        return -1;
    }
    let q = p.pump_flow_ml_s.abs();
    if q >= 0.25 {
        ((q * 2.0).round() * 5.0) as i64
    } else {
        // Phase changes between samples and creeping pumps.
        0
    }
}

/// Standard deviation of the reading noise estimated from the residual's
/// second differences within runs (median absolute value, robust to the
/// few kinks of a piecewise smooth model): for white noise of σ,
/// r\[i+1\] − 2r\[i\] + r\[i−1\] has standard deviation σ·√6.
pub fn noise_floor_estimate(data: &Dataset, r: &[f64]) -> f64 {
    let mut d2 = Vec::new();
    for w in data.offsets.windows(2) {
        let run = &r[w[0]..w[1]];
        for t in run.windows(3) {
            d2.push((t[2] - 2.0 * t[1] + t[0]).abs());
        }
    }
    if d2.is_empty() {
        return 0.0;
    }
    let mid = d2.len() / 2;
    let (_, median, _) = d2.select_nth_unstable_by(mid, f64::total_cmp);
    *median / 0.674_489_75 / 6f64.sqrt()
}

/// Lag-1 autocorrelation within runs and the runs-test z score.
fn structure(data: &Dataset, r: &[f64]) -> (f64, f64) {
    let mean = r.iter().sum::<f64>() / r.len().max(1) as f64;
    let (mut num, mut den) = (0.0, 0.0);
    let (mut pos, mut neg, mut runs) = (0.0f64, 0.0f64, 0.0f64);
    for w in data.offsets.windows(2) {
        let run = &r[w[0]..w[1]];
        for (i, x) in run.iter().enumerate() {
            den += (x - mean) * (x - mean);
            if i > 0 {
                num += (x - mean) * (run[i - 1] - mean);
            }
            if *x >= mean {
                pos += 1.0;
            } else {
                neg += 1.0;
            }
            if i == 0 || ((x >= &mean) != (run[i - 1] >= mean)) {
                runs += 1.0;
            }
        }
    }
    let lag1 = if den > 0.0 { num / den } else { 0.0 };
    let n = pos + neg;
    let z = if pos > 0.0 && neg > 0.0 && n > 2.0 {
        let mu = 2.0 * pos * neg / n + 1.0;
        let var = 2.0 * pos * neg * (2.0 * pos * neg - n) / (n * n * (n - 1.0));
        if var > 0.0 {
            (runs - mu) / var.sqrt()
        } else {
            0.0
        }
    } else {
        0.0
    };
    (lag1, z)
}

/// Analyses residual `r` with the predictions `preds` over `data`.
pub fn analyse(data: &Dataset, r: &[f64], preds: &[Prediction]) -> ResidualReport {
    let samples = || data.runs.iter().flat_map(|run| run.samples.iter());
    let t: Vec<f64> = samples().map(|s| s.t_s).collect();
    let v: Vec<f64> = samples().map(|s| s.volume_ml).collect();
    let flow: Vec<f64> = preds.iter().map(|p| p.pump_flow_ml_s).collect();
    let model: Vec<f64> = preds.iter().map(|p| p.sensor_kpa).collect();
    let depth: Vec<f64> = data.run_of.iter().map(|&i| data.runs[i].depth_mm).collect();
    let by_run = grouped(data.run_of.iter().copied(), r, |&i| data.runs[i].id.clone());
    let by_depth = grouped(depth.iter().map(|d| (d * 1000.0).round() as i64), r, |d| {
        format!("{} mm", *d as f64 / 1000.0)
    });
    let by_flow = grouped(preds.iter().map(flow_bucket), r, |b| {
        if *b < 0 {
            "hold".to_owned()
        } else {
            if *b == 0 {
                "below 0.25 mL/s".to_owned()
            } else {
                format!("{:.1} mL/s", *b as f64 / 10.0)
            }
        }
    });
    let by_phase = grouped(preds.iter().map(|p| p.phase), r, |p| p.as_str().to_owned());
    let correlations = Correlations {
        time: correlation(r, &t),
        flow: correlation(r, &flow),
        volume: correlation(r, &v),
        pressure: correlation(r, &model),
        depth: correlation(r, &depth),
    };
    let (lag1, z) = structure(data, r);
    let mut report = ResidualReport {
        overall: stat("all".to_owned(), r),
        by_run,
        by_depth,
        by_flow,
        by_phase,
        correlations,
        lag1_autocorrelation: lag1,
        runs_test_z: z,
        sentences: Vec::new(),
    };
    report.sentences = sentences(&report);
    report
}

fn direction(mean: f64) -> &'static str {
    if mean > 0.0 {
        "under-predicts"
    } else {
        "over-predicts"
    }
}

/// A few sentences on where the model fails worst and how the residual
/// behaves.
pub fn sentences(rep: &ResidualReport) -> Vec<String> {
    let mut out = vec![format!(
        "Overall RMSE {:.3} kPa over {} samples (mean residual {:+.3} kPa).",
        rep.overall.rmse_kpa, rep.overall.n, rep.overall.mean_kpa
    )];
    // Worst among groups holding at least 5 % of the samples: a handful
    // of transition samples is not where the model fails.
    let floor = rep.overall.n / 20;
    let worst = |groups: &[GroupStat]| {
        groups
            .iter()
            .filter(|g| g.n >= floor)
            .max_by(|a, b| a.rmse_kpa.total_cmp(&b.rmse_kpa))
            .cloned()
    };
    if let (Some(ph), Some(fl), Some(dp)) = (
        worst(&rep.by_phase),
        worst(&rep.by_flow),
        worst(&rep.by_depth),
    ) {
        out.push(format!(
            "Worst phase: {} (RMSE {:.3} kPa; the model {} by {:.3} kPa on average); worst flow group: {} (RMSE {:.3} kPa); worst depth: {} (RMSE {:.3} kPa).",
            ph.group,
            ph.rmse_kpa,
            direction(ph.mean_kpa),
            ph.mean_kpa.abs(),
            fl.group,
            fl.rmse_kpa,
            dp.group,
            dp.rmse_kpa
        ));
    }
    let c = &rep.correlations;
    let named = [
        ("flow rate", c.flow),
        ("time", c.time),
        ("pumped volume", c.volume),
        ("pressure", c.pressure),
        ("depth", c.depth),
    ];
    let strongest = named.iter().max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()));
    if let Some((what, r)) = strongest {
        if r.abs() > 0.3 {
            out.push(format!(
                "The residual follows {what} (correlation {r:+.2}){}.",
                if *what == "flow rate" {
                    let hold = rep
                        .by_phase
                        .iter()
                        .find(|g| g.group == "hold")
                        .map_or(0.0, |g| g.mean_kpa);
                    format!(", mean {hold:+.3} kPa during holds")
                } else {
                    String::new()
                }
            ));
        } else {
            out.push("The residual is not correlated with flow, time, volume, pressure or depth (all |r| ≤ 0.3).".to_owned());
        }
    }
    out.push(
        if rep.lag1_autocorrelation > 0.3 && rep.runs_test_z < -4.0 {
            format!(
                "It is structured, not noise: lag-1 autocorrelation {:.2}, runs test z = {:.1}.",
                rep.lag1_autocorrelation, rep.runs_test_z
            )
        } else {
            format!(
                "It looks like noise: lag-1 autocorrelation {:.2}, runs test z = {:.1}.",
                rep.lag1_autocorrelation, rep.runs_test_z
            )
        },
    );
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};
    use rig::{Run, Sample};

    fn white(n: usize, sigma: f64, seed: u64) -> (Dataset, Vec<f64>) {
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(seed);
        let normal = Normal::new(0.0, sigma).unwrap();
        let r: Vec<f64> = (0..n).map(|_| normal.sample(&mut rng)).collect();
        let run = Run {
            id: "w".into(),
            depth_mm: 0.0,
            samples: (0..n)
                .map(|i| Sample {
                    t_s: i as f64 * 0.01,
                    volume_ml: 0.0,
                    pressure_kpa: r[i],
                    diameter_mm: None,
                    extra: Vec::new(),
                })
                .collect(),
        };
        (Dataset::from_runs(vec![run]), r)
    }

    #[test]
    fn white_noise_reads_as_noise() {
        let (data, r) = white(20_000, 0.05, 3);
        let sigma = noise_floor_estimate(&data, &r);
        assert!((sigma - 0.05).abs() < 0.0025, "{sigma}");
        let (lag1, z) = structure(&data, &r);
        assert!(lag1.abs() < 0.03, "{lag1}");
        assert!(z.abs() < 4.0, "{z}");
        // A slow sine on top is structure.
        let smooth: Vec<f64> = r
            .iter()
            .enumerate()
            .map(|(i, x)| x + 0.2 * (i as f64 * 0.01).sin())
            .collect();
        let (lag1, z) = structure(&data, &smooth);
        assert!(lag1 > 0.5 && z < -10.0, "{lag1} {z}");
        assert!((correlation(&[1.0, 2.0, 3.0], &[2.0, 4.0, 6.0]) - 1.0).abs() < 1e-12);
        assert_eq!(correlation(&[1.0, 1.0], &[2.0, 3.0]), 0.0);
    }
}
