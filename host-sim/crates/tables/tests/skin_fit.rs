//! Any fitted law drives the firmware table: `fit-skin`'s Gent fit of the
//! shipped synthetic *U. unicinctus* data, through `--skin-fit`, against
//! the default skin (the Yeoh fit of the same data).

use std::path::{Path, PathBuf};

use model::pressure_model::SkinSandModel;
use skin::{SkinFitChoice, StrainEnergy};
use tables::{generate, GeneratedTable, TableSpec, TablesOutcome, TablesSettings, TABLE_SAND};

/// The repository root (this crate is host-sim/crates/tables).
fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../..")
}

#[test]
fn a_gent_fit_drives_the_table_and_stiffens_it_as_its_law_does() {
    let dir = tempfile::tempdir().unwrap();
    let fit = skin::report::fit_skin(
        &repo().join("host-sim/data/skin/unicinctus_circumferential.csv"),
        dir.path(),
    )
    .unwrap();
    let choice = SkinFitChoice {
        file: fit.json_path.clone(),
        law: Some("Gent".into()),
    };
    let chosen = choice.read().unwrap();
    assert_eq!(chosen.law.name(), "Gent");
    assert_eq!(
        chosen.law.parameters(),
        fit.report.fit("Gent").unwrap().parameters
    );
    let yeoh = skin::default_skin();
    let gent = chosen.law.clone();

    // The laws' own prediction: both depend on I1 alone, so the wall's
    // stress at a given shape is 2·W1(I1) times the same kinematics. W1
    // of the Gent fit exceeds the Yeoh fit's over every I1 the table's
    // widest tube reaches (the bore's, largest in the wall, with margin).
    let spec = TableSpec::default();
    let d_max = f64::from(*spec.diameters_mm.last().unwrap());
    let tube = skin::membrane::Tube::paper(yeoh, skin::membrane::Ends::Closed);
    let st = tube.state(d_max).unwrap();
    let (lt, lz) = (st.hoop_stretch_inner, st.axial_stretch);
    let i1_max = skin::invariants([lt, lz, 1.0 / (lt * lz)]).0 + 0.2;
    let steps = 200;
    for k in 0..=steps {
        let i1 = 3.0 + (i1_max - 3.0) * f64::from(k) / f64::from(steps);
        assert!(
            gent.dw_di1_kpa(i1, 3.0) > yeoh.dw_di1_kpa(i1, 3.0),
            "I1 {i1}"
        );
    }

    // So every cell of the Gent table above D0 lies above the Yeoh one
    // (the sand is the same).
    let with_gent = TABLE_SAND.model_with_skin(&repo(), Some(&chosen)).unwrap();
    let with_yeoh = TABLE_SAND.model(&repo()).unwrap();
    let tg = GeneratedTable::sample(&spec, &*with_gent).unwrap();
    let ty = GeneratedTable::sample(&spec, &*with_yeoh).unwrap();
    let n = spec.diameters_mm.len();
    for (k, (g, y)) in tg.pressure_kpa.iter().zip(&ty.pressure_kpa).enumerate() {
        let d = spec.diameters_mm[k % n];
        if f64::from(d) > 18.7 + 1e-3 {
            assert!(g > y, "D {d} mm, row {}: Gent {g} vs Yeoh {y} kPa", k / n);
        }
    }
    // Near rest both tubes are linear: their pressures stand as the small-
    // strain moduli (Gent's μ against Yeoh's 2·C10).
    let repo = repo();
    let g = SkinSandModel::paper_solver(&repo)
        .unwrap()
        .with_skin(gent.clone(), chosen.source.clone())
        .unwrap();
    let y = SkinSandModel::paper_solver(&repo).unwrap();
    let ratio = g.membrane_kpa(18.75).unwrap() / y.membrane_kpa(18.75).unwrap();
    let want = gent.shear_modulus_kpa() / yeoh.shear_modulus_kpa();
    println!(
        "p_membrane at 18.75 mm: Gent/Yeoh {ratio:.4}, μ ratio {want:.4}; at {d_max:.1} mm: {:.3} vs {:.3} kPa",
        g.membrane_kpa(d_max).unwrap(),
        y.membrane_kpa(d_max).unwrap()
    );
    assert!((ratio / want - 1.0).abs() < 0.01, "{ratio} vs {want}");

    // The file: the law and the regenerating command in its header; a
    // rerun with the same options finds it fresh.
    let out = dir.path().join("gent.rs");
    let settings = TablesSettings {
        repo: repo.clone(),
        check: false,
        rig: None,
        skin_fit: Some(choice),
        out: Some(out.clone()),
        image: None,
    };
    assert_eq!(generate(&settings).unwrap().outcome, TablesOutcome::Written);
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(text.contains("Gent mu_kpa = "), "{}", &text[..600]);
    assert!(text.contains("--skin-fit ") && text.contains("--skin-law Gent"));
    let check = TablesSettings {
        check: true,
        ..settings
    };
    assert_eq!(generate(&check).unwrap().outcome, TablesOutcome::Unchanged);
}
