//! The skin fits' use of the bounded Levenberg–Marquardt minimiser
//! ([`lsq`]): for the laws whose stresses are nonlinear in their
//! coefficients (Ogden's exponents, Gent's limit) and for the inflation
//! fit. The Jacobian is by central differences (one-sided at a bound).

pub use lsq::{standard_errors, Minimum, Stop};

/// Coupon fits: cheap residuals, run to rounding.
pub const COUPON: Stop = Stop {
    max_iterations: 400,
    tolerance: 1e-13,
};

/// Fits through the tube (each residual solves 40 tubes): to a relative
/// gain of 1e-9 and at most 60 iterations. The synthetic inflation checks
/// converge well inside both.
pub const TUBE: Stop = Stop {
    max_iterations: 60,
    tolerance: 1e-9,
};

/// Damping increases tried in an iteration.
const TRIALS: usize = 16;

/// Minimises Σ r(x)² from `start` within `bounds` ((lower, upper) per
/// coefficient), to [`COUPON`]. `None` when the residuals are refused at
/// the start.
pub fn minimise(
    residuals: impl Fn(&[f64]) -> Option<Vec<f64>>,
    start: &[f64],
    bounds: &[(f64, f64)],
) -> Option<Minimum> {
    minimise_until(residuals, start, bounds, COUPON)
}

/// [`minimise`] with its own stopping rule.
pub fn minimise_until(
    residuals: impl Fn(&[f64]) -> Option<Vec<f64>>,
    start: &[f64],
    bounds: &[(f64, f64)],
    stop: Stop,
) -> Option<Minimum> {
    let lm = lsq::Lm {
        stop,
        trials: TRIALS,
        refine: false,
    };
    let jacobian = |x: &[f64], r: &[f64], _| lsq::central_jacobian(&residuals, x, r, bounds);
    lm.minimise(&residuals, jacobian, start, bounds)
}
