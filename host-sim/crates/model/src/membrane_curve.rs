//! The skin tube's pressure p_membrane(D), sampled once per rig from the
//! thick-tube solution ([`skin::membrane::Tube`]) and interpolated:
//! a time step needs it thousands of times per second of data, the tube
//! solves an axial balance at every call.
//!
//! Scaling W by s (every modulus of the law: all of Yeoh's coefficients,
//! Gent's μ, Ogden's μp; [`skin::SkinLaw::scaled`]) scales all stresses by
//! s and leaves the closed-end axial balance (homogeneous in stress)
//! unchanged, so p_membrane is exactly linear in s for every law: one
//! curve serves every stiffness scale the calibration tries.

use anyhow::{bail, Result};

use skin::membrane::{Ends, Tube, TubeGeometry};
use skin::StrainEnergy;

/// Sample spacing of the curve (mm): cubic Hermite interpolation at this
/// spacing is within ~1e-6 kPa of the tube on the default skin.
pub const SPACING_MM: f64 = 0.05;

/// p_membrane(D) on a uniform grid, cubic Hermite between samples, linear
/// beyond the ends.
#[derive(Clone, Debug, PartialEq)]
pub struct MembraneCurve {
    first_mm: f64,
    spacing_mm: f64,
    pressure_kpa: Vec<f64>,
    slope_kpa_per_mm: Vec<f64>,
}

impl MembraneCurve {
    /// Samples the closed-end tube of `skin` with rest geometry `geometry`
    /// from 0.7·D0 to 2.6·D0 (or over the part of it where the tube can be
    /// solved, which must include D0).
    pub fn sample<S: StrainEnergy>(geometry: TubeGeometry, skin: S) -> Result<Self> {
        let tube = Tube::new(geometry, skin, Ends::Closed)?;
        let d0 = geometry.outer_diameter_mm;
        // Start just above the diameter at which the bore closes.
        let ro = geometry.outer_radius_mm();
        let ri = geometry.inner_radius_mm();
        let closes_mm = 2.0 * (ro * ro - ri * ri).sqrt();
        let start = (0.7 * d0).max(closes_mm + 0.5).min(d0 - SPACING_MM);
        let mut first = start;
        let last = 2.6 * d0;
        let n = ((last - start) / SPACING_MM).ceil() as usize + 1;
        let mut pressure = Vec::with_capacity(n);
        for i in 0..n {
            let d = start + SPACING_MM * i as f64;
            match tube.pressure_kpa(d) {
                Ok(p) if p.is_finite() => pressure.push(p),
                // A law that locks (Gent with a small Jm) has no squeezed
                // tube that far below D0: the curve starts later and is
                // extended linearly below.
                _ if pressure.is_empty() && d < d0 - SPACING_MM => {
                    first = start + SPACING_MM * (i + 1) as f64;
                }
                // The tube stops having a solution: the curve ends here
                // and is extended linearly.
                _ if d > d0 + 1.0 => break,
                Ok(_) => bail!("skin tube: non-finite pressure at D = {d:.3} mm"),
                Err(e) => bail!("skin tube at D = {d:.3} mm: {e}"),
            }
        }
        if pressure.len() < 4 {
            bail!("skin tube: too few solvable diameters above D0 = {d0} mm");
        }
        let m = pressure.len();
        let slope = (0..m)
            .map(|i| {
                let (a, b) = (i.saturating_sub(1), (i + 1).min(m - 1));
                (pressure[b] - pressure[a]) / (SPACING_MM * (b - a) as f64)
            })
            .collect();
        Ok(Self {
            first_mm: first,
            spacing_mm: SPACING_MM,
            pressure_kpa: pressure,
            slope_kpa_per_mm: slope,
        })
    }

    /// p_membrane (kPa) at outer diameter `diameter_mm`.
    pub fn pressure_kpa(&self, diameter_mm: f64) -> f64 {
        let m = self.pressure_kpa.len();
        let x = (diameter_mm - self.first_mm) / self.spacing_mm;
        if !x.is_finite() {
            return f64::NAN;
        }
        let last = (m - 1) as f64;
        if x <= 0.0 {
            return self.pressure_kpa[0] + self.slope_kpa_per_mm[0] * x * self.spacing_mm;
        }
        if x >= last {
            return self.pressure_kpa[m - 1]
                + self.slope_kpa_per_mm[m - 1] * (x - last) * self.spacing_mm;
        }
        let i = (x.floor() as usize).min(m - 2);
        let t = x - i as f64;
        let (p0, p1) = (self.pressure_kpa[i], self.pressure_kpa[i + 1]);
        let (m0, m1) = (
            self.slope_kpa_per_mm[i] * self.spacing_mm,
            self.slope_kpa_per_mm[i + 1] * self.spacing_mm,
        );
        let (t2, t3) = (t * t, t * t * t);
        (2.0 * t3 - 3.0 * t2 + 1.0) * p0
            + (t3 - 2.0 * t2 + t) * m0
            + (-2.0 * t3 + 3.0 * t2) * p1
            + (t3 - t2) * m1
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_gent_or_ogden_curve_matches_its_tube_and_scales_linearly() {
        let g = TubeGeometry::PAPER;
        for name in ["Gent", "Ogden-3"] {
            let spec = skin::LawSpec::by_name(name).unwrap();
            let law = skin::law::example(spec);
            let curve = MembraneCurve::sample(g, law.clone()).unwrap();
            let tube = Tube::new(g, law.clone(), Ends::Closed).unwrap();
            // The scale the workbench fits: W × s is the curve × s.
            let s = 0.37;
            let scaled = MembraneCurve::sample(g, law.scaled(s).unwrap()).unwrap();
            for d in [19.337, 21.0, 22.021, 25.0, 28.46, 31.77] {
                let want = tube.pressure_kpa(d).unwrap();
                let got = curve.pressure_kpa(d);
                assert!(
                    (got - want).abs() < 1e-4 * want.abs(),
                    "{name} D {d}: {got} vs {want}"
                );
                let k = scaled.pressure_kpa(d);
                assert!(
                    (k - s * got).abs() < 1e-9 * got.abs(),
                    "{name} D {d}: scaled {k} vs {s} × {got}"
                );
            }
        }
    }

    #[test]
    fn matches_the_tube_between_samples() {
        let skin = skin::default_skin();
        let g = TubeGeometry::PAPER;
        let curve = MembraneCurve::sample(g, skin).unwrap();
        let tube = Tube::new(g, skin, Ends::Closed).unwrap();
        for d in [15.013, 18.7, 19.337, 22.021, 25.0, 31.77, 40.4] {
            let want = tube.pressure_kpa(d).unwrap();
            let got = curve.pressure_kpa(d);
            assert!(
                (got - want).abs() < 1e-4 * want.abs().max(1.0),
                "D {d}: {got} vs {want}"
            );
        }
        assert!(curve.pressure_kpa(18.7).abs() < 1e-6);
        assert!(curve.pressure_kpa(f64::NAN).is_nan());
        // Far outside the grid: finite, monotone extension.
        assert!(curve.pressure_kpa(5.0) < curve.pressure_kpa(14.0));
        assert!(curve.pressure_kpa(80.0).is_finite());
    }
}
