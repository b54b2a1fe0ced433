//! The solver-fed sand law (issue 5 item 6): the stored data file's
//! reader and its errors, interpolation in D and h against hand values,
//! K held outside the stored depths, monotone loading, the unloading rule
//! shared with the parametric law, and the committed data file itself.

use std::path::Path;

use datafile::DataError;
use sand::solver::{DATA_PATH, UNIT_WEIGHT_KEY};
use sand::{ParametricSand, SandHistory, SandLaw, SolverSand};

/// A data file with γ' = 0.01 kPa/mm: line 1 the unit weight, line 2 the
/// header, rows from line 3.
fn parse(rows: &str) -> Result<SolverSand, DataError> {
    let text = format!("# {UNIT_WEIGHT_KEY} = 0.01\ndepth_mm,diameter_mm,p_e_kpa,samples\n{rows}");
    SolverSand::parse(&text, "hand.csv")
}

fn assert_rejected(text: &str, line: u64, field: &str) {
    let e = SolverSand::parse(text, "bad.csv").unwrap_err();
    assert_eq!(
        (e.file.as_str(), e.line, e.key.as_deref()),
        ("bad.csv", Some(line), Some(field)),
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
fn the_stored_data_file_parses_and_gives_its_own_values() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../..");
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
}
