//! A skin law chosen at run time: any row of [`LAWS`](crate::LAWS) with
//! its coefficients, behind the one [`StrainEnergy`] interface, for the
//! commands that take the skin from a fit (`--skin-fit`) as well as from
//! `rig.toml`'s Yeoh `[skin]`.
//!
//! [`SkinLaw`] serialises as `{"law": NAME, "parameters": [...]}` and is
//! rebuilt through the registry, so a record holding one reads back the
//! same law. A Yeoh law is held as the concrete type: the FEM skin's hot
//! loop keeps its inlined Yeoh derivatives, and the default skin's
//! numbers (the firmware table, stored solver results) stay bit for bit
//! those of the Yeoh law itself.

use std::fmt;
use std::sync::Arc;

use anyhow::{bail, Result};
use serde::{Deserialize, Serialize};

use super::{LawSpec, StrainEnergy, Yeoh};
use fem::LawVisitor;

/// A registered law with its coefficients.
#[derive(Clone, Serialize, Deserialize)]
#[serde(try_from = "LawRecord", into = "LawRecord")]
pub struct SkinLaw {
    spec: &'static LawSpec,
    inner: Inner,
}

#[derive(Clone)]
enum Inner {
    Yeoh(Yeoh),
    Any(Arc<dyn StrainEnergy>),
}

/// The serialised form.
#[derive(Serialize, Deserialize)]
struct LawRecord {
    law: String,
    parameters: Vec<f64>,
}

impl TryFrom<LawRecord> for SkinLaw {
    type Error = anyhow::Error;
    fn try_from(r: LawRecord) -> Result<Self> {
        SkinLaw::new(&r.law, &r.parameters)
    }
}

impl From<SkinLaw> for LawRecord {
    fn from(l: SkinLaw) -> Self {
        LawRecord {
            law: l.spec.name.to_owned(),
            parameters: l.parameters(),
        }
    }
}

impl From<Yeoh> for SkinLaw {
    fn from(y: Yeoh) -> Self {
        SkinLaw {
            spec: &Yeoh::SPEC,
            inner: Inner::Yeoh(y),
        }
    }
}

impl SkinLaw {
    /// The law named `name` (as in the registry) with `parameters` in its
    /// order; an error naming the law and its coefficients when the name
    /// is unknown, the count is wrong or a value is outside its domain.
    pub fn new(name: &str, parameters: &[f64]) -> Result<SkinLaw> {
        let spec = LawSpec::named(name, "skin law")?;
        Self::of(spec, parameters)
    }

    /// [`SkinLaw::new`] from the registry row `spec`.
    pub fn of(spec: &'static LawSpec, parameters: &[f64]) -> Result<SkinLaw> {
        let bad = || {
            anyhow::anyhow!(
                "{}: coefficients {:?} ({}) are not a valid law",
                spec.name,
                parameters,
                spec.parameter_names.join(", ")
            )
        };
        if parameters.iter().any(|v| !v.is_finite()) {
            return Err(bad());
        }
        if spec.name == Yeoh::SPEC.name {
            return match *parameters {
                [c10_kpa, c20_kpa, c30_kpa] => Ok(SkinLaw::from(Yeoh {
                    c10_kpa,
                    c20_kpa,
                    c30_kpa,
                })),
                _ => Err(bad()),
            };
        }
        let law = (spec.from_parameters)(parameters).ok_or_else(bad)?;
        Ok(SkinLaw {
            spec,
            inner: Inner::Any(Arc::from(law)),
        })
    }

    /// The law's registry row.
    pub fn spec(&self) -> &'static LawSpec {
        self.spec
    }

    /// The law as a Yeoh law, if it is one.
    pub fn yeoh(&self) -> Option<Yeoh> {
        match &self.inner {
            Inner::Yeoh(y) => Some(*y),
            Inner::Any(_) => None,
        }
    }

    /// This law with W scaled by `s`: every modulus (the coefficients W is
    /// linear in, [`LawSpec::moduli`]) times `s`, so every stress and the
    /// tube's pressure at a given shape scale by exactly `s`. `None` when
    /// a scaled coefficient leaves the law's domain (`s` not finite).
    pub fn scaled(&self, s: f64) -> Option<SkinLaw> {
        if let Inner::Yeoh(y) = &self.inner {
            // The same products as every Yeoh scaling before this type.
            let scaled = Yeoh {
                c10_kpa: s * y.c10_kpa,
                c20_kpa: s * y.c20_kpa,
                c30_kpa: s * y.c30_kpa,
            };
            return [scaled.c10_kpa, scaled.c20_kpa, scaled.c30_kpa]
                .iter()
                .all(|v| v.is_finite())
                .then(|| SkinLaw::from(scaled));
        }
        let mut p = self.parameters();
        for k in self.spec.moduli() {
            p[k] *= s;
        }
        Self::of(self.spec, &p).ok()
    }

    /// One line: the law's name and coefficients with their units' names,
    /// e.g. `Gent mu_kpa = 6, jm = 2.5`.
    pub fn describe(&self) -> String {
        let p = self.parameters();
        let pairs: Vec<String> = self
            .spec
            .parameter_names
            .iter()
            .zip(&p)
            .map(|(n, v)| format!("{n} = {v}"))
            .collect();
        format!("{} {}", self.spec.name, pairs.join(", "))
    }

    fn law(&self) -> &dyn StrainEnergy {
        match &self.inner {
            Inner::Yeoh(y) => y,
            Inner::Any(a) => a.as_ref(),
        }
    }
}

/// The law's own `Debug` (a Yeoh law prints as `Yeoh { c10_kpa: … }`, as
/// the concrete type always has: case records keyed on it read back).
impl fmt::Debug for SkinLaw {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.inner {
            Inner::Yeoh(y) => fmt::Debug::fmt(y, f),
            Inner::Any(a) => fmt::Debug::fmt(a, f),
        }
    }
}

/// The same law with the same coefficients, bit for bit.
impl PartialEq for SkinLaw {
    fn eq(&self, other: &Self) -> bool {
        self.spec.name == other.spec.name && self.parameters() == other.parameters()
    }
}

/// Forwards to the held law; the Yeoh arm is a direct, inlinable call.
macro_rules! forward {
    ($self:ident, $l:ident => $call:expr) => {
        match &$self.inner {
            Inner::Yeoh($l) => $call,
            Inner::Any(a) => {
                let $l = a.as_ref();
                $call
            }
        }
    };
}

// The FEM's element loops do not come through these per quadrature point:
// `visit` hands them the held law's own type (a Yeoh skin runs the loop
// compiled for Yeoh).
impl StrainEnergy for SkinLaw {
    fn name(&self) -> &'static str {
        self.spec.name
    }
    fn parameters(&self) -> Vec<f64> {
        self.law().parameters()
    }
    fn visit<V: LawVisitor>(&self, v: V) -> V::Output
    where
        Self: Sized,
    {
        match &self.inner {
            Inner::Yeoh(y) => v.visit(y),
            Inner::Any(a) => v.visit(a.as_ref()),
        }
    }
    #[inline]
    fn energy_kpa(&self, i1: f64, i2: f64) -> f64 {
        forward!(self, l => l.energy_kpa(i1, i2))
    }
    #[inline]
    fn dw_di1_kpa(&self, i1: f64, i2: f64) -> f64 {
        forward!(self, l => l.dw_di1_kpa(i1, i2))
    }
    #[inline]
    fn dw_di2_kpa(&self, i1: f64, i2: f64) -> f64 {
        forward!(self, l => l.dw_di2_kpa(i1, i2))
    }
    #[inline]
    fn d2w_di1_di1_kpa(&self, i1: f64, i2: f64) -> f64 {
        forward!(self, l => l.d2w_di1_di1_kpa(i1, i2))
    }
    #[inline]
    fn d2w_di1_di2_kpa(&self, i1: f64, i2: f64) -> f64 {
        forward!(self, l => l.d2w_di1_di2_kpa(i1, i2))
    }
    #[inline]
    fn d2w_di2_di2_kpa(&self, i1: f64, i2: f64) -> f64 {
        forward!(self, l => l.d2w_di2_di2_kpa(i1, i2))
    }
    fn shear_modulus_kpa(&self) -> f64 {
        forward!(self, l => l.shear_modulus_kpa())
    }
    #[inline]
    fn extra_stress_kpa(&self, stretches: [f64; 3]) -> [f64; 3] {
        forward!(self, l => l.extra_stress_kpa(stretches))
    }
    fn uniaxial_cauchy_kpa(&self, stretch: f64) -> f64 {
        forward!(self, l => l.uniaxial_cauchy_kpa(stretch))
    }
    fn uniaxial_nominal_kpa(&self, stretch: f64) -> f64 {
        forward!(self, l => l.uniaxial_nominal_kpa(stretch))
    }
    fn uniaxial_nominal_slope_kpa(&self, stretch: f64) -> f64 {
        forward!(self, l => l.uniaxial_nominal_slope_kpa(stretch))
    }
    fn uniaxial_cauchy_slope_kpa(&self, stretch: f64) -> f64 {
        forward!(self, l => l.uniaxial_cauchy_slope_kpa(stretch))
    }
    fn equibiaxial_nominal_kpa(&self, stretch: f64) -> f64 {
        forward!(self, l => l.equibiaxial_nominal_kpa(stretch))
    }
    fn planar_nominal_kpa(&self, stretch: f64) -> f64 {
        forward!(self, l => l.planar_nominal_kpa(stretch))
    }
}

/// An example of the registered law `spec`, its coefficients chosen to
/// keep every derivative nonzero: for tests here and in the crates that
/// take a law.
pub fn example(spec: &'static LawSpec) -> SkinLaw {
    const EXAMPLES: [(&str, &[f64]); 7] = [
        ("neo-Hookean", &[150.0]),
        ("Mooney-Rivlin", &[120.0, 35.0]),
        ("Yeoh", &[180.0, -4.0, 0.15]),
        ("Gent", &[300.0, 40.0]),
        ("Ogden-1", &[250.0, 2.7]),
        ("Ogden-2", &[400.0, 1.5, 2.0, 4.2]),
        ("Ogden-3", &[630.0, 1.3, 1.2, 5.0, -10.0, -2.0]),
    ];
    let p = EXAMPLES
        .iter()
        .find(|(n, _)| *n == spec.name)
        .map_or(&[][..], |(_, p)| *p);
    match SkinLaw::of(spec, p) {
        Ok(l) => l,
        Err(_) => unreachable!("every registered law has a valid example"),
    }
}

/// Refuses a law the tube cannot inflate: one unstable at rest (μ ≤ 0).
pub fn check_inflatable(law: &SkinLaw, what: &str) -> Result<()> {
    let mu = law.shear_modulus_kpa();
    if !(mu > 0.0 && mu.is_finite()) {
        bail!(
            "{what}: the {} law has shear modulus {mu} kPa at rest (unstable, Drucker): no skin tube can be inflated with it",
            law.describe()
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::LAWS;

    #[test]
    fn every_law_round_trips_through_json_and_keeps_its_stresses() {
        for spec in &LAWS {
            let law = example(spec);
            let json = serde_json::to_string(&law).unwrap();
            assert!(json.starts_with(&format!("{{\"law\":\"{}\"", spec.name)));
            let back: SkinLaw = serde_json::from_str(&json).unwrap();
            assert_eq!(back, law);
            let direct = (spec.from_parameters)(&law.parameters()).unwrap();
            for l in [0.7, 1.4, 2.2] {
                assert_eq!(back.uniaxial_nominal_kpa(l), direct.uniaxial_nominal_kpa(l));
                assert_eq!(back.planar_nominal_kpa(l), direct.planar_nominal_kpa(l));
                assert_eq!(
                    back.dw_di1_kpa(l * 3.0, 3.5),
                    direct.dw_di1_kpa(l * 3.0, 3.5)
                );
            }
        }
        let e = serde_json::from_str::<SkinLaw>(r#"{"law":"Gent","parameters":[5.0,-1.0]}"#)
            .unwrap_err()
            .to_string();
        assert!(e.contains("Gent") && e.contains("mu_kpa, jm"), "{e}");
        let e = serde_json::from_str::<SkinLaw>(r#"{"law":"Hooke","parameters":[5.0]}"#)
            .unwrap_err()
            .to_string();
        assert!(e.contains("no law `Hooke`"), "{e}");
    }

    #[test]
    fn a_yeoh_law_debugs_and_scales_as_the_concrete_type() {
        let y = crate::default_skin();
        let law = SkinLaw::from(y);
        assert_eq!(format!("{law:?}"), format!("{y:?}"));
        assert_eq!(format!("{:?}", Some(law.clone())), format!("{:?}", Some(y)));
        let k = 2.3;
        let s = law.scaled(k).unwrap().yeoh().unwrap();
        assert_eq!(
            [s.c10_kpa, s.c20_kpa, s.c30_kpa],
            [k * y.c10_kpa, k * y.c20_kpa, k * y.c30_kpa]
        );
        assert!(law.scaled(f64::INFINITY).is_none());
    }

    #[test]
    fn scaling_the_moduli_scales_every_stress() {
        for spec in &LAWS {
            let law = example(spec);
            let s = 3.7;
            let scaled = law.scaled(s).unwrap();
            for l in [0.6, 1.2, 2.5] {
                for (a, b) in [
                    (scaled.uniaxial_nominal_kpa(l), law.uniaxial_nominal_kpa(l)),
                    (
                        scaled.equibiaxial_nominal_kpa(l),
                        law.equibiaxial_nominal_kpa(l),
                    ),
                    (scaled.planar_nominal_kpa(l), law.planar_nominal_kpa(l)),
                ] {
                    assert!(
                        (a - s * b).abs() <= 1e-12 * a.abs().max(1.0),
                        "{}",
                        spec.name
                    );
                }
            }
        }
    }
}
