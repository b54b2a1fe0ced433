//! The cell and its tests against closed forms and published values.

use sandtest::cell::{Cell, Grains};
use sandtest::procedure::{consolidate, triaxial};

#[test]
fn a_lattice_under_isotropic_stress_compresses_as_hertz_says() {
    // A simple cubic lattice of n³ grains carries the stress p in columns:
    // each contact a force F = p (2r)², each column of n grains n − 1
    // grain–grain contacts (R* = r/2) and two grain–wall ones (R* = r),
    // Hertz F = 4/3 E* √(R* δ) δ with E* = E / (2 (1 − ν²)) for both.
    let grains = Grains::scenario(1.5e-3);
    let (n, p) = (3usize, 5_000.0);
    let mut cell = Cell::lattice(grains, n, grains.contacts.friction, 2.0).unwrap();
    let side = cell.lengths_m()[0];
    consolidate(&mut cell, p).unwrap();
    let r = grains.radius_m;
    let m = grains.material;
    let e_star = m.youngs_modulus_pa / (2.0 * (1.0 - m.poisson_ratio.powi(2)));
    let f = p * (2.0 * r).powi(2);
    let overlap = |r_star: f64| (3.0 * f / (4.0 * e_star * r_star.sqrt())).powf(2.0 / 3.0);
    let expected = (n - 1) as f64 * overlap(r / 2.0) + 2.0 * overlap(r);
    for (axis, l) in cell.lengths_m().iter().enumerate() {
        let compression = side - l;
        eprintln!(
            "axis {axis}: compression / Hertz = {:.5}",
            compression / expected
        );
        assert!(
            (compression / expected - 1.0).abs() < 0.01,
            "axis {axis}: compressed {compression:.4e} m, Hertz {expected:.4e} m"
        );
    }
    for s in cell.stress_pa() {
        assert!((s / p - 1.0).abs() < 0.02, "{s} Pa");
    }
    // A lattice carries no shear: every grain touches six.
    assert!((cell.coordination() - 2.0 * 3.0 * (n - 1) as f64 / n as f64).abs() < 1e-9);
}

#[test]
fn frictionless_spheres_shear_at_the_published_critical_angle() {
    // Peyneau & Roux (2008), frictionless spheres without rolling
    // resistance: a critical-state friction angle of 5.76° (sin φ = 0.1),
    // about a fifth of a rough sand's. Small sample: its angle scatters
    // by about 2° record to record.
    let mut grains = Grains::scenario(1.5e-3);
    grains.contacts.friction = 0.0;
    grains.contacts.rolling_friction = 0.0;
    let mut cell = Cell::loose(grains, 300, 1, 0.0, 2.0).unwrap();
    consolidate(&mut cell, 2_000.0).unwrap();
    let test = triaxial(&mut cell, 2_000.0, 0.2).unwrap();
    eprintln!(
        "frictionless: φ_cv {:.2}°, φ_peak {:.2}°",
        test.critical_deg, test.peak_deg
    );
    assert!(
        (3.0..9.0).contains(&test.critical_deg),
        "φ_cv {:.2}°",
        test.critical_deg
    );
}
