//! The `host-sim` binary end to end: its subcommands as a user runs them.

use std::path::PathBuf;

use rig::{Experiment, PressureSource};

#[path = "../crates/rig/tests/fixtures/mod.rs"]
mod fixtures;
use fixtures::{noisy_capture, RIG_NO_SAND};

/// The binary, to be given its arguments.
fn host_sim() -> std::process::Command {
    std::process::Command::new(env!("CARGO_BIN_EXE_host-sim"))
}

/// Runs `cmd`, which must succeed (else its stderr is the failure); its
/// stdout.
fn succeeds(cmd: &mut std::process::Command) -> String {
    let out = cmd.output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// Runs `cmd`, which must fail; its stderr.
fn fails(cmd: &mut std::process::Command) -> String {
    let out = cmd.output().unwrap();
    assert!(
        !out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );
    String::from_utf8_lossy(&out.stderr).into_owned()
}

#[test]
fn cli_telemetry_writes_a_readable_folder() {
    let dir = tempfile::tempdir().unwrap();
    let capture = dir.path().join("cap.bin");
    std::fs::write(&capture, noisy_capture()).unwrap();
    let rig = dir.path().join("my-rig.toml");
    std::fs::write(&rig, RIG_NO_SAND).unwrap();
    let out: PathBuf = dir.path().join("out");
    let stdout = succeeds(
        host_sim()
            .arg("telemetry")
            .arg(&capture)
            .arg("--out")
            .arg(&out)
            .arg("--rig")
            .arg(&rig)
            .args(["--run", "bench", "--depth-mm", "0"]),
    );
    assert!(stdout.contains("run bench: 3 samples at depth 0 mm"));
    let exp = Experiment::read(&out).unwrap();
    assert_eq!(exp.runs[0].id, "bench");
    assert_eq!(
        exp.rig.measurement.pressure_source,
        PressureSource::PistonForce
    );

    // Without a depth and with a sand-free rig, a buried run is refused.
    let stderr = fails(
        host_sim()
            .arg("telemetry")
            .arg(&capture)
            .arg("--out")
            .arg(dir.path().join("out2"))
            .arg("--rig")
            .arg(&rig),
    );
    assert!(
        stderr.contains("rig.toml: sand: missing section"),
        "{stderr}"
    );
}

#[test]
fn cli_merge_refuses_parts_that_do_not_make_an_ensemble() {
    let dir = tempfile::tempdir().unwrap();
    // A part number beyond the count is refused when parsed.
    let stderr = fails(
        host_sim()
            .args(["balloon", "--shard", "3/2", "--out"])
            .arg(dir.path().join("b")),
    );
    assert!(stderr.contains("between 1 and 2"), "{stderr}");
    // solver-sand's parts need a folder for their runs.
    let stderr = fails(host_sim().args(["solver-sand", "--shard", "1/2"]));
    assert!(stderr.contains("--runs-out"), "{stderr}");
    // A folder that no part wrote.
    let stderr = fails(
        host_sim()
            .args(["merge", "--out"])
            .arg(dir.path().join("merged"))
            .arg(dir.path()),
    );
    assert!(
        stderr.contains("shard.json") && stderr.contains("--shard I/N"),
        "{stderr}"
    );
}

#[test]
fn cli_sand_test_splits_and_merges_into_the_same_summary() {
    let dir = tempfile::tempdir().unwrap();
    // Two radii, one seed, 150 grains, sheared to 6 %: four short tests.
    let plan = [
        "sand-test",
        "--radii-mm",
        "1.5,1.0",
        "--seeds",
        "1",
        "--grains",
        "150",
        "--confining-kpa",
        "4",
        "--axial-strain",
        "0.06",
    ];
    let whole = dir.path().join("whole");
    succeeds(host_sim().args(plan).arg("--out").arg(&whole));
    let mut parts = Vec::new();
    for i in 1..=2 {
        let part = dir.path().join(format!("part-{i}"));
        let stdout = succeeds(
            host_sim()
                .args(plan)
                .args(["--shard", &format!("{i}/2"), "--out"])
                .arg(&part),
        );
        assert!(stdout.contains("ran 2 of the command's 4 cases"));
        parts.push(part);
    }
    let merged = dir.path().join("merged");
    succeeds(
        host_sim()
            .arg("merge")
            .arg("--out")
            .arg(&merged)
            .args(&parts),
    );
    for file in [
        "summary.json",
        "summary.txt",
        "triaxial.svg",
        "oedometer.svg",
    ] {
        let a = std::fs::read(whole.join(file)).unwrap();
        assert!(
            a == std::fs::read(merged.join(file)).unwrap(),
            "{file} differs"
        );
    }
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(whole.join("summary.json")).unwrap()).unwrap();
    // The dense sample dilates and peaks above its critical state; its
    // angles lie between a frictionless packing's (≈ 6°) and 45°.
    let row = &summary["triaxial"][2];
    assert!(row["radius_mm"].is_null(), "{row}");
    let peak = row["peak_deg"]["mean"].as_f64().unwrap();
    let dilatancy = row["dilatancy_deg"]["mean"].as_f64().unwrap();
    assert!((10.0..45.0).contains(&peak) && dilatancy > 0.0, "{row}");
    let k0 = summary["oedometer"][8 + 3]["k0"]["mean"].as_f64().unwrap();
    assert!((0.2..0.9).contains(&k0), "K0 {k0}");
}

/// A Treloar reference file (shared/reference, beside the repository).
fn treloar(mode: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/reference")
        .join(format!("treloar_{mode}.csv"))
}

#[test]
fn cli_fit_skin_fits_one_mode_and_predicts_another() {
    let dir = tempfile::tempdir().unwrap();
    let stdout = succeeds(
        host_sim()
            .arg("fit-skin")
            .arg(treloar("uniaxial"))
            .arg(treloar("planar"))
            .args(["--fit-modes", "uniaxial", "--out"])
            .arg(dir.path()),
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
    let stderr = fails(
        host_sim()
            .arg("fit-skin")
            .arg(treloar("uniaxial"))
            .args(["--fit-modes", "biaxial"]),
    );
    assert!(
        stderr.contains("--fit-modes: `biaxial` is not a test mode"),
        "{stderr}"
    );
    let stderr = fails(host_sim().arg("fit-skin").arg(treloar("uniaxial")).args([
        "--inflation",
        "/nonexistent",
        "--inflation-law",
        "Arruda-Boyce",
    ]));
    assert!(
        stderr.contains("--inflation-law: no law `Arruda-Boyce` (laws: neo-Hookean, Mooney-Rivlin, Yeoh, Gent, Ogden-1, Ogden-2, Ogden-3)"),
        "{stderr}"
    );
}

#[test]
fn cli_cavity_estimate_from_a_stored_curve() {
    let dir = tempfile::tempdir().unwrap();
    // A bed is read for its far field's packing; G is given here.
    let bed = dir.path().join("bed.csv");
    std::fs::write(
        &bed,
        "id,x,y,z,radius\n1,0.010,0.005,0.010,0.001\n2,0.0119,0.005,0.010,0.001\n",
    )
    .unwrap();
    let mut pe = String::from("percent,d_mm,pe_kpa\n0,18.7,0.35\n");
    for p in 1..=100 {
        let d = 18.7 + 6.3 * f64::from(p) / 100.0;
        pe += &format!("{p},{d},{}\n", 0.35 + 0.0135 * f64::from(p));
    }
    let curve = dir.path().join("pe.csv");
    std::fs::write(&curve, &pe).unwrap();
    let out = dir.path().join("out");
    let stdout = succeeds(
        host_sim()
            .args(["cavity", "--bed"])
            .arg(&bed)
            .arg("--dem-curve")
            .arg(&curve)
            .arg("--out")
            .arg(&out)
            .args([
                "--friction-deg",
                "22.6",
                "--dilatancy-deg",
                "0",
                "--shear-modulus-kpa",
                "11.5",
            ]),
    );
    assert!(stdout.contains("G 11.5 kPa (given"), "{stdout}");
    let table = std::fs::read_to_string(out.join("theory.csv")).unwrap();
    let rows: Vec<Vec<f64>> = table
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 11);
    // The last row's large-strain pressure is the library's, for p0 the
    // curve's at-rest value.
    let t = cavity::theory::CavityTheory::new(
        cavity::theory::Soil {
            friction_deg: 22.6,
            dilatancy_deg: 0.0,
            shear_modulus_kpa: 11.5,
            poisson: 0.3,
        },
        0.35,
    )
    .unwrap();
    let a = 25.0 / 18.7;
    let want = cavity::theory::CavityTheory::pressure_at(&t.large_strain(a * 1.001, 2e-4, 100), a)
        .unwrap();
    assert!(
        (rows[10][3] / want - 1.0).abs() < 1e-5,
        "{} vs {want}",
        rows[10][3]
    );
    assert!((rows[10][2] - 1.7).abs() < 1e-9);
    assert!(out.join("theory.svg").exists());
    // A curve that is not a whole pe.csv is refused by name.
    std::fs::write(&curve, "percent,d_mm,pe_kpa\n0,18.7,0.35\n").unwrap();
    let err = fails(
        host_sim()
            .args(["cavity", "--bed"])
            .arg(&bed)
            .arg("--dem-curve")
            .arg(&curve)
            .arg("--out")
            .arg(&out)
            .args(["--friction-deg", "22.6", "--dilatancy-deg", "0"]),
    );
    assert!(
        err.contains("pe.csv") && err.contains("percent 0, 1"),
        "{err}"
    );
}

/// `--skin-fit`: fit-skin's Gent fit of the shipped skin data drives
/// `tables`, the report's laws are listed when the name is missing, and
/// `compare` reads a folder with it, warning that it replaces [skin].
#[test]
fn cli_a_gent_fit_from_fit_skin_drives_tables_and_compare() {
    let dir = tempfile::tempdir().unwrap();
    let data =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("data/skin/unicinctus_circumferential.csv");
    succeeds(
        host_sim()
            .arg("fit-skin")
            .arg(&data)
            .arg("--out")
            .arg(dir.path()),
    );
    let fit = dir.path().join("unicinctus_circumferential-fit.json");
    let table = dir.path().join("gent.rs");
    // The paper's table keeps the skin its solver sand was measured on:
    // another law is refused, and the way to a consistent table named.
    let stderr = fails(
        host_sim()
            .arg("tables")
            .arg("--skin-fit")
            .arg(&fit)
            .args(["--skin-law", "Gent", "--out"])
            .arg(&table),
    );
    assert!(
        stderr.contains("the table's skin is Gent mu_kpa = ")
            && stderr.contains("solver-sand --rig"),
        "{stderr}"
    );
    assert!(!table.exists());

    // No --skin-law and no inflation fit in the report: the laws listed.
    let stderr = fails(
        host_sim()
            .arg("tables")
            .arg("--skin-fit")
            .arg(&fit)
            .arg("--out")
            .arg(&table),
    );
    assert!(
        stderr.contains("say which law with --skin-law")
            && stderr.contains("Gent (uniaxial R² 0.96"),
        "{stderr}"
    );
    let stderr = fails(
        host_sim()
            .arg("tables")
            .arg("--skin-fit")
            .arg(&fit)
            .args(["--skin-law", "Arruda-Boyce"]),
    );
    assert!(
        stderr.contains("--skin-law Arruda-Boyce: the report has no fit of that law"),
        "{stderr}"
    );

    // compare with the Gent law on a synthetic folder whose rig.toml has a [skin].
    let exp = dir.path().join("exp");
    std::fs::create_dir_all(&exp).unwrap();
    workbench::synth::case(Vec::new(), 0.1, 5)
        .generate()
        .unwrap()
        .write(&exp)
        .unwrap();
    let stdout = succeeds(
        host_sim()
            .arg("compare")
            .arg(&exp)
            .arg("--skin-fit")
            .arg(&fit)
            .args(["--skin-law", "Gent"]),
    );
    assert!(
        stdout.starts_with("warning: ") && stdout.contains("[skin] (Yeoh c10_kpa = 2, c20_kpa = 0, c30_kpa = 0.016) is replaced by the Gent coupon fit (uniaxial)"),
        "{stdout}"
    );
}
