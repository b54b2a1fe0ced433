//! The paper's scenario on a tiny, coarse bed (r = 2.5 mm, a few hundred
//! grains): the settled bed carries its buoyant weight and the surcharge,
//! the sand presses on the resting zone at the overburden's order, and the
//! sand pressure rises as the zone expands to 25 mm.

use burrow::{simulate, FreeCurve, HeadSupport, Options, ScenarioSpec};
use fem::Ends;
use rig::Rig;

/// A tiny, coarse case at 40 mm (grains of `radius_m`, sand to 20 mm over
/// the axis under a surcharge), settling `settle_s` and expanding over
/// `expansion_s` in `frames` frames, round the membrane skin: the solid
/// wall (the scenario's skin) costs 2.5× as much and has its own
/// test below.
fn tiny(radius_m: f64, settle_s: f64, expansion_s: f64, frames: usize) -> ScenarioSpec {
    ScenarioSpec {
        settle_s,
        expansion_s,
        frames,
        samples: 10 * frames,
        ..ScenarioSpec::quick(40e-3, radius_m)
            .with_surcharge(20e-3, burrow::scenario::SURCHARGE_ROWS)
            .with_membrane()
    }
}

#[test]
fn a_tiny_bed_settles_under_its_surcharge_and_pushes_back_on_the_expanding_zone() {
    let spec = tiny(2.5e-3, 0.4, 0.08, 2);
    let dir = tempfile::tempdir().unwrap();
    let report = simulate(&Options {
        spec: spec.clone(),
        out: Some(dir.path().to_path_buf()),
        progress: false,
    })
    .unwrap();
    print!("{}", report.text());
    let st = report.settled;
    let n = report.grains.0 + report.grains.1;
    assert!(n > 200 && n < 800, "{n} grains");
    // At rest, floor, side walls and skin carry the buoyant weight, the
    // surcharge layer's included (means over the last quarter of settling:
    // the skin rings, single steps scatter by tens of per cent). Measured
    // −4.8 %: the front face's friction, which FrontFace does not report,
    // carries ≈ 3 % (−1.6 % with a frictionless face), the rest is motion.
    let err = st.support_n / st.buoyant_weight_n - 1.0;
    assert!(err < 0.0 && err > -0.05, "support off by {err}");
    let surcharge_n = report.surcharge_pa * spec.box_width_m * spec.slab_length_m();
    assert!(st.floor_force_n > 0.5 * surcharge_n);
    let last = report.last().unwrap();
    assert!(last.outer_diameter_m >= 25e-3 && last.outer_diameter_m < 25.3e-3);
    // The sand on the resting zone: the overburden's order (γ'h = 446 Pa).
    let sigma_v = spec.vertical_stress_at_axis_pa();
    let p_e0 = st.sand_pressure_pa;
    assert!(p_e0 > 0.2 * sigma_v && p_e0 < 3.0 * sigma_v, "{p_e0}");
    // Pushing the sand back costs more than holding it.
    assert!(
        last.sand_pressure_pa > 1.3 * p_e0,
        "{}",
        last.sand_pressure_pa
    );
    assert!(last.internal_pressure_pa > st.sample.internal_pressure_pa);
    assert!(last.max_von_mises_pa > 0.0);
    for f in [
        "samples.csv",
        "pressures.svg",
        "summary.txt",
        "grains.vtk.series",
        "vtk/grains_0002.vtk",
        "vtk/skin_0002.vtk",
    ] {
        assert!(dir.path().join(f).exists(), "{f}");
    }
    let csv = std::fs::read_to_string(dir.path().join("samples.csv")).unwrap();
    assert_eq!(csv.lines().count(), report.samples.len() + 1);
    assert!(
        csv.starts_with("time_s,diameter_mm,")
            && csv.lines().next().unwrap().ends_with(
                ",head_receding_mm,sand_share_kpa,min_caliper_mm,max_caliper_mm,head_pull_n"
            )
    );
    // The calipers bracket D (its ring's mean).
    for s in &report.samples {
        let (lo, hi) = s.calipers_m;
        assert!(lo <= s.outer_diameter_m + 1e-12 && s.outer_diameter_m <= hi + 1e-12);
    }
    // The sand's share of p_i: positive, less than p_i; the skin's own
    // pressure at 25 mm is the rest.
    let m = report.final_means().unwrap();
    assert!(m.samples >= 1);
    let free = report.free.pressure_pa(last.outer_diameter_m).unwrap();
    assert!(m.sand_share_pa > 0.0 && m.sand_share_pa < m.internal_pressure_pa);
    assert!((last.internal_pressure_pa - report.sand_share_pa(last).unwrap() - free).abs() < 1e-9);
    // The swelling zone pushes its drawn head forward: the body pulls it
    // back (a free head would come forward).
    assert!(m.head_pull_n > 0.0, "{}", m.head_pull_n);
    // The head moved with the expansion, by less than a grain.
    assert!(
        m.head_receding_m.abs() < spec.grain_radius_m,
        "{}",
        m.head_receding_m
    );
}

#[test]
fn the_free_skin_curve_is_the_relaxed_skin_without_sand() {
    let spec = ScenarioSpec::paper(40e-3, 1.5e-3);
    assert_eq!(spec.head, HeadSupport::Drawn);
    let law = spec.expansion_head_draw().unwrap();
    let curve = FreeCurve::of(&spec).unwrap();
    assert_eq!(curve.pressure_pa(18.0e-3), None);
    assert_eq!(curve.pressure_pa(40.0e-3), None);
    // A fresh skin with the run's ends (the front ring on the head), its
    // head drawn back by the run's law, relaxed at p_free(D) reaches D,
    // for D between the curve's relaxed states.
    for d in [21.0e-3, 24.0e-3, 25.0e-3] {
        let p = curve.pressure_pa(d).unwrap();
        let mut skin = spec.skin(Ends::Head).unwrap();
        // In steps from rest: the solid wall's end row inverts if the
        // head is drawn back 1 mm at once.
        for k in 1..=8 {
            let f = f64::from(k) / 8.0;
            burrow::free_skin::place_head(&mut skin, f * law.receding_at_m(d));
            skin.pressure_pa = f * p;
            skin.relax(if k < 8 { 1e-5 } else { 1e-7 }, 400_000)
                .unwrap();
        }
        let got = skin.outer_diameter_at_mid_length_m();
        assert!(
            (got - d).abs() < 0.02e-3,
            "{} mm at {p} Pa, want {} mm",
            got * 1e3,
            d * 1e3
        );
    }
}

#[test]
fn the_free_skin_reference_moves_its_head_as_the_run_does() {
    // The membrane zone: the same kinematics at a fraction of the cost.
    let drawn = ScenarioSpec::paper(40e-3, 1.5e-3).with_membrane();
    let law = drawn.expansion_head_draw().unwrap();
    let curve = FreeCurve::of(&drawn).unwrap();
    let states: Vec<(f64, f64, f64)> = curve.states().collect();
    assert!(states.len() > 10, "{} states", states.len());
    for &(d, p, r) in &states {
        // The run's law at the state's own D (the head placement iterated
        // to its fixed point).
        let want = law.receding_at_m(d);
        assert!(
            (r - want).abs() < 1e-3 * law.final_receding_m,
            "D {} mm, p {p} Pa: D_r {r} m, the law's {want} m",
            d * 1e3
        );
    }
    let &(d_end, _, r_end) = states.last().unwrap();
    assert!(
        d_end >= drawn.final_diameter_m && r_end > 1.0e-3,
        "{d_end} {r_end}"
    );
    // Held in the run, held in the reference: the clamped ends of before.
    let held = ScenarioSpec {
        head: HeadSupport::Held,
        ..drawn.clone()
    };
    let held_curve = FreeCurve::of(&held).unwrap();
    assert!(held_curve.states().all(|(_, _, r)| r == 0.0));
    // What the draw changes: the zone, shortened, swells at a lower
    // pressure (here 1380 / 1910 / 2125 Pa drawn against 1423 / 1968 /
    // 2178 Pa held at 22 / 24 / 25 mm, 2.4–3.0 % lower); the reference
    // must be the run's.
    for d in [22e-3, 24e-3, 25e-3] {
        let (a, b) = (
            curve.pressure_pa(d).unwrap(),
            held_curve.pressure_pa(d).unwrap(),
        );
        assert!(a < 0.99 * b, "D {d}: drawn {a} Pa, held {b} Pa");
    }
}

#[test]
fn the_balloon_experiment_is_named_only_for_the_papers_case() {
    let b = ScenarioSpec::paper(70e-3, 1.5e-3).balloon_point().unwrap();
    assert_eq!(
        (b.depth_mm, b.external_pressure_kpa, b.sd_kpa),
        (70.0, 7.24, 1.05)
    );
    assert!(ScenarioSpec::paper(60e-3, 1.5e-3).balloon_point().is_none());
    let wider = ScenarioSpec {
        final_diameter_m: 27e-3,
        ..ScenarioSpec::paper(40e-3, 1.5e-3)
    };
    assert!(wider.balloon_point().is_none());
    let fresh_water = ScenarioSpec {
        water_density_kg_m3: 1000.0,
        ..ScenarioSpec::paper(40e-3, 1.5e-3)
    };
    assert!(fresh_water.balloon_point().is_none());
}

#[test]
fn impossible_cases_are_refused_with_what_is_wrong() {
    let err = |spec: ScenarioSpec| burrow::build(&spec).unwrap_err().to_string();
    let e = err(ScenarioSpec::paper(15e-3, 1.5e-3));
    assert!(
        e.contains("depth 15 mm") && e.contains("radius 12.5 mm"),
        "{e}"
    );
    let e = err(ScenarioSpec::paper(40e-3, 0.0));
    assert!(e.contains("grain radius must be positive"), "{e}");
    let e = err(ScenarioSpec::paper(-5e-3, 1.5e-3));
    assert!(e.contains("depth -5 mm must be positive"), "{e}");
    let e =
        err(ScenarioSpec::paper(30e-3, 1.5e-3)
            .with_surcharge(40e-3, burrow::scenario::SURCHARGE_ROWS));
    assert!(e.contains("depth 30 mm") && e.contains("40 mm"), "{e}");
    let e = err(ScenarioSpec {
        rolling_friction: 2.0,
        ..ScenarioSpec::paper(40e-3, 1.5e-3)
    });
    assert!(e.contains("rolling friction 2"), "{e}");
    let e = err(ScenarioSpec {
        skin_stiffness_scale: 0.0,
        ..ScenarioSpec::paper(40e-3, 1.5e-3)
    });
    assert!(e.contains("skin stiffness scale 0"), "{e}");
    let e = err(ScenarioSpec {
        advance_hold_s: -0.01,
        ..ScenarioSpec::paper(40e-3, 1.5e-3)
    });
    assert!(e.contains("pause after the advance (-0.01 s)"), "{e}");
}

#[test]
fn a_held_head_stays_a_free_one_recoils_and_a_drawn_one_follows_its_law() {
    // The tiny bed, advanced 1 mm into: freed, the loaded face pushes the
    // head back at once (nothing but the skin holds it); held, it does
    // not move at all, and the face keeps bearing on the sand; drawn, it
    // recedes with the square of the swelling, never coming forward.
    let run = |head: HeadSupport| {
        simulate(&Options {
            spec: ScenarioSpec {
                head,
                advance_hold_s: 0.002,
                ..tiny(2.5e-3, 0.4, 0.04, 1)
            },
            out: None,
            progress: false,
        })
        .unwrap()
    };
    let held = run(HeadSupport::Held);
    assert!(held
        .text()
        .contains("1.00 mm advance and a 2.0 ms pause, the head then held"));
    assert!(held.samples.iter().all(|s| s.head_receding_m == 0.0));
    let free = run(HeadSupport::Free);
    let recoil = free
        .samples
        .iter()
        .map(|s| s.head_receding_m)
        .fold(0.0, f64::max);
    assert!(recoil > 0.05e-3, "the free head receded at most {recoil} m");
    // The pause is the same in all: the same start.
    assert_eq!(
        held.samples[0].face_pressure_pa,
        free.samples[0].face_pressure_pa
    );
    let drawn = run(HeadSupport::Drawn);
    assert_eq!(
        drawn.samples[0].face_pressure_pa,
        free.samples[0].face_pressure_pa
    );
    let d0 = drawn.samples[0].outer_diameter_m;
    // The law of D the free-skin reference draws its head by too, from
    // the zone's rest diameter.
    let law = drawn.spec.expansion_head_draw().unwrap();
    assert_eq!(
        law.start_diameter_m,
        drawn.spec.tube.outer_diameter_mm * 1e-3
    );
    assert_eq!(
        Some(law),
        drawn
            .spec
            .head_draw(law.start_diameter_m, drawn.spec.zone_length_m())
    );
    // π² δ² / (4 L) for the paper's zone: δ = (25 − D0) / 2, L = 20 mm.
    let rise = 0.5 * (25e-3 - law.start_diameter_m);
    assert!(
        (law.final_receding_m - 9.8696 * rise * rise / 80e-3).abs() < 1e-6 * law.final_receding_m
    );
    let mut reached = d0;
    for w in drawn.samples.windows(2) {
        assert!(w[1].head_receding_m >= w[0].head_receding_m - 1e-12);
        reached = reached.max(w[1].outer_diameter_m);
        // Where the law put it by the end of the step before the sample:
        // the largest diameter then differs by at most one step's swelling.
        let want = law.receding_at_m(reached);
        assert!(
            (w[1].head_receding_m - want).abs() < 0.02 * law.final_receding_m,
            "D_r {} m against the law's {want} m at {reached} m",
            w[1].head_receding_m
        );
    }
    let last = drawn.samples.last().unwrap();
    assert!(last.head_receding_m > 0.9 * law.receding_at_m(last.outer_diameter_m));
}

#[test]
fn head_supports_read_from_the_command_line() {
    assert_eq!("drawn".parse::<HeadSupport>(), Ok(HeadSupport::Drawn));
    assert_eq!("free".parse::<HeadSupport>(), Ok(HeadSupport::Free));
    assert_eq!("held".parse::<HeadSupport>(), Ok(HeadSupport::Held));
    assert_eq!(
        "0.5".parse::<HeadSupport>(),
        Ok(HeadSupport::DrawnBy(0.5e-3))
    );
    for h in [
        HeadSupport::Drawn,
        HeadSupport::Free,
        HeadSupport::Held,
        HeadSupport::DrawnBy(0.25e-3),
    ] {
        assert_eq!(h.to_string().parse::<HeadSupport>(), Ok(h));
    }
    for bad in ["-1", "nan", "pulled"] {
        let e = bad.parse::<HeadSupport>().unwrap_err();
        assert!(e.contains(bad) && e.contains("drawn, free, held"), "{e}");
    }
}

/// The paper's set-up as a rig.toml with the skin left to the solver's
/// default and the sand the paper's.
fn paper_rig_without_skin() -> Rig {
    Rig {
        skin: None,
        ..Rig::paper_default()
    }
}

#[test]
fn the_papers_rig_gives_the_papers_case() {
    let paper = ScenarioSpec::paper(50e-3, 1.5e-3);
    let (spec, notes) = paper
        .clone()
        .with_rig(&paper_rig_without_skin(), "rig.toml", None)
        .unwrap();
    // Everything but the provenance and the float of 18.7 × 25/18.7.
    assert!((spec.final_diameter_m - 25e-3).abs() < 1e-15);
    assert_eq!(
        ScenarioSpec {
            setup: paper.setup.clone(),
            final_diameter_m: paper.final_diameter_m,
            ..spec.clone()
        },
        paper
    );
    assert_eq!(spec.setup, "rig rig.toml");
    // What the rig says and the solver does not take as given is said.
    for key in [
        "grain_radius_mm = 0.36",
        "porosity = 0.4",
        "no [skin]",
        "water_above_sand_mm",
    ] {
        assert!(notes.iter().any(|n| n.contains(key)), "{key}: {notes:?}");
    }
}

#[test]
fn a_rig_sets_the_actuator_the_sand_the_fluid_and_the_box() {
    let mut rig = paper_rig_without_skin();
    rig.actuator.initial_diameter_mm = 30.0;
    rig.actuator.expansion_length_mm = 28.0;
    rig.actuator.skin_thickness_mm = 2.2;
    rig.skin = Some(rig::Skin {
        c10_kpa: 3.0,
        c20_kpa: 0.5,
        c30_kpa: 0.02,
    });
    let sand = rig.sand.as_mut().unwrap();
    sand.grain_density_kg_m3 = 2650.0;
    sand.friction = 0.5;
    sand.grain_radius_mm = 2.0;
    rig.fluid.density_kg_m3 = 1000.0;
    rig.container = None;
    let r = ScenarioSpec::grain_radius_for(&rig);
    assert_eq!(r, 2.0e-3, "grains coarser than the default are kept");
    let (spec, _) = ScenarioSpec::paper(80e-3, r)
        .with_rig(&rig, "my/rig.toml", None)
        .unwrap();
    assert_eq!(spec.tube.outer_diameter_mm, 30.0);
    assert_eq!(spec.tube.length_mm, 28.0);
    assert_eq!(spec.tube.wall_thickness_mm, 2.2);
    // Measured skin: used as given, no calibration scale.
    assert_eq!(spec.skin_stiffness_scale, 1.0);
    assert_eq!(spec.skin_law().unwrap().yeoh().unwrap().c20_kpa, 0.5);
    assert!((spec.final_diameter_m - 30e-3 * 25.0 / 18.7).abs() < 1e-15);
    // A wide tank: 3 final diameters, frictionless sides.
    assert!((spec.box_width_m - 3.0 * spec.final_diameter_m).abs() < 1e-15);
    assert_eq!(spec.wall_friction, 0.0);
    assert_eq!(spec.friction, 0.5);
    // γ' = 0.56 (2650 − 1000) 9.81 N/m³.
    let g = 0.56 * 1650.0 * constants::GRAVITY_M_S2;
    assert!((spec.buoyant_unit_weight_n_m3() - g).abs() < 1e-9);
    // The skin the solver builds is the rig's tube.
    let skin = spec.skin(Ends::Clamped).unwrap();
    assert!((skin.outer_diameter_at_mid_length_m() - 30e-3).abs() < 1e-9);
    // The sand ahead scales with a larger head, the floor with the zone.
    assert!((spec.ahead_m - 24e-3).abs() < 1e-15);
    assert!((spec.below_m - (0.5 * spec.final_diameter_m + 7.5e-3)).abs() < 1e-15);
}

#[test]
fn a_thick_walled_rig_keeps_the_solid_wall_and_a_thin_walled_one_gets_the_membrane() {
    // The paper's wall is 0.19 of its outer radius: the solid wall.
    let (spec, notes) = ScenarioSpec::paper(40e-3, 1.5e-3)
        .with_rig(&paper_rig_without_skin(), "rig.toml", None)
        .unwrap();
    assert_eq!(spec.skin_kind.layers(), 2);
    assert!(!notes.iter().any(|n| n.contains("the skin is the membrane")));
    // A balloon-like 0.4 mm wall on 18.7 mm: 0.043, a membrane, said so.
    let mut rig = paper_rig_without_skin();
    rig.actuator.skin_thickness_mm = 0.4;
    let (spec, notes) = ScenarioSpec::paper(40e-3, 1.5e-3)
        .with_rig(&rig, "thin/rig.toml", None)
        .unwrap();
    assert_eq!(
        (spec.skin_kind.layers(), spec.skin_mesh, spec.skin_end_row_m),
        (0, burrow::scenario::MEMBRANE_MESH, None)
    );
    assert!(
        notes.iter().any(
            |n| n.starts_with("thin/rig.toml: [actuator] skin_thickness_mm = 0.4")
                && n.contains("the skin is the membrane")
        ),
        "{notes:?}"
    );
}

#[test]
fn a_rig_that_cannot_be_simulated_is_refused_naming_the_file_and_key() {
    let base = ScenarioSpec::paper(40e-3, 1.5e-3);
    let msg = |rig: &Rig, final_m: Option<f64>| {
        format!(
            "{:#}",
            base.clone()
                .with_rig(rig, "lab/rig.toml", final_m)
                .unwrap_err()
        )
    };
    let no_sand = Rig {
        sand: None,
        ..paper_rig_without_skin()
    };
    let e = msg(&no_sand, None);
    assert!(e.contains("lab/rig.toml") && e.contains("[sand]"), "{e}");
    let e = msg(&paper_rig_without_skin(), Some(18.0e-3));
    assert!(
        e.contains("lab/rig.toml") && e.contains("initial_diameter_mm = 18.7"),
        "{e}"
    );
    let mut floating = paper_rig_without_skin();
    floating.sand.as_mut().unwrap().grain_density_kg_m3 = 900.0;
    let e = msg(&floating, None);
    assert!(e.contains("lab/rig.toml") && e.contains("float"), "{e}");
    let mut narrow = paper_rig_without_skin();
    narrow.container.as_mut().unwrap().width_mm = Some(26.0);
    let e = msg(&narrow, None);
    assert!(e.contains("box width 26.0 mm"), "{e}");
}

#[test]
fn a_tiny_bed_of_another_rig_carries_its_own_buoyant_weight() {
    // Another actuator (D0 24 mm) in lighter grains in fresh water; the
    // settled bed must carry N·(4/3)πr³(ρs − ρw)g from the rig's numbers.
    let mut rig = paper_rig_without_skin();
    rig.actuator.initial_diameter_mm = 24.0;
    let sand = rig.sand.as_mut().unwrap();
    sand.grain_density_kg_m3 = 2650.0;
    rig.fluid.density_kg_m3 = 1000.0;
    rig.container.as_mut().unwrap().width_mm = Some(50.0);
    let r = 2.5e-3;
    let base = ScenarioSpec {
        settle_s: 0.4,
        expansion_s: 0.08,
        frames: 1,
        samples: 10,
        // The membrane, as the other tiny beds: the bed's weight is the point.
        ..ScenarioSpec::quick(45e-3, r).with_membrane()
    };
    let (spec, _) = base.with_rig(&rig, "rig.toml", None).unwrap();
    let spec = spec.with_surcharge(25e-3, burrow::scenario::SURCHARGE_ROWS);
    let report = simulate(&Options {
        spec: spec.clone(),
        out: None,
        progress: false,
    })
    .unwrap();
    let text = report.text();
    assert!(
        text.contains("rig rig.toml") && text.contains("zone 24 → 32.09 mm"),
        "{text}"
    );
    assert!(!text.contains("paper (4 cm)"), "{text}");
    let st = report.settled;
    let slab_weight = report.grains.0 as f64 * 4.0 / 3.0
        * std::f64::consts::PI
        * r.powi(3)
        * (2650.0 - 1000.0)
        * constants::GRAVITY_M_S2;
    let surcharge_n = report.surcharge_pa * spec.box_width_m * spec.slab_length_m();
    let want = slab_weight + surcharge_n;
    assert!(
        (st.buoyant_weight_n / want - 1.0).abs() < 1e-9,
        "{} vs {want}",
        st.buoyant_weight_n
    );
    let err = st.support_n / want - 1.0;
    assert!(err < 0.0 && err > -0.06, "support off by {err}");
    // The rig's zone rests at its D0 and expands to 24 × 25/18.7 mm.
    assert!((st.sample.outer_diameter_m - 24e-3).abs() < 1.5e-3);
    let last = report.last().unwrap();
    assert!(last.outer_diameter_m >= spec.final_diameter_m);
}

#[test]
fn an_ensemble_reports_each_seeds_run_and_their_mean_and_sd() {
    use burrow::Ensemble;
    let spec = tiny(3e-3, 0.25, 0.05, 1);
    let dir = tempfile::tempdir().unwrap();
    let e = Ensemble::run(&spec, &[4, 5], Some(dir.path()), false).unwrap();
    let seeds: Vec<u64> = e.reports.iter().map(|r| r.spec.seed).collect();
    assert_eq!(seeds, [4, 5]);
    let p_i: Vec<f64> = e
        .reports
        .iter()
        .map(|r| r.final_means().unwrap().internal_pressure_pa * 1e-3)
        .collect();
    // Another lattice jitter is another bed: the runs differ.
    assert_ne!(p_i[0], p_i[1]);
    let m = e
        .metrics()
        .into_iter()
        .find(|m| m.name == "final_p_i_kpa")
        .unwrap();
    assert_eq!(m.values, p_i);
    assert!((m.mean() - 0.5 * (p_i[0] + p_i[1])).abs() < 1e-12);
    // Two values: SD = |a − b| / √2.
    assert!((m.sd() - (p_i[0] - p_i[1]).abs() / 2f64.sqrt()).abs() < 1e-12);
    let csv = std::fs::read_to_string(dir.path().join("ensemble.csv")).unwrap();
    let rows: Vec<&str> = csv.lines().collect();
    assert_eq!(rows.len(), 5, "{csv}");
    assert!(rows[0].starts_with("seed,") && rows[0].contains("final_p_i_kpa"));
    assert!(rows[0].contains("final_min_caliper_mm,final_max_caliper_mm"));
    // The last sample's calipers, per run.
    let hi = e
        .metrics()
        .into_iter()
        .find(|m| m.name == "final_max_caliper_mm")
        .unwrap();
    for (v, r) in hi.values.iter().zip(&e.reports) {
        assert_eq!(*v, r.last().unwrap().calipers_m.1 * 1e3);
    }
    assert!(
        rows[1].starts_with("4,") && rows[3].starts_with("mean,") && rows[4].starts_with("sd,")
    );
    for f in ["seed-4/samples.csv", "seed-5/summary.txt", "ensemble.txt"] {
        assert!(dir.path().join(f).exists(), "{f}");
    }
    let svg = std::fs::read_to_string(dir.path().join("ensemble.svg")).unwrap();
    assert!(
        svg.starts_with("<svg") && svg.contains("mean ± SD"),
        "{}",
        &svg[..200.min(svg.len())]
    );
}

#[test]
fn a_face_block_of_finer_grains_fills_the_front_of_the_head() {
    let spec = ScenarioSpec {
        face_grain_radius_m: Some(0.75e-3),
        ..ScenarioSpec::paper(40e-3, 1.5e-3)
    };
    // The time step and the Verlet skin follow the finest grains.
    assert_eq!(spec.dt_s(), 0.5 * ScenarioSpec::paper(40e-3, 1.5e-3).dt_s());
    let bed = burrow::build(&spec).unwrap();
    assert!((bed.params.skin_m - 0.15e-3).abs() < 1e-15);
    let p = &bed.state.particles;
    let zone_m = bed.coupling.skin.spec.length_m;
    let (lo, hi) = spec.face_block_m(zone_m, 9.35e-3).unwrap();
    let fine: Vec<usize> = (0..p.len()).filter(|&i| p.radius_m[i] == 0.75e-3).collect();
    assert!(fine.len() > 1000, "{} fine grains", fine.len());
    for &i in &fine {
        let x = p.position_m[i];
        let jitter = 0.04 * 0.75e-3;
        assert!(
            (0..3).all(|a| x[a] >= lo[a] - jitter && x[a] <= hi[a] + jitter),
            "fine grain {i} at {x:?} outside the block"
        );
    }
    // The block sits in front of the face, within the face's reach.
    assert!(lo.z > zone_m && hi.z <= zone_m + 9.35e-3 + 1e-12);
    // No grain overlaps another at the start (fine–coarse boundary included).
    let n = p.len();
    for i in 0..n {
        for j in i + 1..n {
            let d = (p.position_m[i] - p.position_m[j]).norm();
            assert!(d >= p.radius_m[i] + p.radius_m[j], "{i} and {j} overlap");
        }
    }
    // The solid volume is the packing's share of the slab, as one size.
    let solid: f64 = p
        .radius_m
        .iter()
        .map(|r| 4.0 / 3.0 * std::f64::consts::PI * r.powi(3))
        .sum();
    let one_size = burrow::build(&ScenarioSpec::paper(40e-3, 1.5e-3)).unwrap();
    let solid_one: f64 = one_size
        .state
        .particles
        .radius_m
        .iter()
        .map(|r| 4.0 / 3.0 * std::f64::consts::PI * r.powi(3))
        .sum();
    assert!(
        (solid / solid_one - 1.0).abs() < 0.005,
        "{solid} vs {solid_one}"
    );
    // A face radius not below the grain radius is refused.
    let e = burrow::build(&ScenarioSpec {
        face_grain_radius_m: Some(1.5e-3),
        ..ScenarioSpec::paper(40e-3, 1.5e-3)
    })
    .unwrap_err()
    .to_string();
    assert!(e.contains("face grain radius 1.5 mm"), "{e}");
}

#[test]
fn the_advance_carries_head_and_zone_together_and_loads_the_face() {
    use burrow::run;
    let spec = tiny(
        2.5e-3,
        0.3,
        ScenarioSpec::quick(40e-3, 2.5e-3).expansion_s,
        1,
    );
    assert_eq!(spec.advance_m, 1e-3, "the paper's advance per cycle");
    let mut bed = burrow::build(&spec).unwrap();
    let bar = run::progress_bar(false).unwrap();
    let settled = run::settle(&mut bed, &bar).unwrap();
    let head0 = bed.coupling.skin.head.unwrap().displacement_m;
    let zone_m = bed.coupling.skin.spec.length_m;
    run::advance(&mut bed, &bar).unwrap();
    let skin = &bed.coupling.skin;
    let head = skin.head.unwrap();
    // Head and back ring moved by the advance (the drive's steps × dt).
    assert!(
        (head.displacement_m - head0 - 1e-3).abs() < 1e-9,
        "{}",
        head.displacement_m - head0
    );
    assert!((skin.body_displacement_m - 1e-3).abs() < 1e-9);
    assert_eq!(head.driven_m_s, None, "the head is free again");
    // The zone kept its length: the ends are the settled gap apart.
    let z = |j: usize| {
        let ring = skin.mesh.ring(j);
        ring.clone().map(|a| skin.position_m[a].z).sum::<f64>() / ring.len() as f64
    };
    assert!((z(skin.mesh.along) - z(0) - (zone_m + head0)).abs() < 1e-9);
    // Pushing into the sand loads the face well above the bed at rest.
    let p_h = bed.coupling.face.as_ref().unwrap().pressure_pa();
    assert!(
        p_h > 2.0 * settled.face_pressure_pa,
        "{p_h} Pa after the advance vs {} Pa settled",
        settled.face_pressure_pa
    );
}

#[test]
fn the_bed_settles_soft_and_is_stiffened_for_the_advance_and_expansion() {
    use burrow::scenario::{skin_material, wall};
    use dem::contact::{ContactModel, Normal, Tangential};
    let spec = ScenarioSpec::paper(40e-3, 1.5e-3);
    assert_eq!(spec.grain_modulus_pa, 10.0 * spec.deposition_modulus_pa);
    // The Rayleigh time goes as 1/√E: four times stiffer, half the step.
    let four = ScenarioSpec {
        grain_modulus_pa: 4.0 * spec.deposition_modulus_pa,
        ..spec.clone()
    };
    assert_eq!(four.dt_s(), 0.5 * four.settle_dt_s());
    assert!((spec.settle_dt_s() / spec.dt_s() - 10f64.sqrt()).abs() < 1e-12);

    let e_star = |m: &ContactModel| match m.normal {
        Normal::Hertz(h) => h.effective_modulus_pa,
        Normal::None(_) => panic!("Hertz contacts"),
    };
    let friction = |m: &ContactModel| match m.tangential {
        Tangential::Mindlin(t) => t.friction,
        Tangential::None(_) => panic!("Mindlin contacts"),
    };
    // Every law of the bed against grains of modulus `e_pa` and step `dt`.
    let check = |bed: &burrow::scenario::Bed, e_pa: f64, dt: f64| {
        // E* of two equal grains: E / (2 (1 − ν²)), ν = 0.3.
        let grains = e_pa / (2.0 * (1.0 - 0.09));
        let face = bed.coupling.face.as_ref().expect("the head's face");
        let mut laws = vec![&bed.params.pair_model, &face.model];
        laws.extend(bed.params.walls.iter().map(|w| &w.model));
        for m in laws {
            assert!((e_star(m) / grains - 1.0).abs() < 1e-12, "{m:?}");
        }
        let sand = dem::contact::Material {
            youngs_modulus_pa: e_pa,
            poisson_ratio: 0.3,
            density_kg_m3: spec.grain_density_kg_m3,
        };
        let skin = sand.effective_modulus_pa(&skin_material(&spec.skin_law().unwrap()));
        assert!((e_star(&bed.coupling.model) / skin - 1.0).abs() < 1e-12);
        assert_eq!(
            (bed.params.dt_s, bed.coupling.dt_s, face.dt_s),
            (dt, dt, dt)
        );
        // The frictions stay the scenario's: smooth floor, rough sides.
        assert_eq!(friction(&bed.params.pair_model), spec.friction);
        assert_eq!(friction(&bed.params.walls[wall::FLOOR].model), 0.0);
        assert_eq!(
            friction(&bed.params.walls[wall::SIDE_POS_X].model),
            spec.wall_friction
        );
    };
    let mut bed = burrow::build(&spec).unwrap();
    check(&bed, spec.deposition_modulus_pa, spec.settle_dt_s());
    bed.set_grain_modulus(spec.grain_modulus_pa).unwrap();
    check(&bed, spec.grain_modulus_pa, spec.dt_s());
    assert!(bed.set_grain_modulus(-1.0).is_err());

    let bad = ScenarioSpec {
        deposition_modulus_pa: 0.0,
        ..spec
    };
    let Err(err) = burrow::build(&bad) else {
        panic!("a zero deposition modulus is refused")
    };
    assert!(err.to_string().contains("deposition modulus"), "{err:#}");
}

#[test]
fn the_shell_skin_bends_where_it_leaves_the_body_and_the_head() {
    // The paper's zone inflated with no sand to D ≈ 25 mm, as a membrane
    // and as the shell of `with_shell`. The shell's rows are fine at the
    // clamped ends; its largest stress is on an end row's surface, where
    // the skin turns from the body's axis into the bulge (linear theory:
    // about twice the hoop stress away from the ends, fem.rs); the
    // membrane's is a mid-surface stress at mid-length.
    let membrane_spec = ScenarioSpec::paper(40e-3, 1.5e-3);
    let shell_spec = membrane_spec.clone().with_shell();
    assert!(!membrane_spec.skin_kind.is_shell() && shell_spec.skin_kind.is_shell());
    let mut peaks = Vec::new();
    for spec in [&membrane_spec, &shell_spec] {
        let mut skin = spec.skin(Ends::Clamped).unwrap();
        let rows = skin.mesh.along;
        skin.pressure_pa = 2.2e3;
        skin.relax(1e-7, 400_000).unwrap();
        let d = skin.outer_diameter_at_mid_length_m();
        assert!((24.0e-3..26.5e-3).contains(&d), "{d}");
        let vm = skin.von_mises_pa().unwrap();
        let (k, peak) = vm
            .iter()
            .enumerate()
            .fold((0, 0.0), |a, (k, &v)| if v > a.1 { (k, v) } else { a });
        let row = k / (2 * skin.mesh.around);
        println!(
            "{rows} rows: D {:.2} mm, max von Mises {:.4} MPa in row {row}",
            d * 1e3,
            peak * 1e-6
        );
        if spec.skin_kind.is_shell() {
            assert!((skin.mesh.row_m(0) / burrow::scenario::SKIN_END_ROW_M - 1.0).abs() < 0.15);
            assert!(row == 0 || row == rows - 1, "row {row} of {rows}");
        } else {
            assert!(row > 0 && row < rows - 1, "row {row} of {rows}");
        }
        peaks.push(peak);
    }
    assert!(peaks[1] > 1.3 * peaks[0], "{peaks:?}");
}

#[test]
fn a_solid_skin_recoils_less_than_the_membrane_and_touches_the_sand_with_its_outer_face() {
    // The tiny bed advanced into, the head then freed, with the membrane
    // and with the solid wall of `with_solid`. A membrane has no stiffness
    // in compression, so the loaded face pushes the free head back at once; the
    // solid wall resists as a tube does and the head recedes about half as
    // far (0.46–0.54× as the skin's step and the settling's mass scaling
    // changed the bed's last bits). Both touch the sand as they swell.
    let run = |layers: usize| {
        let spec = ScenarioSpec {
            head: HeadSupport::Free,
            ..tiny(2.5e-3, 0.4, 0.04, 1)
        };
        // One layer on a coarse uniform mesh: the case's graded mesh is
        // for the fold at the clamp, not needed here, and ten times slower.
        let spec = if let Some(layers) = std::num::NonZeroUsize::new(layers) {
            ScenarioSpec {
                skin_mesh: (16, 4),
                skin_end_row_m: None,
                ..spec.with_solid(layers)
            }
        } else {
            spec
        };
        simulate(&Options {
            spec,
            out: None,
            progress: false,
        })
        .unwrap()
    };
    let recoil = |r: &burrow::Report| {
        r.samples
            .iter()
            .map(|s| s.head_receding_m)
            .fold(0.0, f64::max)
    };
    let membrane = run(0);
    let solid = run(1);
    assert!(solid.text().contains("skin: solid wall 1 hexahedron thick"));
    let (rm, rs) = (recoil(&membrane), recoil(&solid));
    println!("largest D_r: membrane {rm:.2e} m, solid {rs:.2e} m");
    assert!(rm > 0.05e-3 && rs < 0.6 * rm, "membrane {rm}, solid {rs}");
    let last = solid.samples.last().unwrap();
    assert!(last.contacts > 0 && last.sand_pressure_pa > 0.0);
    assert!(last.outer_diameter_m > 24e-3, "{}", last.outer_diameter_m);
    assert!(last.max_von_mises_pa > 0.0 && last.max_bending_strain.is_none());
}

/// `--skin-fit`: a Gent law from fit-skin's report replaces the paper's
/// calibrated default skin (scale 1, a note saying so) and a rig's Yeoh
/// `[skin]` (a warning naming both); the FEM skin is built of it, and the
/// case's key (its `Debug`) names the law.
#[test]
fn a_skin_fit_replaces_the_papers_skin_and_a_rigs() {
    use burrow::settings::SimulateSettings;
    use skin::{SkinFitChoice, StrainEnergy};
    let dir = tempfile::tempdir().unwrap();
    let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../data/skin/unicinctus_circumferential.csv");
    let fit = skin::report::fit_skin(&data, dir.path()).unwrap();
    let choice = SkinFitChoice {
        file: fit.json_path.clone(),
        law: Some("Gent".into()),
    };
    let gent = fit.report.fit("Gent").unwrap().parameters.clone();
    let settings = SimulateSettings {
        depth_mm: 40.0,
        seeds: 1,
        skin_fit: Some(choice.clone()),
        out: dir.path().join("out"),
        ..SimulateSettings::default()
    };
    let plan = settings.plan().unwrap();
    let law = plan.spec.skin_law().unwrap();
    assert_eq!((law.name(), law.parameters()), ("Gent", gent.clone()));
    assert_eq!(plan.spec.skin_stiffness_scale, 1.0);
    assert!(
        plan.notes.iter().any(|n| n.contains("the Gent coupon fit")),
        "{:?}",
        plan.notes
    );
    assert!(format!("{:?}", plan.spec).contains("skin_coefficients: Some(Gent { mu_kpa: "));
    let skin = plan.spec.skin(Ends::Clamped).unwrap();
    assert_eq!(skin.law.name(), "Gent");

    // A rig with a [skin]: replaced, and the warning names both laws.
    let rig_file = dir.path().join("rig.toml");
    std::fs::write(&rig_file, Rig::paper_default().to_toml().unwrap()).unwrap();
    let plan = SimulateSettings {
        rig: Some(rig_file),
        ..settings
    }
    .plan()
    .unwrap();
    assert_eq!(plan.spec.skin_law().unwrap().parameters(), gent);
    assert!(
        plan.warnings
            .iter()
            .any(|w| w.contains("[skin] (Yeoh c10_kpa = 2") && w.contains("Gent mu_kpa")),
        "{:?}",
        plan.warnings
    );
}
