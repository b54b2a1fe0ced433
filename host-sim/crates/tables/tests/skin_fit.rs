//! Any fitted law drives the firmware table: `fit-skin`'s Gent fit of the
//! shipped synthetic *U. unicinctus* data, through `--skin-fit`, against
//! the default skin (the Yeoh fit of the same data).

use std::path::{Path, PathBuf};

use model::pressure_model::SkinSandModel;
use skin::{SkinFitChoice, StrainEnergy};
use tables::{
    generate, GeneratedTable, TableSand, TableSpec, TablesOutcome, TablesSettings, TABLE_SAND,
};

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
    // (the sand is the same: the parametric law, which does not depend on
    // the skin it is added to).
    let with_gent = TableSand::Parametric
        .model_with_skin(&repo(), Some(&chosen))
        .unwrap();
    let with_yeoh = TableSand::Parametric.model(&repo()).unwrap();
    let tg = GeneratedTable::sample(&spec, &*with_gent).unwrap();
    let ty = GeneratedTable::sample(&spec, &*with_yeoh).unwrap();
    let n = spec.diameters_mm.len();
    for (k, (g, y)) in tg.pressure_kpa.iter().zip(&ty.pressure_kpa).enumerate() {
        let d = spec.diameters_mm[k % n];
        if f64::from(d) > 18.7 + 1e-3 {
            assert!(g > y, "D {d} mm, row {}: Gent {g} vs Yeoh {y} kPa", k / n);
        }
    }
    // The committed solver sand was measured on the default skin: with the
    // Gent skin it is refused, naming the file and both skins.
    let e = format!(
        "{:#}",
        TABLE_SAND
            .model_with_skin(&repo(), Some(&chosen))
            .err()
            .unwrap()
    );
    assert!(
        e.contains(sand::solver::DATA_PATH)
            && e.contains("skin_law = Yeoh")
            && e.contains("the table's skin is Gent mu_kpa = ")
            && e.contains("solver-sand --rig"),
        "{e}"
    );
    // Near rest both tubes are linear: their pressures stand as the small-
    // strain moduli (Gent's μ against Yeoh's 2·C10).
    let repo = repo();
    let g = SkinSandModel::paper_default()
        .with_skin(gent.clone(), chosen.source.clone())
        .unwrap();
    let y = SkinSandModel::paper_default();
    let ratio = g.membrane_kpa(18.75).unwrap() / y.membrane_kpa(18.75).unwrap();
    let want = gent.shear_modulus_kpa() / yeoh.shear_modulus_kpa();
    println!(
        "p_membrane at 18.75 mm: Gent/Yeoh {ratio:.4}, μ ratio {want:.4}; at {d_max:.1} mm: {:.3} vs {:.3} kPa",
        g.membrane_kpa(d_max).unwrap(),
        y.membrane_kpa(d_max).unwrap()
    );
    assert!((ratio / want - 1.0).abs() < 0.01, "{ratio} vs {want}");

    // The paper's table with --skin-fit: refused (its solver sand is the
    // default skin's), the way to a consistent table named.
    let paper = TablesSettings {
        repo: repo.clone(),
        check: false,
        rig: None,
        skin_fit: Some(choice.clone()),
        out: Some(dir.path().join("refused.rs")),
        image: None,
    };
    let e = format!("{:#}", generate(&paper).unwrap_err());
    assert!(e.contains("skin_law") && e.contains("Gent"), "{e}");
    assert!(!dir.path().join("refused.rs").exists());

    // A rig's table with a solver file made for the Gent skin
    // (`solver-sand --rig RIG --skin-fit ... --out FILE` records it).
    let rig_dir = dir.path().join("rig");
    std::fs::create_dir_all(&rig_dir).unwrap();
    let rig_file = rig_dir.join("rig.toml");
    std::fs::write(&rig_file, rig::Rig::paper_default().to_toml().unwrap()).unwrap();
    let sand_file = dir.path().join("gent-sand.csv");
    let sand_text = |law: &str| {
        format!(
            "# {} = 0.0104\n# {} = {law}\ndepth_mm,diameter_mm,p_e_kpa,samples\n\
             40,18.9,0.30,5\n40,25.0,2.00,5\n100,18.9,0.50,5\n100,25.0,5.80,5\n",
            sand::solver::UNIT_WEIGHT_KEY,
            sand::solver::SKIN_LAW_KEY,
        )
    };
    std::fs::write(&sand_file, sand_text(&gent.describe())).unwrap();
    // The file: the law and the regenerating command in its header; a
    // rerun with the same options finds it fresh.
    let out = dir.path().join("gent.rs");
    let settings = TablesSettings {
        repo: repo.clone(),
        check: false,
        rig: Some((rig_file.clone(), sand_file.clone())),
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
    // The same file for the rig's own [skin] is refused.
    let own = TablesSettings {
        skin_fit: None,
        check: false,
        ..check
    };
    let e = format!("{:#}", generate(&own).unwrap_err());
    assert!(
        e.contains("gent-sand.csv") && e.contains("the table's skin is Yeoh"),
        "{e}"
    );
}
