//! The experiment-folder contract (shared/data-format.md): reading, writing,
//! strict errors with file and line, and telemetry captures converted into
//! folders.

use std::path::Path;

use datafile::DataError;
use proptest::prelude::*;
use rig::telemetry::{
    convert_file, decode_capture, encode_capture, to_experiment, ConvertOptions, EXTRA_COLUMNS,
};
use rig::{
    Container, Experiment, Measurement, PressureSource, Rig, Run, Sample, RIG_FILE, RUNS_FILE,
};
use urechis::controller::State;
use urechis::protocol::{DeviceMessage, FrameError};

mod fixtures;
use fixtures::{hello, noisy_capture, params_at, telemetry, RIG_NO_SAND};

// ---------------------------------------------------------------------------
// Helpers.

/// The contract document, wherever `shared/` is.
fn data_format_md() -> String {
    let beside = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../../shared/data-format.md");
    std::fs::read_to_string(&beside)
        .or_else(|_| std::fs::read_to_string("/work/shared/data-format.md"))
        .expect("shared/data-format.md")
}

/// The first fenced block of `kind` (```toml or a bare ``` after `after`).
fn fenced_block(text: &str, opening: &str, after: &str) -> String {
    let start = text.find(after).expect("anchor") + after.len();
    let rest = &text[start..];
    let open = rest.find(opening).expect("opening fence") + opening.len();
    let body = &rest[open..];
    let close = body.find("\n```").expect("closing fence");
    body[..close].trim_start_matches('\n').to_owned() + "\n"
}

fn folder(files: &[(&str, &str)]) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    for (name, text) in files {
        std::fs::write(dir.path().join(name), text).unwrap();
    }
    dir
}

/// The full error chain of reading `files` as a folder.
fn read_error(files: &[(&str, &str)]) -> String {
    let dir = folder(files);
    let err = Experiment::read(dir.path()).expect_err("must be rejected");
    format!("{err:#}")
}

/// Where a data file's error sits: file, line, key or column.
type Place<'a> = (&'a str, Option<u64>, Option<&'a str>);

/// Reading `files` as a folder fails with a data file's error at `place`,
/// the full chain containing `expected`.
fn assert_error(files: &[(&str, &str)], place: Place<'_>, expected: &str) {
    let dir = folder(files);
    let err = Experiment::read(dir.path()).expect_err("must be rejected");
    let got = format!("{err:#}");
    let e = err
        .downcast_ref::<DataError>()
        .unwrap_or_else(|| panic!("not a data file's error: {got}"));
    assert_eq!((e.file.as_str(), e.line, e.key.as_deref()), place, "{got}");
    assert!(
        got.contains(expected),
        "error was:\n{got}\nexpected to contain:\n{expected}"
    );
}

fn paper_rig_text() -> String {
    Rig::paper_default().to_toml().unwrap()
}

const RUNS_OK: &str = "\
run,t_s,depth_mm,volume_ml,pressure_kpa
a,0,40,0,0.1
a,0.02,40,0.01,0.2
b,0,0,0,0.05
";

// ---------------------------------------------------------------------------
// The contract's own example.

#[test]
fn contract_example_rig_is_the_paper_default() {
    let doc = data_format_md();
    let rig_text = fenced_block(&doc, "```toml", "## rig.toml");
    let (rig, warnings) = Rig::parse("rig.toml", &rig_text).unwrap();
    assert_eq!(rig, Rig::paper_default());
    assert!(warnings.is_empty(), "{warnings:?}");
}

#[test]
fn contract_example_runs_parse() {
    let doc = data_format_md();
    let csv = fenced_block(&doc, "```", "Example:");
    let exp = Experiment::parse(&paper_rig_text(), &[("runs.csv", &csv)]).unwrap();
    assert_eq!(exp.runs.len(), 1);
    let run = &exp.runs[0];
    assert_eq!(run.id, "h40_q1");
    assert_eq!(run.depth_mm, 40.0);
    let got: Vec<(f64, f64, f64)> = run
        .samples
        .iter()
        .map(|s| (s.t_s, s.volume_ml, s.pressure_kpa))
        .collect();
    assert_eq!(got, [(0.0, 0.0, 0.2263), (0.02, 0.0, 0.2627)]);
    assert!(exp.warnings.is_empty());
}

// ---------------------------------------------------------------------------
// Round trips.

fn awkward_experiment() -> Experiment {
    let mut rig = Rig::paper_default();
    rig.skin = None;
    rig.container = Some(Container {
        width_mm: Some(40.5),
        length_mm: 1e3 / 3.0,
    });
    rig.measurement = Measurement {
        pressure_source: PressureSource::PistonForce,
        pressure_noise_kpa: None,
    };
    let sample = |t_s: f64, v: f64, p: f64, d: Option<f64>, extra: [&str; 2]| Sample {
        t_s,
        volume_ml: v,
        pressure_kpa: p,
        diameter_mm: d,
        extra: extra.iter().map(|s| s.to_string()).collect(),
    };
    let mut exp = Experiment::new(
        rig,
        vec![
            Run {
                id: "h40, quoted \"run\"".into(),
                depth_mm: 40.0,
                samples: vec![
                    sample(0.0, 0.0, -0.0, None, ["Idle", ""]),
                    sample(
                        0.1 + 0.2,
                        1e-300,
                        12.345678901234567,
                        Some(18.7),
                        ["Expand", "x,y"],
                    ),
                    sample(
                        1e5,
                        -3.25,
                        9999.999999999998,
                        Some(25.000000000000004),
                        ["Fault", "Leak"],
                    ),
                ],
            },
            Run {
                id: "free".into(),
                depth_mm: 0.0,
                samples: vec![sample(5e-324, 2.0 / 3.0, 0.1, None, ["", ""])],
            },
        ],
    );
    exp.extra_columns = vec!["state".into(), "fault".into()];
    exp
}

#[test]
fn write_then_read_gives_the_same_experiment() {
    let exp = awkward_experiment();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("new/folder");
    exp.write(&out).unwrap();
    let mut names: Vec<_> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    names.sort();
    assert_eq!(names, [RIG_FILE, RUNS_FILE]);
    let back = Experiment::read(&out).unwrap();
    assert_eq!(back, exp);
    // Bit-exact, not merely ==.
    assert_eq!(
        back.runs[0].samples[1].pressure_kpa.to_bits(),
        12.345678901234567f64.to_bits()
    );
    assert!(back.runs[0].samples[0].pressure_kpa.is_sign_negative());
    // The extra columns are reported, once per file.
    assert_eq!(back.warnings.len(), 2, "{:?}", back.warnings);
    assert!(back.warnings[0].contains("column `state`"));
    // Writing again over the same folder is fine.
    back.write(&out).unwrap();
}

#[test]
fn paper_rig_round_trips_through_toml() {
    for rig in [Rig::paper_default(), awkward_experiment().rig] {
        let (back, warnings) = Rig::parse("rig.toml", &rig.to_toml().unwrap()).unwrap();
        assert_eq!(back, rig);
        assert!(warnings.is_empty());
    }
}

fn any_run(index: usize) -> impl Strategy<Value = Run> {
    // Every bit pattern of a finite double, folded into the column's
    // plausible range (rig::PLAUSIBLE_RANGES).
    let finite = prop::num::f64::NORMAL | prop::num::f64::SUBNORMAL | prop::num::f64::ZERO;
    let volume = finite.prop_map(|v| v % 1e4);
    let pressure = finite.prop_map(|v| (v % 1e4).max(-100.0));
    (
        prop_oneof![Just(0.0), 0.0..500.0f64],
        prop::collection::vec(
            (
                1e-9..10.0f64,
                volume,
                pressure,
                prop::option::of(1e-3..1e3f64),
            ),
            1..20,
        ),
    )
        .prop_map(move |(depth_mm, rows)| {
            let mut t_s = 0.0;
            let samples = rows
                .into_iter()
                .map(|(dt, volume_ml, pressure_kpa, diameter_mm)| {
                    let s = Sample {
                        t_s,
                        volume_ml,
                        pressure_kpa,
                        diameter_mm,
                        extra: vec![],
                    };
                    t_s += dt;
                    s
                })
                .collect();
            Run {
                id: format!("run-{index}"),
                depth_mm,
                samples,
            }
        })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn any_experiment_round_trips(a in any_run(0), b in any_run(1)) {
        let exp = Experiment::new(Rig::paper_default(), vec![a, b]);
        let dir = tempfile::tempdir().unwrap();
        exp.write(dir.path()).unwrap();
        prop_assert_eq!(Experiment::read(dir.path()).unwrap(), exp);
    }
}

#[test]
fn several_files_are_read_in_name_order() {
    let dir = folder(&[
        (RIG_FILE, RIG_NO_SAND),
        (
            "b.csv",
            "run,t_s,depth_mm,volume_ml,pressure_kpa\nsecond,0,0,0,1\n",
        ),
        (
            "a.csv",
            "run,t_s,depth_mm,volume_ml,pressure_kpa,diameter_mm\nfirst,0,0,0,1,19\n",
        ),
        ("notes.txt", "not data"),
    ]);
    let exp = Experiment::read(dir.path()).unwrap();
    let ids: Vec<&str> = exp.runs.iter().map(|r| r.id.as_str()).collect();
    assert_eq!(ids, ["first", "second"]);
    assert_eq!(exp.runs[0].samples[0].diameter_mm, Some(19.0));
    assert_eq!(exp.runs[1].samples[0].diameter_mm, None);
    assert_eq!(
        exp.rig.measurement.pressure_source,
        PressureSource::PistonForce
    );
    assert_eq!(exp.rig.sand, None);
}

#[test]
fn spreadsheet_exports_read() {
    // A UTF-8 byte-order mark, CRLF line ends and padded cells, as saved by
    // common spreadsheet programs.
    let runs = "\u{feff}run, t_s ,depth_mm,volume_ml,pressure_kpa\r\na, 0.5 ,0,1,2\r\n";
    let dir = folder(&[(RIG_FILE, RIG_NO_SAND), ("runs.csv", runs)]);
    let exp = Experiment::read(dir.path()).unwrap();
    assert_eq!(exp.runs[0].id, "a");
    assert_eq!(exp.runs[0].samples[0].t_s, 0.5);
    assert!(exp.warnings.is_empty(), "{:?}", exp.warnings);
}

// ---------------------------------------------------------------------------
// Errors name file, line and key or column.

#[test]
fn lines_count_every_line_of_the_file() {
    // CRLF, a byte-order mark and an empty line: the bad value is on line 4.
    let runs = "\u{feff}run,t_s,depth_mm,volume_ml,pressure_kpa\r\na,0,0,0,1\r\n\r\na,1,0,x,1\r\n";
    assert_error(
        &[(RIG_FILE, RIG_NO_SAND), ("runs.csv", runs)],
        ("runs.csv", Some(4), Some("volume_ml")),
        "runs.csv:4: volume_ml: `x` is not a number",
    );
    // Bytes that are not UTF-8 name their line.
    let dir = folder(&[(RIG_FILE, RIG_NO_SAND)]);
    let runs = b"run,t_s,depth_mm,volume_ml,pressure_kpa\na,0,0,0,1\na,1,0,0,\xff\n";
    std::fs::write(dir.path().join("runs.csv"), runs).unwrap();
    let err = Experiment::read(dir.path()).unwrap_err();
    let e = err.downcast_ref::<DataError>().unwrap();
    assert_eq!(
        (e.file.as_str(), e.line, e.message.as_str()),
        ("runs.csv", Some(3), "not valid UTF-8"),
        "{err:#}"
    );
}

#[test]
fn not_a_number_names_line_and_column() {
    let runs = "run,t_s,depth_mm,volume_ml,pressure_kpa\na,0,40,0,0.1\na,0.02,40,0.01,abc\n";
    assert_error(
        &[(RIG_FILE, &paper_rig_text()), ("runs.csv", runs)],
        ("runs.csv", Some(3), Some("pressure_kpa")),
        "runs.csv:3: pressure_kpa: `abc` is not a number",
    );
}

#[test]
fn non_finite_and_empty_values_are_errors() {
    let rig = paper_rig_text();
    let header = "run,t_s,depth_mm,volume_ml,pressure_kpa\n";
    assert_error(
        &[
            (RIG_FILE, &rig),
            ("runs.csv", &format!("{header}a,0,0,NaN,1\n")),
        ],
        ("runs.csv", Some(2), Some("volume_ml")),
        "runs.csv:2: volume_ml: `NaN` is not a finite number",
    );
    assert_error(
        &[
            (RIG_FILE, &rig),
            ("runs.csv", &format!("{header}a,,0,0,1\n")),
        ],
        ("runs.csv", Some(2), Some("t_s")),
        "runs.csv:2: t_s: empty",
    );
    assert_error(
        &[
            (RIG_FILE, &rig),
            ("runs.csv", &format!("{header}a,0,0,0,1\n,1,0,0,1\n")),
        ],
        ("runs.csv", Some(3), Some("run")),
        "runs.csv:3: run: empty run id",
    );
    assert_error(
        &[
            (RIG_FILE, &rig),
            ("runs.csv", &format!("{header}a,-1,0,0,1\n")),
        ],
        ("runs.csv", Some(2), Some("t_s")),
        "runs.csv:2: t_s: -1 is negative",
    );
}

#[test]
fn missing_rig_key_is_named() {
    let rig = RIG_NO_SAND.replace("initial_diameter_mm = 18.7\n", "");
    assert_error(
        &[
            (RIG_FILE, &rig),
            (
                "runs.csv",
                "run,t_s,depth_mm,volume_ml,pressure_kpa\na,0,0,0,1\n",
            ),
        ],
        ("rig.toml", None, Some("actuator.initial_diameter_mm")),
        "rig.toml: actuator.initial_diameter_mm: missing key",
    );
    let rig = RIG_NO_SAND.replace("[pump]\nsyringe_bore_mm = 29.21\n", "");
    assert_error(
        &[
            (RIG_FILE, &rig),
            (
                "runs.csv",
                "run,t_s,depth_mm,volume_ml,pressure_kpa\na,0,0,0,1\n",
            ),
        ],
        ("rig.toml", None, Some("pump")),
        "rig.toml: pump: missing section",
    );
}

#[test]
fn bad_rig_values_name_their_line() {
    let runs = (
        "runs.csv",
        "run,t_s,depth_mm,volume_ml,pressure_kpa\na,0,0,0,1\n",
    );
    // RIG_NO_SAND starts with an empty line: [actuator] is line 2.
    let rig = RIG_NO_SAND.replace("expansion_length_mm = 20.0", "expansion_length_mm = \"20\"");
    assert_error(
        &[(RIG_FILE, &rig), runs],
        ("rig.toml", Some(4), Some("actuator.expansion_length_mm")),
        "rig.toml:4: actuator.expansion_length_mm: expected a number, found a string",
    );
    let rig = RIG_NO_SAND.replace("\"piston_force\"", "\"manometer\"");
    assert_error(
        &[(RIG_FILE, &rig), runs],
        ("rig.toml", Some(15), Some("measurement.pressure_source")),
        "rig.toml:15: measurement.pressure_source: \"manometer\" is not \"line_sensor\" or \"piston_force\"",
    );
    let rig = format!("{RIG_NO_SAND}\n[sand]\ngrain_radius_mm = 0.36\ngrain_density_kg_m3 = 2920\nporosity = 1.4\nfriction = 0.25\n");
    assert_error(
        &[(RIG_FILE, &rig), runs],
        ("rig.toml", Some(20), Some("sand.porosity")),
        "rig.toml:20: sand.porosity: 1.4 is not a number strictly between 0 and 1",
    );
    let rig = RIG_NO_SAND.replace("skin_thickness_mm = 1.75", "skin_thickness_mm = 9.35");
    assert_error(
        &[(RIG_FILE, &rig), runs],
        ("rig.toml", Some(5), Some("actuator.skin_thickness_mm")),
        "rig.toml:5: actuator.skin_thickness_mm: 9.35 is not below half of `actuator.initial_diameter_mm` (18.7)",
    );
    let rig = RIG_NO_SAND.replace("[pump]", "[pump");
    assert_error(
        &[(RIG_FILE, &rig), runs],
        ("rig.toml", Some(11), None),
        "rig.toml:11: unclosed table, expected `]` (column 6)",
    );
}

#[test]
fn unknown_keys_and_columns_are_warnings() {
    let rig = format!("{RIG_NO_SAND}operator = \"ada\"\n\n[camera]\nfps = 30\n");
    let runs = "run,t_s,depth_mm,volume_ml,pressure_kpa,temp_c\na,0,0,0,1,21.5\n";
    let dir = folder(&[(RIG_FILE, &rig), ("runs.csv", runs)]);
    let exp = Experiment::read(dir.path()).unwrap();
    assert_eq!(
        exp.warnings,
        [
            "rig.toml line 18: unknown section or key `camera` ignored",
            "rig.toml line 16: unknown key `measurement.operator` ignored",
            "runs.csv line 1: column `temp_c` is not in the format; kept as text, ignored by the tools",
        ]
    );
    assert_eq!(exp.extra_columns, ["temp_c"]);
    assert_eq!(exp.runs[0].samples[0].extra, ["21.5"]);
}

#[test]
fn header_problems_are_named() {
    let rig = paper_rig_text();
    assert_error(
        &[
            (RIG_FILE, &rig),
            ("runs.csv", "run,t_s,depth_mm,pressure_kpa\na,0,0,1\n"),
        ],
        ("runs.csv", Some(1), Some("volume_ml")),
        "runs.csv:1: volume_ml: missing column",
    );
    assert_error(
        &[
            (RIG_FILE, &rig),
            ("runs.csv", "run,t_s,t_s,depth_mm,volume_ml,pressure_kpa\n"),
        ],
        ("runs.csv", Some(1), Some("t_s")),
        "runs.csv:1: t_s: appears twice in the header",
    );
    assert_error(
        &[
            (RIG_FILE, &rig),
            (
                "runs.csv",
                "run,t_s,depth_mm,volume_ml,pressure_kpa\na,0,0,0,1\na,1,0,0\n",
            ),
        ],
        ("runs.csv", Some(3), None),
        "runs.csv:3: 4 fields, but the header has 5",
    );
}

#[test]
fn rows_must_be_in_time_order() {
    let runs = "run,t_s,depth_mm,volume_ml,pressure_kpa\na,0,0,0,1\na,0.02,0,0,1\na,0.01,0,0,1\n";
    assert_error(
        &[(RIG_FILE, RIG_NO_SAND), ("runs.csv", runs)],
        ("runs.csv", Some(4), Some("t_s")),
        "runs.csv:4: t_s: 0.01 is not after 0.02 (line 3); rows of run `a` must be in increasing time",
    );
    let repeated = "run,t_s,depth_mm,volume_ml,pressure_kpa\na,0,0,0,1\na,0,0,0,1\n";
    assert_error(
        &[(RIG_FILE, RIG_NO_SAND), ("runs.csv", repeated)],
        ("runs.csv", Some(3), Some("t_s")),
        "runs.csv:3: t_s: 0 is not after 0 (line 2)",
    );
}

#[test]
fn a_run_must_be_contiguous_and_in_one_file() {
    let interleaved =
        "run,t_s,depth_mm,volume_ml,pressure_kpa\na,0,0,0,1\na,1,0,0,1\nb,0,0,0,1\na,2,0,0,1\n";
    assert_error(
        &[(RIG_FILE, RIG_NO_SAND), ("runs.csv", interleaved)],
        ("runs.csv", Some(5), Some("run")),
        "runs.csv:5: run: run `a` continues after other rows (it ran from line 2 to 3)",
    );
    let header = "run,t_s,depth_mm,volume_ml,pressure_kpa\n";
    assert_error(
        &[
            (RIG_FILE, RIG_NO_SAND),
            ("1.csv", &format!("{header}x,0,0,0,1\nx,1,0,0,1\n")),
            ("2.csv", &format!("{header}y,0,0,0,1\nx,2,0,0,1\n")),
        ],
        ("2.csv", Some(3), Some("run")),
        "2.csv:3: run: run `x` already appeared in 1.csv (lines 2–3)",
    );
}

#[test]
fn depth_must_be_constant_within_a_run() {
    let runs = "run,t_s,depth_mm,volume_ml,pressure_kpa\na,0,40,0,1\na,1,40,0,1\na,2,50,0,1\n";
    assert_error(
        &[(RIG_FILE, &paper_rig_text()), ("runs.csv", runs)],
        ("runs.csv", Some(4), Some("depth_mm")),
        "runs.csv:4: depth_mm: 50 differs from the depth 40 of run `a` (line 2)",
    );
}

#[test]
fn sand_is_required_only_below_sand() {
    let header = "run,t_s,depth_mm,volume_ml,pressure_kpa\n";
    let free = format!("{header}w,0,0,0,1\n");
    assert!(Experiment::parse(RIG_NO_SAND, &[("runs.csv", &free)]).is_ok());
    let buried = format!("{free}h40,0,40,0,1\n");
    assert_error(
        &[(RIG_FILE, RIG_NO_SAND), ("runs.csv", &buried)],
        ("rig.toml", None, Some("sand")),
        "rig.toml: sand: missing section, required because run `h40` (runs.csv line 3) has depth_mm = 40",
    );
}

#[test]
fn empty_folders_are_errors() {
    let got = read_error(&[(RIG_FILE, RIG_NO_SAND)]);
    assert!(got.contains("no samples"), "{got}");
    let got = read_error(&[
        (RIG_FILE, RIG_NO_SAND),
        ("runs.csv", "run,t_s,depth_mm,volume_ml,pressure_kpa\n"),
    ]);
    assert!(got.contains("runs.csv: no samples"), "{got}");
    let got = read_error(&[("runs.csv", RUNS_OK)]);
    assert!(got.contains("rig.toml"), "{got}");
}

#[test]
fn write_refuses_what_would_not_read_back() {
    let dir = folder(&[("other.csv", RUNS_OK)]);
    let exp = Experiment::new(
        Rig::paper_default(),
        vec![Run {
            id: "a".into(),
            depth_mm: 0.0,
            samples: vec![Sample {
                t_s: 0.0,
                volume_ml: 0.0,
                pressure_kpa: 1.0,
                diameter_mm: None,
                extra: vec![],
            }],
        }],
    );
    let err = format!("{:#}", exp.write(dir.path()).unwrap_err());
    assert!(err.contains("other CSV files (other.csv)"), "{err}");

    let empty_dir = tempfile::tempdir().unwrap();
    let mut spaced = exp.clone();
    spaced.runs[0].id = " a".into();
    let err = format!("{:#}", spaced.write(empty_dir.path()).unwrap_err());
    assert!(err.contains("would not read back identically"), "{err}");

    let mut unordered = exp.clone();
    let first = unordered.runs[0].samples[0].clone();
    unordered.runs[0].samples.push(first);
    let err = format!("{:#}", unordered.write(empty_dir.path()).unwrap_err());
    assert!(err.contains("runs.csv:3: t_s: 0 is not after 0"), "{err}");

    let mut nan = exp.clone();
    nan.runs[0].samples[0].pressure_kpa = f64::NAN;
    assert!(nan.write(empty_dir.path()).is_err());
    // Nothing was written by the refused attempts.
    assert_eq!(std::fs::read_dir(empty_dir.path()).unwrap().count(), 0);
}

#[test]
fn capture_decodes_around_noise() {
    let capture = decode_capture(&noisy_capture());
    assert_eq!(capture.samples().count(), 4);
    assert_eq!(capture.messages.len(), 7);
    assert_eq!(capture.frame_errors.len(), 3, "{:?}", capture.frame_errors);
    assert!(capture.frame_errors.contains(&FrameError::Crc));
    assert_eq!(capture.unterminated_bytes, 2);
}

#[test]
fn capture_converts_to_an_experiment_folder() {
    let dir = tempfile::tempdir().unwrap();
    let capture_path = dir.path().join("bench-7.bin");
    std::fs::write(&capture_path, noisy_capture()).unwrap();
    let out = dir.path().join("exp");
    let done = convert_file(&capture_path, &out, None, None, None).unwrap();
    assert_eq!(done.dropped_samples, 1);
    assert!(
        done.notes.iter().any(|n| n.contains("PLACEHOLDER")),
        "{:?}",
        done.notes
    );
    assert!(done.notes.iter().any(|n| n.contains("paper's set-up")));

    let exp = Experiment::read(&out).unwrap();
    assert_eq!(exp, done.experiment);
    assert_eq!(exp.rig, Rig::paper_default());
    assert_eq!(exp.extra_columns, EXTRA_COLUMNS);
    assert_eq!(exp.runs.len(), 1);
    let run = &exp.runs[0];
    assert_eq!(run.id, "bench-7");
    assert_eq!(run.depth_mm, 40.0);
    let rows: Vec<(f64, f64, f64)> = run
        .samples
        .iter()
        .map(|s| (s.t_s, s.volume_ml, s.pressure_kpa))
        .collect();
    // Time and volume count from the first sample with a pressure reading;
    // f32 values keep their shortest decimal form: 0.34f32 − 0.3f32 is
    // exactly 0.03999999165534973 (Sterbenz), shortest f32 form 0.03999999.
    assert_eq!(
        rows,
        [
            (0.0, 0.0, 0.1),
            (0.02, 0.03999999, 0.25),
            (0.04, 0.099999994, 1.3)
        ]
    );
    assert_eq!(
        run.samples[2].extra,
        ["Fault", "Leak", "3", "18.7", "18.75"]
    );
    assert_eq!(run.samples[0].extra, ["Idle", "", "0", "18.7", "18.75"]);
    assert!(run.samples.iter().all(|s| s.diameter_mm.is_none()));
}

#[test]
fn reboots_and_time_jumps_start_new_runs() {
    let msgs = [
        DeviceMessage::Sample(telemetry(100, 0.0, 0.1, State::Idle)),
        DeviceMessage::Sample(telemetry(120, 0.5, 0.2, State::Expand)),
        hello(),
        DeviceMessage::Sample(telemetry(u32::MAX - 1, 2.0, 0.1, State::Idle)),
        // t_ms wraps: 3 ms later.
        DeviceMessage::Sample(telemetry(1, 2.5, 0.3, State::Expand)),
        // Backwards: a new run.
        DeviceMessage::Sample(telemetry(0, 2.5, 0.3, State::Expand)),
    ];
    let capture = decode_capture(&encode_capture(&msgs).unwrap());
    let options = ConvertOptions {
        run_id: "r".into(),
        depth_mm: Some(0.0),
        rig: Rig::paper_default(),
    };
    let exp = to_experiment(&capture, &options).unwrap().experiment;
    let shape: Vec<(&str, usize)> = exp
        .runs
        .iter()
        .map(|r| (r.id.as_str(), r.samples.len()))
        .collect();
    assert_eq!(shape, [("r", 2), ("r_2", 2), ("r_3", 1)]);
    let wrapped = &exp.runs[1].samples[1];
    assert_eq!((wrapped.t_s, wrapped.volume_ml), (0.003, 0.5));
}

#[test]
fn a_sample_at_the_same_millisecond_is_left_out_and_counted() {
    // Two control steps within one millisecond (a late tick caught up):
    // the run stays one, the repeat is named in the notes.
    let msgs = [
        DeviceMessage::Sample(telemetry(100, 0.0, 0.1, State::Idle)),
        DeviceMessage::Sample(telemetry(110, 0.5, 0.2, State::Expand)),
        DeviceMessage::Sample(telemetry(110, 0.6, 0.2, State::Expand)),
        DeviceMessage::Sample(telemetry(120, 1.0, 0.3, State::Expand)),
    ];
    let capture = decode_capture(&encode_capture(&msgs).unwrap());
    let options = ConvertOptions {
        run_id: "r".into(),
        depth_mm: Some(0.0),
        rig: Rig::paper_default(),
    };
    let conversion = to_experiment(&capture, &options).unwrap();
    let runs = &conversion.experiment.runs;
    assert_eq!(runs.len(), 1);
    let t: Vec<f64> = runs[0].samples.iter().map(|s| s.t_s).collect();
    assert_eq!(t, [0.0, 0.01, 0.02]);
    assert_eq!(conversion.same_ms_samples, 1);
    assert!(
        conversion
            .notes
            .iter()
            .any(|n| n.starts_with("1 sample(s) with the same t_ms")),
        "{:?}",
        conversion.notes
    );
}

#[test]
fn depth_changes_split_runs_and_missing_depth_is_an_error() {
    let msgs = [
        params_at(0.0),
        DeviceMessage::Sample(telemetry(0, 0.0, 0.1, State::Idle)),
        params_at(40.0),
        DeviceMessage::Sample(telemetry(10, 0.0, 0.1, State::Idle)),
    ];
    let capture = decode_capture(&encode_capture(&msgs).unwrap());
    let options = ConvertOptions {
        run_id: "d".into(),
        depth_mm: None,
        rig: Rig::paper_default(),
    };
    let exp = to_experiment(&capture, &options).unwrap().experiment;
    let depths: Vec<f64> = exp.runs.iter().map(|r| r.depth_mm).collect();
    assert_eq!(depths, [0.0, 40.0]);

    let no_params = decode_capture(
        &encode_capture(&[DeviceMessage::Sample(telemetry(0, 0.0, 0.1, State::Idle))]).unwrap(),
    );
    let err = format!("{:#}", to_experiment(&no_params, &options).unwrap_err());
    assert!(err.contains("--depth-mm"), "{err}");
}
