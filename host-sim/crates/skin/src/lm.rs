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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rosenbrock_reaches_its_minimum() {
        let f = |x: &[f64]| Some(vec![10.0 * (x[1] - x[0] * x[0]), 1.0 - x[0]]);
        let m = minimise(f, &[-1.2, 1.0], &[(-5.0, 5.0), (-5.0, 5.0)]).unwrap();
        assert!(
            (m.x[0] - 1.0).abs() < 1e-6 && (m.x[1] - 1.0).abs() < 1e-6,
            "{:?}",
            m.x
        );
    }

    #[test]
    fn a_bound_holds_and_refused_points_only_shrink_the_step() {
        // Unconstrained minimum at 3, bound at 2.
        let m = minimise(|x| Some(vec![x[0] - 3.0]), &[0.0], &[(0.0, 2.0)]).unwrap();
        assert_eq!(m.x[0], 2.0);
        // The residual refuses x > 1.5: the minimiser stays below it and
        // still gets close to it.
        let m = minimise(
            |x| (x[0] <= 1.5).then(|| vec![x[0] - 3.0]),
            &[0.0],
            &[(0.0, 10.0)],
        )
        .unwrap();
        assert!(m.x[0] <= 1.5 && m.x[0] > 1.4, "{}", m.x[0]);
        assert!(minimise(|_| None, &[0.0], &[(0.0, 1.0)]).is_none());
    }

    #[test]
    fn exponential_fit_recovers_its_parameters_and_closed_form_errors() {
        // y = a·e^(b·t) exactly: recovered to rounding.
        let t: Vec<f64> = (0..20).map(|i| 0.1 * f64::from(i)).collect();
        let y: Vec<f64> = t.iter().map(|t| 2.5 * (-1.3 * t).exp()).collect();
        let f = |x: &[f64]| {
            Some(
                t.iter()
                    .zip(&y)
                    .map(|(t, y)| x[0] * (x[1] * t).exp() - y)
                    .collect(),
            )
        };
        let m = minimise(f, &[1.0, 0.0], &[(-10.0, 10.0), (-10.0, 10.0)]).unwrap();
        assert!(
            (m.x[0] - 2.5).abs() < 1e-8 && (m.x[1] + 1.3).abs() < 1e-8,
            "{:?}",
            m.x
        );
        // One linear coefficient: se = √(s²/Σφ²) in closed form.
        let phi: Vec<f64> = t.iter().map(|t| t * t).collect();
        let yy: Vec<f64> = phi
            .iter()
            .enumerate()
            .map(|(i, p)| 3.0 * p + if i % 2 == 0 { 0.1 } else { -0.1 })
            .collect();
        let g = |x: &[f64]| Some(phi.iter().zip(&yy).map(|(p, y)| x[0] * p - y).collect());
        let m = minimise(g, &[0.0], &[(-10.0, 10.0)]).unwrap();
        let spp: f64 = phi.iter().map(|p| p * p).sum();
        let se = (m.rss / 19.0 / spp).sqrt();
        let got = standard_errors(&m.jacobian, m.rss)[0].unwrap();
        assert!((got - se).abs() < 1e-6 * se, "{got} vs {se}");
    }
}
