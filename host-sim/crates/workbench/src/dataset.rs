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

/// Widest spacing of the samples a fit steps through (s): the sensor's
/// lag (about 9 ms) and the line's transients are resolved at 20 ms, and
/// the model integrates from one kept sample to the next.
pub const MAX_THINNED_INTERVAL_S: f64 = 0.02;

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

    /// A copy with at most about `max_samples` samples for fitting: each
    /// run keeps every k-th sample (and its last). The stride is capped so
    /// that the kept samples stay [`MAX_THINNED_INTERVAL_S`] apart at most
    /// (the model steps from sample to sample, and coarser steps misstate
    /// its dynamics); when that cap binds, a subset of whole runs is kept
    /// instead, taken in turn from each depth and spread over each depth's
    /// runs, at least one per depth. A kept run still longer than its
    /// share of the budget (a run of hours) is fitted on its opening
    /// stretch at that stride: only there is the model's state known (the
    /// run starts at rest), whereas a window later in the run would need
    /// the whole run stepped through to carry a leak's lost volume or the
    /// skin's memory. The rest of the run is predicted from that fit and
    /// scored with every other sample, so a run that changes later shows
    /// as a residual, not as a different fit.
    pub fn thinned(&self, max_samples: usize) -> Dataset {
        let n = self.len();
        if n <= max_samples || max_samples == 0 {
            return self.clone();
        }
        let wanted = n.div_ceil(max_samples);
        let k = wanted.min(self.max_stride());
        let chosen: Vec<usize> = if k == wanted {
            (0..self.runs.len()).collect()
        } else {
            self.spread_runs(max_samples, k)
        };
        let size = |j: usize| self.runs[j].samples.len().div_ceil(k) + 1;
        let total: usize = chosen.iter().map(|&j| size(j)).sum();
        let share = if total > max_samples {
            max_samples / chosen.len().max(1)
        } else {
            usize::MAX
        };
        let plans: Vec<Vec<usize>> = chosen
            .iter()
            .map(|&j| {
                let len = self.runs[j].samples.len();
                let end = if size(j) > share {
                    ((share.max(2) - 1) * k + 1).min(len)
                } else {
                    len
                };
                (0..end)
                    .filter(|&i| i.is_multiple_of(k) || i + 1 == end)
                    .collect()
            })
            .collect();
        let runs = chosen
            .iter()
            .zip(&plans)
            .map(|(&j, plan)| {
                let r = &self.runs[j];
                Run {
                    samples: plan.iter().map(|&i| r.samples[i].clone()).collect(),
                    ..r.clone()
                }
            })
            .collect();
        let mut thin = Self::from_runs(runs);
        thin.skip = chosen
            .iter()
            .zip(&plans)
            .flat_map(|(&j, plan)| {
                let a = self.offsets[j];
                plan.iter().map(move |&i| self.skip[a + i])
            })
            .collect();
        thin
    }

    /// The largest stride that keeps thinned samples at most
    /// [`MAX_THINNED_INTERVAL_S`] apart, at the folder's median sampling
    /// interval (at least 1).
    fn max_stride(&self) -> usize {
        let mut dts: Vec<f64> = self
            .runs
            .iter()
            .flat_map(|r| r.samples.windows(2).map(|w| w[1].t_s - w[0].t_s))
            .collect();
        if dts.is_empty() {
            return 1;
        }
        let mid = dts.len() / 2;
        let (_, dt, _) = dts.select_nth_unstable_by(mid, f64::total_cmp);
        let stride = (MAX_THINNED_INTERVAL_S / *dt).floor();
        if stride.is_finite() && stride >= 1.0 {
            stride as usize
        } else {
            1
        }
    }

    /// Whole runs, thinned by `stride`, within `budget` samples: taken in
    /// turn from each depth (in the order depths first appear), each
    /// depth's runs spread over its list; at least one per depth. Indices
    /// in the folder's order.
    fn spread_runs(&self, budget: usize, stride: usize) -> Vec<usize> {
        let mut groups: Vec<(u64, Vec<usize>)> = Vec::new();
        for (j, r) in self.runs.iter().enumerate() {
            let key = r.depth_mm.to_bits();
            match groups.iter_mut().find(|g| g.0 == key) {
                Some(g) => g.1.push(j),
                None => groups.push((key, vec![j])),
            }
        }
        let orders: Vec<Vec<usize>> = groups.iter().map(|g| spread_order(&g.1)).collect();
        let size = |j: usize| self.runs[j].samples.len().div_ceil(stride) + 1;
        let (mut chosen, mut total) = (Vec::new(), 0usize);
        let rounds = orders.iter().map(Vec::len).max().unwrap_or(0);
        'rounds: for round in 0..rounds {
            for order in &orders {
                let Some(&j) = order.get(round) else {
                    continue;
                };
                if round > 0 && total + size(j) > budget {
                    break 'rounds;
                }
                total += size(j);
                chosen.push(j);
            }
        }
        chosen.sort_unstable();
        chosen
    }

    /// The samples not skipped, as their own dataset (for statistics over
    /// the runs: a skipped sample leaves its run), in [`Dataset::used`]
    /// order.
    pub fn kept(&self) -> Dataset {
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
        Self::from_runs(runs)
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

/// `items` reordered so that every prefix is spread over the list: the
/// first, then each time the one farthest from those already taken.
fn spread_order(items: &[usize]) -> Vec<usize> {
    let n = items.len();
    // Each position's distance to the nearest one taken, kept up to date
    // as positions are taken (n·n work, not n³, for hundreds of runs).
    let mut gap = vec![n; n];
    let mut used = vec![false; n];
    let mut order = Vec::with_capacity(n);
    for _ in 0..n {
        // Farthest first; the earliest of equals.
        let next = (0..n)
            .filter(|&i| !used[i])
            .max_by_key(|&i| (gap[i], std::cmp::Reverse(i)))
            .unwrap_or(0);
        used[next] = true;
        for (i, g) in gap.iter_mut().enumerate() {
            *g = (*g).min(i.abs_diff(next));
        }
        order.push(items[next]);
    }
    order
}

#[cfg(test)]
mod tests {
    use super::*;
    use rig::Sample;

    fn run(id: &str, depth_mm: f64, n: usize, dt_s: f64) -> Run {
        Run {
            id: id.into(),
            depth_mm,
            samples: (0..n)
                .map(|i| Sample {
                    t_s: i as f64 * dt_s,
                    volume_ml: 0.0,
                    pressure_kpa: i as f64,
                    diameter_mm: None,
                    extra: Vec::new(),
                })
                .collect(),
        }
    }

    #[test]
    fn a_run_longer_than_its_share_is_fitted_on_its_opening_stretch() {
        // At 10 ms the stride is capped at 2 (20 ms): every run is kept,
        // the hour-long one cut to its opening, within the budget.
        let mut data = Dataset::from_runs(vec![
            run("short0", 0.0, 600, 0.01),
            run("hour", 50.0, 360_000, 0.01),
            run("short120", 120.0, 600, 0.01),
        ]);
        data.skip[600 + 4] = true;
        let thin = data.thinned(MAX_FIT_SAMPLES);
        let ids: Vec<&str> = thin.runs.iter().map(|r| r.id.as_str()).collect();
        assert_eq!(ids, ["short0", "hour", "short120"]);
        assert!(thin.len() <= MAX_FIT_SAMPLES, "{}", thin.len());
        let hour = &thin.runs[1].samples;
        let t: Vec<f64> = hour.iter().map(|s| s.t_s).collect();
        assert_eq!(t[0], 0.0);
        assert!(t.windows(2).all(|w| (w[1] - w[0] - 0.02).abs() < 1e-9));
        assert!(hour.len() >= MAX_FIT_SAMPLES / 3 - 1, "{}", hour.len());
        // The spike flag travels with its sample.
        let at = thin.offsets[1] + 2;
        assert!(thin.skip[at] && thin.skip.iter().filter(|s| **s).count() == 1);
        // Short runs keep every second sample and their last.
        assert_eq!(thin.runs[0].samples.len(), 301);
    }

    #[test]
    fn folders_within_the_budget_are_not_thinned() {
        let data = Dataset::from_runs(vec![run("a", 0.0, 1000, 0.01), run("b", 40.0, 1000, 0.01)]);
        assert_eq!(data.thinned(MAX_FIT_SAMPLES).len(), 2000);
    }
}
