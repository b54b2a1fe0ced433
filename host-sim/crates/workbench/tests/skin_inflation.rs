//! The free inflation as a skin test (`fit-skin --inflation`), on a
//! synthetic experiment folder whose pressures come from a known law
//! through the thick-walled closed-end tube, with sensor noise, written
//! to disk and read back by the workbench's own folder reader.
//!
//! Predicted: nothing here is tuned to the truth; the tolerances are the
//! noise's and the law families' (stated with each check).

use std::fmt::Write as _;
use std::path::Path;

use skin::coupon::{CouponTest, Mode};
use skin::fit::fit_law;
use skin::inflation::{agreement, tube_pressures_kpa, InflationPoint};
use skin::membrane::{Ends, Tube, TubeGeometry};
use skin::{default_skin, Gent, StrainEnergy, Yeoh};
use urechis::controller::geometry::ExpansionZone;
use workbench::skin_inflation::FreeInflation;

/// Sensor noise of the synthetic folder (kPa): the contract's example.
const NOISE_KPA: f64 = 0.03;

/// The truth: a Gent skin with a strong lock (Jm = 2.5) so its curve is
/// not a rescaled neo-Hookean or Yeoh one over the actuator's range.
const TRUTH: Gent = Gent {
    mu_kpa: 6.0,
    jm: 2.5,
};

/// Deterministic standard normal numbers (xorshift + Box–Muller).
struct Normal(u64);
impl Normal {
    fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        ((self.0 >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }
    fn next(&mut self) -> f64 {
        let (u, v) = (self.uniform(), self.uniform());
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }
}

/// Writes the folder: two free inflate–deflate runs from the truth, and a
/// buried run (depth 40 mm) whose pressures are far off, which the fit
/// must leave out.
fn write_folder(dir: &Path) {
    std::fs::write(
        dir.join("rig.toml"),
        "[actuator]\ninitial_diameter_mm = 18.7\nexpansion_length_mm = 20.0\nskin_thickness_mm = 1.75\n\
         [sand]\ngrain_radius_mm = 0.36\ngrain_density_kg_m3 = 2920\nporosity = 0.40\nfriction = 0.25\n\
         [fluid]\ndensity_kg_m3 = 1025\nwater_above_sand_mm = 180\n\
         [pump]\nsyringe_bore_mm = 29.21\n\
         [measurement]\npressure_source = \"line_sensor\"\npressure_noise_kpa = 0.03\n",
    )
    .unwrap();
    let zone = ExpansionZone {
        initial_diameter_mm: 18.7,
        expansion_length_mm: 20.0,
    };
    let tube = Tube::paper(TRUTH, Ends::Closed);
    let mut noise = Normal(0x2545_f491_4f6c_dd1d);
    let mut csv = String::from("run,t_s,depth_mm,volume_ml,pressure_kpa\n");
    let top_ml = f64::from(zone.volume_ml(25.5));
    for (run, depth, steps) in [("free_a", 0, 300), ("free_b", 0, 220), ("buried", 40, 50)] {
        for i in 0..=2 * steps {
            // Up to D = 25.5 mm and back, at a constant rate.
            let f = 1.0 - (f64::from(i) / f64::from(steps) - 1.0).abs();
            let v = top_ml * f;
            let d = f64::from(zone.diameter_mm(v as f32));
            let p = if depth == 0 {
                tube.pressure_kpa(d).unwrap() + NOISE_KPA * noise.next()
            } else {
                50.0 + v
            };
            let _ = writeln!(
                csv,
                "{run},{:.3},{depth},{v:.6},{p:.5}",
                0.05 * f64::from(i)
            );
        }
    }
    std::fs::write(dir.join("runs.csv"), csv).unwrap();
}

fn folder() -> (tempfile::TempDir, FreeInflation) {
    let dir = tempfile::tempdir().unwrap();
    write_folder(dir.path());
    let free = FreeInflation::read(dir.path()).unwrap();
    (dir, free)
}

#[test]
fn the_same_family_comes_back_within_its_standard_errors() {
    let (_dir, free) = folder();
    assert_eq!(free.runs, ["free_a", "free_b"]);
    assert!(free.fit_warnings.is_empty());
    let r = free.fit(&Gent::SPEC, None).unwrap();
    let f = &r.fit;
    println!("{}", r.table());
    // Within 3 standard errors of the truth, and the errors small: the
    // curve determines both coefficients.
    for ((got, se), want) in f
        .parameters
        .iter()
        .zip(&f.standard_errors)
        .zip(TRUTH.parameters())
    {
        let se = se.expect("the curve determines every coefficient");
        assert!((got - want).abs() < 3.0 * se, "{got} ± {se} vs {want}");
        assert!(se < 0.05 * want, "{se} vs {want}");
    }
    // The residual is the noise averaged in each bin: RMSE below the noise.
    assert!(f.rmse_kpa < NOISE_KPA, "{}", f.rmse_kpa);
}

#[test]
fn another_family_recovers_the_curve_and_the_modulus_where_a_scale_cannot() {
    let (_dir, free) = folder();
    let r = free.fit(&Yeoh::SPEC, None).unwrap();
    println!("{}", r.table());
    let geometry = TubeGeometry::PAPER;
    // Over the whole inflated range the fitted Yeoh tube is within 2 % of
    // the truth's pressure at the top (≈ 1.1 kPa), on a fine grid that
    // includes diameters between the bins.
    let grid: Vec<InflationPoint> = (0..=68)
        .map(|i| InflationPoint {
            diameter_mm: 18.7 + 0.1 * f64::from(i),
            pressure_kpa: 0.0,
        })
        .collect();
    let truth = tube_pressures_kpa(Box::new(TRUTH), geometry, &grid).unwrap();
    let fitted = tube_pressures_kpa(r.fit.model(), geometry, &grid).unwrap();
    let top = *truth.last().unwrap();
    let worst = truth
        .iter()
        .zip(&fitted)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    println!("Yeoh vs Gent truth: worst gap {worst:.4} kPa of {top:.3} kPa at the top");
    assert!(worst < 0.02 * top, "{worst} vs {top}");
    // The small-strain modulus, which the inflation's start sets, within 5 %.
    let mu = r.fit.shear_modulus_kpa;
    assert!((mu / TRUTH.mu_kpa - 1.0).abs() < 0.05, "μ {mu}");
    // A stiffness scale on the default skin's shape, the best such scale
    // by least squares, misses by far more: the shape is what was fitted.
    let bins = &r.bins;
    let base = tube_pressures_kpa(Box::new(default_skin()), geometry, bins).unwrap();
    let s = bins
        .iter()
        .zip(&base)
        .map(|(p, q)| p.pressure_kpa * q)
        .sum::<f64>()
        / base.iter().map(|q| q * q).sum::<f64>();
    let scaled: Vec<f64> = base.iter().map(|q| s * q).collect();
    let (_, scale_rmse) = agreement(bins, &scaled);
    println!(
        "scale-only default skin: RMSE {scale_rmse:.4} kPa; shape fit {:.4} kPa",
        r.fit.rmse_kpa
    );
    assert!(scale_rmse > 5.0 * r.fit.rmse_kpa);
}

#[test]
fn a_coupon_fit_of_the_same_skin_agrees_with_the_inflation_fit() {
    let (_dir, free) = folder();
    // Uniaxial and equibiaxial coupons of the same Gent skin, noise-free,
    // over the states the inflation reaches: at D = 25.4 mm the bore has
    // I1 − 3 ≈ 0.83 (λθ ≈ 1.5, λz ≈ 1.1), which uniaxial reaches at
    // ε ≈ 0.68 and equibiaxial at ε ≈ 0.32.
    let coupons: Vec<CouponTest> = [(Mode::Uniaxial, 0.65), (Mode::Equibiaxial, 0.3)]
        .into_iter()
        .map(|(m, top)| {
            let strain: Vec<f64> = (0..=12).map(|i| top * f64::from(i) / 12.0).collect();
            let p = strain
                .iter()
                .map(|e| m.nominal_kpa(&TRUTH, 1.0 + e))
                .collect();
            CouponTest::from_nominal("coupon.csv", m, strain, p)
        })
        .collect();
    let coupon = fit_law(&Yeoh::SPEC, &coupons).unwrap();
    let r = free.fit(&Yeoh::SPEC, Some((&coupon, &coupons))).unwrap();
    println!("{}", r.table());
    let c = r.coupon.as_ref().unwrap();
    // Both see the same skin: the coupon law predicts the inflation and
    // the inflation law the coupons, each with R² > 0.99, and their moduli
    // agree within 5 %.
    assert!(c.coupon_law_on_inflation_r_squared > 0.99, "{c:?}");
    for m in &c.inflation_law_on_coupons {
        assert!(!m.fitted && m.r_squared > 0.99, "{m:?}");
    }
    assert!((c.shear_modulus_ratio - 1.0).abs() < 0.05, "{c:?}");
    // What fit-skin writes: the coupon panels and the inflation's.
    let mut report = skin::report::FitSkinReport::from_tests(&coupons, None).unwrap();
    report.inflation = Some(r);
    let out = tempfile::tempdir().unwrap();
    let done = skin::report::write_report(report, &coupons, "both", out.path()).unwrap();
    let svg = std::fs::read_to_string(&done.svg_path).unwrap();
    assert!(svg.contains("free inflation (depth 0)") && svg.contains("equibiaxial (fitted)"));
    assert!(svg.contains("inflation Yeoh (R²") && svg.contains("coupon Yeoh (tube)"));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&done.json_path).unwrap()).unwrap();
    assert_eq!(json["inflation"]["fit"]["law"], "Yeoh");
    assert_eq!(json["inflation"]["bins"].as_array().unwrap().len(), 40);
    assert!(done.report.table().contains("free inflation"));
}

#[test]
fn a_folder_without_a_free_run_is_named() {
    let dir = tempfile::tempdir().unwrap();
    write_folder(dir.path());
    let text = std::fs::read_to_string(dir.path().join("runs.csv")).unwrap();
    let buried: String = text
        .lines()
        .filter(|l| !l.starts_with("free"))
        .map(|l| format!("{l}\n"))
        .collect();
    std::fs::write(dir.path().join("runs.csv"), buried).unwrap();
    let e = FreeInflation::read(dir.path()).unwrap_err();
    let msg = format!("{e:#}");
    assert!(
        msg.contains("no free run (depth_mm = 0)") && msg.contains("buried at 40 mm"),
        "{msg}"
    );
}

#[test]
fn beyond_the_inflations_states_its_fit_is_an_extrapolation() {
    // The same inflation fit asked for equibiaxial strains up to 0.55
    // (I1 − 3 up to 2.0, near the truth's lock at 2.5): far outside what
    // the tube saw, the prediction fails. The docs say so: fit the skin on
    // the states it will work in.
    let (_dir, free) = folder();
    let r = free.fit(&Yeoh::SPEC, None).unwrap();
    let strain: Vec<f64> = (0..=11).map(|i| 0.05 * f64::from(i)).collect();
    let p: Vec<f64> = strain
        .iter()
        .map(|e| Mode::Equibiaxial.nominal_kpa(&TRUTH, 1.0 + e))
        .collect();
    let far = CouponTest::from_nominal("far.csv", Mode::Equibiaxial, strain, p);
    let mut probe = fit_law(&Yeoh::SPEC, std::slice::from_ref(&far)).unwrap();
    probe.parameters = r.fit.parameters.clone();
    probe.modes.clear();
    probe.predict(std::slice::from_ref(&far));
    let m = probe.mode(Mode::Equibiaxial).unwrap();
    println!(
        "inflation Yeoh on equibiaxial to ε = 0.55: R² {:.4}",
        m.r_squared
    );
    assert!(m.r_squared < 0.95, "{m:?}");
}

#[test]
fn a_piston_force_pressure_is_warned_about() {
    let dir = tempfile::tempdir().unwrap();
    write_folder(dir.path());
    let rig = dir.path().join("rig.toml");
    let text = std::fs::read_to_string(&rig).unwrap();
    std::fs::write(&rig, text.replace("line_sensor", "piston_force")).unwrap();
    let free = FreeInflation::read(dir.path()).unwrap();
    assert_eq!(free.fit_warnings.len(), 1);
    assert!(
        free.fit_warnings[0].contains("rig.toml: pressure_source = \"piston_force\""),
        "{:?}",
        free.fit_warnings
    );
}
