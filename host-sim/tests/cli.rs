//! The `host-sim` binary end to end: its subcommands as a user runs them.

use std::path::PathBuf;

use rig::{Experiment, PressureSource};

#[path = "../crates/rig/tests/fixtures/mod.rs"]
mod fixtures;
use fixtures::{noisy_capture, RIG_NO_SAND};

#[test]
fn cli_telemetry_writes_a_readable_folder() {
    let dir = tempfile::tempdir().unwrap();
    let capture = dir.path().join("cap.bin");
    std::fs::write(&capture, noisy_capture()).unwrap();
    let rig = dir.path().join("my-rig.toml");
    std::fs::write(&rig, RIG_NO_SAND).unwrap();
    let out: PathBuf = dir.path().join("out");
    let status = std::process::Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .arg("telemetry")
        .arg(&capture)
        .arg("--out")
        .arg(&out)
        .arg("--rig")
        .arg(&rig)
        .args(["--run", "bench", "--depth-mm", "0"])
        .output()
        .unwrap();
    assert!(
        status.status.success(),
        "{}",
        String::from_utf8_lossy(&status.stderr)
    );
    assert!(String::from_utf8_lossy(&status.stdout).contains("run bench: 3 samples at depth 0 mm"));
    let exp = Experiment::read(&out).unwrap();
    assert_eq!(exp.runs[0].id, "bench");
    assert_eq!(
        exp.rig.measurement.pressure_source,
        PressureSource::PistonForce
    );

    // Without a depth and with a sand-free rig, a buried run is refused.
    let bad = std::process::Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .arg("telemetry")
        .arg(&capture)
        .arg("--out")
        .arg(dir.path().join("out2"))
        .arg("--rig")
        .arg(&rig)
        .output()
        .unwrap();
    assert!(!bad.status.success());
    let stderr = String::from_utf8_lossy(&bad.stderr);
    assert!(
        stderr.contains("rig.toml: sand: missing section"),
        "{stderr}"
    );
}

#[test]
fn cli_merge_refuses_parts_that_do_not_make_an_ensemble() {
    let host_sim = || std::process::Command::new(env!("CARGO_BIN_EXE_host-sim"));
    let dir = tempfile::tempdir().unwrap();
    // A part number beyond the count is refused when parsed.
    let bad = host_sim()
        .args(["balloon", "--shard", "3/2", "--out"])
        .arg(dir.path().join("b"))
        .output()
        .unwrap();
    assert!(!bad.status.success());
    let stderr = String::from_utf8_lossy(&bad.stderr);
    assert!(stderr.contains("between 1 and 2"), "{stderr}");
    // solver-sand's parts need a folder for their runs.
    let bad = host_sim()
        .args(["solver-sand", "--shard", "1/2"])
        .output()
        .unwrap();
    assert!(!bad.status.success());
    let stderr = String::from_utf8_lossy(&bad.stderr);
    assert!(stderr.contains("--runs-out"), "{stderr}");
    // A folder that no part wrote.
    let out = host_sim()
        .args(["merge", "--out"])
        .arg(dir.path().join("merged"))
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("shard.json") && stderr.contains("--shard I/N"),
        "{stderr}"
    );
}

/// A Treloar reference file (shared/reference, beside the repository).
fn treloar(mode: &str) -> PathBuf {
    let rel = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/reference")
        .join(format!("treloar_{mode}.csv"));
    if rel.exists() {
        rel
    } else {
        PathBuf::from(format!("/work/shared/reference/treloar_{mode}.csv"))
    }
}

#[test]
fn cli_fit_skin_fits_one_mode_and_predicts_another() {
    let dir = tempfile::tempdir().unwrap();
    let host_sim = || std::process::Command::new(env!("CARGO_BIN_EXE_host-sim"));
    let out = host_sim()
        .arg("fit-skin")
        .arg(treloar("uniaxial"))
        .arg(treloar("planar"))
        .args(["--fit-modes", "uniaxial", "--out"])
        .arg(dir.path())
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(stdout.contains("treloar_planar.csv planar (14 rows, nominal stress, max strain 3.970): predicted, not fitted"), "{stdout}");
    // Yeoh's row of the per-mode table: fitted uniaxial, predicted planar.
    let yeoh = stdout
        .lines()
        .filter(|l| l.starts_with("Yeoh "))
        .nth(1)
        .unwrap();
    assert!(
        yeoh.contains("0.9973 (100.6)") && yeoh.contains("*0.9818"),
        "{yeoh}"
    );
    assert!(dir.path().join("skin-fit.json").exists() && dir.path().join("skin-fit.svg").exists());

    // A mode name that is none of the three, and a law that does not exist.
    let bad = host_sim()
        .arg("fit-skin")
        .arg(treloar("uniaxial"))
        .args(["--fit-modes", "biaxial"])
        .output()
        .unwrap();
    assert!(!bad.status.success());
    assert!(
        String::from_utf8_lossy(&bad.stderr).contains("--fit-modes: `biaxial` is not a test mode")
    );
    let bad = host_sim()
        .arg("fit-skin")
        .arg(treloar("uniaxial"))
        .args([
            "--inflation",
            "/nonexistent",
            "--inflation-law",
            "Arruda-Boyce",
        ])
        .output()
        .unwrap();
    assert!(!bad.status.success());
    let stderr = String::from_utf8_lossy(&bad.stderr);
    assert!(
        stderr.contains("--inflation-law: no law `Arruda-Boyce` (laws: neo-Hookean, Mooney-Rivlin, Yeoh, Gent, Ogden-1, Ogden-2, Ogden-3)"),
        "{stderr}"
    );
}
