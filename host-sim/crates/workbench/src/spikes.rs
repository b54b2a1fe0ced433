//! Isolated spikes: single readings (a sensor glitch, a dropped bit) far
//! off both the model and their neighbours. Left in, one of them can
//! drag a least-squares fit further than every other sample together; so
//! they are found, named by file and line, and left out of every fit and
//! score, never silently used and never silently dropped.
//!
//! The test is robust: each residual minus the median of its run's
//! residuals around it (a median follows steps and slow misfit, not a
//! lone outlier), against 1.4826 × the median absolute value of those
//! differences over the folder (the normal-noise standard deviation, which
//! the outliers themselves do not inflate).

use serde::Serialize;

use rig::Experiment;

use crate::dataset::Dataset;

/// Half-width of the running median (samples each side).
pub const WINDOW: usize = 3;
/// A reading is a spike beyond this many robust standard deviations.
pub const THRESHOLD_SIGMAS: f64 = 25.0;
/// Longest run of consecutive outliers still called a spike; longer ones
/// are an event the model should explain, and stay in.
pub const MAX_LENGTH: usize = 2;
/// Half-width of the stretch whose own spread a spike must also stand
/// out of (samples each side).
pub const LOCAL: usize = 12;

/// One reading left out as a spike.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Spike {
    /// The run.
    pub run: String,
    /// Its time in the run (s).
    pub t_s: f64,
    /// File and 1-based line it was read from, when it was read from one.
    pub file: Option<String>,
    /// See `file`.
    pub line: Option<u64>,
    /// Measured reading (kPa).
    pub reading_kpa: f64,
    /// How far it stands off its neighbours' trend (kPa).
    pub off_kpa: f64,
}

/// The spikes of `data` (every sample of `experiment`) against residual
/// `r` (measured − model, one per sample), as flat sample indices with
/// their description.
pub fn find(experiment: &Experiment, data: &Dataset, r: &[f64]) -> Vec<(usize, Spike)> {
    let n = data.len();
    if r.len() != n || n < 2 * WINDOW + 1 {
        return Vec::new();
    }
    // Each residual off the running median of its own run.
    let mut off = vec![0.0; n];
    for w in data.offsets.windows(2) {
        let (a, b) = (w[0], w[1]);
        for i in a..b {
            let lo = i.saturating_sub(WINDOW).max(a);
            let hi = (i + WINDOW + 1).min(b);
            off[i] = r[i] - median(&mut r[lo..hi].to_vec());
        }
    }
    let sigma = 1.4826 * median(&mut off.iter().map(|x| x.abs()).collect::<Vec<_>>());
    if !(sigma > 0.0 && sigma.is_finite()) {
        return Vec::new();
    }
    // Outliers: far off the folder's noise and off their own stretch's
    // (a fast transient the model misses has large differences all round;
    // a glitch stands alone). The first and last WINDOW samples of a run
    // have no two-sided median and are not judged.
    let mut outlier = vec![false; n];
    for w in data.offsets.windows(2) {
        let (a, b) = (w[0], w[1]);
        for i in (a + WINDOW)..b.saturating_sub(WINDOW) {
            let lo = i.saturating_sub(LOCAL).max(a);
            let hi = (i + LOCAL + 1).min(b);
            let mut around: Vec<f64> = (lo..hi)
                .filter(|&j| j.abs_diff(i) > MAX_LENGTH)
                .map(|j| off[j].abs())
                .collect();
            let local = 1.4826 * median(&mut around);
            outlier[i] = off[i].abs() > THRESHOLD_SIGMAS * sigma.max(local);
        }
    }
    let mut spikes = Vec::new();
    for w in data.offsets.windows(2) {
        let mut i = w[0];
        while i < w[1] {
            if !outlier[i] {
                i += 1;
                continue;
            }
            // A cluster: outliers with fewer than WINDOW clean samples
            // between them.
            let start = i;
            let mut end = i + 1;
            let mut j = end;
            while j < w[1] && j < end + WINDOW {
                if outlier[j] {
                    end = j + 1;
                }
                j += 1;
            }
            if end - start <= MAX_LENGTH {
                spikes.extend((start..end).map(|k| (k, describe(experiment, data, k, off[k]))));
            }
            i = end;
        }
    }
    spikes
}

/// Sample `k` as a [`Spike`], with its file and line when known.
fn describe(experiment: &Experiment, data: &Dataset, k: usize, off_kpa: f64) -> Spike {
    let ri = data.run_of[k];
    let run = &data.runs[ri];
    let j = k - data.offsets[ri];
    let source = experiment
        .runs
        .iter()
        .position(|r| r.id == run.id)
        .and_then(|p| experiment.sources.get(p));
    Spike {
        run: run.id.clone(),
        t_s: run.samples[j].t_s,
        file: source.map(|s| s.file.clone()),
        line: source.and_then(|s| s.lines.get(j).copied()),
        reading_kpa: data.measured[k],
        off_kpa,
    }
}

/// Median of `v` (reordered); NaN for none.
fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let m = v.len() / 2;
    if v.len() % 2 == 1 {
        v[m]
    } else {
        0.5 * (v[m - 1] + v[m])
    }
}

impl std::fmt::Display for Spike {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match (&self.file, self.line) {
            (Some(file), Some(line)) => write!(f, "{file}:{line}")?,
            _ => write!(f, "run {}", self.run)?,
        }
        write!(
            f,
            " (run {}, t {} s): {} kPa, {:+.3} kPa off its neighbours",
            self.run, self.t_s, self.reading_kpa, self.off_kpa
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rig::{Rig, Run, Sample};

    fn run(id: &str, readings: &[f64]) -> Run {
        Run {
            id: id.into(),
            depth_mm: 0.0,
            samples: readings
                .iter()
                .enumerate()
                .map(|(i, &p)| Sample {
                    t_s: i as f64 * 0.1,
                    volume_ml: 0.0,
                    pressure_kpa: p,
                    diameter_mm: None,
                    extra: Vec::new(),
                })
                .collect(),
        }
    }

    #[test]
    fn a_lone_outlier_is_a_spike_a_step_and_a_plateau_are_not() {
        // Noise of ±0.01 around a slow ramp, a step at 30, a three-sample
        // plateau at 45, and one glitch at 20.
        let mut readings: Vec<f64> = (0..60)
            .map(|i| 0.002 * i as f64 + 0.01 * ((i * 7919) % 13) as f64 / 6.0 - 0.01)
            .collect();
        for p in &mut readings[30..] {
            *p += 1.0;
        }
        for p in &mut readings[45..48] {
            *p += 0.8;
        }
        readings[20] += 0.5;
        let exp = Experiment::new(Rig::paper_default(), vec![run("a", &readings)]);
        let data = Dataset::new(&exp);
        // The model predicts zero: the residual is the reading.
        let found = find(&exp, &data, &readings);
        let at: Vec<usize> = found.iter().map(|(k, _)| *k).collect();
        assert_eq!(at, [20], "{found:?}");
        assert!((found[0].1.off_kpa - 0.5).abs() < 0.05, "{found:?}");
        assert_eq!(found[0].1.run, "a");
        assert_eq!(found[0].1.line, None);
    }

    #[test]
    fn clean_noise_has_no_spike() {
        let readings: Vec<f64> = (0..200)
            .map(|i| 0.01 * (((i * 7919) % 101) as f64 / 50.0 - 1.0))
            .collect();
        let exp = Experiment::new(Rig::paper_default(), vec![run("a", &readings)]);
        let data = Dataset::new(&exp);
        assert!(find(&exp, &data, &readings).is_empty());
    }
}
