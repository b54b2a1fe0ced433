//! Statistics over runs: binning a run's (D, p_e) samples over the
//! diameter (the solver sand's stored rows, the ensembles' mean curves)
//! and the mean ± SD over beds.

use serde::Serialize;

/// One diameter bin of a run.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Bin {
    /// Mean outer diameter of the samples in the bin (mm).
    pub diameter_mm: f64,
    /// Mean p_e of those samples (kPa).
    pub p_e_kpa: f64,
    /// How many samples fell in the bin.
    pub samples: usize,
}

/// Bins `(D mm, p_e kPa)` points into bins of `width_mm` from `start_mm`
/// (the first bin is [start, start + width)) up to the bin holding
/// `end_mm`: each bin's mean D and mean p_e; empty bins, points outside
/// and non-finite points are left out.
pub fn bin_samples(points: &[(f64, f64)], start_mm: f64, end_mm: f64, width_mm: f64) -> Vec<Bin> {
    bin_samples_indexed(points, start_mm, end_mm, width_mm)
        .into_iter()
        .map(|(_, b)| b)
        .collect()
}

/// [`bin_samples`] with each bin's index k (the bin [start + k·width,
/// start + (k + 1)·width)), so bins of several runs can be matched.
pub fn bin_samples_indexed(
    points: &[(f64, f64)],
    start_mm: f64,
    end_mm: f64,
    width_mm: f64,
) -> Vec<(usize, Bin)> {
    if !(width_mm > 0.0 && start_mm.is_finite() && end_mm.is_finite() && end_mm > start_mm) {
        return Vec::new();
    }
    let n = ((end_mm - start_mm) / width_mm).ceil() as usize;
    let mut sums = vec![(0.0f64, 0.0f64, 0usize); n];
    for &(d, p) in points {
        if !(d.is_finite() && p.is_finite()) {
            continue;
        }
        let k = ((d - start_mm) / width_mm).floor();
        if k < 0.0 {
            continue;
        }
        if let Some(s) = sums.get_mut(k as usize) {
            s.0 += d;
            s.1 += p;
            s.2 += 1;
        }
    }
    sums.into_iter()
        .enumerate()
        .filter(|(_, s)| s.2 > 0)
        .map(|(k, (d, p, n))| {
            (
                k,
                Bin {
                    diameter_mm: d / n as f64,
                    p_e_kpa: p / n as f64,
                    samples: n,
                },
            )
        })
        .collect()
}

/// Mean and sample standard deviation (n − 1) of `values`; the SD is 0
/// for a single value, both NaN for none.
pub fn mean_sd(values: &[f64]) -> (f64, f64) {
    let n = values.len();
    let m = values.iter().sum::<f64>() / n as f64;
    let sd = match n {
        0 => f64::NAN,
        1 => 0.0,
        _ => (values.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / (n - 1) as f64).sqrt(),
    };
    (m, sd)
}
