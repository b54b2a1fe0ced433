//! Force evaluation: contacts of each listed pair (computed once per pair,
//! in parallel over the flat pair list), then per particle, in a fixed
//! order, the sum of its pairs, its wall contacts and its buoyant weight.

use nalgebra::Vector3;
use rayon::prelude::*;

use super::contact::{ContactForce, ContactGeometry, History};
use super::neighbour::NeighbourList;
use super::particles::Particles;
use super::walls::Wall;
use super::Params;

/// Pairs per parallel task.
const PAIR_CHUNK: usize = 2048;
/// Particles per parallel task in the gather (also fixes the order of the
/// wall-force partial sums, so totals do not depend on the thread count).
pub(crate) const GATHER_CHUNK: usize = 512;

/// Geometry of the pair (i, j), if the spheres overlap.
#[inline]
fn pair_geometry(p: &Particles, i: usize, j: usize) -> Option<ContactGeometry> {
    let dx = p.position_m[i] - p.position_m[j];
    let (ri, rj) = (p.radius_m[i], p.radius_m[j]);
    let sum = ri + rj;
    let d2 = dx.norm_squared();
    if d2 >= sum * sum {
        return None;
    }
    let d = d2.sqrt();
    let n = dx / d;
    let vr = p.velocity_m_s[i] - p.velocity_m_s[j];
    let vn = vr.dot(&n);
    // Contact-point velocities: v_i − R_i ω_i × n minus v_j + R_j ω_j × n.
    let spin = p.angular_velocity_rad_s[i] * ri + p.angular_velocity_rad_s[j] * rj;
    let vt = vr - n * vn - spin.cross(&n);
    let (mi, mj) = (p.mass_kg[i], p.mass_kg[j]);
    Some(ContactGeometry {
        normal: n,
        overlap_m: sum - d,
        radius_eff_m: ri * rj / sum,
        mass_eff_kg: mi * mj / (mi + mj),
        normal_velocity_m_s: vn,
        tangential_velocity_m_s: vt,
        relative_spin_rad_s: p.angular_velocity_rad_s[i] - p.angular_velocity_rad_s[j],
    })
}

/// Geometry of particle i against `wall`, if they touch.
#[inline]
fn wall_geometry(p: &Particles, i: usize, wall: &Wall) -> Option<ContactGeometry> {
    let r = p.radius_m[i];
    let (n, overlap) = wall.touch(&p.position_m[i], r)?;
    let vr = p.velocity_m_s[i] - wall.velocity_m_s;
    let vn = vr.dot(&n);
    let vt = vr - n * vn - (p.angular_velocity_rad_s[i] * r).cross(&n);
    Some(ContactGeometry {
        normal: n,
        overlap_m: overlap,
        radius_eff_m: r,
        mass_eff_kg: p.mass_kg[i],
        normal_velocity_m_s: vn,
        tangential_velocity_m_s: vt,
        relative_spin_rad_s: p.angular_velocity_rad_s[i],
    })
}

/// Evaluates every listed pair into `out` (one entry per pair, zero when
/// apart; the history of a pair apart is cleared).
pub(crate) fn pair_forces(
    params: &Params,
    p: &Particles,
    list: &mut NeighbourList,
    out: &mut [ContactForce],
) {
    let model = &params.pair_model;
    let dt = params.dt_s;
    (
        list.pair_i.par_chunks(PAIR_CHUNK),
        list.pair_j.par_chunks(PAIR_CHUNK),
        list.history.par_chunks_mut(PAIR_CHUNK),
        out.par_chunks_mut(PAIR_CHUNK),
    )
        .into_par_iter()
        .for_each(|(pi, pj, hist, out)| {
            for k in 0..pi.len() {
                let (i, j) = (pi[k] as usize, pj[k] as usize);
                out[k] = match pair_geometry(p, i, j) {
                    Some(g) => model.evaluate(&g, dt, &mut hist[k]),
                    None => {
                        hist[k] = History::default();
                        ContactForce::default()
                    }
                };
            }
        });
}

/// Sums, per particle, body force, pair forces from `pairs` and wall
/// contacts into `force_n`/`torque_n_m`. Wall histories are
/// `wall_history[i * stride + w]`, with bit w of `wall_mask[i]` set while
/// that contact is open (walls past the 64th share bit 63);
/// `wall_partial[c * stride + w]` receives
/// chunk c's force on wall w (N) (stride = max(walls, 1)).
pub(crate) fn gather(
    params: &Params,
    p: &mut Particles,
    list: &NeighbourList,
    pairs: &[ContactForce],
    wall_history: &mut [History],
    wall_mask: &mut [u64],
    wall_partial: &mut [Vector3<f64>],
) {
    let stride = params.walls.len().max(1);
    let dt = params.dt_s;
    let body_accel = params.gravity_m_s2 * params.buoyancy_factor();
    let mut force = std::mem::take(&mut p.force_n);
    let mut torque = std::mem::take(&mut p.torque_n_m);
    let pr: &Particles = p;
    (
        force.par_chunks_mut(GATHER_CHUNK),
        torque.par_chunks_mut(GATHER_CHUNK),
        wall_history.par_chunks_mut(GATHER_CHUNK * stride),
        wall_mask.par_chunks_mut(GATHER_CHUNK),
        wall_partial.par_chunks_mut(stride),
    )
        .into_par_iter()
        .enumerate()
        .for_each(|(c, (f, t, wh, mask, wp))| {
            wp.iter_mut().for_each(|w| *w = Vector3::zeros());
            for k in 0..f.len() {
                let i = c * GATHER_CHUNK + k;
                let ri = pr.radius_m[i];
                let mut fi = body_accel * pr.mass_kg[i];
                let mut ti = Vector3::zeros();
                for cf in &pairs[list.start[i] as usize..list.start[i + 1] as usize] {
                    fi += cf.force_n;
                    ti += cf.torque_per_radius_n * ri + cf.rolling_torque_n_m;
                }
                for &q in &list.rev_pair[list.rev_start[i] as usize..list.rev_start[i + 1] as usize]
                {
                    let cf = &pairs[q as usize];
                    fi -= cf.force_n;
                    ti += cf.torque_per_radius_n * ri - cf.rolling_torque_n_m;
                }
                let mut touching = 0u64;
                for (w, wall) in params.walls.iter().enumerate() {
                    let bit = 1u64 << w.min(63);
                    match wall_geometry(pr, i, wall) {
                        Some(g) => {
                            let h = &mut wh[k * stride + w];
                            let cf = wall.model.evaluate(&g, dt, h);
                            fi += cf.force_n;
                            ti += cf.torque_per_radius_n * ri + cf.rolling_torque_n_m;
                            wp[w] -= cf.force_n;
                            touching |= bit;
                        }
                        // Clear a history only where a contact just opened
                        // (keeps the step from streaming every history).
                        None if mask[k] & bit != 0 => wh[k * stride + w] = History::default(),
                        None => {}
                    }
                }
                mask[k] = touching;
                f[k] = fi;
                t[k] = ti;
            }
        });
    p.force_n = force;
    p.torque_n_m = torque;
}
