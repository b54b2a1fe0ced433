//! The data contract's own examples (`shared/contract-examples/`), read as
//! outside data comes: every `valid/` folder is read, every `invalid/`
//! folder is refused with the file, line and key its entry in
//! `invalid/expected-errors.json` names.

use std::path::PathBuf;

use datafile::DataError;
use rig::Experiment;

/// `shared/contract-examples`, wherever `shared/` is.
fn examples() -> PathBuf {
    let beside =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../../shared/contract-examples");
    if beside.is_dir() {
        return beside;
    }
    let fallback = PathBuf::from("/work/shared/contract-examples");
    assert!(fallback.is_dir(), "shared/contract-examples not found");
    fallback
}

fn folders(kind: &str) -> Vec<PathBuf> {
    let mut dirs: Vec<PathBuf> = std::fs::read_dir(examples().join(kind))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_dir())
        .collect();
    dirs.sort();
    dirs
}

#[test]
fn every_valid_example_is_read() {
    let dirs = folders("valid");
    assert!(dirs.len() >= 13, "{} valid examples", dirs.len());
    for dir in dirs {
        let exp = Experiment::read(&dir).unwrap_or_else(|e| panic!("{}: {e:#}", dir.display()));
        assert!(!exp.runs.is_empty(), "{}: no run", dir.display());
        assert!(
            exp.runs.iter().all(|r| !r.samples.is_empty()),
            "{}: an empty run",
            dir.display()
        );
    }
}

#[test]
fn a_tank_without_a_width_is_a_wide_tank() {
    let exp = Experiment::read(&examples().join("valid/wide_tank_no_width")).unwrap();
    let container = exp.rig.container.expect("[container] is there");
    assert_eq!(container.width_mm, None);
    assert_eq!(container.length_mm, 200.0);
}

#[test]
fn every_invalid_example_is_refused_at_its_place() {
    let expected: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(examples().join("invalid/expected-errors.json")).unwrap(),
    )
    .unwrap();
    let expected = expected.as_object().unwrap();
    let dirs = folders("invalid");
    assert_eq!(dirs.len(), expected.len(), "one expectation per folder");
    for dir in dirs {
        let name = dir.file_name().unwrap().to_string_lossy().into_owned();
        let want = &expected[&name];
        let err = Experiment::read(&dir).expect_err(&name);
        let e = err
            .downcast_ref::<DataError>()
            .unwrap_or_else(|| panic!("{name}: not a placed error: {err:#}"));
        assert_eq!(e.file, want["file"].as_str().unwrap(), "{name}: {e}");
        assert_eq!(e.line, want["line"].as_u64(), "{name}: {e}");
        assert_eq!(e.key.as_deref(), want["key"].as_str(), "{name}: {e}");
    }
}
