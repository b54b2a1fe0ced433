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
        while k > 0 && iterations < self.stop.max_iterations && s > 0.0 {
            iterations += 1;
            let jac = jacobian(&x, &r, differences);
            let jtj = jac.transpose() * &jac;
            let g = jac.transpose() * DVector::from_column_slice(&r);
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
                }
                _ => break,
            }
        }
        let jacobian = jacobian(&x, &r, differences);
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

/// Standard errors s·√((JᵀJ)⁻¹)kk, s² = RSS/(n − p); NaN where JᵀJ is
/// singular (a coefficient the data do not determine).
pub fn standard_errors(jacobian: &DMatrix<f64>, rss: f64) -> Vec<f64> {
    let (n, p) = jacobian.shape();
    let nan = vec![f64::NAN; p];
    if n <= p {
        return nan;
    }
    let s2 = rss / (n - p) as f64;
    // Scale columns to unit norm before inverting (moduli in kPa beside
    // dimensionless exponents differ by orders of magnitude).
    let scale: Vec<f64> = jacobian.column_iter().map(|c| c.norm()).collect();
    if scale
        .iter()
        .any(|s| s.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) || !s.is_finite())
    {
        return nan;
    }
    let mut js = jacobian.clone();
    for (k, s) in scale.iter().enumerate() {
        js.column_mut(k).unscale_mut(*s);
    }
    let Some(inv) = (js.transpose() * &js).try_inverse() else {
        return nan;
    };
    (0..p)
        .map(|k| {
            let v = s2 * inv[(k, k)];
            if v.is_finite() && v >= 0.0 {
                v.sqrt() / scale[k]
            } else {
                f64::NAN
            }
        })
        .collect()
}
