//! What the DEM's test files share: the benchmark's sand and the seeded
//! jitter of its lattices.
#![allow(dead_code)] // each test file uses its own subset

use dem::contact::Material;

/// The benchmark's grains (shared/bench): E 1e7 Pa, ν 0.3, 2920 kg/m³.
pub fn sand() -> Material {
    Material {
        youngs_modulus_pa: 1.0e7,
        poisson_ratio: 0.3,
        density_kg_m3: 2920.0,
    }
}

/// A seeded draw, uniform in ±`half_width` (a 64-bit LCG, Knuth's
/// constants: the same lattice on every machine).
pub fn jitter(seed: u64, half_width: f64) -> impl FnMut() -> f64 {
    let mut s = seed;
    move || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((s >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 2.0 * half_width
    }
}

/// A sink that adds no force but does not say so: the solver keeps the
/// particles themselves current at every step, as before it could keep the
/// motion in its packed rows alone.
pub struct Plain;

impl dem::Sink for Plain {}

/// Everything a step leaves behind, bit for bit.
pub type Snapshot = (
    Vec<nalgebra::Vector3<f64>>,
    Vec<nalgebra::Vector3<f64>>,
    Vec<nalgebra::Vector3<f64>>,
    Vec<nalgebra::Vector3<f64>>,
    Vec<nalgebra::Vector3<f64>>,
    Vec<nalgebra::Vector3<f64>>,
    u64,
    u64,
    u64,
);

/// `s`'s particles, wall forces, time, step count and list builds.
pub fn snapshot(s: &dem::State) -> Snapshot {
    let p = &s.particles;
    (
        p.position_m.clone(),
        p.velocity_m_s.clone(),
        p.angular_velocity_rad_s.clone(),
        p.force_n.clone(),
        p.torque_n_m.clone(),
        s.wall_forces_n().to_vec(),
        s.time_s.to_bits(),
        s.step_count,
        s.neighbours().builds,
    )
}

/// Runs `steps` (which must sum to 1,500) from `state` twice: one step at
/// a time with [`Plain`], and in `advance` calls of those lengths with
/// `()`, whose motion then lives in the packed rows between the steps of
/// a call; asserts the same bits and returns the stepped end state.
pub fn rows_only_matches_plain(params: &dem::Params, state: &dem::State) -> dem::State {
    let (mut stepped, mut advanced) = (state.clone(), state.clone());
    for _ in 0..1_500 {
        dem::step(params, &mut stepped, &mut Plain).unwrap();
    }
    for chunk in [1, 7, 500, 0, 992] {
        dem::advance(params, &mut advanced, &mut (), chunk).unwrap();
    }
    assert!(stepped.neighbours().builds > 2, "no list rebuild tested");
    assert!(
        snapshot(&stepped) == snapshot(&advanced),
        "the motion kept in the rows gives other bits"
    );
    stepped
}
