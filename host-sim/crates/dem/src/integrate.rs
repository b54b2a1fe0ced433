//! Velocity Verlet for translation and rotation (spheres: isotropic
//! inertia, so ω advances like v): half kick, drift, forces, half kick.

use nalgebra::Vector3;
use rayon::prelude::*;

use super::particles::{pack_one, Packed, Particles};

/// Particles per parallel task.
const CHUNK: usize = 1024;

/// First half: v += dt/2 F/m, ω += dt/2 τ/I, x += dt v, writing the new
/// state into `packed` (resized to fit) for the force pass that follows.
/// With `close_previous`, the previous step's closing half kick (the same
/// forces, since nothing changed them) is applied first, in the same
/// operations as [`kick`]: one sweep instead of two, the same bits.
/// Once read, each force and torque is set to the body force
/// `body_accel_m_s2` × m and zero, where the pair pass would start its
/// sums (on a bed beyond the caches, a sweep of its own that came from
/// memory). Returns the largest squared displacement from `reference_m`
/// (m²), for the Verlet-list check.
pub(crate) fn kick_drift(
    p: &mut Particles,
    dt_s: f64,
    body_accel_m_s2: Vector3<f64>,
    reference_m: &[Vector3<f64>],
    packed: &mut Packed,
    close_previous: bool,
) -> f64 {
    if close_previous {
        kick_drift_in::<true>(p, dt_s, body_accel_m_s2, reference_m, packed)
    } else {
        kick_drift_in::<false>(p, dt_s, body_accel_m_s2, reference_m, packed)
    }
}

/// [`kick_drift`], compiled with and without the closing half kick
/// (`CLOSE`) so that neither pays a branch per particle.
fn kick_drift_in<const CLOSE: bool>(
    p: &mut Particles,
    dt_s: f64,
    body: Vector3<f64>,
    reference_m: &[Vector3<f64>],
    packed: &mut Packed,
) -> f64 {
    let h = 0.5 * dt_s;
    packed.resize(p.len());
    let (r, m) = (&p.radius_m, &p.mass_kg);
    (
        p.position_m.par_chunks_mut(CHUNK),
        p.velocity_m_s.par_chunks_mut(CHUNK),
        p.angular_velocity_rad_s.par_chunks_mut(CHUNK),
        p.force_n.par_chunks_mut(CHUNK),
        p.torque_n_m.par_chunks_mut(CHUNK),
        p.inv_mass_per_kg.par_chunks(CHUNK),
        p.inv_inertia_per_kg_m2.par_chunks(CHUNK),
        reference_m.par_chunks(CHUNK),
        packed.sphere.par_chunks_mut(CHUNK),
        packed.motion.par_chunks_mut(CHUNK),
    )
        .into_par_iter()
        .enumerate()
        .map(|(c, (x, v, w, f, t, im, ii, x0, sphere, motion))| {
            let mut max2 = 0.0f64;
            for k in 0..x.len() {
                let dv = f[k] * (h * im[k]);
                let dw = t[k] * (h * ii[k]);
                let i = c * CHUNK + k;
                f[k] = body * m[i];
                t[k] = Vector3::zeros();
                if CLOSE {
                    v[k] += dv;
                    w[k] += dw;
                }
                v[k] += dv;
                w[k] += dw;
                x[k] += v[k] * dt_s;
                max2 = max2.max((x[k] - x0[k]).norm_squared());
                (sphere[k], motion[k]) = pack_one(&x[k], &v[k], &w[k], r[i], m[i]);
            }
            max2
        })
        .reduce(|| 0.0, f64::max)
}

/// Second half: v += dt/2 F/m, ω += dt/2 τ/I.
pub fn kick(p: &mut Particles, dt_s: f64) {
    let h = 0.5 * dt_s;
    (
        p.velocity_m_s.par_chunks_mut(CHUNK),
        p.angular_velocity_rad_s.par_chunks_mut(CHUNK),
        p.force_n.par_chunks(CHUNK),
        p.torque_n_m.par_chunks(CHUNK),
        p.inv_mass_per_kg.par_chunks(CHUNK),
        p.inv_inertia_per_kg_m2.par_chunks(CHUNK),
    )
        .into_par_iter()
        .for_each(|(v, w, f, t, im, ii)| {
            for k in 0..v.len() {
                v[k] += f[k] * (h * im[k]);
                w[k] += t[k] * (h * ii[k]);
            }
        });
}
