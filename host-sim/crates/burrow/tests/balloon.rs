//! The balloon experiment's reproduction: the measured table, the skin
//! matched to a free pressure, the comparison, and the whole pipeline on a
//! tiny bed.

use burrow::balloon::{run_cases, Row};
use burrow::cases::{Part, Runner};
use burrow::free_skin::MATCH_TOLERANCE;
use burrow::{FreeCurve, HeadSupport, ScenarioSpec};
use sand::{BALLOON_FREE_PRESSURE_KPA, BALLOON_TABLE};

#[test]
fn the_measured_internal_pressures_are_the_h0_reading_plus_p_e() {
    // paper-figures.md: internal pressure at each depth, kPa.
    let measured = [17.45, 18.77, 20.83, 22.66];
    for (b, want) in BALLOON_TABLE.iter().zip(measured) {
        assert!(
            (b.internal_pressure_kpa() - want).abs() < 1e-9,
            "{} mm: {} kPa",
            b.depth_mm,
            b.internal_pressure_kpa()
        );
    }
    assert_eq!(BALLOON_FREE_PRESSURE_KPA, 13.59);
}

#[test]
fn a_balloon_case_is_inflated_where_it_lies_with_its_ends_held() {
    let b = ScenarioSpec::paper(70e-3, 1.5e-3).as_balloon();
    assert_eq!(b.advance_m, 0.0);
    assert_eq!(b.head, HeadSupport::Held);
    assert!(b.balloon);
    // The sand, the depth and the zone stay the paper's.
    let p = ScenarioSpec::paper(70e-3, 1.5e-3);
    assert_eq!(
        (b.depth_m, b.final_diameter_m, b.tube, b.friction),
        (p.depth_m, p.final_diameter_m, p.tube, p.friction)
    );
    assert_eq!(b.balloon_point(), p.balloon_point());
}

/// The membrane zone: the same matching at a fraction of the solid
/// wall's cost.
fn membrane() -> ScenarioSpec {
    ScenarioSpec::paper(40e-3, 1.5e-3).with_membrane()
}

#[test]
fn matching_the_skin_scales_its_law_until_the_free_zone_needs_the_target() {
    let spec = membrane();
    let base = FreeCurve::of(&spec).unwrap();
    let p0 = base.pressure_pa(spec.final_diameter_m).unwrap();
    let target = 1.8 * p0;
    let (matched, curve) = FreeCurve::matched(&spec, target).unwrap();
    let p = curve.pressure_pa(matched.final_diameter_m).unwrap();
    assert!(
        (p / target - 1.0).abs() <= MATCH_TOLERANCE,
        "{p} Pa against {target} Pa"
    );
    // Every coefficient scaled: p_free at a given shape scales with them,
    // so the scale is the pressure ratio (to the curve's sampling).
    let ratio = matched.skin_stiffness_scale / spec.skin_stiffness_scale;
    assert!((ratio / 1.8 - 1.0).abs() < 0.01, "scale ratio {ratio}");
    // The same curve, scaled, along the whole range.
    for d in [20.0e-3, 22.0e-3, 24.0e-3] {
        let (a, b) = (base.pressure_pa(d).unwrap(), curve.pressure_pa(d).unwrap());
        assert!((b / (ratio * a) - 1.0).abs() < 0.02, "{d}: {a} → {b}");
    }
    // Nothing else about the case changes.
    assert_eq!(
        ScenarioSpec {
            skin_stiffness_scale: spec.skin_stiffness_scale,
            ..matched
        },
        spec
    );
    assert!(FreeCurve::matched(&spec, 0.0).is_err());
    assert!(FreeCurve::matched(&spec, f64::NAN).is_err());
}

#[test]
fn a_row_is_within_the_measured_sd_only_inside_it() {
    let measured = BALLOON_TABLE[0]; // 3.86 ± 1.24 kPa, p_i 17.45.
    let row = |share: f64, p_i: f64| Row {
        depth_mm: 40.0,
        internal_kpa: (p_i, 0.1),
        sand_share_kpa: (share, 0.1),
        contact_kpa: (share, 0.1),
        calipers_mm: (24.5, 25.5),
        measured: Some(measured),
    };
    assert_eq!(row(3.86, 17.45).sand_share_within_sd(), Some(true));
    assert_eq!(row(2.63, 17.45).sand_share_within_sd(), Some(true));
    assert_eq!(row(2.61, 17.45).sand_share_within_sd(), Some(false));
    assert_eq!(row(5.11, 17.45).sand_share_within_sd(), Some(false));
    assert_eq!(row(3.86, 18.68).internal_within_sd(), Some(true));
    assert_eq!(row(3.86, 18.70).internal_within_sd(), Some(false));
    let unmeasured = Row {
        measured: None,
        ..row(3.86, 17.45)
    };
    assert_eq!(unmeasured.sand_share_within_sd(), None);
}

#[test]
fn the_whole_comparison_runs_on_a_tiny_bed() {
    // Coarse grains under a surcharge, a short settling and expansion, the
    // membrane zone matched to twice its own free pressure.
    let case = tiny_balloon();
    let p0 = FreeCurve::of(&case)
        .unwrap()
        .pressure_pa(case.final_diameter_m)
        .unwrap();
    let dir = tempfile::tempdir().unwrap();
    let run = run_cases(
        std::slice::from_ref(&case),
        &[1],
        2.0 * p0,
        Some(dir.path()),
        false,
        &Runner::whole(),
    )
    .unwrap()
    .unwrap();
    print!("{}", run.text());
    assert!((run.free_pressure_pa / (2.0 * p0) - 1.0).abs() <= MATCH_TOLERANCE);
    let row = &run.rows[0];
    let report = &run.ensembles[0].reports[0];
    // The ends held: the head never moved; no advance.
    assert!(report.samples.iter().all(|s| s.head_receding_m == 0.0));
    // Δp_i is p_i less the matched skin's own pressure, and positive.
    let m = report.final_means().unwrap();
    assert_eq!(row.internal_kpa.0, m.internal_pressure_pa * 1e-3);
    assert_eq!(row.sand_share_kpa.0, m.sand_share_pa * 1e-3);
    assert!(row.sand_share_kpa.0 > 0.0 && row.sand_share_kpa.0 < row.internal_kpa.0);
    assert_eq!(row.measured, Some(BALLOON_TABLE[0]));
    // The files: one CSV row per depth, the plot, the depth's ensemble.
    let csv = std::fs::read_to_string(dir.path().join("balloon.csv")).unwrap();
    assert_eq!(csv.lines().count(), 2, "{csv}");
    assert!(csv.lines().nth(1).unwrap().starts_with("40,"));
    let svg = std::fs::read_to_string(dir.path().join("balloon.svg")).unwrap();
    assert!(svg.contains("measured p_i"));
    assert!(dir.path().join("h40mm/ensemble.csv").is_file());
    // Cases with different skins cannot share one matched curve.
    let other = ScenarioSpec {
        final_diameter_m: 24e-3,
        ..case.clone()
    };
    let err = run_cases(
        &[case, other],
        &[1],
        2.0 * p0,
        None,
        false,
        &Runner::whole(),
    )
    .unwrap_err();
    assert!(format!("{err:#}").contains("share one skin"), "{err:#}");
}

/// A tiny bed: coarse grains under a surcharge, a short settling and
/// expansion, the membrane zone inflated as the balloon.
fn tiny_balloon() -> ScenarioSpec {
    ScenarioSpec {
        settle_s: 0.4,
        expansion_s: 0.04,
        frames: 1,
        samples: 10,
        ..ScenarioSpec::quick(40e-3, 2.5e-3)
            .with_surcharge(20e-3, burrow::scenario::SURCHARGE_ROWS)
            .with_membrane()
            .as_balloon()
    }
}

#[test]
fn a_stiffer_skin_takes_a_larger_share_from_the_same_bed() {
    // In small: the sand's share is not the sand's
    // alone. The same seed's bed against the skin matched to its own
    // free pressure and to four times it: 1.55 and 4.06 kPa when written.
    let case = tiny_balloon();
    let p0 = FreeCurve::of(&case)
        .unwrap()
        .pressure_pa(case.final_diameter_m)
        .unwrap();
    let share = |k: f64| {
        let run = run_cases(
            std::slice::from_ref(&case),
            &[1],
            k * p0,
            None,
            false,
            &Runner::whole(),
        )
        .unwrap()
        .unwrap();
        run.rows[0].sand_share_kpa.0
    };
    let (soft, stiff) = (share(1.0), share(4.0));
    assert!(soft > 0.0, "{soft}");
    assert!(stiff > 1.5 * soft, "{soft} kPa soft, {stiff} kPa stiff");
}

#[test]
fn a_rig_sets_the_balloons_sand_and_the_papers_rig_keeps_the_measured_table() {
    use burrow::balloon::BalloonOptions;
    use burrow::solver_sand::RigSetup;
    use rig::Rig;
    let with = |rig: Rig| BalloonOptions {
        rig: Some(RigSetup {
            rig,
            file: "rig.toml".into(),
            final_diameter_mm: None,
        }),
        ..BalloonOptions::paper(1)
    };
    // The paper's set-up given as a rig: the paper's balloon case (but for
    // the provenance and the float of 18.7 × 25/18.7), the table beside it.
    let paper = Rig {
        skin: None,
        ..Rig::paper_default()
    };
    let (spec, notes) = with(paper.clone()).spec(50e-3).unwrap();
    let (plain, none) = BalloonOptions::paper(1).spec(50e-3).unwrap();
    assert!(none.is_empty());
    assert!(notes.iter().any(|n| n.contains("no [skin]")), "{notes:?}");
    assert_eq!(
        ScenarioSpec {
            setup: plain.setup.clone(),
            final_diameter_m: plain.final_diameter_m,
            ..spec.clone()
        },
        plain
    );
    assert!(spec.balloon && spec.head == HeadSupport::Held && spec.advance_m == 0.0);
    assert_eq!(spec.balloon_point(), Some(BALLOON_TABLE[1]));
    // A lighter sand: the user's own balloon, nothing measured beside it.
    let mut light = paper;
    if let Some(s) = &mut light.sand {
        s.grain_density_kg_m3 = 2650.0;
    }
    let (spec, _) = with(light).spec(50e-3).unwrap();
    assert_eq!(spec.grain_density_kg_m3, 2650.0);
    assert!(spec.balloon && spec.balloon_point().is_none());
    // A rig without sand cannot be a balloon in sand.
    let sandless = Rig {
        sand: None,
        ..Rig::paper_default()
    };
    let err = with(sandless).spec(50e-3).unwrap_err();
    assert!(format!("{err:#}").contains("[sand]"), "{err:#}");
}

/// Every file under `dir`, relative, with its bytes.
fn files(dir: &std::path::Path) -> std::collections::BTreeMap<std::path::PathBuf, Vec<u8>> {
    let mut all = std::collections::BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                let rel = p.strip_prefix(dir).unwrap().to_path_buf();
                all.insert(rel, std::fs::read(&p).unwrap());
            }
        }
    }
    all
}

#[test]
fn a_split_run_merges_to_the_same_bits_as_one_machine() {
    // Two depths × two seeds, on one machine and as parts 1/3, 2/3, 3/3
    // (one part with two cases, one with a case of each depth's).
    let case = |h: f64| ScenarioSpec {
        depth_m: h,
        ..tiny_balloon()
    };
    let cases = [case(40e-3), case(50e-3)];
    let p0 = FreeCurve::of(&cases[0])
        .unwrap()
        .pressure_pa(cases[0].final_diameter_m)
        .unwrap();
    let seeds = [1, 2];
    let tmp = tempfile::tempdir().unwrap();
    let whole = tmp.path().join("whole");
    let one = run_cases(
        &cases,
        &seeds,
        2.0 * p0,
        Some(&whole),
        false,
        &Runner::whole(),
    )
    .unwrap()
    .unwrap();
    let command: Vec<String> = ["balloon", "--seeds", "2"].map(String::from).to_vec();
    let mut parts = Vec::new();
    for i in 1..=3 {
        let dir = tmp.path().join(format!("part-{i}"));
        let runner = Runner::new(
            Part::Shard(shard::Shard::new(i, 3).unwrap()),
            Some(&dir),
            command.clone(),
        )
        .unwrap();
        let partial = run_cases(&cases, &seeds, 2.0 * p0, Some(&dir), false, &runner).unwrap();
        assert!(partial.is_none(), "part {i} has only some of the cases");
        assert!(runner
            .finish()
            .unwrap()
            .unwrap()
            .contains("of the command's 4 cases"));
        parts.push(dir);
    }
    // Part 1 holds cases 0 and 3: seed 1 at 40 mm, seed 2 at 50 mm.
    let m = shard::Manifest::read(&parts[0]).unwrap();
    assert_eq!(
        m.cases,
        ["h40mm/seed-1", "h50mm/seed-2"].map(std::path::PathBuf::from)
    );
    let merged = tmp.path().join("merged");
    assert_eq!(shard::assemble(&parts, &merged).unwrap(), command);
    let runner = Runner::new(Part::Merge, Some(&merged), Vec::new()).unwrap();
    let again = run_cases(&cases, &seeds, 2.0 * p0, Some(&merged), false, &runner)
        .unwrap()
        .unwrap();
    assert_eq!(again.rows, one.rows);
    // Every file but the wall times (timing.*), to the byte.
    let (a, b) = (files(&whole), files(&merged));
    assert_eq!(a.keys().collect::<Vec<_>>(), b.keys().collect::<Vec<_>>());
    let mut compared = 0;
    for (path, bytes) in &a {
        if !path
            .file_name()
            .unwrap()
            .to_string_lossy()
            .starts_with("timing.")
        {
            assert!(b[path] == *bytes, "{} differs", path.display());
            compared += 1;
        }
    }
    assert!(compared > 20, "{compared} files");

    // A record of another case is refused by name.
    let record = merged.join("h40mm/seed-1").join(burrow::cases::RECORD);
    std::fs::copy(
        merged.join("h50mm/seed-1").join(burrow::cases::RECORD),
        &record,
    )
    .unwrap();
    let runner = Runner::new(Part::Merge, Some(&merged), Vec::new()).unwrap();
    let e = run_cases(&cases, &seeds, 2.0 * p0, Some(&merged), false, &runner).unwrap_err();
    assert!(format!("{e:#}").contains("another case"), "{e:#}");
}

#[test]
fn the_balloons_floor_box_and_rate_can_be_swept() {
    use burrow::balloon::BalloonOptions;
    let paper = BalloonOptions::paper(1);
    let (base, _) = paper.spec(40e-3).unwrap();
    let swept = BalloonOptions {
        below_m: Some(40e-3),
        box_width_m: Some(80e-3),
        expansion_s: Some(2.0 * base.expansion_s),
        ..paper.clone()
    };
    let (s, _) = swept.spec(40e-3).unwrap();
    assert_eq!(s.below_m, 40e-3);
    // The deeper column settles longer, by the scenario's own rule.
    assert_eq!(
        s.settle_s,
        ScenarioSpec::column_settle_s(40e-3 + base.above_m())
    );
    assert!(s.settle_s > base.settle_s);
    assert_eq!(s.box_width_m, 80e-3);
    assert_eq!(s.expansion_s, 2.0 * base.expansion_s);
    // Still the balloon, and nothing else moved.
    assert!(s.balloon && s.head == HeadSupport::Held);
    assert_eq!(
        ScenarioSpec {
            below_m: base.below_m,
            settle_s: base.settle_s,
            box_width_m: base.box_width_m,
            expansion_s: base.expansion_s,
            ..s
        },
        base
    );
}
