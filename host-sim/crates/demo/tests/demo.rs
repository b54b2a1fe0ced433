//! The README's first command (`cargo demo`) end to end, into a temporary
//! folder: every step runs and writes what it says.

#[test]
fn demo_runs_end_to_end_and_writes_its_results() {
    let dir = tempfile::tempdir().unwrap();
    let report = demo::run(
        &std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../.."),
        dir.path(),
    )
    .unwrap();
    for file in &report.files {
        assert!(file.is_file(), "{} missing", file.display());
    }
    let text = report.lines.join("\n");
    // The shipped skin's Yeoh fit is the one the project keeps (R² > 0.99).
    assert!(text.contains("Yeoh R²=0.99"), "{text}");
    assert!(text.contains("identical to a fresh generation"), "{text}");
    // The emulated burrowing reaches its expected outcome (20 cycles).
    assert!(text.contains("cycles completed: 20"), "{text}");
    assert!(text.contains("outcome: as expected"), "{text}");
    // The emulated sensor reads ~9 ms late (conversion + sampling); the
    // workbench must name that and nothing else, and leave no structure.
    assert!(text.contains("selected: sensor_lag\n"), "{text}");
    assert!(text.contains("unexplained: none"), "{text}");
    assert!(dir.path().join("emulate/runs.csv").is_file());
    assert!(dir
        .path()
        .join("emulate/workbench/diagnosis.json")
        .is_file());
}
