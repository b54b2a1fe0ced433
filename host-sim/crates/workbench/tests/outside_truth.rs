//! `diagnose` on folders from a truth that is not the project's
//! (`outside/`): its own actuator, Gent skin, sand law and effects.

mod outside;

use outside::{Hidden, Truth};
use rig::Experiment;
use workbench::diagnose::{diagnose, DiagnoseOptions, Diagnosis};

fn diagnosed(truth: &Truth) -> (Experiment, Diagnosis) {
    let dir = tempfile::tempdir().unwrap();
    truth.write(dir.path());
    let exp = Experiment::read(dir.path()).unwrap();
    let d = diagnose(&exp, &DiagnoseOptions::default()).unwrap();
    (exp, d)
}

fn primary(d: &Diagnosis, effect: &str, param: &str) -> Option<f64> {
    let key = format!("{effect}.{param}");
    d.params.iter().find(|p| p.name == key).map(|p| p.value)
}

/// The cases of the outside confusion matrix.
pub fn cases() -> Vec<(&'static str, Vec<Hidden>)> {
    vec![
        ("none", vec![]),
        ("leak", vec![Hidden::Leak(0.004)]),
        ("trapped_air", vec![Hidden::TrappedAir(1.5)]),
        ("line_loss", vec![Hidden::LineLoss(0.3)]),
        ("sensor_offset", vec![Hidden::SensorOffset(-0.3)]),
        ("sensor_gain", vec![Hidden::SensorGain(1.1)]),
        ("sensor_lag", vec![Hidden::SensorLag(0.03)]),
        (
            "leak + line_loss",
            vec![Hidden::Leak(0.004), Hidden::LineLoss(0.3)],
        ),
        (
            "sensor_offset + trapped_air",
            vec![Hidden::SensorOffset(-0.3), Hidden::TrappedAir(1.5)],
        ),
        ("drift (outside)", vec![Hidden::Drift(0.2, 9.0)]),
    ]
}

/// Whether `name` is a form of the baseline rather than an effect.
fn is_baseline_form(name: &str) -> bool {
    model::effects::EffectSpec::by_name(name).is_ok_and(|s| s.kind.is_baseline_form())
}

/// The library effects a diagnosis selected (its forms of the baseline
/// left out).
fn effects(d: &Diagnosis) -> Vec<&str> {
    d.selected
        .iter()
        .map(String::as_str)
        .filter(|s| !is_baseline_form(s))
        .collect()
}

#[test]
fn the_outside_control_gets_no_physical_effect() {
    for skin_known in [false, true] {
        let mut truth = Truth::new(Vec::new(), 1);
        truth.skin_known = skin_known;
        let (_, d) = diagnosed(&truth);
        assert!(
            effects(&d).is_empty(),
            "[skin] {skin_known}: {:?}",
            d.selected
        );
    }
}

#[test]
fn an_outside_line_loss_is_named_within_15_percent() {
    for skin_known in [false, true] {
        let mut truth = Truth::new(vec![Hidden::LineLoss(0.3)], 1);
        truth.skin_known = skin_known;
        let (_, d) = diagnosed(&truth);
        assert_eq!(effects(&d), ["line_loss"], "[skin] {skin_known}");
        let r = primary(&d, "line_loss", "resistance_kpa_s_per_ml").unwrap();
        assert!((r - 0.3).abs() <= 0.15 * 0.3, "[skin] {skin_known}: {r}");
    }
}

#[test]
#[ignore = "the full matrix: cargo test -p workbench --test outside_truth -- --ignored --nocapture"]
fn outside_confusion_matrix() {
    println!("case | seed | skin | baseline forms selected | effects selected | primary true→fit | final/noise | unexplained");
    for seed in 1..=3 {
        for skin_known in [false, true] {
            for (name, hidden) in cases() {
                let mut truth = Truth::new(hidden.clone(), seed);
                truth.skin_known = skin_known;
                let (_, d) = diagnosed(&truth);
                let (forms, effects): (Vec<&String>, Vec<&String>) =
                    d.selected.iter().partition(|s| is_baseline_form(s));
                let prim: Vec<String> = hidden
                    .iter()
                    .filter_map(|h| h.library())
                    .map(|(e, p, v)| {
                        format!(
                            "{v}→{}",
                            primary(&d, e, p).map_or("-".into(), |x| format!("{x:.4}"))
                        )
                    })
                    .collect();
                println!(
                    "{name} | {seed} | {} | {} | {} | {} | {:.3}/{:.3} | {}",
                    if skin_known { "[skin]" } else { "none" },
                    if forms.is_empty() {
                        "-".to_string()
                    } else {
                        forms
                            .iter()
                            .map(|s| s.as_str())
                            .collect::<Vec<_>>()
                            .join(", ")
                    },
                    if effects.is_empty() {
                        "-".to_string()
                    } else {
                        effects
                            .iter()
                            .map(|s| s.as_str())
                            .collect::<Vec<_>>()
                            .join(", ")
                    },
                    if prim.is_empty() {
                        "-".to_string()
                    } else {
                        prim.join(", ")
                    },
                    d.final_rmse_kpa,
                    d.noise_floor_kpa,
                    if d.unexplained.is_some() {
                        "set"
                    } else {
                        "null"
                    }
                );
            }
        }
    }
}
