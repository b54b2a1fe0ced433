//! The shared h = 40 mm bed at rest against LAMMPS (the rest of the
//! expansion is `scripts/cavity-lammps.sh`, minutes long).

use std::path::{Path, PathBuf};

use cavity::{at_rest_kpa, Bed, Cavity};

/// `shared/cavity`, beside the repository or at /work/shared.
fn shared_cavity() -> PathBuf {
    let beside = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../../shared/cavity");
    if beside.is_dir() {
        beside
    } else {
        PathBuf::from("/work/shared/cavity")
    }
}

/// LAMMPS 29Sep2021 (Debian bookworm) on `in.expand`, bed h40, T = 1 s:
/// p_e at rest, the mean of the 5 windows before the expansion (kPa).
const LAMMPS_H40_AT_REST_KPA: f64 = 0.3525;

#[test]
fn the_h40_bed_at_rest_loads_the_cylinder_as_in_lammps() {
    let bed = Bed::read(&shared_cavity().join("bed_h40.csv")).unwrap();
    assert_eq!(bed.len(), 22_383);
    let pe = at_rest_kpa(&Cavity::default(), &bed, 1.0).unwrap();
    let off = pe / LAMMPS_H40_AT_REST_KPA - 1.0;
    assert!(
        off.abs() < 0.03,
        "p_e at rest {pe} kPa, LAMMPS {LAMMPS_H40_AT_REST_KPA}: {:+.1} %",
        100.0 * off
    );
}
