//! A table for another actuator: a rig's own solver sand gives its own
//! table, and a solver file of another actuator is refused.

use sand::solver::{SKIN_LAW_KEY, UNIT_WEIGHT_KEY};
use sand::SolverSand;

/// A solver file of another actuator (D0 = 30 mm), as `solver-sand --rig`
/// writes it.
/// It records the skin it ran: the paper rig's `[skin]`, as a rig's table
/// takes it.
fn other_actuator_file(d0_line: &str) -> String {
    let skin = rig::Rig::paper_default().skin_law().describe();
    format!(
        "# {UNIT_WEIGHT_KEY} = 0.0090\n{d0_line}\n# {SKIN_LAW_KEY} = {skin}\ndepth_mm,diameter_mm,p_e_kpa,samples\n\
         40,30.2,0.40,5\n40,35.0,1.20,5\n40,40.0,1.50,5\n100,30.2,1.00,5\n100,40.0,3.80,5\n"
    )
}

#[test]
fn a_rigs_solver_file_gives_its_actuators_table() {
    use model::pressure_model::SkinSandModel;
    use rig::Rig;
    use tables::{GeneratedTable, TableSpec};
    let sand =
        SolverSand::parse(&other_actuator_file("# initial_diameter_mm = 30"), "s.csv").unwrap();
    assert_eq!(sand.initial_diameter_mm(), 30.0);
    let mut rig = Rig::paper_default();
    rig.actuator.initial_diameter_mm = 30.0;
    rig.actuator.expansion_length_mm = 28.0;
    let spec = TableSpec::for_rig(&rig);
    // The paper's relative span (18.7 → 26.2 mm) from D0 = 30 mm, within
    // the firmware's column limit.
    let last = *spec.diameters_mm.last().unwrap();
    assert_eq!(spec.diameters_mm[0], 30.0);
    assert!(
        (f64::from(last) - 30.0 * 26.2 / 18.7).abs() < 1e-4,
        "{last}"
    );
    assert!(spec.diameters_mm.len() <= 48);
    let model = SkinSandModel::for_rig(&rig, "rig.toml", sand).unwrap();
    // The table's p_i is the rig's skin tube plus the file's sand: at
    // D = 40 mm, h = 100 mm the sand adds the stored 3.8 kPa.
    let p = model::pressure_model::PressureModel::internal_pressure_kpa(&model, 40.0, 100.0);
    let skin = model.membrane_kpa(40.0).unwrap();
    assert!((p - skin - 3.8).abs() < 1e-9, "{p} {skin}");
    let table = GeneratedTable::sample(&spec, &model).unwrap();
    assert_eq!(table.as_table().verify(), Ok(()));
    assert!(table.provenance.contains("the rig's [skin]") && table.provenance.contains("D0=30"));
    // The paper's rig gives the paper's grid.
    assert_eq!(
        TableSpec::for_rig(&Rig::paper_default()),
        TableSpec::default()
    );
}

#[test]
fn a_solver_file_of_another_actuator_is_refused_and_a_bad_d0_named() {
    use model::pressure_model::SkinSandModel;
    use rig::Rig;
    let sand =
        SolverSand::parse(&other_actuator_file("# initial_diameter_mm = 30"), "s.csv").unwrap();
    let e = SkinSandModel::for_rig(&Rig::paper_default(), "lab/rig.toml", sand)
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("D0 = 30 mm") && e.contains("lab/rig.toml") && e.contains("18.7"),
        "{e}"
    );
    let e = SolverSand::parse(
        &other_actuator_file("# initial_diameter_mm = wide"),
        "s.csv",
    )
    .unwrap_err();
    assert_eq!(
        (e.file.as_str(), e.line, e.key.as_deref()),
        ("s.csv", Some(2), Some("initial_diameter_mm")),
        "{e}"
    );
    // Without the key: the paper's actuator.
    let sand = SolverSand::parse(&other_actuator_file("# no diameter here"), "s.csv").unwrap();
    assert_eq!(sand.initial_diameter_mm(), 18.7);
}

#[test]
fn a_solver_file_of_another_skin_or_of_none_is_refused() {
    use model::pressure_model::SkinSandModel;
    use rig::Rig;
    let mut rig = Rig::paper_default();
    rig.actuator.initial_diameter_mm = 30.0;
    let file = other_actuator_file("# initial_diameter_mm = 30");
    // The rig's skin twice as stiff: the file's sand was measured on the
    // other one.
    let mut stiffer = rig.clone();
    if let Some(s) = &mut stiffer.skin {
        s.c10_kpa *= 2.0;
    }
    let sand = SolverSand::parse(&file, "lab/sand.csv").unwrap();
    assert_eq!(sand.skin_law(), Some(rig.skin_law().describe().as_str()));
    assert!(SkinSandModel::for_rig(&rig, "lab/rig.toml", sand.clone()).is_ok());
    let e = SkinSandModel::for_rig(&stiffer, "lab/rig.toml", sand)
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("lab/sand.csv")
            && e.contains(&format!("skin_law = {}", rig.skin_law().describe()))
            && e.contains(&format!(
                "the table's skin is {}",
                stiffer.skin_law().describe()
            )),
        "{e}"
    );
    // A file that does not say which skin: refused too.
    let silent: String = file
        .lines()
        .filter(|l| !l.contains(SKIN_LAW_KEY))
        .map(|l| format!("{l}\n"))
        .collect();
    let sand = SolverSand::parse(&silent, "old.csv").unwrap();
    assert_eq!(sand.skin_law(), None);
    let e = SkinSandModel::for_rig(&rig, "lab/rig.toml", sand)
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("old.csv") && e.contains("no `# skin_law = ...`"),
        "{e}"
    );
}
