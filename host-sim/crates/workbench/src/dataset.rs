//! The runs of an experiment folder as the fitter sees them: one flat
//! vector of measured readings over all runs, with each sample's run, and
//! a decimated copy for calibration when the folder is large.

use rayon::prelude::*;

use model::RigModel;
use rig::{Experiment, Run};

/// Largest number of samples calibration steps through; bigger folders
/// are thinned (every k-th sample of each run) for fitting, and scored
/// on every sample.
pub const MAX_FIT_SAMPLES: usize = 4000;

/// Runs plus their readings, flattened.
#[derive(Clone, Debug)]
pub struct Dataset {
    /// The runs (possibly thinned).
    pub runs: Vec<Run>,
    /// Start of each run in the flat vectors (one past the end last).
    pub offsets: Vec<usize>,
    /// Measured reading of every sample (kPa).
    pub measured: Vec<f64>,
    /// Run index of every sample.
    pub run_of: Vec<usize>,
    /// Samples left out of every fit and score (isolated spikes,
    /// [`crate::spikes`]); their readings stay in the runs.
    pub skip: Vec<bool>,
}

impl Dataset {
    /// Every sample of `experiment`.
    pub fn new(experiment: &Experiment) -> Dataset {
        Self::from_runs(experiment.runs.clone())
    }

    /// From runs (empty runs are dropped).
    pub fn from_runs(runs: Vec<Run>) -> Dataset {
        let runs: Vec<Run> = runs.into_iter().filter(|r| !r.samples.is_empty()).collect();
        let mut offsets = vec![0];
        let mut measured = Vec::new();
        let mut run_of = Vec::new();
        for (i, r) in runs.iter().enumerate() {
            measured.extend(r.samples.iter().map(|s| s.pressure_kpa));
            run_of.extend(std::iter::repeat_n(i, r.samples.len()));
            offsets.push(measured.len());
        }
        let skip = vec![false; measured.len()];
        Dataset {
            runs,
            offsets,
            measured,
            run_of,
            skip,
        }
    }

    /// A copy with at most about `max_samples` samples: each run keeps
    /// every k-th sample (and its last).
    pub fn thinned(&self, max_samples: usize) -> Dataset {
        let n = self.len();
        if n <= max_samples || max_samples == 0 {
            return self.clone();
        }
        let k = n.div_ceil(max_samples);
        let keep = |r: &Run, i: usize| i.is_multiple_of(k) || i + 1 == r.samples.len();
        let runs = self
            .runs
            .iter()
            .map(|r| Run {
                samples: r
                    .samples
                    .iter()
                    .enumerate()
                    .filter(|(i, _)| keep(r, *i))
                    .map(|(_, s)| s.clone())
                    .collect(),
                ..r.clone()
            })
            .collect();
        let mut thin = Self::from_runs(runs);
        thin.skip = self
            .runs
            .iter()
            .zip(self.offsets.windows(2))
            .flat_map(|(r, w)| {
                (0..r.samples.len())
                    .filter(move |&i| keep(r, i))
                    .map(move |i| self.skip[w[0] + i])
            })
            .collect();
        thin
    }

    /// The samples not skipped, as their own dataset (for statistics over
    /// the runs: a skipped sample leaves its run), with each kept sample's
    /// index here.
    pub fn kept(&self) -> (Dataset, Vec<usize>) {
        let runs = self
            .runs
            .iter()
            .zip(self.offsets.windows(2))
            .map(|(r, w)| Run {
                samples: r
                    .samples
                    .iter()
                    .enumerate()
                    .filter(|(i, _)| !self.skip[w[0] + i])
                    .map(|(_, s)| s.clone())
                    .collect(),
                ..r.clone()
            })
            .collect();
        (Self::from_runs(runs), self.used().collect())
    }

    /// The samples a fit or a score uses, as indices.
    pub fn used(&self) -> impl Iterator<Item = usize> + '_ {
        (0..self.len()).filter(|&i| !self.skip[i])
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.measured.len()
    }

    /// Whether there are no samples.
    pub fn is_empty(&self) -> bool {
        self.measured.is_empty()
    }

    /// The model's reading at every sample, runs in parallel.
    pub fn predict(&self, model: &RigModel) -> Vec<f64> {
        let parts: Vec<Vec<f64>> = self.runs.par_iter().map(|r| model.predict(r)).collect();
        parts.concat()
    }
}
