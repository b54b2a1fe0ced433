//! The paper's scenario on a tiny, coarse bed (r = 2.5 mm, a few hundred
//! grains): the settled bed carries its buoyant weight and the surcharge,
//! the sand presses on the resting zone at the overburden's order, and the
//! sand pressure rises as the zone expands to 25 mm.

use host_sim::fem::Ends;
use host_sim::simulate::{simulate, FreeCurve, Options, ScenarioSpec};

#[test]
fn a_tiny_bed_settles_under_its_surcharge_and_pushes_back_on_the_expanding_zone() {
    let spec = ScenarioSpec {
        settle_s: 0.4,
        expansion_s: 0.08,
        frames: 2,
        samples: 20,
        ..ScenarioSpec::quick(40e-3, 2.5e-3).with_surcharge(20e-3, 2)
    };
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
            && csv
                .lines()
                .next()
                .unwrap()
                .ends_with(",head_receding_mm,sand_share_kpa")
    );
    // The sand's share of p_i: positive, less than p_i; the skin's own
    // pressure at 25 mm is the rest.
    let m = report.final_means().unwrap();
    assert!(m.samples >= 1);
    let free = report.free.pressure_pa(last.outer_diameter_m).unwrap();
    assert!(m.sand_share_pa > 0.0 && m.sand_share_pa < m.internal_pressure_pa);
    assert!((last.internal_pressure_pa - report.sand_share_pa(last).unwrap() - free).abs() < 1e-9);
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
    let curve = FreeCurve::of(&spec).unwrap();
    assert_eq!(curve.pressure_pa(18.0e-3), None);
    assert_eq!(curve.pressure_pa(40.0e-3), None);
    // A fresh skin relaxed at p_free(D) reaches D, for D between the
    // curve's relaxed states.
    for d in [21.0e-3, 24.0e-3, 25.0e-3] {
        let p = curve.pressure_pa(d).unwrap();
        let mut skin = spec.skin(Ends::Clamped).unwrap();
        skin.pressure_pa = p;
        skin.relax(1e-7, 400_000).unwrap();
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
fn impossible_cases_are_refused_with_what_is_wrong() {
    let err = |spec: ScenarioSpec| host_sim::simulate::build(&spec).unwrap_err().to_string();
    let e = err(ScenarioSpec::paper(15e-3, 1.5e-3));
    assert!(
        e.contains("depth 15 mm") && e.contains("radius 12.5 mm"),
        "{e}"
    );
    let e = err(ScenarioSpec::paper(40e-3, 0.0));
    assert!(e.contains("grain radius must be positive"), "{e}");
    let e = err(ScenarioSpec::paper(30e-3, 1.5e-3).with_surcharge(40e-3, 2));
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
}
