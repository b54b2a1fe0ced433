//! The actuator's skin: incompressible isotropic hyperelastic laws, their
//! fit to coupon tests (uniaxial, equibiaxial, planar) and to the
//! actuator's own free inflation, and the inflation of the skin tube.
//!
//! Shape (after felupe): one small struct per strain energy
//! ([`NeoHookean`], [`MooneyRivlin`], [`Yeoh`], [`Gent`], [`Ogden`] with
//! 1–3 terms), each giving W(I1, I2) and its first and second derivatives;
//! the [`StrainEnergy`] trait derives the stresses of every homogeneous
//! test once from those derivatives (a principal-stretch law such as Ogden
//! overrides the principal views with its closed forms). [`LAWS`] is the
//! registry the fitter iterates: a new law is one file plus one row there.
//!
//! NH, MR and Yeoh are linear in their coefficients and fitted by linear
//! least squares; Ogden and Gent by a bounded Levenberg–Marquardt from
//! several starts ([`fit`], [`lm`]).
//!
//! - [`law`]: [`SkinLaw`], any registered law with its coefficients,
//!   chosen at run time, serialisable, scalable;
//! - [`choice`]: the command line's skin options (`--skin-fit`,
//!   `--skin-law`, `--fit-modes`, `--inflation-law`);
//! - [`coupon`]: reading skin tests of every mode (`shared/data-format.md`);
//! - [`fit`]: joint least-squares fit, standard errors, per-mode R² and
//!   RMSE, Drucker stability scan;
//! - [`lm`]: the fits' use of the bounded Levenberg–Marquardt minimiser
//!   ([`lsq`]), with its stopping rules;
//! - [`inflation`]: fitting a law to a free inflation, p(D), through the tube;
//! - [`plot`]: the SVG of data and fits;
//! - [`report`]: the `fit-skin` command's library side (read, fit, write);
//! - [`membrane`]: thick-walled tube inflation, pressure vs diameter;
//! - [`unicinctus`]: the synthetic *U. unicinctus* data set and the default
//!   skin fitted to it.

pub mod choice;
pub mod coupon;
pub mod fit;
pub mod gent;
pub mod inflation;
pub mod law;
pub mod lm;
pub mod membrane;
pub mod mooney_rivlin;
pub mod neo_hookean;
pub mod ogden;
pub mod plot;
pub mod report;
pub mod unicinctus;
pub mod yeoh;

pub use choice::{ChosenLaw, SkinFitChoice};
pub use gent::Gent;
pub use law::SkinLaw;
pub use mooney_rivlin::MooneyRivlin;
pub use neo_hookean::NeoHookean;
pub use ogden::{Ogden, OgdenTerm};
pub use yeoh::Yeoh;

/// The strain-energy interface, defined by the FEM kernel that consumes
/// it and implemented by every law here.
pub use fem::StrainEnergy;

/// One row of the law registry: what the fitter needs to know about a law.
#[derive(Clone, Copy, Debug)]
pub struct LawSpec {
    /// Name shown in tables, plots and JSON.
    pub name: &'static str,
    /// Coefficient names, in fitting order, with their units (`_kpa`:
    /// kPa; none: dimensionless).
    pub parameter_names: &'static [&'static str],
    /// Builds the law from coefficients in that order; `None` when the
    /// count is wrong or a value is outside the law's domain.
    pub from_parameters: fn(&[f64]) -> Option<Box<dyn StrainEnergy>>,
    /// How the stresses depend on the coefficients, i.e. how to fit them.
    pub form: Form,
}

/// How a law's stresses depend on its coefficients.
#[derive(Clone, Copy, Debug)]
pub enum Form {
    /// Linear in every coefficient: ordinary least squares.
    Linear,
    /// Nonlinear: bounded Levenberg–Marquardt from several starts.
    Nonlinear {
        /// Bounds (lower, upper) of each coefficient.
        bounds: &'static [(f64, f64)],
        /// Indices of the coefficients the stresses are linear in (the
        /// moduli); at each start they are solved by least squares.
        linear_in: &'static [usize],
        /// Starting values of the other coefficients, one vector per start.
        starts: fn() -> Vec<Vec<f64>>,
        /// Modulus–exponent pairs whose product must not be negative
        /// (Ogden's μp·αp > 0, Ogden 1972): each start keeps every pair in
        /// the sign of its starting exponent ([`LawSpec::bounds_from`]).
        sign_pairs: &'static [SignPair],
    },
}

/// A modulus and an exponent (indices into the coefficients) that must
/// share their sign: the term's contribution μp·αp/2 to the shear modulus
/// is then positive, and the term stiffens as it is stretched.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SignPair {
    /// Index of the modulus.
    pub modulus: usize,
    /// Index of the exponent.
    pub exponent: usize,
}

/// Smallest |exponent| of a [`SignPair`] in a fit: the pair's sign must not
/// flip through zero, where the term vanishes (dimensionless).
pub const MIN_ABS_EXPONENT: f64 = 0.01;

impl LawSpec {
    /// Looks a law up in [`LAWS`] by name.
    pub fn by_name(name: &str) -> Option<&'static LawSpec> {
        LAWS.iter().find(|l| l.name == name)
    }

    /// [`LawSpec::by_name`], or an error naming `what` (the option or
    /// file field it came from) and listing every law.
    pub fn named(name: &str, what: &str) -> anyhow::Result<&'static LawSpec> {
        Self::by_name(name).ok_or_else(|| {
            let names: Vec<&str> = LAWS.iter().map(|l| l.name).collect();
            anyhow::anyhow!("{what}: no law `{name}` (laws: {})", names.join(", "))
        })
    }

    /// Indices of the coefficients W is linear in (the moduli): scaling
    /// them by s scales W, and every stress, by s.
    pub fn moduli(&self) -> Vec<usize> {
        match self.form {
            Form::Linear => (0..self.parameter_names.len()).collect(),
            Form::Nonlinear { linear_in, .. } => linear_in.to_vec(),
        }
    }

    /// The bounds a nonlinear fit from `start` keeps to: the law's own,
    /// and each [`SignPair`] held in the sign of its starting exponent
    /// (modulus and exponent of that sign, |exponent| ≥
    /// [`MIN_ABS_EXPONENT`]); a zero starting exponent counts as positive.
    /// `None` for a linear law (no bounds).
    pub fn bounds_from(&self, start: &[f64]) -> Option<Vec<(f64, f64)>> {
        let Form::Nonlinear {
            bounds, sign_pairs, ..
        } = self.form
        else {
            return None;
        };
        let mut b = bounds.to_vec();
        for pair in sign_pairs {
            let positive = start.get(pair.exponent).is_none_or(|a| *a >= 0.0);
            let (m, e) = (pair.modulus, pair.exponent);
            if positive {
                b[m].0 = b[m].0.max(0.0);
                b[e].0 = b[e].0.max(MIN_ABS_EXPONENT);
            } else {
                b[m].1 = b[m].1.min(0.0);
                b[e].1 = b[e].1.min(-MIN_ABS_EXPONENT);
            }
        }
        Some(b)
    }
}

/// Every law the fitter knows, simplest first. A row marked
/// [`Form::Linear`] has stresses linear in its coefficients, which the
/// least-squares fit relies on (and a test checks for each such row).
pub static LAWS: [LawSpec; 7] = [
    NeoHookean::SPEC,
    MooneyRivlin::SPEC,
    Yeoh::SPEC,
    Gent::SPEC,
    Ogden::SPECS[0],
    Ogden::SPECS[1],
    Ogden::SPECS[2],
];

/// Invariants (I1, I2) of C for principal stretches `stretches`.
pub fn invariants(stretches: [f64; 3]) -> (f64, f64) {
    let [a, b, c] = stretches.map(|l| l * l);
    (a + b + c, a * b + b * c + c * a)
}

/// The skin the tables and solver use by default: the Yeoh fit to the
/// synthetic *U. unicinctus* circumferential data (see [`unicinctus`]).
pub fn default_skin() -> Yeoh {
    unicinctus::DEFAULT_YEOH
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A set of coefficients for each law that keeps every derivative
    /// nonzero, so the checks below are not trivially satisfied.
    fn sample_laws() -> Vec<Box<dyn StrainEnergy>> {
        LAWS.iter()
            .map(|spec| (spec.from_parameters)(&law::example(spec).parameters()).unwrap())
            .collect()
    }

    fn fd(f: impl Fn(f64) -> f64, x: f64) -> f64 {
        let h = 1e-5 * x.abs().max(1.0);
        (f(x + h) - f(x - h)) / (2.0 * h)
    }

    fn close(a: f64, b: f64, rel: f64, what: &str) {
        assert!(
            (a - b).abs() <= rel * a.abs().max(b.abs()).max(1e-9),
            "{what}: {a} vs {b}"
        );
    }

    #[test]
    fn registry_names_and_counts_match_the_laws() {
        for (spec, law) in LAWS.iter().zip(sample_laws()) {
            assert_eq!(law.name(), spec.name);
            assert_eq!(law.parameters().len(), spec.parameter_names.len());
            assert!((spec.from_parameters)(&[1.0; 7]).is_none());
            assert_eq!(LawSpec::by_name(spec.name).unwrap().name, spec.name);
        }
    }

    #[test]
    fn first_and_second_derivatives_match_finite_differences() {
        for law in sample_laws() {
            for (i1, i2) in [(3.0, 3.0), (3.7, 3.4), (9.0, 14.0), (25.0, 11.0)] {
                let n = law.name();
                close(
                    law.dw_di1_kpa(i1, i2),
                    fd(|x| law.energy_kpa(x, i2), i1),
                    1e-7,
                    n,
                );
                close(
                    law.dw_di2_kpa(i1, i2),
                    fd(|x| law.energy_kpa(i1, x), i2),
                    1e-7,
                    n,
                );
                close(
                    law.d2w_di1_di1_kpa(i1, i2),
                    fd(|x| law.dw_di1_kpa(x, i2), i1),
                    1e-6,
                    n,
                );
                close(
                    law.d2w_di1_di2_kpa(i1, i2),
                    fd(|x| law.dw_di1_kpa(i1, x), i2),
                    1e-6,
                    n,
                );
                close(
                    law.d2w_di1_di2_kpa(i1, i2),
                    fd(|x| law.dw_di2_kpa(x, i2), i1),
                    1e-6,
                    n,
                );
                close(
                    law.d2w_di2_di2_kpa(i1, i2),
                    fd(|x| law.dw_di2_kpa(i1, x), i2),
                    1e-6,
                    n,
                );
            }
        }
    }

    #[test]
    fn homogeneous_stresses_are_the_derivative_of_the_energy_along_the_path() {
        // Incompressible homogeneous tests: the work-conjugate nominal stress
        // is dW/dλ along the path, independently of the formulas above.
        for law in sample_laws() {
            let path_uni = |l: f64| invariants([l, l.powf(-0.5), l.powf(-0.5)]);
            let path_bi = |l: f64| invariants([l, l, l.powi(-2)]);
            let path_pl = |l: f64| invariants([l, 1.0, 1.0 / l]);
            for l in [0.4, 0.8, 1.3, 2.0, 4.5] {
                let w = |p: (f64, f64)| law.energy_kpa(p.0, p.1);
                let n = law.name();
                close(
                    law.uniaxial_nominal_kpa(l),
                    fd(|x| w(path_uni(x)), l),
                    1e-6,
                    n,
                );
                // Equibiaxial: two loaded directions share the work.
                close(
                    law.equibiaxial_nominal_kpa(l),
                    0.5 * fd(|x| w(path_bi(x)), l),
                    1e-6,
                    n,
                );
                close(law.planar_nominal_kpa(l), fd(|x| w(path_pl(x)), l), 1e-6, n);
                close(
                    law.uniaxial_nominal_slope_kpa(l),
                    fd(|x| law.uniaxial_nominal_kpa(x), l),
                    1e-6,
                    n,
                );
                close(
                    law.uniaxial_cauchy_slope_kpa(l),
                    fd(|x| law.uniaxial_cauchy_kpa(x), l),
                    1e-6,
                    n,
                );
            }
        }
    }

    #[test]
    fn small_strain_limit_gives_youngs_modulus_three_mu() {
        for law in sample_laws() {
            let mu = law.shear_modulus_kpa();
            // dP/dλ at λ = 1 is E = 3μ for an incompressible solid.
            close(
                law.uniaxial_nominal_slope_kpa(1.0),
                3.0 * mu,
                1e-12,
                law.name(),
            );
            assert_eq!(law.uniaxial_nominal_kpa(1.0), 0.0);
        }
    }

    #[test]
    fn stresses_are_linear_in_the_coefficients() {
        // The fitter's assumption, checked for every law marked linear.
        for spec in LAWS.iter().filter(|s| matches!(s.form, Form::Linear)) {
            let n = spec.parameter_names.len();
            let a: Vec<f64> = (0..n).map(|k| 10.0 + 3.0 * k as f64).collect();
            let b: Vec<f64> = (0..n).map(|k| -2.0 + 0.7 * k as f64).collect();
            let sum: Vec<f64> = a.iter().zip(&b).map(|(x, y)| 2.0 * x + y).collect();
            let [la, lb, ls] = [a, b, sum].map(|p| (spec.from_parameters)(&p).unwrap());
            for l in [0.6, 1.5, 3.0, 7.0] {
                let want = 2.0 * la.uniaxial_nominal_kpa(l) + lb.uniaxial_nominal_kpa(l);
                close(ls.uniaxial_nominal_kpa(l), want, 1e-12, spec.name);
            }
        }
    }
}
