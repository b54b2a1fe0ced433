//! The solver sand's regeneration: binning of solver samples, the data
//! file written and read back, and the options' checks.

use burrow::cases::Runner;
use burrow::solver_sand::{
    bin_samples, csv_text, run_depth, spec, Bin, DepthRun, RegenerateOptions,
};
use sand::{SandLaw, SolverSand};

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
    let e = format!(
        "{:#}",
        run_depth(&opts, 40.0, &Runner::whole()).unwrap_err()
    );
    assert!(e.contains("at least one seed"), "{e}");
}

#[test]
fn the_stored_data_files_unit_weight_is_the_solvers() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../..");
    let sand = SolverSand::from_repo(&root).unwrap();
    let g = spec(40.0, true).buoyant_unit_weight_n_m3() * 1e-6;
    assert!((sand.unit_weight_kpa_per_mm() - g).abs() < 1e-12);
}
