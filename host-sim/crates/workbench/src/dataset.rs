//! The runs of an experiment folder as the fitter sees them: one flat
//! vector of measured readings over all runs, with each sample's run, and
//! a decimated copy for calibration when the folder is large.

use rayon::prelude::*;

use model::{Prediction, RigModel};
use rig::{Experiment, Run, Sample};

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
    /// On a thinned copy, each sample's pump flow in the whole recording
    /// (mL/s, the backward difference to its previous sample there), so
    /// that the model reads at a kept sample the flow it reads when every
    /// sample is stepped through ([`RigModel::step_at_flow`]). `None`:
    /// every sample of the recording is here.
    pub recorded_flow_ml_s: Option<Vec<f64>>,
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
            recorded_flow_ml_s: None,
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
        thin.recorded_flow_ml_s = Some(
            chosen
                .iter()
                .zip(&plans)
                .flat_map(|(&j, plan)| {
                    let s = &self.runs[j].samples;
                    plan.iter().map(move |&i| recorded_flow_ml_s(s, i))
                })
                .collect(),
        );
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
    /// depth's runs spread over its list; at least one per depth, and as
    /// many from each depth as it has runs. Indices in the folder's order.
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
        for round in 0..rounds {
            // Whole rounds only: a depth with a run more than another
            // would weigh more in the fit than it does in the folder.
            let next: Vec<usize> = orders
                .iter()
                .filter_map(|o| o.get(round).copied())
                .collect();
            let more: usize = next.iter().map(|&j| size(j)).sum();
            if round > 0 && total + more > budget {
                break;
            }
            total += more;
            chosen.extend(next);
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
        self.per_run(|run, flows| model.predict_at(run, flows))
    }

    /// The model's full prediction at every sample, runs in parallel.
    pub fn predict_full(&self, model: &RigModel) -> Vec<Prediction> {
        self.per_run(|run, flows| model.predict_full_at(run, flows))
    }

    /// `predict` over every run with its recorded flows, runs in
    /// parallel, concatenated in the flat order.
    fn per_run<T: Send>(&self, predict: impl Fn(&Run, Option<&[f64]>) -> Vec<T> + Sync) -> Vec<T> {
        let parts: Vec<Vec<T>> = (0..self.runs.len())
            .into_par_iter()
            .map(|k| predict(&self.runs[k], self.run_flows(k)))
            .collect();
        parts.into_iter().flatten().collect()
    }

    /// Run `k`'s slice of [`Dataset::recorded_flow_ml_s`].
    fn run_flows(&self, k: usize) -> Option<&[f64]> {
        let flows = self.recorded_flow_ml_s.as_ref()?;
        flows.get(self.offsets[k]..self.offsets[k + 1])
    }
}

/// The pump flow at sample `i` of `samples` as [`RigModel::step`] sees it
/// stepping through them all (mL/s, [`model::pump_flow`]); 0 at the first
/// sample, as there.
fn recorded_flow_ml_s(samples: &[Sample], i: usize) -> f64 {
    let prev = i.checked_sub(1).and_then(|p| samples.get(p));
    match (prev, samples.get(i)) {
        (Some(a), Some(b)) => {
            model::pump_flow(a.t_s, a.volume_ml, b.t_s, b.volume_ml).map_or(0.0, |(_, flow)| flow)
        }
        _ => 0.0,
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
    fn a_thinned_copy_reads_the_flow_of_the_whole_recording() {
        // A fill and a drain at 1 mL/s logged to 1 µL every 1.73 ms, in
        // free water with a line loss: the reading at a kept sample is
        // the skin at that volume plus R times the flow, so the thinned
        // copy must give every kept sample's full-recording reading, bit
        // for bit, although its own steps are ten samples long.
        let dt = 0.00173;
        let samples: Vec<Sample> = (0..2000)
            .map(|i| {
                let t = i as f64 * dt;
                let v = if t < 1.7 { t } else { (3.4 - t).max(0.0) };
                Sample {
                    t_s: t,
                    volume_ml: (v * 1e3).round() / 1e3,
                    pressure_kpa: 0.0,
                    diameter_mm: None,
                    extra: Vec::new(),
                }
            })
            .collect();
        let data = Dataset::from_runs(vec![Run {
            id: "a".into(),
            depth_mm: 0.0,
            samples,
        }]);
        let loss =
            model::effects::EffectInstance::new("line_loss", &[("resistance_kpa_s_per_ml", 0.25)])
                .unwrap();
        let m = RigModel::new(
            &rig::Rig::paper_default(),
            &model::Params::default(),
            &[loss],
        )
        .unwrap();
        let full = data.predict(&m);
        let mut thin = data.thinned(201);
        assert_eq!(thin.runs[0].samples[1].t_s, 10.0 * dt);
        let kept: Vec<f64> = (0..2000)
            .filter(|i| i % 10 == 0 || *i == 1999)
            .map(|i| full[i])
            .collect();
        assert_eq!(thin.predict(&m), kept);
        // Stepping the thinned copy on its own differences smooths the
        // log's 1 µL steps: the readings move by up to R·0.58 mL/s/2.
        thin.recorded_flow_ml_s = None;
        let off = thin
            .predict(&m)
            .iter()
            .zip(&kept)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(off > 0.05, "{off}");
    }

    #[test]
    fn whole_runs_are_kept_as_many_from_every_depth() {
        // Three runs at the first depth and two at each other, 901 samples
        // each at 20 ms (no thinning): a fourth run, from the first depth
        // only, would fit the budget but weigh that depth twice.
        let runs = [0.0, 0.0, 0.0, 50.0, 50.0, 120.0, 120.0]
            .iter()
            .enumerate()
            .map(|(k, &h)| run(&format!("r{k}"), h, 900, 0.02))
            .collect();
        let thin = Dataset::from_runs(runs).thinned(MAX_FIT_SAMPLES);
        let depths: Vec<f64> = thin.runs.iter().map(|r| r.depth_mm).collect();
        assert_eq!(depths, [0.0, 50.0, 120.0]);
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
