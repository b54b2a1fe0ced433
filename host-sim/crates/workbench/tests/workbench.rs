//! The model workbench on synthetic experiments with hidden effects
//! (issue 4): the project's own generator (`workbench::synth`) hides one
//! library effect, two, none, or one outside the library, adds seeded
//! noise, and `diagnose` must name what was hidden.
//!
//! Small sets (3 runs, ~500 samples each) keep this fast in the dev
//! profile; the full confusion matrix is `examples/confusion.rs`.

use rig::{Experiment, PressureSource};
use workbench::diagnose::{diagnose, DiagnoseOptions, Diagnosis};
use workbench::synth::{case, typical, Outside, Synth};

/// Sample interval of the test sets (s).
const DT_S: f64 = 0.04;

fn run(synth: &Synth) -> Diagnosis {
    let exp = synth.generate().unwrap();
    let d = diagnose(&exp, &DiagnoseOptions::default()).unwrap();
    // Synthetic folders hold no glitch: nothing may be left out as one.
    assert!(d.spikes.is_empty(), "false spikes: {:?}", d.spikes);
    d
}

fn primary(d: &Diagnosis, effect: &str, param: &str) -> f64 {
    let key = format!("{effect}.{param}");
    d.params
        .iter()
        .find(|p| p.name == key)
        .unwrap_or_else(|| panic!("{key} not in {:?}", d.params))
        .value
}

/// One hidden effect: ranked first, selected alone, primary parameter
/// within 15 %, final RMSE within 1.5× the noise floor, nothing unexplained.
fn hidden(name: &str, seed: u64) {
    let (want, got) = hidden_fit(name, seed);
    assert!(
        (got - want).abs() <= 0.15 * want.abs(),
        "{name}: fitted {got}, hidden {want}"
    );
}

/// As [`hidden`], the primary parameter's mean over `seeds` within 15 %:
/// for a parameter whose scatter between noise draws is itself near 15 %.
fn hidden_over_seeds(name: &str, seeds: &[u64]) {
    let fits: Vec<(f64, f64)> = seeds.iter().map(|&k| hidden_fit(name, k)).collect();
    let want = fits[0].0;
    let mean = fits.iter().map(|f| f.1).sum::<f64>() / fits.len() as f64;
    assert!(
        (mean - want).abs() <= 0.15 * want.abs(),
        "{name}: fitted {fits:?}, mean {mean}, hidden {want}"
    );
}

/// Runs [`hidden`]'s checks but the primary's; returns (hidden, fitted).
fn hidden_fit(name: &str, seed: u64) -> (f64, f64) {
    let truth = typical(name).unwrap();
    let mut synth = case(vec![truth.clone()], DT_S, seed);
    if name == "piston_friction" {
        synth.rig.measurement.pressure_source = PressureSource::PistonForce;
    }
    if name == "skin_shape" {
        // The harder case: the skin's scale is fitted beside its shape.
        synth.rig.skin = None;
    }
    let d = run(&synth);
    assert_eq!(d.candidates[0].effect, name, "ranking: {:?}", names(&d));
    assert_eq!(
        d.selected,
        vec![name.to_owned()],
        "{:?} {:?} base {:?}",
        names(&d),
        d.candidates[0],
        d.baseline
    );
    let p = truth.spec.params[0].name;
    let (want, got) = (truth.values[0], primary(&d, name, p));
    assert!(
        d.final_rmse_kpa <= 1.5 * d.noise_floor_kpa,
        "{name}: final RMSE {} vs noise {}",
        d.final_rmse_kpa,
        d.noise_floor_kpa
    );
    assert!(d.unexplained.is_none(), "{name}: {:?}", d.unexplained);
    (want, got)
}

fn names(d: &Diagnosis) -> Vec<(String, f64)> {
    d.candidates
        .iter()
        .map(|c| (c.effect.clone(), c.score))
        .collect()
}

#[test]
fn finds_hidden_sensor_offset() {
    hidden("sensor_offset", 1);
}

#[test]
fn finds_hidden_sensor_gain() {
    hidden("sensor_gain", 2);
}

#[test]
fn finds_hidden_line_loss() {
    hidden("line_loss", 3);
}

#[test]
fn finds_hidden_piston_friction() {
    hidden("piston_friction", 4);
}

#[test]
fn finds_hidden_trapped_air() {
    // The gas volume trades off against the sand's rise (both set the
    // early compliance): over seeds 1–16 it scatters by 11 % (SD) about
    // the hidden 0.8 mL, twice its reported standard error, so one draw
    // misses 15 % about one time in six. Their mean does not.
    hidden_over_seeds("trapped_air", &[5, 6, 7, 8]);
}

#[test]
fn finds_hidden_leak() {
    hidden("leak", 6);
}

#[test]
fn finds_hidden_skin_viscoelasticity() {
    hidden("skin_viscoelasticity", 7);
}

#[test]
fn finds_hidden_mullins_softening() {
    hidden("mullins_softening", 8);
}

#[test]
fn finds_hidden_wall_arching() {
    hidden("wall_arching", 9);
}

#[test]
fn finds_hidden_sensor_lag() {
    hidden("sensor_lag", 10);
}

/// Two hidden effects: both selected, both primaries within 15 %.
fn pair(a: &str, b: &str, seed: u64) {
    let truths = vec![typical(a).unwrap(), typical(b).unwrap()];
    let d = run(&case(truths.clone(), DT_S, seed));
    let mut sel = d.selected.clone();
    sel.sort();
    let mut want = vec![a.to_owned(), b.to_owned()];
    want.sort();
    assert_eq!(sel, want, "ranking {:?}", names(&d));
    assert!(d.candidates[0].effect == a || d.candidates[0].effect == b);
    for t in &truths {
        let p = t.spec.params[0].name;
        let got = primary(&d, t.spec.name, p);
        assert!(
            (got - t.values[0]).abs() <= 0.15 * t.values[0].abs(),
            "{}.{p}: {got} vs {}",
            t.spec.name,
            t.values[0]
        );
    }
    assert!(
        d.final_rmse_kpa <= 1.5 * d.noise_floor_kpa,
        "{} vs {}",
        d.final_rmse_kpa,
        d.noise_floor_kpa
    );
}

#[test]
fn finds_line_loss_and_leak_together() {
    pair("line_loss", "leak", 11);
}

#[test]
fn finds_wall_arching_and_sensor_offset_together() {
    pair("wall_arching", "sensor_offset", 12);
}

#[test]
fn control_selects_nothing() {
    let d = run(&case(Vec::new(), DT_S, 13));
    assert!(d.selected.is_empty(), "{:?}", names(&d));
    assert!(d.unexplained.is_none(), "{:?}", d.unexplained);
    assert!(d.final_rmse_kpa <= 1.5 * d.noise_floor_kpa);
    // The baseline's sand factors are recovered (truth 1.15 and 0.9).
    let get = |n: &str| d.params.iter().find(|p| p.name == n).unwrap();
    let k0 = get("sand_at_rest_factor");
    assert!((k0.value - 1.15).abs() < 0.05, "{k0:?}");
    assert!((get("sand_limit_factor").value - 0.9).abs() < 0.05);
    assert!(k0.std_error.is_some_and(|e| e > 0.0 && e < 0.05));
}

#[test]
fn effect_outside_the_library_is_reported_unexplained() {
    let mut synth = case(Vec::new(), DT_S, 14);
    synth.outside = Some(Outside::TemperatureDrift {
        amplitude_kpa: 0.25,
        period_s: 7.0,
    });
    let d = run(&synth);
    assert!(d.selected.is_empty(), "picked {:?}", d.selected);
    let why = d
        .unexplained
        .expect("a structured residual must be reported");
    assert!(why.contains("unexplained residual"), "{why}");
}

#[test]
fn noise_floor_is_estimated_when_the_rig_does_not_state_it() {
    let mut synth = case(Vec::new(), DT_S, 15);
    synth.rig.measurement.pressure_noise_kpa = None;
    synth.noise_kpa = 0.05;
    let d = run(&synth);
    assert!(
        (d.noise_floor_kpa - 0.05).abs() < 0.01,
        "{}",
        d.noise_floor_kpa
    );
    assert!(d.noise_floor_source.contains("estimated"));
}

#[test]
fn json_has_the_documented_fields_and_free_water_rigs_work() {
    // Free water only, no [sand], piston force, runs of different lengths.
    let mut synth = case(vec![typical("line_loss").unwrap()], DT_S, 16);
    synth.rig.sand = None;
    synth.rig.measurement.pressure_source = PressureSource::PistonForce;
    for (i, r) in synth.runs.iter_mut().enumerate() {
        r.depth_mm = 0.0;
        r.flows_ml_s.truncate(1 + i % 2);
    }
    let exp: Experiment = synth.generate().unwrap();
    let d = diagnose(&exp, &DiagnoseOptions::default()).unwrap();
    assert_eq!(d.selected, vec!["line_loss".to_owned()]);
    let v = serde_json::to_value(&d).unwrap();
    for key in [
        "candidates",
        "selected",
        "params",
        "final_rmse_kpa",
        "noise_floor_kpa",
        "unexplained",
    ] {
        assert!(v.get(key).is_some(), "{key}");
    }
    assert!(v["baseline"]["rmse_kpa"].is_number());
    let c = &v["candidates"][0];
    for key in ["effect", "rmse_kpa", "score", "params"] {
        assert!(c.get(key).is_some(), "candidates[0].{key}");
    }
    // Arching cannot act without sand; friction can (piston force).
    assert!(d.not_applicable.iter().any(|(n, _)| n == "wall_arching"));
    assert!(d.candidates.iter().any(|c| c.effect == "piston_friction"));
}

#[test]
fn the_loop_add_an_effect_and_watch_the_error_fall() {
    use workbench::commands::{compare, diagnose_folder, ledger, DiagnoseOutcome};
    let dir = tempfile::tempdir().unwrap();
    let exp = case(vec![typical("line_loss").unwrap()], 0.05, 17)
        .generate()
        .unwrap();
    exp.write(dir.path()).unwrap();
    let opts = DiagnoseOptions::default();
    // First diagnosis records the bare model as version 0.
    match diagnose_folder(dir.path(), None, &opts).unwrap() {
        DiagnoseOutcome::Diagnosis(d) => assert_eq!(d.selected, vec!["line_loss".to_owned()]),
        other => panic!("{other:?}"),
    }
    assert!(dir.path().join("workbench/diagnosis.json").exists());
    // Refused: unknown effect, effect that cannot act in a line-sensor rig.
    assert!(diagnose_folder(dir.path(), Some("flux_capacitor"), &opts).is_err());
    assert!(diagnose_folder(dir.path(), Some("piston_friction"), &opts).is_err());
    diagnose_folder(dir.path(), Some("line_loss"), &opts).unwrap();
    let (entries, svg) = ledger(dir.path()).unwrap();
    assert_eq!(entries.len(), 2);
    assert_eq!((entries[0].version, entries[1].version), (0, 1));
    assert!(entries[0].effects.is_empty());
    assert_eq!(entries[1].effects, vec!["line_loss".to_owned()]);
    // Each version records the skin it was fitted with.
    let skin = exp.rig.skin_description();
    assert!(skin.contains("Yeoh"), "{skin}");
    assert!(entries.iter().all(|e| e.skin == skin));
    assert!(workbench::commands::ledger_text(&entries).contains(&format!("skin: {skin}\n")));
    assert!(entries[1].rmse_kpa < 0.5 * entries[0].rmse_kpa);
    assert!(entries[1].rmse_kpa <= 1.5 * 0.03);
    assert!(svg.exists());
    let model = std::fs::read_to_string(dir.path().join("model.toml")).unwrap();
    assert!(model.contains("line_loss"));
    // Adding it twice is refused; compare uses the model file.
    assert!(diagnose_folder(dir.path(), Some("line_loss"), &opts).is_err());
    let cmp = compare(dir.path()).unwrap();
    assert_eq!(cmp.effects, vec!["line_loss".to_owned()]);
    assert!(cmp.residual.overall.rmse_kpa <= 1.5 * 0.03);
    assert!(cmp.files.iter().all(|f| f.exists()));
    // The folder still reads as an experiment (no stray CSV written).
    assert_eq!(Experiment::read(dir.path()).unwrap(), exp);
}

#[test]
fn an_effect_fitted_to_its_bound_is_reported_and_not_accepted() {
    // A lag at the very end of the library's range (50 ms): the fit runs
    // into the bound, where the data may want more than the effect can
    // be. Such a fit is reported as at its bound and not accepted.
    let truth = typical("sensor_lag").unwrap();
    let mut synth = case(vec![truth], DT_S, 1);
    synth.effects[0].set("lag_s", 0.05).unwrap();
    let d = run(&synth);
    let lag = d
        .candidates
        .iter()
        .find(|c| c.effect == "sensor_lag")
        .expect("sensor_lag tried");
    assert_eq!(lag.at_bound, ["sensor_lag.lag_s"], "{lag:?}");
    assert!(
        !d.selected.contains(&"sensor_lag".to_owned()),
        "{:?}",
        d.selected
    );
    let text = workbench::commands::diagnosis_text(&d);
    assert!(
        text.contains("[sensor_lag.lag_s at its bound: not accepted]"),
        "{text}"
    );
}

#[test]
fn isolated_spikes_are_named_by_line_and_left_out_of_the_fit() {
    let synth = case(vec![typical("line_loss").unwrap()], DT_S, 2);
    let clean = synth.generate().unwrap();
    let want = diagnose(&clean, &DiagnoseOptions::default()).unwrap();
    // Three glitches of 5 to 8 kPa, as written to and read from a folder.
    let mut glitched = clean.clone();
    let hits = [(0, 40, 8.0), (1, 75, -5.0), (2, 10, 6.0)];
    for &(run, k, kpa) in &hits {
        glitched.runs[run].samples[k].pressure_kpa += kpa;
    }
    let dir = tempfile::tempdir().unwrap();
    glitched.write(dir.path()).unwrap();
    let read = Experiment::read(dir.path()).unwrap();
    let d = diagnose(&read, &DiagnoseOptions::default()).unwrap();

    let mut got: Vec<(String, u64)> = d
        .spikes
        .iter()
        .map(|s| (s.run.clone(), s.line.expect("read from a file")))
        .collect();
    got.sort();
    let mut expected: Vec<(String, u64)> = hits
        .iter()
        .map(|&(run, k, _)| {
            let line = read.sources[run].lines[k];
            (read.runs[run].id.clone(), line)
        })
        .collect();
    expected.sort();
    assert_eq!(got, expected, "{:?}", d.spikes);
    // The same diagnosis as without the glitches, to within the noise.
    assert_eq!(d.selected, want.selected);
    assert!(
        (d.final_rmse_kpa - want.final_rmse_kpa).abs() < 0.1 * want.final_rmse_kpa,
        "{} vs {}",
        d.final_rmse_kpa,
        want.final_rmse_kpa
    );
    let text = workbench::commands::diagnosis_text(&d);
    assert!(text.contains("spikes: 3 isolated reading(s)"), "{text}");
    // `compare` leaves the same readings out of its calibration.
    let cmp = workbench::commands::compare(dir.path()).unwrap();
    let mut lines: Vec<u64> = cmp.spikes.iter().filter_map(|s| s.line).collect();
    lines.sort_unstable();
    let mut want_lines: Vec<u64> = expected.iter().map(|e| e.1).collect();
    want_lines.sort_unstable();
    assert_eq!(lines, want_lines, "{:?}", cmp.spikes);
    // Without glitches, nothing is called a spike.
    assert!(want.spikes.is_empty(), "{:?}", want.spikes);
}

#[test]
fn many_repeated_runs_get_the_diagnosis_of_one() {
    // The three standard runs repeated 40 times as separate runs (51,000
    // samples): the fit keeps whole runs at the original's resolution
    // instead of every 13th sample of each, and names the same effects.
    let synth = case(
        vec![typical("line_loss").unwrap(), typical("leak").unwrap()],
        DT_S,
        3,
    );
    let one = synth.generate().unwrap();
    let want = run(&synth);
    let mut many = one.clone();
    many.runs = (0..40)
        .flat_map(|k| {
            one.runs.iter().map(move |r| rig::Run {
                id: format!("{}_r{k}", r.id),
                ..r.clone()
            })
        })
        .collect();
    let d = diagnose(&many, &DiagnoseOptions::default()).unwrap();
    assert_eq!(d.selected, want.selected);
    assert_eq!(d.samples[0], 40 * want.samples[0]);
    assert!(d.samples[1] <= 4000 + 3 * 400, "{:?}", d.samples);
    for (effect, param) in [
        ("line_loss", "resistance_kpa_s_per_ml"),
        ("leak", "ml_per_s_per_kpa"),
    ] {
        let (a, b) = (primary(&d, effect, param), primary(&want, effect, param));
        assert!((a - b).abs() <= 0.05 * b.abs(), "{effect}: {a} vs {b}");
    }
    assert!(d.final_rmse_kpa <= 1.1 * want.final_rmse_kpa);
}

#[test]
fn long_runs_get_the_diagnosis_of_their_first_cycles() {
    // Each standard run goes through its two cycles 40 times in one
    // recording (three runs of about 11 minutes, 51,000 samples), the
    // leak's lost volume carried through: the fit takes each run's
    // opening stretch, and the whole runs are scored against it.
    let effects = vec![typical("line_loss").unwrap(), typical("leak").unwrap()];
    let synth = case(effects, DT_S, 3);
    let want = run(&synth);
    let mut long = synth.clone();
    for plan in &mut long.runs {
        plan.flows_ml_s = plan.flows_ml_s.repeat(40);
    }
    let d = run(&long);
    assert_eq!(d.selected, want.selected);
    assert!(d.samples[0] > 39 * want.samples[0], "{:?}", d.samples);
    assert!(d.samples[1] <= 4000, "{:?}", d.samples);
    for (effect, param) in [
        ("line_loss", "resistance_kpa_s_per_ml"),
        ("leak", "ml_per_s_per_kpa"),
    ] {
        let (a, b) = (primary(&d, effect, param), primary(&want, effect, param));
        assert!((a - b).abs() <= 0.05 * b.abs(), "{effect}: {a} vs {b}");
    }
    // Scored on every sample of the 40 cycles, not only those fitted.
    assert!(
        d.final_rmse_kpa <= 1.1 * d.noise_floor_kpa,
        "{}",
        d.final_rmse_kpa
    );
    assert!(d.unexplained.is_none(), "{:?}", d.unexplained);
}

#[test]
fn a_sand_whose_push_is_not_proportional_to_depth_is_named_in_words() {
    hidden("sand_depth_power", 7);
    let d = run(&case(vec![typical("sand_depth_power").unwrap()], DT_S, 7));
    let text = workbench::commands::diagnosis_text(&d);
    assert!(
        text.contains("sand_depth_power (the baseline's form): the sand's push grows as depth^0.70, less than in proportion to depth"),
        "{text}"
    );
}

#[test]
fn a_skin_of_another_shape_is_named_with_or_without_its_law() {
    // Without [skin] (the scale fitted too), in `hidden`.
    hidden("skin_shape", 7);
    // With rig.toml's [skin] (a coupon law that does not carry over to
    // the tube): named in words.
    let d = run(&case(vec![typical("skin_shape").unwrap()], DT_S, 7));
    assert_eq!(d.selected, ["skin_shape"]);
    let text = workbench::commands::diagnosis_text(&d);
    assert!(
        text.contains(
            "skin_shape (the baseline's form): the skin stiffens more with stretch than its law"
        ),
        "{text}"
    );
}

#[test]
fn a_sand_that_unloads_more_softly_is_named_in_words() {
    hidden("sand_unloading", 7);
    let d = run(&case(vec![typical("sand_unloading").unwrap()], DT_S, 7));
    let text = workbench::commands::diagnosis_text(&d);
    assert!(
        text.contains(
            "sand_unloading (the baseline's form): the sand unloads more softly than the model"
        ),
        "{text}"
    );
}
