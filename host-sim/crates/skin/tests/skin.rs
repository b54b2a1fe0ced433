//! Integration tests of the skin model, sand law and pressure model
//! (issue 3): Treloar's data, the shipped default skin, the `fit-skin`
//! outputs, the default skin's inflation.

use std::path::{Path, PathBuf};

use skin::coupon::Mode;
use skin::coupon::{CouponTest, StressMeasure};
use skin::fit::fit_law;
use skin::membrane::{Ends, Tube};
use skin::report::{fit_skin, FitSkinReport};
use skin::{default_skin, unicinctus, Gent, Ogden, StrainEnergy, Yeoh};

/// A path relative to host-sim (this crate is host-sim/crates/skin).
fn host_sim_path(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .join(rel)
}

fn treloar() -> CouponTest {
    CouponTest::read(&host_sim_path(
        "../../shared/reference/treloar_uniaxial.csv",
    ))
    .or_else(|_| CouponTest::read(Path::new("/work/shared/reference/treloar_uniaxial.csv")))
    .expect("Treloar's data (shared/reference/treloar_uniaxial.csv)")
}

#[test]
fn issue_3_treloar_yeoh_reaches_r2_0_997_on_nominal_stress() {
    let report = FitSkinReport::from_test(&treloar()).unwrap();
    let yeoh = report.fit("Yeoh").unwrap();
    assert!(yeoh.r_squared >= 0.997, "Yeoh R² = {}", yeoh.r_squared);
    // And the ranking the literature reports: Yeoh > Mooney–Rivlin > neo-Hookean.
    let r2 = |law: &str| report.fit(law).unwrap().r_squared;
    assert!(r2("Yeoh") > r2("Mooney-Rivlin") && r2("Mooney-Rivlin") > r2("neo-Hookean"));
}

/// Solves the square system `a·x = b` by Gaussian elimination with partial
/// pivoting: the test's own solver, independent of nalgebra.
fn gauss_solve(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Vec<f64> {
    let n = b.len();
    for k in 0..n {
        let piv = (k..n)
            .max_by(|&i, &j| a[i][k].abs().total_cmp(&a[j][k].abs()))
            .unwrap();
        a.swap(k, piv);
        b.swap(k, piv);
        let (top, rest) = a.split_at_mut(k + 1);
        let (pivot, bk) = (&top[k], b[k]);
        for (row, bi) in rest.iter_mut().zip(&mut b[k + 1..]) {
            let f = row[k] / pivot[k];
            for (x, p) in row[k..].iter_mut().zip(&pivot[k..]) {
                *x -= f * p;
            }
            *bi -= f * bk;
        }
    }
    let mut x = vec![0.0; n];
    for k in (0..n).rev() {
        let s: f64 = (k + 1..n).map(|j| a[k][j] * x[j]).sum();
        x[k] = (b[k] - s) / a[k][k];
    }
    x
}

#[test]
fn issue_3_yeoh_fit_equals_an_independent_normal_equation_solution() {
    let t = treloar();
    // Yeoh nominal stress written out: P = 2(λ − λ⁻²)[C10 + 2C20·x + 3C30·x²],
    // x = I1 − 3 = λ² + 2/λ − 3; the basis columns are its coefficients.
    let rows: Vec<[f64; 3]> = t
        .stretch()
        .map(|l| {
            let x = l * l + 2.0 / l - 3.0;
            let f = 2.0 * (l - 1.0 / (l * l));
            [f, 2.0 * f * x, 3.0 * f * x * x]
        })
        .collect();
    // Scale columns (the solution is unchanged) so the normal equations
    // stay well conditioned, then form JᵀJ c = Jᵀy.
    let scale: Vec<f64> = (0..3)
        .map(|k| rows.iter().map(|r| r[k] * r[k]).sum::<f64>().sqrt())
        .collect();
    let y = &t.nominal_stress_kpa;
    let jtj: Vec<Vec<f64>> = (0..3)
        .map(|a| {
            (0..3)
                .map(|b| rows.iter().map(|r| r[a] * r[b]).sum::<f64>() / (scale[a] * scale[b]))
                .collect()
        })
        .collect();
    let jty: Vec<f64> = (0..3)
        .map(|a| rows.iter().zip(y).map(|(r, v)| r[a] * v).sum::<f64>() / scale[a])
        .collect();
    let c: Vec<f64> = gauss_solve(jtj.clone(), jty)
        .iter()
        .zip(&scale)
        .map(|(c, s)| c / s)
        .collect();

    let fit = fit_law(&Yeoh::SPEC, std::slice::from_ref(&t)).unwrap();
    for (got, want) in fit.parameters.iter().zip(&c) {
        assert!((got - want).abs() < 1e-8 * want.abs(), "{got} vs {want}");
    }
    // R² and RMSE recomputed from the independent coefficients.
    let resid: Vec<f64> = rows
        .iter()
        .zip(y)
        .map(|(r, v)| v - (r[0] * c[0] + r[1] * c[1] + r[2] * c[2]))
        .collect();
    let rss: f64 = resid.iter().map(|r| r * r).sum();
    let mean = y.iter().sum::<f64>() / y.len() as f64;
    let tss: f64 = y.iter().map(|v| (v - mean).powi(2)).sum();
    assert!((fit.r_squared - (1.0 - rss / tss)).abs() < 1e-12);
    assert!((fit.rmse_kpa - (rss / y.len() as f64).sqrt()).abs() < 1e-9 * fit.rmse_kpa);
    // Standard errors: s²·(JᵀJ)⁻¹ with the inverse from the test's own solver.
    let s2 = rss / (y.len() - 3) as f64;
    for (k, (sk, got)) in scale.iter().zip(&fit.standard_errors).enumerate() {
        let e: Vec<f64> = (0..3).map(|j| if j == k { 1.0 } else { 0.0 }).collect();
        let inv_kk = gauss_solve(jtj.clone(), e)[k] / (sk * sk);
        let se = (s2 * inv_kk).sqrt();
        let got = got.expect("every coefficient is determined");
        assert!((got - se).abs() < 1e-7 * se, "se[{k}]: {got} vs {se}");
    }
}

/// Regenerate with `UPDATE_SKIN_DATA=1 cargo test --target host-tuple -p skin --test skin`.
#[test]
fn shipped_synthetic_data_is_the_documented_generator_output() {
    let path = host_sim_path(unicinctus::DATA_PATH);
    let fresh = unicinctus::CIRCUMFERENTIAL.csv_text();
    if std::env::var_os("UPDATE_SKIN_DATA").is_some() {
        datafile::write_atomic(&path, fresh.as_bytes()).unwrap();
    }
    let shipped = std::fs::read_to_string(&path).unwrap();
    assert_eq!(shipped, fresh, "{} is stale", path.display());
}

#[test]
fn synthetic_data_honours_the_papers_summary_numbers() {
    let t = CouponTest::read(&host_sim_path(unicinctus::DATA_PATH)).unwrap();
    assert_eq!(t.measured, StressMeasure::Cauchy);
    let cauchy = t.cauchy_stress_kpa();
    // Failure at ε = 3.61 and σ = 0.78 MPa (within the paper's SDs exactly).
    assert_eq!(*t.strain.last().unwrap(), 3.61);
    assert!((cauchy.last().unwrap() - 780.0).abs() < 0.01);
    // Soft then stiff: the toe slope is under 5 % of the final slope, the
    // stress at half the failure strain under 10 % of the strength, and the
    // slope over the last 0.4 of strain roughly constant (within 15 %).
    let at = |e: f64| unicinctus::CIRCUMFERENTIAL.cauchy_stress_kpa(e);
    let slope = |a: f64, b: f64| (at(b) - at(a)) / (b - a);
    assert!(slope(0.0, 0.5) < 0.05 * slope(3.41, 3.61));
    assert!(at(1.805) < 0.1 * 780.0);
    assert!(slope(3.21, 3.41) > 0.85 * slope(3.41, 3.61));
    // Slope never decreases (no softening anywhere): convex on a fine grid.
    let es: Vec<f64> = (0..=361).map(|i| 0.01 * f64::from(i)).collect();
    assert!(es
        .windows(3)
        .all(|w| at(w[2]) - at(w[1]) >= at(w[1]) - at(w[0]) - 1e-9));
}

#[test]
fn refitting_the_shipped_data_reproduces_the_default_skin() {
    let t = CouponTest::read(&host_sim_path(unicinctus::DATA_PATH)).unwrap();
    let fit = fit_law(&Yeoh::SPEC, std::slice::from_ref(&t)).unwrap();
    let d = default_skin();
    for (got, want) in fit.parameters.iter().zip(d.parameters()) {
        assert!((got - want).abs() < 1e-9 * want.abs(), "{got} vs {want}");
    }
    // The paper's findings hold for it: Yeoh Drucker-stable to λ = 10, with
    // a negative C20; Mooney–Rivlin unstable; Yeoh the best of the three.
    assert!(fit.stability.stable_over_data);
    assert_eq!(fit.stability.first_unstable_stretch_tension, None);
    assert!(d.c20_kpa < 0.0 && d.c10_kpa > 0.0 && d.c30_kpa > 0.0);
    let report = FitSkinReport::from_test(&t).unwrap();
    assert!(
        !report
            .fit("Mooney-Rivlin")
            .unwrap()
            .stability
            .stable_over_data
    );
    assert!(fit.r_squared > report.fit("Mooney-Rivlin").unwrap().r_squared);
    // The shipped fit-skin JSON carries the same coefficients.
    let json: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(host_sim_path(
            "data/skin/unicinctus_circumferential-fit.json",
        ))
        .unwrap(),
    )
    .unwrap();
    let yeoh = json["fits"]
        .as_array()
        .unwrap()
        .iter()
        .find(|f| f["law"] == "Yeoh")
        .unwrap();
    let shipped: Vec<f64> = yeoh["parameters"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    assert_eq!(shipped, d.parameters());
}

#[test]
fn fit_skin_writes_json_and_svg() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("spec.csv");
    std::fs::write(
        &csv,
        "strain,cauchy_stress_kpa,operator\n0,0,a\n0.5,30,a\n1,80,a\n2,250,a\n3,600,a\n",
    )
    .unwrap();
    let out = fit_skin(&csv, &dir.path().join("out")).unwrap();
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out.json_path).unwrap()).unwrap();
    // Five rows: every law but Ogden-3 (six coefficients) is fitted, and
    // the one left out is named with the file and lines.
    assert_eq!(json["fits"].as_array().unwrap().len(), 6);
    assert_eq!(json["inputs"][0]["measured"], "cauchy");
    let warnings: Vec<&str> = json["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .map(|w| w.as_str().unwrap())
        .collect();
    assert_eq!(warnings.len(), 2, "{warnings:?}");
    assert!(warnings[0].contains("operator"));
    assert!(
        warnings[1].contains("Ogden-3: 5 rows in ")
            && warnings[1].contains("spec.csv (uniaxial, lines 2–6) for 6 coefficients"),
        "{}",
        warnings[1]
    );
    assert_eq!(json["not_fitted"].as_array().unwrap().len(), 1);
    let svg = std::fs::read_to_string(&out.svg_path).unwrap();
    assert!(svg.starts_with("<svg") && svg.contains("Yeoh") && svg.contains("circle"));
    let table = out.report.table();
    assert!(
        table.contains("neo-Hookean") && table.contains("Mooney-Rivlin") && table.contains("Gent")
    );
    // Bad input: an error naming the file and line, and nothing written.
    std::fs::write(&csv, "strain,cauchy_stress_kpa\n0,0\n1,x\n").unwrap();
    let err = fit_skin(&csv, &dir.path().join("bad")).unwrap_err();
    assert!(
        format!("{err:#}").contains("spec.csv:3: cauchy_stress_kpa: `x` is not a number"),
        "{err:#}"
    );
    let e = err
        .downcast_ref::<datafile::DataError>()
        .expect("a data file's error");
    assert_eq!(
        (e.file.as_str(), e.line, e.key.as_deref()),
        (
            csv.display().to_string().as_str(),
            Some(3),
            Some("cauchy_stress_kpa")
        ),
    );
    assert!(!dir.path().join("bad").exists());
}

/// Prints the default skin's inflation (the crate README) and checks it:
/// `cargo test --target host-tuple -p skin --test skin inflation -- --nocapture`.
#[test]
fn default_skin_inflation_is_monotone_and_far_below_the_strength() {
    let ds: Vec<f64> = (0..=15)
        .map(|i| 18.7 + 0.5 * f64::from(i))
        .chain([25.0])
        .collect();
    for ends in [Ends::PlaneStrain, Ends::Closed] {
        let tube = Tube::paper(default_skin(), ends);
        let curve = tube.inflation_curve(&ds).unwrap();
        println!("{}:", ends.label());
        println!("  D mm   p kPa   vm_max kPa  at R mm  λθ,in  λz     wall mm  V mL");
        for s in &curve {
            println!(
                "  {:5.2}  {:6.4}  {:9.4}  {:6.3}  {:6.4} {:6.4} {:6.4} {:6.3}",
                s.outer_diameter_mm,
                s.pressure_kpa,
                s.max_von_mises_kpa,
                s.max_von_mises_at_reference_radius_mm,
                s.hoop_stretch_inner,
                s.axial_stretch,
                s.wall_thickness_mm,
                s.volume_ml
            );
        }
        let (body, _) = curve.split_at(curve.len() - 1);
        assert!(body
            .windows(2)
            .all(|w| w[1].pressure_kpa > w[0].pressure_kpa));
        let at25 = curve.last().unwrap();
        // Largest stress at the bore, where the hoop stretch is largest.
        assert_eq!(at25.max_von_mises_at_reference_radius_mm, 7.6);
        // The paper: peak skin stress an order of magnitude below 0.78 MPa.
        assert!(at25.max_von_mises_kpa < 78.0);
    }
}

/// Treloar's three tests (shared/reference), each one file and mode.
fn treloar_all() -> Vec<CouponTest> {
    ["uniaxial", "equibiaxial", "planar"]
        .iter()
        .flat_map(|m| {
            let rel = format!("../../shared/reference/treloar_{m}.csv");
            skin::coupon::read_file(&host_sim_path(&rel))
                .or_else(|_| {
                    skin::coupon::read_file(Path::new(&format!(
                        "/work/shared/reference/treloar_{m}.csv"
                    )))
                })
                .expect("Treloar's data (shared/reference)")
        })
        .collect()
}

/// Per-mode RMSE (kPa) of `law` on `tests`, in Mode::ALL order.
fn rmse_per_mode(law: &dyn StrainEnergy, tests: &[CouponTest]) -> Vec<(Mode, f64)> {
    Mode::ALL
        .iter()
        .map(|m| {
            let (rss, n) = tests
                .iter()
                .filter(|t| t.mode == *m)
                .flat_map(|t| t.stretch().zip(t.nominal_stress_kpa.clone()))
                .fold((0.0, 0), |(r, n), (l, p)| {
                    (r + (m.nominal_kpa(law, l) - p).powi(2), n + 1)
                });
            (*m, (rss / f64::from(n)).sqrt())
        })
        .collect()
}

/// The joint fit of Treloar's three modes (the skin README's table):
/// `cargo test --target host-tuple -p skin --test skin treloar_joint -- --nocapture`.
#[test]
fn issue_29_treloar_joint_ogden_beats_the_published_set_on_every_mode() {
    let tests = treloar_all();
    assert_eq!(tests.len(), 3);
    let report = FitSkinReport::from_tests(&tests, None).unwrap();
    print!("{}", report.table());
    let fitted = report.fit("Ogden-3").unwrap();
    let published = Ogden::ogden_1972_treloar();
    let ours = rmse_per_mode(fitted.model().as_ref(), &tests);
    let theirs = rmse_per_mode(&published, &tests);
    for ((mode, a), (_, b)) in ours.iter().zip(&theirs) {
        println!("{mode}: fitted Ogden-3 RMSE {a:.2} kPa, published Ogden (1972) {b:.2} kPa");
        assert!(a <= b, "{mode}: fitted {a} vs published {b}");
        // The report's own per-mode figure is the same number.
        assert!((fitted.mode(*mode).unwrap().rmse_kpa - a).abs() < 1e-9 * a);
    }
    // The published set is the literature's: μ = ½Σμpαp ≈ 0.42 MPa.
    assert!((published.shear_modulus_kpa() - 422.5).abs() < 1e-9);
    // Every Ogden fit keeps μp·αp ≥ 0 in every term (Ogden 1972).
    for law in ["Ogden-1", "Ogden-2", "Ogden-3"] {
        let p = &report.fit(law).unwrap().parameters;
        for t in p.chunks_exact(2) {
            assert!(t[0] * t[1] >= 0.0, "{law}: {p:?}");
        }
    }
    assert!(fitted.stability.stable_over_data);
    // Every mode fitted well by the best laws; each nonlinear fit's
    // standard errors exist.
    for m in Mode::ALL {
        assert!(fitted.mode(m).unwrap().r_squared > 0.995, "{m}");
    }
    for law in ["Gent", "Ogden-3"] {
        let f = report.fit(law).unwrap();
        assert!(
            f.standard_errors.iter().all(|e| e.is_some_and(|e| e > 0.0)),
            "{law}"
        );
    }
}

#[test]
fn issue_29_uniaxial_yeoh_predicts_equibiaxial_with_r2_0_89() {
    let tests = treloar_all();
    let report = FitSkinReport::from_tests(&tests, Some(&[Mode::Uniaxial])).unwrap();
    assert_eq!(report.predicted_modes, [Mode::Equibiaxial, Mode::Planar]);
    let yeoh = report.fit("Yeoh").unwrap();
    // Fitted on the uniaxial rows alone: the issue-3 coefficients.
    let alone = FitSkinReport::from_test(&treloar()).unwrap();
    assert_eq!(yeoh.parameters, alone.fit("Yeoh").unwrap().parameters);
    let eq = yeoh.mode(Mode::Equibiaxial).unwrap();
    assert!(!eq.fitted);
    assert!((0.885..0.900).contains(&eq.r_squared), "{}", eq.r_squared);
    // Fitting all three modes jointly lifts the equibiaxial R² of Yeoh.
    let joint = FitSkinReport::from_tests(&tests, None).unwrap();
    let j = joint.fit("Yeoh").unwrap().mode(Mode::Equibiaxial).unwrap();
    assert!(
        j.fitted && j.r_squared > eq.r_squared + 0.05,
        "{}",
        j.r_squared
    );
}

#[test]
fn issue_29_a_fit_mode_no_file_holds_is_an_error_naming_the_files() {
    let e = FitSkinReport::from_tests(&[treloar()], Some(&[Mode::Planar])).unwrap_err();
    let msg = format!("{e:#}");
    assert!(
        msg.contains("fit mode `planar`: no file holds rows of that mode")
            && msg.contains("treloar_uniaxial.csv: uniaxial"),
        "{msg}"
    );
}

#[test]
fn issue_29_every_nonlinear_law_recovers_its_own_three_mode_data() {
    // Data from a known law in all three modes: the fit's stresses match
    // them to rounding (Ogden's coefficients need not be unique, its
    // stresses are), and Gent's two coefficients come back exactly.
    let truths: [Box<dyn StrainEnergy>; 2] = [
        Box::new(Gent {
            mu_kpa: 310.0,
            jm: 45.0,
        }),
        Box::new(Ogden::ogden_1972_treloar()),
    ];
    for (truth, spec) in truths.iter().zip([&Gent::SPEC, &Ogden::SPECS[2]]) {
        let tests: Vec<CouponTest> = Mode::ALL
            .iter()
            .map(|m| {
                let strain: Vec<f64> = (0..20).map(|i| 0.2 * f64::from(i)).collect();
                let p = strain
                    .iter()
                    .map(|e| m.nominal_kpa(truth.as_ref(), 1.0 + e))
                    .collect();
                CouponTest::from_nominal("synthetic", *m, strain, p)
            })
            .collect();
        let fit = fit_law(spec, &tests).unwrap();
        for m in &fit.modes {
            assert!(m.r_squared > 1.0 - 1e-10, "{}: {m:?}", spec.name);
        }
        if spec.name == "Gent" {
            for (got, want) in fit.parameters.iter().zip(truth.parameters()) {
                assert!((got - want).abs() < 1e-6 * want, "{got} vs {want}");
            }
        }
    }
}

/// Keeps the rows of `tests` with strain ≤ `max_strain`.
fn up_to(tests: &[CouponTest], max_strain: f64) -> Vec<CouponTest> {
    tests
        .iter()
        .map(|t| {
            let keep: Vec<usize> = (0..t.strain.len())
                .filter(|&i| t.strain[i] <= max_strain)
                .collect();
            CouponTest::from_nominal(
                t.source.clone(),
                t.mode,
                keep.iter().map(|&i| t.strain[i]).collect(),
                keep.iter().map(|&i| t.nominal_stress_kpa[i]).collect(),
            )
        })
        .collect()
}

/// Which law to trust for the actuator's tube (the skin README's table):
/// Treloar's rubber in the paper's zone (closed ends, D0 18.7 mm, 1.75 mm
/// wall) inflated to 26.2 mm (λθ at the bore ≈ 1.6, λz ≈ 1.13), each
/// law's tube pressure against that of the joint Ogden-3 fit (the law
/// that fits all three modes best, R² ≥ 0.997 on each):
/// `cargo test --target host-tuple -p skin --test skin tube_law -- --nocapture`.
#[test]
fn issue_29_tube_law_choice_at_the_actuators_stretch() {
    let tests = treloar_all();
    let reference = FitSkinReport::from_tests(&tests, None).unwrap();
    let ref_tube = Tube::paper(reference.fit("Ogden-3").unwrap().model(), Ends::Closed);
    let ds = [19.5, 22.7, 25.0, 26.2];
    let p_ref: Vec<f64> = ds
        .iter()
        .map(|d| ref_tube.pressure_kpa(*d).unwrap())
        .collect();
    // Largest |deviation| over the diameters (NaN where the tube has no
    // solution: an unstable law).
    let deviation = |f: &skin::fit::LawFit| -> f64 {
        let tube = Tube::paper(f.model(), Ends::Closed);
        ds.iter()
            .zip(&p_ref)
            .map(|(d, p)| tube.pressure_kpa(*d).map_or(f64::NAN, |q| q / p - 1.0))
            .fold(0.0, |w: f64, x| {
                if x.is_nan() || w.is_nan() {
                    f64::NAN
                } else {
                    w.max(x.abs())
                }
            })
    };
    let cases = [
        (
            "uniaxial, full range",
            up_to(&tests, f64::INFINITY),
            Some(vec![Mode::Uniaxial]),
        ),
        ("all modes, full range", up_to(&tests, f64::INFINITY), None),
        (
            "uniaxial, ε ≤ 0.6",
            up_to(&tests, 0.6),
            Some(vec![Mode::Uniaxial]),
        ),
        ("all modes, ε ≤ 0.6", up_to(&tests, 0.6), None),
    ];
    let mut worst = std::collections::HashMap::new();
    println!("p_ref (kPa) at D = {ds:?} mm: {p_ref:.2?}");
    for (name, data, modes) in &cases {
        let r = FitSkinReport::from_tests(data, modes.as_deref()).unwrap();
        let line: Vec<String> = r
            .fits
            .iter()
            .map(|f| {
                let d = deviation(f);
                worst.insert((*name, f.law), d);
                format!(
                    "{} {:.0} % (μ {:.0})",
                    f.law,
                    100.0 * d,
                    f.shear_modulus_kpa
                )
            })
            .collect();
        println!("{name}: {}", line.join(", "));
    }
    let w = |case: &str, law: &str| worst[&(case, law)];
    // Fitted over the full range to uniaxial data, the one- and
    // two-coefficient laws spend their freedom on the large-strain upturn
    // and miss the tube by a third or more; Yeoh stays within 10 %, the
    // closest of all (Ogden-3, its terms held to μp·αp ≥ 0, misses by
    // about 16 %).
    for law in ["neo-Hookean", "Gent", "Ogden-1"] {
        assert!(w("uniaxial, full range", law) > 0.3, "{law}");
    }
    let yeoh = w("uniaxial, full range", "Yeoh");
    assert!(yeoh < 0.1, "{yeoh}");
    for law in LAWS_FITTED_SMALL {
        let d = w("uniaxial, full range", law);
        assert!(law == "Yeoh" || d.is_nan() || d > yeoh, "{law}: {d}");
    }
    // Mooney–Rivlin fitted to uniaxial data alone is unstable at rest: no tube.
    assert!(w("uniaxial, full range", "Mooney-Rivlin").is_nan());
    // Fitted to every mode over the strains the tube reaches, every law
    // lands within 15 % of the reference (most within 7 %).
    for f in LAWS_FITTED_SMALL {
        assert!(w("all modes, ε ≤ 0.6", f) < 0.15, "{f}");
    }
}

const LAWS_FITTED_SMALL: [&str; 7] = [
    "neo-Hookean",
    "Mooney-Rivlin",
    "Yeoh",
    "Gent",
    "Ogden-1",
    "Ogden-2",
    "Ogden-3",
];

/// Ogden fits hold μp·αp ≥ 0 in every term, even where the unconstrained
/// least-squares optimum breaks it: data of Ogden-2 with μ1 = 300 kPa,
/// α1 = 2 and μ2 = 20 kPa, α2 = −2 (Mooney–Rivlin with C01 = −10 kPa,
/// stable over the data), all three modes to λ = 3.
#[test]
fn issue_29_an_ogden_fit_never_returns_a_term_with_negative_mu_alpha() {
    let truth = Ogden::new(&[
        skin::OgdenTerm {
            mu_kpa: 300.0,
            alpha: 2.0,
        },
        skin::OgdenTerm {
            mu_kpa: 20.0,
            alpha: -2.0,
        },
    ])
    .unwrap();
    let tests: Vec<CouponTest> = Mode::ALL
        .iter()
        .map(|m| {
            let strain: Vec<f64> = (1..=20).map(|i| 0.1 * f64::from(i)).collect();
            let p = strain
                .iter()
                .map(|e| m.nominal_kpa(&truth, 1.0 + e))
                .collect();
            CouponTest::from_nominal("synthetic", *m, strain, p)
        })
        .collect();
    let spec = &Ogden::SPECS[1];
    let skin::Form::Nonlinear { bounds, .. } = spec.form else {
        unreachable!("Ogden is fitted nonlinearly")
    };
    // Unconstrained, within the law's own bounds alone, the truth is the
    // optimum (zero residual) and it breaks the condition: μ2·α2 = −40.
    let rows: Vec<(Mode, f64, f64)> = tests
        .iter()
        .flat_map(|t| {
            t.stretch()
                .zip(t.nominal_stress_kpa.clone())
                .map(move |(l, p)| (t.mode, l, p))
        })
        .collect();
    let residuals = |x: &[f64]| -> Option<Vec<f64>> {
        let law = (spec.from_parameters)(x)?;
        Some(
            rows.iter()
                .map(|(m, l, p)| m.nominal_kpa(law.as_ref(), *l) - p)
                .collect(),
        )
    };
    let free = skin::lm::minimise(residuals, &truth.parameters(), bounds).unwrap();
    assert!(free.rss < 1e-12, "{}", free.rss);
    assert!(free.x[2] * free.x[3] < 0.0, "{:?}", free.x);
    // The fit does not return it: every term keeps μp·αp ≥ 0, at a cost.
    let fit = fit_law(spec, &tests).unwrap();
    println!(
        "constrained Ogden-2 {:?}, RMSE per mode {:?} kPa",
        fit.parameters,
        fit.modes.iter().map(|m| m.rmse_kpa).collect::<Vec<_>>()
    );
    for t in fit.parameters.chunks_exact(2) {
        assert!(t[0] * t[1] >= 0.0, "{:?}", fit.parameters);
    }
    assert!(fit.shear_modulus_kpa > 0.0);
    assert!(
        fit.modes.iter().any(|m| m.rmse_kpa > 1e-3),
        "{:?}",
        fit.modes
    );
}
