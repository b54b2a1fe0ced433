//! The axial forces on the front half of the zone and its head, frame by
//! frame through the paper's expansion: what pushes the head forward and
//! what holds it back (the crate README).
//! `cargo run --profile sim --target host-tuple -p burrow --example head_forces -- [DEPTH_MM] [round]`
//! (default 40 mm; `round`: the zone's rings kept round). The head is
//! free here (the scenario's default draws it back; `simulate` reports
//! the body's pull on it).
//!
//! Front half: the nodes ahead of mid-length, the head's ring included.
//! Per frame, each force's z component (N, + forward): the fluid's pressure
//! on those nodes, the sand's contacts on them, the wall's internal force
//! across mid-length (the elements cut there; the others sum to zero), and
//! the sand on the head's face. At rest they balance, up to the wall's
//! damping and the head's inertia.

use anyhow::{Context, Result};
use burrow::{build, run, HeadSupport, ScenarioSpec};
use fem::Skin;
use nalgebra::Vector3;
use skin::StrainEnergy;

fn main() -> Result<()> {
    // On a worker of rayon's pool, as `host-sim` runs.
    rayon::scope(|_| run_case())
}

fn run_case() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let depth_mm: f64 = match args.first() {
        Some(s) => s.parse().with_context(|| format!("DEPTH_MM: {s}"))?,
        None => 40.0,
    };
    let mut spec = ScenarioSpec::paper(depth_mm * 1e-3, 1.5e-3);
    spec.round_zone = args.iter().any(|a| a == "round");
    spec.head = HeadSupport::Free;
    let bar = run::progress_bar(false)?;
    let mut bed = build(&spec)?;
    run::settle(&mut bed, &bar)?;
    run::advance(&mut bed, &bar)?;
    println!("frame,diameter_mm,head_mm,fluid_n,sand_on_skin_n,wall_across_n,face_n");
    let mut frame = 0;
    run::inflate(&mut bed, &bar, |b, _| {
        let face_n = b
            .coupling
            .face
            .as_ref()
            .map_or(0.0, |f| -f.normal_force_n() * f.normal.z);
        let [fluid, sand, wall] = front_half_n(&b.coupling.skin)?;
        let skin = &b.coupling.skin;
        println!(
            "{frame},{:.3},{:.4},{fluid:.5},{sand:.5},{wall:.5},{face_n:.5}",
            skin.outer_diameter_at_mid_length_m() * 1e3,
            skin.head.map_or(0.0, |h| h.displacement_m * 1e3),
        );
        frame += 1;
        Ok(())
    })?;
    Ok(())
}

/// Fluid, sand-contact and internal (across mid-length) z forces on the
/// nodes ahead of mid-length (N).
fn front_half_n<S: StrainEnergy>(skin: &Skin<S>) -> Result<[f64; 3]> {
    let n = skin.node_count();
    let mut pressure = vec![Vector3::zeros(); n];
    skin.add_pressure_forces_n(&mut pressure);
    let mut internal = vec![Vector3::zeros(); n];
    skin.internal_forces_n(&mut internal)?;
    let mid = 0.5 * skin.spec.length_m + skin.head.map_or(0.0, |h| 0.5 * h.displacement_m);
    let mut sums = [0.0; 3];
    for a in (0..n).filter(|&a| skin.position_m[a].z > mid) {
        sums[0] += pressure[a].z;
        sums[1] += skin.external_force_n[a].z;
        sums[2] -= internal[a].z;
    }
    Ok(sums)
}
