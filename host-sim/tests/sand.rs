//! The solver-fed sand law (issue 5 item 6): the stored data file's
//! reader and its errors, interpolation in D and h against hand values,
//! K held outside the stored depths, monotone loading, the unloading rule
//! shared with the parametric law, the binning of solver samples, and the
//! committed data file itself.

use std::path::Path;

use host_sim::sand::regenerate::{
    bin_samples, csv_text, run_depth, spec, Bin, DepthRun, RegenerateOptions,
};
use host_sim::sand::solver::{SolverSandError, DATA_PATH, UNIT_WEIGHT_KEY};
use host_sim::sand::{ParametricSand, SandHistory, SandLaw, SolverSand};

/// A data file with γ' = 0.01 kPa/mm: line 1 the unit weight, line 2 the
/// header, rows from line 3.
fn parse(rows: &str) -> Result<SolverSand, SolverSandError> {
    let text = format!("# {UNIT_WEIGHT_KEY} = 0.01\ndepth_mm,diameter_mm,p_e_kpa,samples\n{rows}");
    SolverSand::parse(&text, "hand.csv")
}

fn assert_rejected(text: &str, line: u64, field: &str) {
    let e = SolverSand::parse(text, "bad.csv").unwrap_err();
    assert_eq!(
        (e.file.as_str(), e.line, e.field.as_str()),
        ("bad.csv", line, field),
        "{e}"
    );
    let shown = e.to_string();
    assert!(
        shown.starts_with(&format!("bad.csv:{line}: {field}: ")),
        "{shown}"
    );
}

const HEAD: &str =
    "# buoyant_unit_weight_kpa_per_mm = 0.01\ndepth_mm,diameter_mm,p_e_kpa,samples\n";

#[test]
fn reader_rejects_bad_input_naming_file_line_and_field() {
    // A missing column: the header line.
    assert_rejected(
        "# buoyant_unit_weight_kpa_per_mm = 0.01\n# run = quick\ndepth_mm,diameter_mm,p_e_kpa\n40,19,0.2\n",
        3,
        "samples",
    );
    // Not a number.
    assert_rejected(
        &format!("{HEAD}40,19,0.2,3\n40,abc,0.3,3\n"),
        4,
        "diameter_mm",
    );
    // Not finite.
    assert_rejected(&format!("{HEAD}40,19,0.2,3\n40,20,NaN,3\n"), 4, "p_e_kpa");
    assert_rejected(&format!("{HEAD}inf,19,0.2,3\n"), 3, "depth_mm");
    // Negative pressure.
    assert_rejected(&format!("{HEAD}40,19,0.2,3\n40,20,-0.1,3\n"), 4, "p_e_kpa");
    // Diameter not increasing within a depth (equal, then smaller).
    assert_rejected(
        &format!("{HEAD}40,19,0.2,3\n40,19,0.3,3\n"),
        4,
        "diameter_mm",
    );
    assert_rejected(
        &format!("{HEAD}40,19,0.2,3\n40,20,0.3,3\n40,19.5,0.3,3\n"),
        5,
        "diameter_mm",
    );
    // Fewer than 2 rows at a depth: the line of that depth's row.
    assert_rejected(
        &format!("{HEAD}40,19,0.2,3\n40,20,0.3,3\n70,19,0.4,3\n"),
        5,
        "depth_mm",
    );
    // No depths at all: the header line.
    assert_rejected(HEAD, 2, "depth_mm");
    // Depths out of order.
    assert_rejected(
        &format!("{HEAD}70,19,0.2,3\n70,20,0.3,3\n40,19,0.4,3\n"),
        5,
        "depth_mm",
    );
    // A bin without samples, or a fractional count.
    assert_rejected(&format!("{HEAD}40,19,0.2,0\n40,20,0.3,3\n"), 3, "samples");
    assert_rejected(&format!("{HEAD}40,19,0.2,2.5\n40,20,0.3,3\n"), 3, "samples");
    // The unit weight: missing (reported at the header), or not usable.
    assert_rejected(
        "depth_mm,diameter_mm,p_e_kpa,samples\n40,19,0.2,3\n40,20,0.3,3\n",
        1,
        UNIT_WEIGHT_KEY,
    );
    assert_rejected(
        "# note: K = p_e / sigma\n# buoyant_unit_weight_kpa_per_mm = -1\ndepth_mm,diameter_mm,p_e_kpa,samples\n40,19,0.2,3\n40,20,0.3,3\n",
        2,
        UNIT_WEIGHT_KEY,
    );
    // A missing file names its path.
    let e = SolverSand::load(Path::new("/nonexistent/solver-pe.csv")).unwrap_err();
    assert!(
        format!("{e:#}").contains("/nonexistent/solver-pe.csv"),
        "{e:#}"
    );
}

/// Two depths by hand (γ' = 0.01 kPa/mm):
/// h = 40 mm (σ'v 0.4 kPa): D 19, 20, 21 → p_e 0.2, 0.4, 0.5 → K 0.5, 1.0, 1.25;
/// h = 80 mm (σ'v 0.8 kPa): D 19, 21 → p_e 0.48, 1.6 → K 0.6, 2.0.
fn two_depths() -> SolverSand {
    parse("40,19,0.2,4\n40,20,0.4,4\n40,21,0.5,4\n80,19,0.48,5\n80,21,1.6,5\n").unwrap()
}

#[test]
fn interpolation_in_d_and_h_is_exact_against_hand_values() {
    let sand = two_depths();
    assert_eq!(sand.unit_weight_kpa_per_mm(), 0.01);
    let at = |d: f64, h: f64| sand.loading_pressure_kpa(d, h);
    let close = |a: f64, b: f64| assert!((a - b).abs() < 1e-12, "{a} vs {b}");
    // The stored rows come back.
    close(at(19.0, 40.0), 0.2);
    close(at(20.0, 40.0), 0.4);
    close(at(21.0, 80.0), 1.6);
    // Between rows: K40(20.5) = 1.125 → 0.45 kPa.
    close(at(20.5, 40.0), 0.45);
    // Between depths, h = 60: K40(20) = 1.0, K80(20) = 1.3, t = 0.5 →
    // K = 1.15, σ'v = 0.6 → 0.69 kPa.
    close(at(20.0, 60.0), 0.69);
    // h = 50, D = 19.5: K40 = 0.75, K80 = 0.95, t = 0.25 → 0.8 × 0.5 = 0.4.
    close(at(19.5, 50.0), 0.4);
    // Past the last row: held (K40 = 1.25, K80 = 2.0).
    close(at(23.0, 40.0), 0.5);
    close(at(23.0, 60.0), 1.625 * 0.6);
}

#[test]
fn coefficient_is_held_outside_the_stored_depths() {
    let sand = two_depths();
    for d in [19.0, 19.7, 20.0, 21.0, 22.0] {
        // Below 40 mm: K of 40 mm, so p_e ∝ h down to the surface.
        let k40 = sand.loading_coefficient(d, 40.0);
        for h in [0.5, 10.0, 20.0, 39.9] {
            assert_eq!(sand.loading_coefficient(d, h), k40);
            let want = k40 * 0.01 * h;
            assert!((sand.loading_pressure_kpa(d, h) - want).abs() < 1e-12);
        }
        // Beyond 80 mm: K of 80 mm.
        let k80 = sand.loading_coefficient(d, 80.0);
        for h in [80.1, 150.0, 200.0] {
            assert_eq!(sand.loading_coefficient(d, h), k80);
            let want = k80 * 0.01 * h;
            assert!((sand.loading_pressure_kpa(d, h) - want).abs() < 1e-12);
        }
    }
    // No sand, no pressure.
    assert_eq!(sand.loading_pressure_kpa(21.0, 0.0), 0.0);
}

#[test]
fn loading_is_monotone_through_a_dip_in_the_data() {
    // K 0.5, 1.25, 0.75 (a dip), 1.5 at σ'v = 0.4 kPa: the dip is read as
    // the running max, 1.25.
    let sand = parse("40,19,0.2,3\n40,20,0.5,3\n40,21,0.3,3\n40,22,0.6,3\n").unwrap();
    let curve = &sand.curves()[0];
    let want = [0.5, 1.25, 1.25, 1.5];
    assert!(
        curve
            .coefficients
            .iter()
            .zip(want)
            .all(|(k, w)| (k - w).abs() < 1e-12),
        "{:?}",
        curve.coefficients
    );
    assert_eq!(curve.pressures_kpa, [0.2, 0.5, 0.3, 0.6]);
    let at = |d: f64| sand.loading_pressure_kpa(d, 40.0);
    assert!((at(21.0) - 0.5).abs() < 1e-12);
    // Half-way from 21 to 22: K = 1.375 → 0.55 kPa.
    assert!((at(21.5) - 0.55).abs() < 1e-12);
    let sweep: Vec<f64> = (0..=40).map(|i| at(18.5 + 0.1 * f64::from(i))).collect();
    assert!(sweep.windows(2).all(|w| w[1] >= w[0]), "{sweep:?}");
}

#[test]
fn unloading_and_fresh_cycles_are_the_parametric_laws_rule() {
    // The solver data are the parametric law's own loading branch at h =
    // 50 mm (printed so they read back exactly), with its γ'.
    let param = ParametricSand::calibrated_to_balloon();
    let g = param.params.buoyant_unit_weight_kpa_per_mm();
    let mut text = format!("# {UNIT_WEIGHT_KEY} = {g}\ndepth_mm,diameter_mm,p_e_kpa,samples\n");
    for d in [18.7, 19.5, 20.5, 21.0, 22.0] {
        let p = param.loading_pressure_kpa(d, 50.0);
        text.push_str(&format!("50,{d},{p},5\n"));
    }
    let solver = SolverSand::parse(&text, "same.csv").unwrap();
    assert_eq!(solver.unloading(), param.unloading());
    // Both cycles start at rest at D0 = 18.7 mm with K0 = 0.5.
    let (hs, hp) = (solver.fresh_cycle(), param.fresh_cycle());
    assert_eq!(hs.peak_diameter_mm, hp.peak_diameter_mm);
    assert!((hs.peak_coefficient - hp.peak_coefficient).abs() < 1e-12);
    // Load both to a stored diameter, then shrink, hit the floor, regrow
    // below the peak: the same pressures at every step.
    let (mut hs, mut hp) = (hs, hp);
    for d in [19.5, 21.0, 20.9, 20.5, 19.0, 18.7, 20.95, 21.0] {
        let s = solver.external_pressure_kpa(&mut hs, d, 50.0);
        let p = param.external_pressure_kpa(&mut hp, d, 50.0);
        assert!((s - p).abs() < 1e-12, "D = {d}: {s} vs {p}");
        assert_eq!(hs.peak_diameter_mm, hp.peak_diameter_mm);
    }
    // The floor was reached: Ka·σ'v at D0.
    let mut h = SandHistory::at_rest(21.0, param.loading_coefficient(21.0));
    let floor = solver.external_pressure_kpa(&mut h, 18.7, 50.0);
    assert!((floor - param.params.active_coefficient * g * 50.0).abs() < 1e-12);
}

#[test]
fn binning_gives_the_mean_of_each_bins_samples() {
    let points = [
        (18.70, 1.0),
        (18.80, 3.0), // bin 0 [18.70, 18.95): D 18.75, p 2
        (19.00, 5.0), // bin 1 [18.95, 19.20): D 19.00, p 5; bin 2 empty
        (19.50, 9.0),
        (19.60, 11.0),  // bin 3 [19.45, 19.70): D 19.55, p 10
        (19.72, 100.0), // past the last bin (end 19.65 is in bin 3)
        (18.60, 50.0),  // before the first
        (f64::NAN, 1.0),
    ];
    let bins = bin_samples(&points, 18.7, 19.65, 0.25);
    let want = [(18.75, 2.0, 2), (19.0, 5.0, 1), (19.55, 10.0, 2)];
    assert_eq!(bins.len(), want.len(), "{bins:?}");
    for (b, (d, p, n)) in bins.iter().zip(want) {
        assert!(
            (b.diameter_mm - d).abs() < 1e-12 && (b.p_e_kpa - p).abs() < 1e-12,
            "{b:?}"
        );
        assert_eq!(b.samples, n);
    }
}

#[test]
fn written_data_read_back_with_the_solvers_unit_weight() {
    let run = |depth_mm: f64, bins: Vec<Bin>| DepthRun {
        depth_mm,
        settled_diameter_mm: 18.6,
        final_diameter_mm: 25.0,
        final_p_e_kpa: bins.last().map_or(0.0, |b| b.p_e_kpa),
        final_p_e_sd_kpa: 0.0,
        grains: 100,
        bins,
        wall_s: 1.0,
    };
    let bin = |d: f64, p: f64| Bin {
        diameter_mm: d,
        p_e_kpa: p,
        samples: 4,
    };
    let runs = [
        run(40.0, vec![bin(18.7, 0.3), bin(20.0, 0.7), bin(24.9, 0.8)]),
        run(70.0, vec![bin(18.6, 0.5), bin(24.95, 1.3)]),
    ];
    let text = csv_text(&runs, &RegenerateOptions::paper(vec![40.0, 70.0], true)).unwrap();
    let sand = SolverSand::parse(&text, "written.csv").unwrap();
    // γ' = 0.56·(2920 − 1025)·9.81 N/m³ = 10410.372 N/m³, stated in kPa/mm.
    let g = spec(40.0, true).buoyant_unit_weight_n_m3() * 1e-6;
    assert!((g - 0.010_410_372).abs() < 1e-12);
    assert!((sand.unit_weight_kpa_per_mm() - g).abs() < 1e-12);
    assert_eq!(sand.curves().len(), 2);
    assert_eq!(sand.curves()[1].diameters_mm, [18.6, 24.95]);
    assert!((sand.loading_pressure_kpa(24.95, 70.0) - 1.3).abs() < 1e-9);
    let line = sand.describe();
    assert!(
        line.contains("run=quick")
            && line.contains("grain_radius_mm=1.5")
            && line.contains("seeds=1 2 3"),
        "{line}"
    );
}

#[test]
fn a_solver_run_needs_a_seed() {
    let opts = RegenerateOptions {
        seeds: 0,
        ..RegenerateOptions::paper(vec![40.0], true)
    };
    let e = format!("{:#}", run_depth(&opts, 40.0).unwrap_err());
    assert!(e.contains("at least one seed"), "{e}");
}

#[test]
fn the_stored_data_file_parses_and_gives_its_own_values() {
    let root = host_sim::repo_root();
    let sand = SolverSand::from_repo(&root).unwrap();
    let depths: Vec<f64> = sand.curves().iter().map(|c| c.depth_mm).collect();
    assert_eq!(depths, [40.0, 50.0, 70.0, 100.0]);
    // Read the 40 mm rows independently: p_e at D = 25 mm is the largest
    // p_e stored at 40 mm up to 25 mm (the running max; 25 mm is the last
    // row's diameter or past it).
    let mut reader = csv::ReaderBuilder::new()
        .comment(Some(b'#'))
        .from_path(root.join(DATA_PATH))
        .unwrap();
    let mut max_40 = f64::NEG_INFINITY;
    let mut last_d_40 = 0.0;
    for r in reader.records() {
        let r = r.unwrap();
        let (h, d, p): (f64, f64, f64) = (
            r[0].parse().unwrap(),
            r[1].parse().unwrap(),
            r[2].parse().unwrap(),
        );
        if h == 40.0 && d <= 25.0 {
            max_40 = max_40.max(p);
            last_d_40 = d;
        }
    }
    assert!(last_d_40 > 24.5, "the 40 mm rows end at {last_d_40} mm");
    let pe = sand.loading_pressure_kpa(25.0, 40.0);
    assert!((pe - max_40).abs() < 1e-9, "{pe} vs {max_40}");
    // The file's stated γ' is the solver's.
    let g = spec(40.0, true).buoyant_unit_weight_n_m3() * 1e-6;
    assert!((sand.unit_weight_kpa_per_mm() - g).abs() < 1e-12);
}

/// A solver file of another actuator (D0 = 30 mm), as `solver-sand --rig`
/// writes it.
fn other_actuator_file(d0_line: &str) -> String {
    format!(
        "# {UNIT_WEIGHT_KEY} = 0.0090\n{d0_line}\ndepth_mm,diameter_mm,p_e_kpa,samples\n\
         40,30.2,0.40,5\n40,35.0,1.20,5\n40,40.0,1.50,5\n100,30.2,1.00,5\n100,40.0,3.80,5\n"
    )
}

#[test]
fn a_rigs_solver_file_gives_its_actuators_table() {
    use host_sim::experiment::Rig;
    use host_sim::pressure_model::SkinSandModel;
    use host_sim::tables::{GeneratedTable, TableSpec};
    let sand =
        SolverSand::parse(&other_actuator_file("# initial_diameter_mm = 30"), "s.csv").unwrap();
    assert_eq!(sand.initial_diameter_mm(), 30.0);
    let mut rig = Rig::paper_default();
    rig.actuator.initial_diameter_mm = 30.0;
    rig.actuator.expansion_length_mm = 28.0;
    let spec = TableSpec::for_rig(&rig);
    // The paper's relative span (18.7 → 26.2 mm) from D0 = 30 mm, within
    // the firmware's column limit.
    let last = *spec.diameters_mm.last().unwrap();
    assert_eq!(spec.diameters_mm[0], 30.0);
    assert!(
        (f64::from(last) - 30.0 * 26.2 / 18.7).abs() < 1e-4,
        "{last}"
    );
    assert!(spec.diameters_mm.len() <= 48);
    let model = SkinSandModel::for_rig(&rig, "rig.toml", sand).unwrap();
    // The table's p_i is the rig's skin tube plus the file's sand: at
    // D = 40 mm, h = 100 mm the sand adds the stored 3.8 kPa.
    let p = host_sim::tables::PressureModel::internal_pressure_kpa(&model, 40.0, 100.0);
    let skin = model.membrane_kpa(40.0).unwrap();
    assert!((p - skin - 3.8).abs() < 1e-9, "{p} {skin}");
    let table = GeneratedTable::sample(&spec, &model).unwrap();
    assert_eq!(table.as_table().verify(), Ok(()));
    assert!(table.provenance.contains("the rig's [skin]") && table.provenance.contains("D0=30"));
    // The paper's rig gives the paper's grid.
    assert_eq!(
        TableSpec::for_rig(&Rig::paper_default()),
        TableSpec::default()
    );
}

#[test]
fn a_solver_file_of_another_actuator_is_refused_and_a_bad_d0_named() {
    use host_sim::experiment::Rig;
    use host_sim::pressure_model::SkinSandModel;
    let sand =
        SolverSand::parse(&other_actuator_file("# initial_diameter_mm = 30"), "s.csv").unwrap();
    let e = SkinSandModel::for_rig(&Rig::paper_default(), "lab/rig.toml", sand)
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("D0 = 30 mm") && e.contains("lab/rig.toml") && e.contains("18.7"),
        "{e}"
    );
    let e = SolverSand::parse(
        &other_actuator_file("# initial_diameter_mm = wide"),
        "s.csv",
    )
    .unwrap_err();
    assert_eq!(
        (e.line, e.field.as_str()),
        (2, "initial_diameter_mm"),
        "{e}"
    );
    // Without the key: the paper's actuator.
    let sand = SolverSand::parse(&other_actuator_file("# no diameter here"), "s.csv").unwrap();
    assert_eq!(sand.initial_diameter_mm(), 18.7);
}
