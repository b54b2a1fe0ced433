//! Force evaluation: contacts of each listed pair (computed once per pair,
//! in parallel over the flat pair list), then per particle, in a fixed
//! order, the sum of its pairs, its wall contacts and its buoyant weight.

use nalgebra::Vector3;
use rayon::prelude::*;

use super::contact::{ContactForce, ContactGeometry, History};
use super::neighbour::NeighbourList;
use super::particles::Particles;
use super::walls::{Wall, WallShape};
use super::Params;

/// Pairs per parallel task.
const PAIR_CHUNK: usize = 2048;
/// Particles per parallel task in the gather (also fixes the order of the
/// wall-force partial sums, so totals do not depend on the thread count).
const GATHER_CHUNK: usize = 512;

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
/// contacts into `force_n`/`torque_n_m`, keeping the wall contacts'
/// history and each chunk's force on each wall in `walls`.
pub(crate) fn gather(
    params: &Params,
    p: &mut Particles,
    list: &NeighbourList,
    pairs: &[ContactForce],
    walls: &mut WallContacts,
) {
    let stride = params.walls.len().max(1);
    let dt = params.dt_s;
    let body_accel = params.gravity_m_s2 * params.buoyancy_factor();
    let mut force = std::mem::take(&mut p.force_n);
    let mut torque = std::mem::take(&mut p.torque_n_m);
    let pr: &Particles = p;
    let near = &walls.near;
    (
        force.par_chunks_mut(GATHER_CHUNK),
        torque.par_chunks_mut(GATHER_CHUNK),
        walls.history.par_chunks_mut(GATHER_CHUNK * stride),
        walls.open.par_chunks_mut(GATHER_CHUNK),
        walls.partial.par_chunks_mut(stride),
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
                // Walls that can touch i before the next list build, and
                // those it touched last step (to clear their history).
                let candidates = near[i] | mask[k];
                for (w, wall) in params.walls.iter().enumerate() {
                    let bit = 1u64 << w.min(63);
                    if candidates & bit == 0 {
                        continue;
                    }
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

/// Most walls [`WallContacts`] culls by: with more, every wall is checked.
const MAX_CULLED_WALLS: usize = 64;

/// Per-particle state of the wall contacts.
#[derive(Clone, Debug, Default)]
pub(crate) struct WallContacts {
    /// Contact history of particle i on wall w at `i * stride + w`
    /// (stride = max(walls, 1)).
    pub(crate) history: Vec<History>,
    /// Bit w set while particle i touches wall w (walls past the 64th
    /// share bit 63).
    pub(crate) open: Vec<u64>,
    /// Bit w set if particle i can touch wall w before the next list build
    /// ([`WallContacts::cull`]); only those and the open ones are checked.
    pub(crate) near: Vec<u64>,
    /// The list build and wall shapes `near` was made for.
    near_for: (u64, Vec<WallShape>),
    /// Chunk c's force on wall w at `c * stride + w` (N), summed in chunk
    /// order for totals independent of the thread count.
    pub(crate) partial: Vec<Vector3<f64>>,
}

impl WallContacts {
    /// Whether the arrays fit `n` particles and `walls` walls.
    pub(crate) fn fits(&self, n: usize, walls: usize) -> bool {
        self.history.len() == n * walls.max(1) && self.open.len() == n
    }

    /// Empties every contact and sizes the arrays for `n` particles and
    /// `walls` walls.
    pub(crate) fn reset(&mut self, n: usize, walls: usize) {
        let stride = walls.max(1);
        self.history = vec![History::default(); n * stride];
        self.open = vec![u64::MAX; n];
        self.near_for = (u64::MAX, Vec::new());
        self.partial = vec![Vector3::zeros(); n.div_ceil(GATHER_CHUNK).max(1) * stride];
    }

    /// Marks, per particle, the walls it can touch while it stays within
    /// half the skin (m) of `list.reference_m`: those closer than the skin
    /// to its surface there. Redone when the list was rebuilt or the walls
    /// moved (the caller changed them); every wall when there are more than
    /// [`MAX_CULLED_WALLS`].
    pub(crate) fn cull(
        &mut self,
        walls: &[Wall],
        p: &Particles,
        list: &NeighbourList,
        skin_m: f64,
    ) {
        let shapes = walls.iter().map(|w| w.shape);
        if self.near_for.0 == list.builds
            && self.near.len() == p.len()
            && shapes.clone().eq(self.near_for.1.iter().copied())
        {
            return;
        }
        self.near_for = (list.builds, shapes.collect());
        if walls.len() > MAX_CULLED_WALLS {
            self.near.clear();
            self.near.resize(p.len(), u64::MAX);
            return;
        }
        list.reference_m
            .par_iter()
            .zip(p.radius_m.par_iter())
            .map(|(x, &r)| {
                walls
                    .iter()
                    .enumerate()
                    .filter(|(_, wall)| wall.clearance_m(x, r) < skin_m)
                    .fold(0u64, |m, (w, _)| m | 1 << w)
            })
            .collect_into_vec(&mut self.near);
    }

    /// Total force on each wall (N) from the chunks' partial sums.
    pub(crate) fn totals(&self, out: &mut [Vector3<f64>]) {
        let stride = out.len().max(1);
        for (w, total) in out.iter_mut().enumerate() {
            *total = self
                .partial
                .iter()
                .skip(w)
                .step_by(stride)
                .fold(Vector3::zeros(), |a, b| a + b);
        }
    }
}
