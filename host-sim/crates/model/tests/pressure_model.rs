//! The table's physics against the paper: the sand calibrated to the
//! balloon experiment and p_i = p_membrane + p_e.

use model::pressure_model::{PressureModel, SkinSandModel};
use sand::{calibrate_limit_coefficient, SandParams, BALLOON_TABLE};

#[test]
fn sand_calibration_and_pressure_model_against_the_paper() {
    let cal = calibrate_limit_coefficient(
        &SandParams::paper_uncalibrated(),
        &BALLOON_TABLE,
        sand::BALLOON_FINAL_DIAMETER_MM,
    );
    println!(
        "N = {:.3} ± {:.3}, chi² = {:.3}",
        cal.limit_coefficient, cal.limit_coefficient_se, cal.chi_squared
    );
    for (p, m) in BALLOON_TABLE.iter().zip(&cal.model_kpa) {
        println!(
            "  h = {:5.1} mm: measured {:.2} ± {:.2}, model {:.3} kPa",
            p.depth_mm, p.external_pressure_kpa, p.sd_kpa, m
        );
        assert!((m - p.external_pressure_kpa).abs() < p.sd_kpa);
    }
    let model = SkinSandModel::paper_default();
    let pm = model.membrane_kpa(25.0).unwrap();
    let pi = model.internal_pressure_kpa(25.0, 40.0);
    println!("p_membrane(25 mm) = {pm:.4} kPa");
    for h in [0.0, 40.0, 50.0, 70.0, 100.0, 200.0] {
        let at = |d: f64| model.internal_pressure_kpa(d, h);
        println!(
            "  p_i(h = {h:5.1} mm): D = 18.7: {:.4}, 20: {:.4}, 22: {:.4}, 25: {:.4} kPa",
            at(18.7),
            at(20.0),
            at(22.0),
            at(25.0)
        );
    }
    // p_i − p_membrane is the calibrated p_e at 4 cm.
    assert!((pi - pm - cal.model_kpa[0]).abs() < 1e-12);
}
