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
