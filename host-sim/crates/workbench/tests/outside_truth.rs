//! `diagnose` on folders from a truth that is not the project's
//! (`outside/`): its own actuator, Gent skin, sand law and effects.

mod outside;

use model::effects::{EffectInstance, EffectSpec};
use model::{Params, RigBasis};
use outside::{Hidden, Truth, TWO_SAND_DEPTHS};
use rig::Experiment;
use workbench::calibrate::{calibrate, FitOptions, FitSpace, Slot};
use workbench::dataset::{Dataset, MAX_FIT_SAMPLES};
use workbench::diagnose::{diagnose, DiagnoseOptions, Diagnosis};

fn diagnosed(truth: &Truth) -> (Experiment, Diagnosis) {
    let dir = tempfile::tempdir().unwrap();
    truth.write(dir.path());
    let exp = Experiment::read(dir.path()).unwrap();
    let d = diagnose(&exp, &DiagnoseOptions::default()).unwrap();
    (exp, d)
}

/// The diagnosis of `truth`, a 5 mL bubble, checked to name the bubble
/// alone and within 15 % of its volume.
fn bubble_named_within_15_percent(truth: &Truth) -> Diagnosis {
    let (_, d) = diagnosed(truth);
    assert_eq!(effects(&d), ["trapped_air"], "{:?}", d.selected);
    let v = primary(&d, "trapped_air", "gas_volume_ml").unwrap();
    assert!((v - 5.0).abs() <= 0.15 * 5.0, "{v}");
    d
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
        ("trapped_air", vec![Hidden::TrappedAir(5.0)]),
        ("line_loss", vec![Hidden::LineLoss(0.3)]),
        ("sensor_offset", vec![Hidden::SensorOffset(-0.3)]),
        ("sensor_gain", vec![Hidden::SensorGain(1.1)]),
        ("sensor_lag", vec![Hidden::SensorLag(0.04)]),
        (
            "leak + line_loss",
            vec![Hidden::Leak(0.004), Hidden::LineLoss(0.3)],
        ),
        (
            "sensor_offset + trapped_air",
            vec![Hidden::SensorOffset(-0.3), Hidden::TrappedAir(5.0)],
        ),
        ("piston_friction", vec![Hidden::PistonFriction(0.5)]),
        (
            "skin_viscoelasticity",
            vec![Hidden::SkinViscoelastic(0.3, 1.5)],
        ),
        ("mullins_softening", vec![Hidden::Mullins(0.3, 0.3)]),
        ("wall_arching", vec![Hidden::WallFriction(0.18)]),
        (
            "leak + skin_viscoelasticity",
            vec![Hidden::Leak(0.004), Hidden::SkinViscoelastic(0.3, 1.5)],
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
fn two_forms_that_share_the_misfit_are_added_together() {
    // Seed 1 without [skin], a drift outside the library, sand at two
    // depths only: in the first round no candidate takes a third of the misfit alone, while the
    // unloading and skin-shape forms pay on every other count; judged
    // together they do, and go in in one round. No physical effect
    // follows, and the drift is reported.
    let mut truth = Truth::new(vec![Hidden::Drift(0.2, 9.0)], 1);
    truth.runs = TWO_SAND_DEPTHS.to_vec();
    let (_, d) = diagnosed(&truth);
    assert_eq!(
        d.selected,
        ["sand_unloading", "skin_shape"],
        "{:?}",
        d.selected
    );
    // One round chose both: the first round and the one that found
    // nothing more to add.
    assert_eq!(d.later_rounds.len(), 1, "{:?}", d.selected);
    assert!(d.unexplained.is_some());
}

#[test]
fn an_effect_that_follows_a_drift_outside_the_library_is_withdrawn() {
    // Seed 1 with [skin]: the zero swings 0.2 kPa every 9 s. A skin
    // viscoelasticity pays in its round (ΔBIC, every fold) by following
    // part of the swing, but takes under half of the misfit there, and
    // the residual stays unexplained: it is withdrawn, not named.
    let mut truth = Truth::new(vec![Hidden::Drift(0.2, 9.0)], 1);
    truth.skin_known = true;
    let (_, d) = diagnosed(&truth);
    assert!(effects(&d).is_empty(), "{:?}", d.selected);
    assert!(d.unexplained.is_some());
    let w: Vec<&str> = d.withdrawn.iter().map(|w| w.effect.as_str()).collect();
    assert_eq!(w, ["skin_viscoelasticity"]);
    let share = d.withdrawn[0].excess_explained;
    let opts = DiagnoseOptions::default();
    assert!(
        share >= opts.min_excess_explained && share < opts.min_excess_explained_unexplained,
        "{share}"
    );
}

#[test]
fn a_bubble_the_forms_partly_mimic_is_still_named() {
    // Seed 1 without [skin]: the forms of the baseline take up most of the
    // 5 mL bubble's give (a softer unloading, a skin that stiffens), so
    // once they are in the air changes the reading by less than one noise
    // floor; it still pays on every count and is named at its volume.
    let truth = Truth::new(vec![Hidden::TrappedAir(5.0)], 1);
    let d = bubble_named_within_15_percent(&truth);
    let change = d
        .every_candidate()
        .filter(|c| c.effect == "trapped_air" && c.refusals.is_empty())
        .map(|c| c.change_rms_kpa)
        .next_back()
        .unwrap();
    assert!(change < d.noise_floor_kpa, "{change}");
}

#[test]
fn a_bubble_in_a_shallow_valley_is_fitted_to_its_floor() {
    // Second rig, seed 1, no [skin]: the skin's shape form takes part of
    // the 5 mL bubble's give and the fit's valley along the volume is
    // shallow and curved. The candidate's fit stopped at 4.23 ± 0.15 mL,
    // above the RMSE the volume's profile reaches at 5 mL; the accepted
    // model, refined (restarted, then central differences), ends at
    // 4.68 mL. Without the refinement this fails.
    let truth = Truth::second_rig(vec![Hidden::TrappedAir(5.0)], 1);
    bubble_named_within_15_percent(&truth);
}

#[test]
fn a_bubble_beside_a_stated_skins_scale_is_still_named() {
    // Seed 1 with [skin]: the stated coupon law's scale (≈ 0.965 in the
    // tube) goes in a round before the 5 mL bubble. Fitted from its own
    // defaults beside that scale, the air stalled at 1.2 mL and changed
    // the reading too little to name; started also where the round before
    // left it (5.9 mL), it comes back to its volume.
    let mut truth = Truth::new(vec![Hidden::TrappedAir(5.0)], 1);
    truth.skin_known = true;
    bubble_named_within_15_percent(&truth);
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
fn an_effect_that_outranks_a_form_must_keep_its_gain_beside_it() {
    // Second rig, seed 3, [skin], wall friction in the box, sand at two
    // depths: in the first
    // round the arching outranks the depth form and keeps its gain beside
    // it (every fold better), so it goes in; later a Mullins softening
    // outranks skin_shape but beside it helps in 3 folds of 4 only, so
    // the form goes in instead and the softening stays out.
    let mut truth = Truth::second_rig(vec![Hidden::WallFriction(0.18)], 3);
    truth.skin_known = true;
    truth.runs = TWO_SAND_DEPTHS.to_vec();
    let (_, d) = diagnosed(&truth);
    let contests: Vec<_> = d
        .every_candidate()
        .filter_map(|c| c.beside_form.as_ref())
        .map(|t| (t.effect.as_str(), t.form.as_str(), t.accepted))
        .collect();
    assert!(
        contests.contains(&("wall_arching", "sand_depth_power", true)),
        "{contests:?}"
    );
    assert!(
        contests.contains(&("mullins_softening", "skin_shape", false)),
        "{contests:?}"
    );
    assert!(
        d.selected.iter().any(|s| s == "skin_shape"),
        "{:?}",
        d.selected
    );
    assert!(effects(&d).contains(&"wall_arching"), "{:?}", d.selected);
    assert!(
        !effects(&d).contains(&"mullins_softening"),
        "{:?}",
        d.selected
    );
}

#[test]
fn wall_arching_on_two_sand_depths_is_not_separated_from_the_depth_law() {
    // First rig, seed 1, no [skin]: wall friction in the box (μk 0.18)
    // and a sand whose push goes as depth^0.85, on runs at 50 and 120 mm
    // only. Arching alone takes up both with a
    // narrow interval that misses the truth; with the depth law also free
    // the data leave μk free, and the diagnosis says so.
    let mut truth = Truth::new(vec![Hidden::WallFriction(0.18)], 1);
    truth.runs = TWO_SAND_DEPTHS.to_vec();
    let (_, d) = diagnosed(&truth);
    assert_eq!(effects(&d), ["wall_arching"], "{:?}", d.selected);
    let c = d
        .confounds
        .iter()
        .find(|c| c.param == "wall_arching.mu_k")
        .unwrap_or_else(|| panic!("{:?}", d.confounds));
    assert_eq!(c.form, "sand_depth_power");
    let [a, b] = c.interval_95.unwrap();
    assert!(
        b - a < 0.3 * c.value && !(a..=b).contains(&0.18),
        "{a} … {b}"
    );
    assert!(
        c.interval_95_with_form
            .is_none_or(|[a, b]| b - a > 0.3 * c.value_with_form),
        "{:?}",
        c.interval_95_with_form
    );
}

#[test]
fn wall_arching_on_three_sand_depths_is_told_apart_from_the_depth_law() {
    // The same folder on the generator's schedule, with a run at 85 mm as
    // well: now the depth law and
    // the arching can be told apart. At the noise floor the depth form's
    // held-out gain is under 2 % (ΔBIC ≈ −100, every fold better), but
    // with it arching's μk leaves its own interval, from ≈ 0.24 to the
    // truth: the form goes in for that, and no confound is left.
    let truth = Truth::new(vec![Hidden::WallFriction(0.18)], 1);
    let (_, d) = diagnosed(&truth);
    assert_eq!(effects(&d), ["wall_arching"], "{:?}", d.selected);
    assert!(
        d.selected.iter().any(|s| s == "sand_depth_power"),
        "{:?}",
        d.selected
    );
    let mu_k = primary(&d, "wall_arching", "mu_k").unwrap();
    assert!((mu_k - 0.18).abs() <= 0.15 * 0.18, "{mu_k}");
    assert!(d.confounds.is_empty(), "{:?}", d.confounds);
}

/// `exp` with its runs written `times` times over as separate runs.
fn repeated(exp: &Experiment, times: usize) -> Experiment {
    let mut many = exp.clone();
    many.runs = (1..=times)
        .flat_map(|k| {
            exp.runs.iter().map(move |r| rig::Run {
                id: format!("{}_r{k}", r.id),
                ..r.clone()
            })
        })
        .collect();
    many
}

/// Asserts that `many` got `one`'s diagnosis: the same selection, every
/// parameter of a selected effect within 5 % of `one`'s (or, near zero,
/// within its interval), and a final RMSE within 10 %.
fn same_diagnosis(label: &str, one: &Diagnosis, many: &Diagnosis) {
    assert_eq!(many.selected, one.selected, "{label}");
    for p in one.params.iter().filter(|p| p.name.contains('.')) {
        let q = many.params.iter().find(|q| q.name == p.name).unwrap();
        let within = p
            .interval_95
            .is_some_and(|[a, b]| (a..=b).contains(&q.value));
        assert!(
            (q.value - p.value).abs() <= 0.05 * p.value.abs() || within,
            "{label}: {} {} against {}",
            p.name,
            q.value,
            p.value
        );
    }
    assert!(
        many.final_rmse_kpa <= 1.1 * one.final_rmse_kpa,
        "{label}: {} against {}",
        many.final_rmse_kpa,
        one.final_rmse_kpa
    );
}

#[test]
fn outside_runs_repeated_many_times_get_the_diagnosis_of_one() {
    // A line loss and a leak from the outside truth, its four runs
    // written 30 times as 120 runs (90,000 samples): the fit runs on a
    // few whole runs, the score on all of them, and the answer is the
    // original's.
    let truth = Truth::new(vec![Hidden::Leak(0.004), Hidden::LineLoss(0.3)], 1);
    let (one, want) = diagnosed(&truth);
    let many = repeated(&one, 30);
    let got = diagnose(&many, &DiagnoseOptions::default()).unwrap();
    assert_eq!(got.samples[0], 30 * want.samples[0]);
    assert!(got.samples[1] <= MAX_FIT_SAMPLES + 400, "{:?}", got.samples);
    same_diagnosis("leak + line_loss", &want, &got);
}

#[test]
#[ignore = "a million samples a case: [OUTSIDE_REPEAT=340] [OUTSIDE_KEEP=DIR] cargo test --profile sim -p workbench --test outside_truth outside_folders_of_a_million_samples -- --ignored --nocapture"]
fn outside_folders_of_a_million_samples_get_the_diagnosis_of_one() {
    let times: usize = std::env::var("OUTSIDE_REPEAT").map_or(340, |s| s.parse().unwrap());
    for (label, hidden) in cases()
        .into_iter()
        .filter(|(l, _)| ["none", "leak + line_loss", "leak + skin_viscoelasticity"].contains(l))
    {
        let truth = Truth::new(hidden, 1);
        let (one, want) = diagnosed(&truth);
        let many = repeated(&one, times);
        if let Ok(dir) = std::env::var("OUTSIDE_KEEP") {
            let name: String = label.chars().filter(char::is_ascii_alphanumeric).collect();
            many.write(&std::path::Path::new(&dir).join(name)).unwrap();
        }
        let clock = std::time::Instant::now();
        let got = diagnose(&many, &DiagnoseOptions::default()).unwrap();
        println!(
            "{label}: {} samples, {:.2} s; {:?} RMSE {:.4} against {:?} {:.4}",
            got.samples[0],
            clock.elapsed().as_secs_f64(),
            got.selected,
            got.final_rmse_kpa,
            want.selected,
            want.final_rmse_kpa
        );
        same_diagnosis(label, &want, &got);
    }
}

#[test]
fn outside_mullins_softening_is_named_at_its_ogden_roxburgh_rate() {
    // First rig, seed 1, no [skin]: the 5 mL fill reaches W_max/m ≈ 0.8,
    // where the erf is nearly linear: the saturation is not determined
    // (it may end at 0, the linear law), the initial rate 1/(r·m) is.
    let truth = Truth::new(vec![Hidden::Mullins(0.3, 0.3)], 1);
    let (_, d) = diagnosed(&truth);
    assert_eq!(effects(&d), ["mullins_softening"], "{:?}", d.selected);
    let s = primary(&d, "mullins_softening", "rate").unwrap();
    assert!((s - 1.0).abs() <= 0.15, "{s}");
}

/// The outside rig the ignored studies run: `OUTSIDE_RIG=second` for
/// [`Truth::second_rig`], else [`Truth::new`].
fn chosen_rig() -> fn(Vec<Hidden>, u64) -> Truth {
    if std::env::var("OUTSIDE_RIG").is_ok_and(|r| r == "second") {
        Truth::second_rig
    } else {
        Truth::new
    }
}

/// The cases the ignored matrix runs: `OUTSIDE_CASES=none,leak` for a
/// subset (by name), else every case.
fn chosen_cases() -> Vec<(&'static str, Vec<Hidden>)> {
    let only = std::env::var("OUTSIDE_CASES").ok();
    cases()
        .into_iter()
        .filter(|(name, _)| {
            only.as_ref()
                .is_none_or(|o| o.split(',').any(|c| c == *name))
        })
        .collect()
}

/// The runs of the ignored matrix, when `OUTSIDE_DEPTHS=0,50,120` asks
/// for others than the generator's [`outside::SCHEDULE`]: one run at each sand
/// cover (mm), the flow rates 1.5 and 3 mL/s taking turns first.
fn chosen_runs() -> Option<Vec<(f64, [f64; 2])>> {
    let depths = std::env::var("OUTSIDE_DEPTHS").ok()?;
    Some(
        depths
            .split(',')
            .enumerate()
            .map(|(k, d)| {
                let d: f64 = d
                    .trim()
                    .parse()
                    .expect("OUTSIDE_DEPTHS: mm, comma separated");
                (d, if k % 2 == 0 { [1.5, 3.0] } else { [3.0, 1.5] })
            })
            .collect(),
    )
}

/// The seeds the ignored studies run: `OUTSIDE_SEEDS=1,3` for a subset,
/// else 1–3.
fn chosen_seeds() -> Vec<u64> {
    match std::env::var("OUTSIDE_SEEDS") {
        Ok(list) => list
            .split(',')
            .filter_map(|s| s.trim().parse().ok())
            .collect(),
        Err(_) => vec![1, 2, 3],
    }
}

/// The library effects a folder of `truth` should be named with: those
/// the rig can tell apart (a gain cannot be without `[skin]`: the skin's
/// fitted scale carries it).
fn expected(truth: &Truth) -> Vec<&'static str> {
    let skin_known = truth.skin_known;
    let mut want: Vec<&str> = truth
        .hidden
        .iter()
        .filter_map(|h| h.library())
        .filter(|(e, ..)| skin_known || *e != "sensor_gain")
        .map(|(e, ..)| e)
        .collect();
    want.sort_unstable();
    want
}

#[test]
#[ignore = "the full matrix: [OUTSIDE_RIG=second] [OUTSIDE_CASES=none,leak] [OUTSIDE_SEEDS=1,2] [OUTSIDE_DEPTHS=0,50,120] [OUTSIDE_KEEP=DIR] cargo test -p workbench --test outside_truth -- --ignored --nocapture"]
fn outside_confusion_matrix() {
    println!("case | seed | skin | baseline forms selected | effects selected | primary true→fit | final/noise | unexplained | right");
    let (mut right, mut total, mut primaries_ok, mut primaries) = (0, 0, 0, 0);
    // Primaries reported resting on a form (`Diagnosis::confounds`): off
    // by more than 15 %, and within it.
    let (mut apart_off, mut apart_ok) = (0, 0);
    let mut worst_ratio: f64 = 0.0;
    let make = chosen_rig();
    for seed in chosen_seeds() {
        for skin_known in [false, true] {
            for (name, hidden) in chosen_cases() {
                let mut truth = make(hidden.clone(), seed);
                truth.skin_known = skin_known;
                if let Some(runs) = chosen_runs() {
                    truth.runs = runs;
                }
                if let Ok(keep) = std::env::var("OUTSIDE_KEEP") {
                    let skin = if skin_known { "skin" } else { "noskin" };
                    let slug: String = name
                        .chars()
                        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
                        .collect();
                    truth.write(&std::path::Path::new(&keep).join(format!("{slug}-{seed}-{skin}")));
                }
                let (_, d) = diagnosed(&truth);
                let (forms, effects): (Vec<&String>, Vec<&String>) =
                    d.selected.iter().partition(|s| is_baseline_form(s));
                let mut named: Vec<&str> = effects.iter().map(|s| s.as_str()).collect();
                named.sort_unstable();
                let want = expected(&truth);
                let drift = hidden.iter().any(|h| h.library().is_none());
                let ok = named == want && (!drift || d.unexplained.is_some());
                total += 1;
                right += usize::from(ok);
                if !drift {
                    worst_ratio = worst_ratio.max(d.final_rmse_kpa / d.noise_floor_kpa);
                }
                let prim: Vec<String> = hidden
                    .iter()
                    .filter_map(|h| h.library())
                    .map(|(e, p, v)| {
                        let fit = primary(&d, e, p);
                        let key = format!("{e}.{p}");
                        let apart = d.confounds.iter().find(|c| c.param == key);
                        if let Some(x) = fit {
                            let within = (x - v).abs() <= 0.15 * v.abs();
                            primaries += 1;
                            primaries_ok += usize::from(within);
                            if apart.is_some() {
                                apart_off += usize::from(!within);
                                apart_ok += usize::from(within);
                            }
                        }
                        format!(
                            "{}→{}{}",
                            short(v),
                            fit.map_or("-".into(), |x| format!("{x:.4}")),
                            apart.map_or(String::new(), |c| match c.interval_95_with_form {
                                None => format!(" (not separated from {})", c.form),
                                Some(_) => format!(
                                    " (rests on {}: {:.4} with it)",
                                    c.form, c.value_with_form
                                ),
                            })
                        )
                    })
                    .collect();
                let list = |v: &[&String]| {
                    if v.is_empty() {
                        "-".to_string()
                    } else {
                        v.iter().map(|s| s.as_str()).collect::<Vec<_>>().join(", ")
                    }
                };
                println!(
                    "{name} | {seed} | {} | {} | {} | {} | {:.3}/{:.3} | {} | {}",
                    if skin_known { "[skin]" } else { "none" },
                    list(&forms),
                    list(&effects),
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
                    },
                    if ok { "yes" } else { "no" }
                );
            }
        }
    }
    println!(
        "named right: {right}/{total}; primaries within 15 %: {primaries_ok}/{primaries}; \
         reported resting on a form: {apart_off} of those off, {apart_ok} of those within; \
         worst final RMSE / noise where the truth is in the library: {worst_ratio:.2}"
    );
}

/// `v` with at most four decimals, trailing zeros dropped.
fn short(v: f64) -> String {
    let s = format!("{v:.4}");
    s.trim_end_matches('0').trim_end_matches('.').to_owned()
}

/// The RMS change each hidden effect makes to the noise-free readings
/// (the "signature" of the README's table).
#[test]
#[ignore = "cargo test -p workbench --test outside_truth signatures -- --ignored --nocapture"]
fn signatures() {
    let make = chosen_rig();
    let read = |t: &Truth| -> Vec<f64> {
        t.runs_csv()
            .lines()
            .skip(1)
            .map(|l| l.rsplit(',').next().unwrap().parse().unwrap())
            .collect()
    };
    let mut none = make(Vec::new(), 1);
    none.noise_kpa = 0.0;
    let base = read(&none);
    for (name, hidden) in cases() {
        for h in &hidden {
            let mut t = make(vec![*h], 1);
            t.noise_kpa = 0.0;
            let r = read(&t);
            let rms = (r
                .iter()
                .zip(&base)
                .map(|(a, b)| (a - b).powi(2))
                .sum::<f64>()
                / r.len() as f64)
                .sqrt();
            println!(
                "{name}: {h:?} signature {rms:.4} kPa = {:.2} noise",
                rms / 0.02
            );
        }
    }
}

/// For every folder the matrix names wrong, why each true effect left
/// out stayed out: its last-round candidate, fitted onto what diagnose
/// selected (warm, as diagnose fits it), with its ΔBIC, the excess it
/// explains, its folds and its own refusals. A ΔBIC above the selection's
/// threshold means the data do not prefer the truth (a limit of the
/// data and the library); below it, one of the selection's own rules kept
/// the truth out.
#[test]
#[ignore = "cargo test --profile sim -p workbench --test outside_truth why_missed -- --ignored --nocapture"]
fn why_missed() {
    println!(
        "case | seed | skin | selected | left out: ΔBIC, excess, folds better, change, refusals"
    );
    let (mut missed, mut not_preferred) = (0, 0);
    let mut refused: Vec<(String, usize)> = Vec::new();
    let opts = DiagnoseOptions::default();
    let make = chosen_rig();
    for seed in chosen_seeds() {
        for skin_known in [false, true] {
            for (name, hidden) in chosen_cases() {
                let mut truth = make(hidden.clone(), seed);
                truth.skin_known = skin_known;
                if hidden.iter().any(|h| h.library().is_none()) {
                    continue;
                }
                let (_, d) = diagnosed(&truth);
                let mut named = effects(&d);
                named.sort_unstable();
                let want = expected(&truth);
                if named == want {
                    continue;
                }
                missed += 1;
                let last = d.later_rounds.last().unwrap_or(&d.candidates);
                let mut lines = Vec::new();
                for c in want
                    .iter()
                    .filter(|w| !named.contains(w))
                    .filter_map(|w| last.iter().find(|c| c.effect == *w))
                {
                    if c.score > opts.max_delta_bic {
                        not_preferred += 1;
                    }
                    for r in &c.refusals {
                        // The reason's kind, without its numbers.
                        let kind: String = r
                            .split(|ch: char| ch.is_ascii_digit())
                            .next()
                            .unwrap_or(r)
                            .trim()
                            .to_string();
                        match refused.iter_mut().find(|(k, _)| *k == kind) {
                            Some((_, n)) => *n += 1,
                            None => refused.push((kind, 1)),
                        }
                    }
                    lines.push(format!(
                        "{}: {:+.1}, {:.2}, {:?}, {:.4} kPa{}",
                        c.effect,
                        c.score,
                        c.excess_explained,
                        c.heldout_folds_better,
                        c.change_rms_kpa,
                        if c.refusals.is_empty() {
                            String::new()
                        } else {
                            format!(" ({})", c.refusals.join("; "))
                        }
                    ));
                }
                println!(
                    "{name} | {seed} | {} | {} | {}",
                    if skin_known { "[skin]" } else { "none" },
                    d.selected.join(", "),
                    lines.join("; ")
                );
            }
        }
    }
    println!(
        "named wrong: {missed}; true effects left out that the data do not prefer (ΔBIC > {}): {not_preferred}",
        opts.max_delta_bic
    );
    for (kind, n) in refused {
        println!("refused {n}×: {kind}");
    }
}

/// The fit with every form of the baseline and the air held at 0–7.5 mL
/// (all else fitted from the defaults), on the seed-1 control and 5 mL
/// folders, with and without `[skin]`: where the data put the bubble
/// once the forms are free to take up its volume. `FORMS=a,b;c` for
/// other sets of forms.
#[test]
#[ignore = "cargo test --profile sim -p workbench --test outside_truth bubble_profile -- --ignored --nocapture"]
fn bubble_profile() {
    let sets = std::env::var("FORMS")
        .unwrap_or_else(|_| "sand_depth_power,sand_unloading,sand_rise,skin_shape".into());
    let sets: Vec<Vec<&str>> = sets
        .split(';')
        .map(|s| s.split(',').filter(|x| !x.is_empty()).collect())
        .collect();
    // The air volumes held (mL): `VOLS=4,4.5,5` for others.
    let vols: Vec<f64> = std::env::var("VOLS").map_or(vec![0.0, 1.0, 2.5, 5.0, 7.5], |s| {
        s.split(',')
            .map(|x| x.parse().expect("VOLS: mL, comma separated"))
            .collect()
    });
    let make = chosen_rig();
    let air = EffectSpec::by_name("trapped_air").unwrap();
    for (label, hidden) in [
        ("none", vec![]),
        ("air 5 mL", vec![Hidden::TrappedAir(5.0)]),
    ] {
        for skin_known in [false, true] {
            let mut truth = make(hidden.clone(), 1);
            truth.skin_known = skin_known;
            let dir = tempfile::tempdir().unwrap();
            truth.write(dir.path());
            let exp = Experiment::read(dir.path()).unwrap();
            let basis = RigBasis::new(&exp.rig).unwrap();
            let data = Dataset::new(&exp).thinned(MAX_FIT_SAMPLES);
            for forms in &sets {
                let mut line = format!("{label} | [skin] {skin_known} | {}", forms.join(", "));
                for &v in &vols {
                    let mut effects: Vec<EffectInstance> = forms
                        .iter()
                        .map(|f| {
                            let spec = EffectSpec::by_name(f).unwrap();
                            EffectInstance {
                                spec,
                                values: spec.params.iter().map(|p| p.default).collect(),
                            }
                        })
                        .collect();
                    effects.push(EffectInstance {
                        spec: air,
                        values: vec![v],
                    });
                    let held = effects.len() - 1;
                    let mut space = FitSpace::new(basis.clone(), &data, Params::default(), effects);
                    space
                        .free
                        .retain(|(slot, _)| !matches!(slot, Slot::Effect(e, _) if *e == held));
                    let fit = calibrate(&space, &data, None, FitOptions::default()).unwrap();
                    line += &format!(" | {v} mL: {:.6} kPa, BIC {:.1}", fit.rmse_kpa, fit.bic());
                }
                println!("{line}");
            }
        }
    }
}
