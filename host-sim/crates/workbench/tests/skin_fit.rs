//! `--skin-fit` in the workbench: a synthetic folder whose truth skin is
//! Gent (the workbench's own generator, `workbench::synth`, with that law
//! as its rig's skin), its rig.toml holding the paper's Yeoh `[skin]` as
//! the data contract allows. Read with the Gent law of fit-skin's report,
//! the baseline fits to the noise; read with its `[skin]`, it cannot.

use skin::coupon::{CouponTest, Mode};
use skin::report::{write_report, FitSkinReport};
use skin::{Gent, SkinFitChoice, StrainEnergy};
use workbench::commands::{compare, compare_with, diagnose_folder_with};
use workbench::synth::case;

/// The truth: a Gent skin with a strong lock, so its tube curve is not a
/// rescaled Yeoh one over the actuator's range.
const TRUTH: Gent = Gent {
    mu_kpa: 6.0,
    jm: 2.5,
};

/// Noise of the synthetic readings ([`case`]'s, kPa).
const NOISE_KPA: f64 = 0.03;

#[test]
fn a_gent_skin_from_a_fit_report_lets_the_baseline_fit_to_the_noise() {
    let dir = tempfile::tempdir().unwrap();
    // fit-skin's report of coupons of the truth in all three modes.
    let tests: Vec<CouponTest> = Mode::ALL
        .iter()
        .map(|m| {
            let strain: Vec<f64> = (1..=12).map(|i| 0.05 * f64::from(i)).collect();
            let p = strain
                .iter()
                .map(|e| m.nominal_kpa(&TRUTH, 1.0 + e))
                .collect();
            CouponTest::from_nominal("coupons.csv", *m, strain, p)
        })
        .collect();
    let report = FitSkinReport::from_tests(&tests, None).unwrap();
    let fit_dir = dir.path().join("fit");
    std::fs::create_dir_all(&fit_dir).unwrap();
    let written = write_report(report, &tests, "coupons", &fit_dir).unwrap();
    let choice = SkinFitChoice {
        file: written.json_path,
        law: Some("Gent".into()),
    };
    let chosen = choice.read().unwrap();
    for (got, want) in chosen.law.parameters().iter().zip(TRUTH.parameters()) {
        assert!((got - want).abs() < 1e-6 * want, "{got} vs {want}");
    }

    // The folder: the truth's skin is the Gent law; rig.toml keeps the
    // paper's Yeoh [skin] (c10 2 kPa: μ 4 kPa against the truth's 6).
    let mut synth = case(Vec::new(), 0.04, 11);
    synth.rig.skin_fit = Some(chosen);
    let mut exp = synth.generate().unwrap();
    // What the folder holds: rig.toml as the contract has it.
    exp.rig.skin_fit = None;
    let exp_dir = dir.path().join("exp");
    std::fs::create_dir_all(&exp_dir).unwrap();
    exp.write(&exp_dir).unwrap();
    let rig_toml = std::fs::read_to_string(exp_dir.join("rig.toml")).unwrap();
    assert!(rig_toml.contains("c10_kpa") && !rig_toml.contains("Gent"));

    let with = compare_with(&exp_dir, Some(&choice)).unwrap();
    let without = compare(&exp_dir).unwrap();
    println!(
        "baseline RMSE with the Gent law {:.4} kPa, with rig.toml's Yeoh [skin] {:.4} kPa (noise {NOISE_KPA})",
        with.residual.overall.rmse_kpa, without.residual.overall.rmse_kpa
    );
    assert!(
        with.residual.overall.rmse_kpa <= 1.5 * NOISE_KPA,
        "{}",
        with.residual.overall.rmse_kpa
    );
    assert!(
        without.residual.overall.rmse_kpa > 3.0 * NOISE_KPA,
        "{}",
        without.residual.overall.rmse_kpa
    );
    // The warning names both laws.
    assert!(
        with.warnings
            .iter()
            .any(|w| w.contains("[skin] (Yeoh c10_kpa = 2") && w.contains("Gent mu_kpa")),
        "{:?}",
        with.warnings
    );
    assert!(with.text().starts_with("warning: "));

    // The ledger records each version's skin, and a change of skin is
    // warned of: errors under different skins do not compare.
    let opts = workbench::diagnose::DiagnoseOptions::default();
    let (_, first) = diagnose_folder_with(&exp_dir, Some("leak"), None, &opts).unwrap();
    assert!(first.is_empty(), "{first:?}");
    let (_, second) =
        diagnose_folder_with(&exp_dir, Some("line_loss"), Some(&choice), &opts).unwrap();
    assert!(
        second
            .iter()
            .any(|w| w.contains("was fitted with [skin] Yeoh") && w.contains("Gent mu_kpa")),
        "{second:?}"
    );
    let (entries, _) = workbench::commands::ledger(&exp_dir).unwrap();
    let skins: Vec<bool> = entries.iter().map(|e| e.skin.contains("Gent")).collect();
    assert_eq!(skins, [false, true]);
}
