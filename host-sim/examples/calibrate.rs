//! One scenario run with the calibration knobs on the command line, one
//! summary line out (for sweeps): `cargo run --profile sim --example
//! calibrate -- DEPTH_MM RADIUS_MM ROLLING DEPOSITION [quick|full] [SEED] [ABOVE_MM]
//! [WALL_MU] [SKIN_SCALE] [AHEAD_MM] [FACE_RADIUS_MM] [ADVANCE_MM] [EXPANSION_S]
//! [GRAIN_MODULUS_PA] [DEPOSITION_MODULUS_PA] [SHELL] [BELOW_MM] [BOX_WIDTH_MM] [ROUND]
//! [ADVANCE_S] [AROUND ALONG] [HOLD_S] [HEAD_HELD] [LAYERS] [END_ROW_MM] [MASS_SCALED]
//! [SKIN_MU]`
//! (face radius 0: one grain size; shell 1: the skin as a shell,
//! `ScenarioSpec::with_shell`, else the membrane; below: the floor under
//! the axis; round 1: the zone's rings kept round; advance: its duration;
//! around, along: the membrane's mesh, default 24 × 6; hold: the pause
//! after the advance, the head held, before the expansion; head held 1:
//! the head held through the expansion too, 0 (default here, unlike
//! `simulate`): free, 2: drawn back by the meridian law, −R: drawn back R mm
//! (`ScenarioSpec::head`); layers n ≥ 1: the skin as a
//! solid wall n hexahedra thick, `ScenarioSpec::with_solid`, with the
//! around × along mesh when given, 0 (default here, unlike `simulate`):
//! the membrane, `ScenarioSpec::with_membrane`; end row: the graded rows' length at the
//! clamped ends, 0 for equal rows; mass scaled 0: the solid wall keeps
//! its own mass while the bed settles, `ScenarioSpec::skin_mass_scaling`;
//! skin mu: the grains' friction on the skin, `ScenarioSpec::skin_friction`).

use anyhow::{Context, Result};
use host_sim::simulate::{simulate, Options, ScenarioSpec};

fn main() -> Result<()> {
    // On a worker of rayon's pool, as `host-sim` runs (its main.rs: the
    // parallel loops are not handed across threads).
    rayon::scope(|_| run())
}

fn run() -> Result<()> {
    let a: Vec<String> = std::env::args().skip(1).collect();
    let num = |i: usize, d: f64| -> Result<f64> {
        a.get(i).map_or(Ok(d), |s| {
            s.parse().with_context(|| format!("argument {i}: {s}"))
        })
    };
    let (h, r) = (num(0, 40.0)? * 1e-3, num(1, 1.5)? * 1e-3);
    // Spec defaults for anything not given (num's fallbacks read them).
    let mut spec = if a.get(4).map(String::as_str) == Some("full") {
        ScenarioSpec::paper(h, r)
    } else {
        ScenarioSpec::quick(h, r)
    };
    spec.rolling_friction = num(2, spec.rolling_friction)?;
    spec.deposition_friction = num(3, spec.deposition_friction)?;
    spec.seed = num(5, 1.0)? as u64;
    spec.wall_friction = num(7, spec.wall_friction)?;
    spec.skin_friction = num(27, spec.skin_friction)?;
    spec.skin_stiffness_scale = num(8, spec.skin_stiffness_scale)?;
    spec.ahead_m = num(9, spec.ahead_m * 1e3)? * 1e-3;
    let face_r = num(10, 0.0)? * 1e-3;
    spec.face_grain_radius_m = (face_r > 0.0).then_some(face_r);
    spec.advance_m = num(11, spec.advance_m * 1e3)? * 1e-3;
    spec.expansion_s = num(12, spec.expansion_s)?;
    spec.grain_modulus_pa = num(13, spec.grain_modulus_pa)?;
    spec.deposition_modulus_pa = num(14, spec.deposition_modulus_pa)?;
    spec.below_m = num(16, spec.below_m * 1e3)? * 1e-3;
    spec.box_width_m = num(17, spec.box_width_m * 1e3)? * 1e-3;
    spec.settle_s = ScenarioSpec::column_settle_s(spec.below_m + spec.above_m);
    spec.round_zone = num(18, 0.0)? != 0.0;
    spec.advance_s = num(19, spec.advance_s)?;
    // LAYERS 0 (the default here): the membrane, as in the sweeps before
    // the solid wall became the scenario's skin, so their commands still
    // reproduce them.
    let layers = num(24, 0.0)? as usize;
    spec = if layers > 0 {
        spec.with_solid(layers)
    } else if num(15, 0.0)? != 0.0 {
        spec.with_shell()
    } else {
        spec.with_membrane()
    };
    spec.skin_mesh = (
        num(20, spec.skin_mesh.0 as f64)? as usize,
        num(21, spec.skin_mesh.1 as f64)? as usize,
    );
    let end_row = num(25, spec.skin_end_row_m.map_or(0.0, |m| m * 1e3))?;
    spec.skin_end_row_m = (end_row > 0.0).then_some(end_row * 1e-3);
    spec.advance_hold_s = num(22, spec.advance_hold_s)?;
    // HEAD_HELD: 1 held, 0 free (the sweeps before session 14), else
    // drawn (2: the meridian law, -R: drawn back R mm).
    spec.head = match num(23, 0.0)? {
        0.0 => host_sim::simulate::HeadSupport::Free,
        1.0 => host_sim::simulate::HeadSupport::Held,
        2.0 => host_sim::simulate::HeadSupport::Drawn,
        r => host_sim::simulate::HeadSupport::DrawnBy(-r * 1e-3),
    };
    spec.skin_mass_scaling = num(26, 1.0)? != 0.0;
    let above = num(6, 0.0)? * 1e-3;
    if above > 0.0 {
        spec = spec.with_surcharge(above, 2);
    }
    let rep = simulate(&Options {
        spec,
        out: None,
        progress: false,
    })?;
    let m = rep.final_means().context("no samples")?;
    let st = &rep.settled;
    println!(
        "h {:>3.0} n {} above {:.0} r {:.2} mu_r {:.2} wall {:.2} skin_mu {:.2} skin {:.1} ahead {:.0} dep {:.2} adv {:.2} s seed {} | settled p_e {:.3} p_h {:.3} surface {:.1} | start p_h {:.3} | final p_i {:.3} dp_i {:.3} p_e {:.3} p_h {:.3} drop {:5.1}% (>=22mm {:5.1}%) D_r {:.2} vm {:.4} E {:.0e} (settled at {:.0e}) {}{} bend {:.2} calipers {:.2}-{:.2} mm mesh {}x{} | {:.0} s, skin steps/DEM step {:.2}, added mass {:.2}",
        h * 1e3, rep.grains.0 + rep.grains.1, rep.spec.above_m * 1e3, r * 1e3, rep.spec.rolling_friction, rep.spec.wall_friction, rep.spec.skin_friction, rep.spec.skin_stiffness_scale, rep.spec.ahead_m * 1e3, rep.spec.deposition_friction, rep.spec.advance_s, rep.spec.seed,
        st.sand_pressure_pa * 1e-3, st.face_pressure_pa * 1e-3, st.surface_m * 1e3,
        rep.initial_face_pressure_pa() * 1e-3,
        m.internal_pressure_pa * 1e-3, m.sand_share_pa * 1e-3, m.sand_pressure_pa * 1e-3, m.face_pressure_pa * 1e-3,
        100.0 * rep.face_pressure_drop().unwrap_or(f64::NAN),
        100.0 * rep.face_pressure_drop_beyond(rep.spec.face_drop_from_m()).unwrap_or(f64::NAN),
        m.head_receding_m * 1e3,
        m.max_von_mises_pa * 1e-6, rep.spec.grain_modulus_pa, rep.spec.deposition_modulus_pa, if rep.spec.skin_layers > 0 { format!("solid x{}", rep.spec.skin_layers) } else if rep.spec.skin_bending { "shell".to_string() } else { "membrane".to_string() }, if rep.spec.round_zone { " (round)" } else { "" }, m.max_bending_strain.unwrap_or(f64::NAN), rep.last().map_or(f64::NAN, |s| s.calipers_m.0 * 1e3), rep.last().map_or(f64::NAN, |s| s.calipers_m.1 * 1e3), rep.spec.skin_mesh.0, rep.spec.skin_mesh.1, rep.wall_s,
        rep.skin_steps_per_dem_step, rep.skin_added_mass
    );
    Ok(())
}
