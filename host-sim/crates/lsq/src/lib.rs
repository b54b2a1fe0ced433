//! Bounded Levenberg–Marquardt least squares, the one minimiser of the
//! skin's fits (coupons, inflation) and the workbench's calibration.
//!
//! Marquardt's scaled damping (JᵀJ + λ·diag JᵀJ)δ = −Jᵀr, each trial
//! projected onto the bounds; a trial is taken only when it lowers the sum
//! of squares, so a residual function may refuse a point (return `None`:
//! outside a law's domain, a tube that cannot be solved, a model that
//! cannot be built) and the step just shrinks. The problem differences its
//! own Jacobian ([`central_jacobian`] is one way), and may offer a finer
//! one for where the first stops making progress ([`Lm::refine`]).

use nalgebra::{DMatrix, DVector};

/// Where the minimiser stopped.
#[derive(Clone, Debug)]
pub struct Minimum {
    /// The coefficients.
    pub x: Vec<f64>,
    /// Residuals there.
    pub residuals: Vec<f64>,
    /// Their sum of squares.
    pub rss: f64,
    /// ∂r/∂x there (rows: residuals, columns: coefficients), as last
    /// differenced.
    pub jacobian: DMatrix<f64>,
    /// Iterations taken.
    pub iterations: usize,
}

/// When to stop.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stop {
    /// Iteration cap: it bounds a start that wanders along a flat valley
    /// (an over-parameterised law), where each step still gains a little.
    pub max_iterations: usize,
    /// Stop when an accepted step lowers the sum of squares by less than
    /// this fraction.
    pub tolerance: f64,
}

/// How the Jacobian is differenced, as the minimiser asks for it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Differences {
    /// The problem's usual differences.
    First,
    /// Finer ones, asked for once the first stop making progress (only
    /// with [`Lm::refine`]).
    Refined,
}

/// The minimiser's settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lm {
    /// When to stop.
    pub stop: Stop,
    /// Damping increases tried in an iteration before it gives up (each
    /// one residual evaluation).
    pub trials: usize,
    /// Where the first differences stop making progress, go on with
    /// [`Differences::Refined`] until those make none either: a fit in a
    /// curved valley whose floor a forward difference's O(h) error hides.
    pub refine: bool,
}

impl Lm {
    /// Minimises Σ r(x)² from `start` within `bounds` ((lower, upper) per
    /// coefficient), with ∂r/∂x from `jacobian(x, r(x), differences)`.
    /// `None` when the residuals are refused (or not finite) at the start.
    pub fn minimise(
        &self,
        residuals: impl Fn(&[f64]) -> Option<Vec<f64>>,
        jacobian: impl Fn(&[f64], &[f64], Differences) -> DMatrix<f64>,
        start: &[f64],
        bounds: &[(f64, f64)],
    ) -> Option<Minimum> {
        let clamp = |x: &[f64]| -> Vec<f64> {
            x.iter()
                .zip(bounds)
                .map(|(v, (lo, hi))| v.clamp(*lo, *hi))
                .collect()
        };
        let finite = |r: Option<Vec<f64>>| r.filter(|r| r.iter().all(|v| v.is_finite()));
        let mut x = clamp(start);
        let mut r = finite(residuals(&x))?;
        let mut s = ssr(&r);
        let k = x.len();
        let mut lambda = 1e-3;
        let mut iterations = 0;
        let mut differences = Differences::First;
        // ∂r/∂x at `x` with `differences`, kept until either changes: an
        // iteration that takes no step leaves it current for the result
        // (each costs the problem 2k or more residual evaluations).
        let mut jac: Option<DMatrix<f64>> = None;
        while k > 0 && iterations < self.stop.max_iterations && s > 0.0 {
            iterations += 1;
            let j = jac.get_or_insert_with(|| jacobian(&x, &r, differences));
            let jtj = j.transpose() * &*j;
            let g = j.transpose() * DVector::from_column_slice(&r);
            let top = jtj.diagonal().max().max(1e-300);
            let mut improved = None;
            for _ in 0..self.trials {
                let mut a = jtj.clone();
                for i in 0..k {
                    // Marquardt scaling, floored so a dead column stays put.
                    a[(i, i)] += lambda * jtj[(i, i)].max(1e-12 * top);
                }
                let Some(step) = a.cholesky().map(|c| c.solve(&(-&g))) else {
                    lambda *= 10.0;
                    continue;
                };
                let trial: Vec<f64> = clamp(
                    &x.iter()
                        .zip(step.iter())
                        .map(|(v, d)| v + d)
                        .collect::<Vec<_>>(),
                );
                if let Some(rt) = finite(residuals(&trial)) {
                    let st = ssr(&rt);
                    if st < s {
                        improved = Some((s - st) / s);
                        x = trial;
                        r = rt;
                        s = st;
                        jac = None;
                        lambda = (lambda / 3.0).max(1e-12);
                        break;
                    }
                }
                lambda *= 4.0;
            }
            match improved {
                Some(gain) if gain > self.stop.tolerance => {}
                _ if self.refine && differences == Differences::First => {
                    differences = Differences::Refined;
                    jac = None;
                }
                _ => break,
            }
        }
        let jacobian = jac.unwrap_or_else(|| jacobian(&x, &r, differences));
        Some(Minimum {
            x,
            residuals: r,
            rss: s,
            jacobian,
            iterations,
        })
    }
}

fn ssr(r: &[f64]) -> f64 {
    r.iter().map(|v| v * v).sum()
}

/// ∂r/∂x at `x` (where the residuals are `r0`) by central differences,
/// one-sided at a bound or where one side is refused; a column neither
/// side of which can be evaluated is zero. Steps of 10⁻⁶ of each
/// coefficient (at least 10⁻⁸).
pub fn central_jacobian(
    residuals: &impl Fn(&[f64]) -> Option<Vec<f64>>,
    x: &[f64],
    r0: &[f64],
    bounds: &[(f64, f64)],
) -> DMatrix<f64> {
    let eval = |x: &[f64]| residuals(x).filter(|r| r.iter().all(|v| v.is_finite()));
    let cols: Vec<Vec<f64>> = (0..x.len())
        .map(|j| {
            let h = 1e-6 * x[j].abs().max(1e-2);
            let (lo, hi) = bounds[j];
            let at = |v: f64| {
                let mut t = x.to_vec();
                t[j] = v;
                eval(&t)
            };
            let up = (x[j] + h <= hi).then(|| at(x[j] + h)).flatten();
            let down = (x[j] - h >= lo).then(|| at(x[j] - h)).flatten();
            match (up, down) {
                (Some(u), Some(d)) => u.iter().zip(&d).map(|(a, b)| (a - b) / (2.0 * h)).collect(),
                (Some(u), None) => u.iter().zip(r0).map(|(a, b)| (a - b) / h).collect(),
                (None, Some(d)) => r0.iter().zip(&d).map(|(a, b)| (a - b) / h).collect(),
                (None, None) => vec![0.0; r0.len()],
            }
        })
        .collect();
    DMatrix::from_fn(r0.len(), x.len(), |i, j| cols[j][i])
}

/// Standard errors σ·√((JᵀJ)⁻¹)ₖₖ, σ² = `rss`/(n − p) over the n rows
/// of `jacobian` and the p coefficients the data determine; `None` for the
/// others: a column with no effect on the residuals, and every coefficient
/// with a share in a combination the data leave free (two that trade off
/// exactly, as a sand law's depth power against wall arching on runs at
/// two depths). Only those: a coefficient outside the combination keeps
/// its standard error, which an inverse of the whole of JᵀJ would lose
/// with the rest. Computed from the eigenvectors of JᵀJ with its columns
/// scaled to unit length, so that "free" does not depend on the
/// coefficients' units (moduli in kPa beside dimensionless exponents);
/// where JᵀJ is regular this is its inverse's diagonal. All `None` when
/// there are no more rows than determined coefficients.
pub fn standard_errors(jacobian: &DMatrix<f64>, rss: f64) -> Vec<Option<f64>> {
    let (n, k) = jacobian.shape();
    let norms: Vec<f64> = jacobian.column_iter().map(|c| c.norm()).collect();
    let top = norms.iter().copied().fold(0.0, f64::max);
    let live: Vec<usize> = (0..k)
        .filter(|&j| norms[j] > 1e-9 * top.max(1e-300))
        .collect();
    let mut se = vec![None; k];
    if live.is_empty() || n <= live.len() || !rss.is_finite() {
        return se;
    }
    let sigma2 = rss / (n - live.len()) as f64;
    let scaled = DMatrix::from_fn(n, live.len(), |i, a| {
        jacobian[(i, live[a])] / norms[live[a]]
    });
    let eigen = (scaled.transpose() * &scaled).symmetric_eigen();
    let largest = eigen.eigenvalues.iter().copied().fold(0.0, f64::max);
    // Directions the data leave free: eigenvalues at the rounding level of
    // a unit-diagonal JᵀJ of a differenced Jacobian.
    let free = |lambda: f64| lambda.is_nan() || lambda <= FREE_EIGENVALUE * largest;
    for (a, &j) in live.iter().enumerate() {
        let mut var = 0.0;
        let mut share_free = 0.0;
        for (m, &lambda) in eigen.eigenvalues.iter().enumerate() {
            let v2 = eigen.eigenvectors[(a, m)].powi(2);
            if free(lambda) {
                share_free += v2;
            } else {
                var += v2 / lambda;
            }
        }
        let var = var * sigma2 / (norms[j] * norms[j]);
        if share_free < FREE_SHARE && var.is_finite() && var >= 0.0 {
            se[j] = Some(var.sqrt());
        }
    }
    se
}

/// Eigenvalue of the unit-diagonal JᵀJ, relative to its largest, below
/// which a direction counts as left free by the data (a condition number
/// of J of 10⁶).
const FREE_EIGENVALUE: f64 = 1e-12;

/// Share of a coefficient's unit vector in the free directions above which
/// it is not determined.
const FREE_SHARE: f64 = 1e-6;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pair_that_trades_off_leaves_the_others_determined() {
        // a on the even rows, b on the odd ones (orthogonal); the second
        // column is 2a: it trades off exactly with the first.
        let rows = 50;
        let a = |i: usize| {
            if i.is_multiple_of(2) {
                0.1 * (i + 1) as f64
            } else {
                0.0
            }
        };
        let b = |i: usize| {
            if !i.is_multiple_of(2) {
                0.5 + 0.01 * i as f64
            } else {
                0.0
            }
        };
        let jac = DMatrix::from_fn(rows, 3, |i, j| match j {
            0 => a(i),
            1 => 2.0 * a(i),
            _ => b(i),
        });
        let rss = 4.7;
        let se = standard_errors(&jac, rss);
        assert_eq!(se[0], None);
        assert_eq!(se[1], None);
        // b is orthogonal to the pair, which counts once among the
        // determined: σ/‖b‖, σ² = RSS/(n − 3).
        let want = (rss / (rows - 3) as f64).sqrt() / jac.column(2).norm();
        let got = se[2].expect("b is determined");
        assert!((got - want).abs() < 1e-9 * want, "{got} vs {want}");
        // a and a + b: JᵀJ is regular, and the errors are its inverse's
        // diagonal.
        let two = DMatrix::from_fn(rows, 2, |i, j| a(i) + j as f64 * b(i));
        let inv = (two.transpose() * &two).try_inverse().unwrap();
        for (j, s) in standard_errors(&two, rss).iter().enumerate() {
            let want = (inv[(j, j)] * rss / (rows - 2) as f64).sqrt();
            let got = s.expect("determined");
            assert!((got - want).abs() < 1e-9 * want, "{j}: {got} vs {want}");
        }
    }

    #[test]
    fn the_jacobian_is_differenced_once_per_point_and_kind() {
        // A curved one-coefficient problem, refined at the end: every
        // (x, differences) the minimiser asks a Jacobian for is new.
        let t: Vec<f64> = (0..20).map(|i| 0.1 * i as f64).collect();
        let y: Vec<f64> = t.iter().map(|t| (0.7 * t).exp() + 0.01 * t.sin()).collect();
        let residuals = |x: &[f64]| {
            Some(
                t.iter()
                    .zip(&y)
                    .map(|(t, y)| (x[0] * t).exp() - y)
                    .collect(),
            )
        };
        let bounds = [(-5.0, 5.0)];
        let asked = std::cell::RefCell::new(Vec::new());
        let jacobian = |x: &[f64], r: &[f64], d: Differences| {
            asked.borrow_mut().push((x.to_vec(), d));
            central_jacobian(&residuals, x, r, &bounds)
        };
        let lm = Lm {
            // Until no trial lowers the sum: the last iteration takes no
            // step, and its Jacobian is the result's.
            stop: Stop {
                max_iterations: 100,
                tolerance: 0.0,
            },
            trials: 16,
            refine: true,
        };
        let m = lm.minimise(residuals, jacobian, &[0.0], &bounds).unwrap();
        assert!((m.x[0] - 0.7).abs() < 1e-2, "{:?}", m.x);
        let asked = asked.into_inner();
        assert!(asked.len() >= 2, "{asked:?}");
        for (k, a) in asked.iter().enumerate() {
            assert!(!asked[..k].contains(a), "asked twice for {a:?}");
        }
        // The result's Jacobian is the last one asked for, at the result.
        assert_eq!(asked.last().unwrap().0, m.x);
    }

    #[test]
    fn no_effect_or_too_few_rows_determine_nothing() {
        let zero = DMatrix::from_fn(10, 2, |i, j| if j == 0 { i as f64 } else { 0.0 });
        let se = standard_errors(&zero, 1.0);
        assert!(se[0].is_some());
        assert_eq!(se[1], None);
        let square = DMatrix::from_fn(2, 2, |i, j| if i == j { 1.0 } else { 0.0 });
        assert_eq!(standard_errors(&square, 1.0), vec![None, None]);
    }
}
