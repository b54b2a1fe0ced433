//! Particle–wall contacts: which particles can touch which wall before the
//! next list build (the cull), their histories, and their forces, four
//! touching contacts of one wall at a time (SIMD).
//!
//! Each (wall, particle) that the cull keeps is an *entry*. The entries lie
//! by chunk of [`WALL_CHUNK`] particles, then by wall, then by particle,
//! each with its own history beside it, so a chunk's contacts are read and
//! written in order rather than scattered over every particle's slots.
//! An evaluation reads the current histories and writes the next ones,
//! swapped in once the step's forces stand: a step whose evaluation turns
//! out stale (the list had to be rebuilt after it) redoes it from the same
//! histories.
//!
//! A step's wall contacts are evaluated either after the pair pass, added
//! to the sums directly ([`wall_forces`]), or inside the first sweep, right
//! after a chunk has drifted and while its rows are still in the caches,
//! and kept per entry until the next sweep adds them before it reads the
//! sums ([`SweepWalls`]). Either way each particle adds its wall contacts
//! after its pair contacts, wall by wall, so the sums are the same bits.

use std::ops::Range;

use nalgebra::Vector3;

use super::contact::{ContactGeometry, History, Lanes, Real, HISTORY_LEN, LANE_COUNT};
use super::forces::{simd, Simd};
use super::neighbour::NeighbourList;
use super::particles::{Motion, Packed, Particles, Sphere};
use super::team::Team;
use super::walls::{Wall, WallShape};
use super::{split_lengths, Params};

/// Particles per wall chunk: the unit of the parallel tasks and of the
/// wall-force partial sums (whose order so does not depend on the thread
/// count).
pub(crate) const WALL_CHUNK: usize = 512;

/// Most walls [`WallContacts`] culls by: with more, every wall is checked.
const MAX_CULLED_WALLS: usize = 64;

/// Wall w's bit in the per-particle masks (walls past the 64th share bit 63).
fn bit(w: usize) -> u64 {
    1u64 << w.min(63)
}

/// Per-entry state of the wall contacts.
#[derive(Clone, Debug, Default)]
pub(crate) struct WallContacts {
    /// Particles and walls the arrays are sized for.
    size: (usize, usize),
    /// Each entry's particle: chunk c's entries on wall w are
    /// `particle[start[c * walls + w]..start[c * walls + w + 1]]`,
    /// ascending.
    particle: Vec<u32>,
    start: Vec<usize>,
    /// Each entry's tangential history (zero unless it touched) and
    /// whether it touched, at the last evaluation.
    history: Vec<History>,
    touching: Vec<u8>,
    /// What the evaluation under way writes, swapped in when it stands.
    next_history: Vec<History>,
    next_touching: Vec<u8>,
    /// Each touching entry's force (N) and torque (N·m) on its particle,
    /// from an evaluation in the first sweep, until they are added.
    force_n: Vec<Vector3<f64>>,
    torque_n_m: Vec<Vector3<f64>>,
    /// Whether `force_n`/`torque_n_m` wait to be added to the sums.
    pending: bool,
    /// Bit w set if particle i can touch wall w before the next list build
    /// ([`WallContacts::cull`]).
    near: Vec<u64>,
    /// Per particle, the walls it touched at the last evaluation (the
    /// cull's scratch).
    open: Vec<u64>,
    /// The list build and wall shapes the entries were culled for.
    near_for: (u64, Vec<WallShape>),
    /// Chunk c's force on wall w at `c * stride + w` (N), stride =
    /// max(walls, 1), summed in chunk order for totals independent of the
    /// thread count.
    partial: Vec<Vector3<f64>>,
    /// Chunk c's normal load on wall w at `c * stride + w` (N): the sum of
    /// its contacts' forces along their normals.
    partial_normal: Vec<f64>,
}

impl WallContacts {
    /// Whether the arrays fit `n` particles and `walls` walls.
    pub(crate) fn fits(&self, n: usize, walls: usize) -> bool {
        self.size == (n, walls) && self.partial.len() == chunks(n).max(1) * walls.max(1)
    }

    /// Empties every contact and sizes the arrays for `n` particles and
    /// `walls` walls.
    pub(crate) fn reset(&mut self, n: usize, walls: usize) {
        *self = WallContacts {
            size: (n, walls),
            near_for: (u64::MAX, Vec::new()),
            partial: vec![Vector3::zeros(); chunks(n).max(1) * walls.max(1)],
            partial_normal: vec![0.0; chunks(n).max(1) * walls.max(1)],
            ..WallContacts::default()
        };
    }

    /// Marks, per particle, the walls it can touch while it stays within
    /// half the skin (m) of `list.reference_m`: those closer than the skin
    /// to its surface there, or touching it at the last evaluation; every
    /// (wall, particle) so marked becomes an entry, its history carried
    /// over. Redone when the list was rebuilt or a wall moved half the
    /// skin or more since (the caller moves them; a particle within half
    /// the skin of its reference and a wall within half the skin of its
    /// culled place cannot meet unmarked), or changed its normal or axis;
    /// every wall when there are more than [`MAX_CULLED_WALLS`]. No
    /// contributions may be pending.
    pub(crate) fn cull(
        &mut self,
        walls: &[Wall],
        p: &Particles,
        list: &NeighbourList,
        skin_m: f64,
        team: &Team,
    ) {
        let moved_little = |(w, then): (&Wall, &WallShape)| {
            w.shape.shift_from(then).is_some_and(|d| d < 0.5 * skin_m)
        };
        let n = p.len();
        if self.near_for.0 == list.builds
            && self.near.len() == n
            && self.near_for.1.len() == walls.len()
            && walls.iter().zip(&self.near_for.1).all(moved_little)
        {
            return;
        }
        debug_assert!(!self.pending, "wall contributions lost to a cull");
        self.near_for = (list.builds, walls.iter().map(|w| w.shape).collect());
        self.near.clear();
        if walls.len() > MAX_CULLED_WALLS {
            self.near.resize(n, u64::MAX);
        } else {
            self.near.resize(n, 0);
            let pieces = (self.near.chunks_mut(WALL_CHUNK))
                .zip(list.reference_m.chunks(WALL_CHUNK))
                .zip(p.radius_m.chunks(WALL_CHUNK))
                .collect();
            team.map(pieces, |_, ((near, x), r)| {
                for ((near, x), &r) in near.iter_mut().zip(x).zip(r) {
                    *near = (walls.iter().enumerate())
                        .filter(|(_, wall)| wall.clearance_m(x, r) < skin_m)
                        .fold(0u64, |m, (w, _)| m | bit(w));
                }
            });
        }
        let wall_count = walls.len();
        let chunk_count = chunks(n);
        // The walls each particle touched at the last evaluation (none
        // before the first: a particle touching a wall now is near it).
        let carried = self.start.len() == chunk_count * wall_count + 1;
        self.open.clear();
        self.open.resize(n, 0);
        if carried {
            for c in 0..chunk_count {
                for w in 0..wall_count {
                    let es = self.start[c * wall_count + w]..self.start[c * wall_count + w + 1];
                    for e in es.filter(|&e| self.touching[e] != 0) {
                        self.open[self.particle[e] as usize] |= bit(w);
                    }
                }
            }
        }
        let mut particle = Vec::with_capacity(self.particle.len());
        let mut start = Vec::with_capacity(chunk_count * wall_count + 1);
        let mut history = Vec::with_capacity(self.history.len());
        let mut touching = Vec::with_capacity(self.touching.len());
        start.push(0);
        let mut mine = Vec::with_capacity(WALL_CHUNK);
        for c in 0..chunk_count {
            let range = c * WALL_CHUNK..((c + 1) * WALL_CHUNK).min(n);
            mine.clear();
            let marked = |i: &usize| self.near[*i] | self.open[*i] != 0;
            mine.extend(range.filter(marked).map(|i| i as u32));
            for w in 0..wall_count {
                let old = if carried {
                    self.start[c * wall_count + w]..self.start[c * wall_count + w + 1]
                } else {
                    0..0
                };
                let mut o = old.start;
                let on = |&&i: &&u32| (self.near[i as usize] | self.open[i as usize]) & bit(w) != 0;
                for &i in mine.iter().filter(on) {
                    // Both runs ascend: carry the history of the same
                    // particle on the same wall.
                    while o < old.end && self.particle[o] < i {
                        o += 1;
                    }
                    let kept = o < old.end && self.particle[o] == i;
                    particle.push(i);
                    history.push(if kept {
                        self.history[o]
                    } else {
                        History::default()
                    });
                    touching.push(if kept { self.touching[o] } else { 0 });
                }
                start.push(particle.len());
            }
        }
        let entries = particle.len();
        (self.particle, self.start) = (particle, start);
        (self.history, self.touching) = (history, touching);
        self.next_history.resize(entries, History::default());
        self.next_touching.resize(entries, 0);
        self.force_n.resize(entries, Vector3::zeros());
        self.torque_n_m.resize(entries, Vector3::zeros());
    }

    /// Makes the evaluation just done in the first sweep stand: its
    /// histories become the current ones, its contributions wait for the
    /// next sweep (or [`WallContacts::settle`]).
    pub(crate) fn commit_sweep(&mut self) {
        self.swap();
        self.pending = true;
    }

    fn swap(&mut self) {
        std::mem::swap(&mut self.history, &mut self.next_history);
        std::mem::swap(&mut self.touching, &mut self.next_touching);
    }

    /// Adds pending contributions to `f` (N) and `t` (N·m), every
    /// particle's.
    pub(crate) fn settle(&mut self, f: &mut [Vector3<f64>], t: &mut [Vector3<f64>]) {
        if !std::mem::take(&mut self.pending) {
            return;
        }
        let walls = self.size.1;
        for (c, (f, t)) in f
            .chunks_mut(WALL_CHUNK)
            .zip(t.chunks_mut(WALL_CHUNK))
            .enumerate()
        {
            let (entries, es) =
                Entries::chunk(&self.particle, &self.start, walls, c, c * WALL_CHUNK);
            entries.add(
                &self.touching[es.clone()],
                &self.force_n[es.clone()],
                &self.torque_n_m[es],
                f,
                t,
            );
        }
    }

    /// The first sweep's share of the wall contacts, one piece per
    /// `per_task` particles (a multiple of [`WALL_CHUNK`]): with
    /// `evaluate`, each piece evaluates its particles' contacts once they
    /// have drifted, keeping them per entry; either way it first adds the
    /// pending ones (which are then no longer pending).
    pub(crate) fn sweep_pieces<'a>(
        &'a mut self,
        params: &'a Params,
        per_task: usize,
        evaluate: bool,
    ) -> Vec<SweepWalls<'a>> {
        debug_assert_eq!(per_task % WALL_CHUNK, 0);
        let (n, walls) = self.size;
        if !evaluate && !self.pending {
            return Vec::new();
        }
        debug_assert_eq!(self.start.len(), chunks(n) * walls + 1, "not culled");
        let stride = walls.max(1);
        let per = per_task / WALL_CHUNK;
        let apply = std::mem::take(&mut self.pending);
        let task_count = n.div_ceil(per_task);
        let task_chunks = |k: usize| k * per..((k + 1) * per).min(chunks(n));
        let entries_of = |k: usize| {
            let cs = task_chunks(k);
            self.start[cs.start * walls]..self.start[cs.end * walls]
        };
        let lens: Vec<usize> = (0..task_count).map(|k| entries_of(k).len()).collect();
        let partial_lens = || (0..task_count).map(|k| task_chunks(k).len() * stride);
        let mut next_history =
            split_lengths(&mut self.next_history, lens.iter().copied()).into_iter();
        let mut next_touching =
            split_lengths(&mut self.next_touching, lens.iter().copied()).into_iter();
        let mut force = split_lengths(&mut self.force_n, lens.iter().copied()).into_iter();
        let mut torque = split_lengths(&mut self.torque_n_m, lens.iter().copied()).into_iter();
        let mut wp = split_lengths(&mut self.partial, partial_lens()).into_iter();
        let mut wn = split_lengths(&mut self.partial_normal, partial_lens()).into_iter();
        let (particle, start) = (&self.particle, &self.start);
        let (history, touching) = (&self.history, &self.touching);
        (0..task_count)
            .map_while(|k| {
                let cs = task_chunks(k);
                let es = entries_of(k);
                Some(SweepWalls {
                    params,
                    apply,
                    evaluate,
                    first_chunk: cs.start,
                    particle: &particle[es.clone()],
                    start: &start[cs.start * walls..=cs.end * walls],
                    history: &history[es.clone()],
                    touching: &touching[es],
                    out: WallOut {
                        history: next_history.next()?,
                        touching: next_touching.next()?,
                        f: force.next()?,
                        t: torque.next()?,
                        wp: wp.next()?,
                        wn: wn.next()?,
                    },
                })
            })
            .collect()
    }

    /// Total force on each wall and its normal load (N) from the chunks'
    /// partial sums.
    pub(crate) fn totals(&self, out: &mut [Vector3<f64>], normal: &mut [f64]) {
        let stride = out.len().max(1);
        for (w, (total, load)) in out.iter_mut().zip(normal.iter_mut()).enumerate() {
            *total = self
                .partial
                .iter()
                .skip(w)
                .step_by(stride)
                .fold(Vector3::zeros(), |a, b| a + b);
            *load = self.partial_normal.iter().skip(w).step_by(stride).sum();
        }
    }
}

/// Number of wall chunks of `n` particles.
fn chunks(n: usize) -> usize {
    n.div_ceil(WALL_CHUNK)
}

/// One wall chunk's entries: its particles from `lo`, wall by wall.
struct Entries<'a> {
    lo: usize,
    /// The chunk's entries' particles.
    particle: &'a [u32],
    /// Wall w's entries at `start[w] - start[0]..start[w + 1] - start[0]`.
    start: &'a [usize],
}

impl<'a> Entries<'a> {
    /// Wall chunk c of the entries `particle` of whole chunks whose walls'
    /// entries start at `start` (`walls` a chunk, offsets counted from
    /// `start[0]`), its first particle `lo`; with the range of its entries
    /// in `particle`.
    fn chunk(
        particle: &'a [u32],
        start: &'a [usize],
        walls: usize,
        c: usize,
        lo: usize,
    ) -> (Self, Range<usize>) {
        let starts = &start[c * walls..=(c + 1) * walls];
        let es = starts[0] - start[0]..starts[walls] - start[0];
        let entries = Entries {
            lo,
            particle: &particle[es.clone()],
            start: starts,
        };
        (entries, es)
    }

    /// Wall w's entries (indices into the chunk's).
    fn of(&self, w: usize) -> std::ops::Range<usize> {
        self.start[w] - self.start[0]..self.start[w + 1] - self.start[0]
    }

    /// Adds the touching entries' force `fe` and torque `te` to their
    /// particles' `f` and `t` (from `lo`), each particle's wall by wall.
    fn add(
        &self,
        touching: &[u8],
        fe: &[Vector3<f64>],
        te: &[Vector3<f64>],
        f: &mut [Vector3<f64>],
        t: &mut [Vector3<f64>],
    ) {
        for w in 0..self.start.len() - 1 {
            for e in self.of(w).filter(|&e| touching[e] != 0) {
                let k = self.particle[e] as usize - self.lo;
                f[k] += fe[e];
                t[k] += te[e];
            }
        }
    }
}

/// What an evaluation of one or more wall chunks writes: the entries' next
/// histories and touching flags, their forces and torques (on the entries
/// or added to the particles' sums), and each chunk's sums per wall.
struct WallOut<'a> {
    history: &'a mut [History],
    touching: &'a mut [u8],
    f: &'a mut [Vector3<f64>],
    t: &'a mut [Vector3<f64>],
    wp: &'a mut [Vector3<f64>],
    wn: &'a mut [f64],
}

/// One wall chunk's evaluation: what it reads.
struct WallChunk<'a> {
    params: &'a Params,
    entries: Entries<'a>,
    /// The entries' current histories.
    history: &'a [History],
    /// The chunk's particles' rows (particle `entries.lo + k` at k).
    sphere: &'a [Sphere],
    motion: &'a [Motion],
}

/// The touching contacts of one wall gathered for a four-lane evaluation:
/// entry, particle in the chunk, geometry.
struct WallBatch {
    e: [usize; LANE_COUNT],
    k: [usize; LANE_COUNT],
    g: [ContactGeometry; LANE_COUNT],
    len: usize,
}

/// Geometry of the sphere with rows `sphere`, `motion` against `wall`, if
/// they touch.
#[inline(always)]
fn wall_geometry(sphere: &Sphere, motion: &Motion, wall: &Wall) -> Option<ContactGeometry> {
    let r = sphere.radius_m();
    let (n, overlap) = wall.touch(&sphere.position_m(), r)?;
    Some(ContactGeometry::sphere_on_surface(
        n,
        overlap,
        r,
        motion.mass_kg(),
        motion.velocity_m_s() - wall.velocity_m_s - n * wall.normal_velocity_m_s,
        motion.spin_rad_s(),
    ))
}

impl WallChunk<'_> {
    /// Evaluates the chunk's entries, wall by wall, four touching contacts
    /// at a time, into `out`: with `DEFER` each contact's force and torque
    /// on `out.f`, `out.t` at its entry, else added to its particle's there
    /// (from `lo`), each particle's in wall order; `out.wp[w]` sums wall
    /// w's reaction in particle order.
    #[inline(always)]
    fn run<const DEFER: bool>(&self, out: WallOut) {
        let WallOut {
            history,
            touching,
            f,
            t,
            wp,
            wn,
        } = out;
        wp.iter_mut().for_each(|w| *w = Vector3::zeros());
        wn.iter_mut().for_each(|w| *w = 0.0);
        let mut sums = (wp, wn);
        let mut out = (history, touching, f, t);
        for (w, wall) in self.params.walls.iter().enumerate() {
            let mut batch = WallBatch {
                e: [0; LANE_COUNT],
                k: [0; LANE_COUNT],
                g: [ContactGeometry::default(); LANE_COUNT],
                len: 0,
            };
            for e in self.entries.of(w) {
                let k = self.entries.particle[e] as usize - self.entries.lo;
                match wall_geometry(&self.sphere[k], &self.motion[k], wall) {
                    Some(g) => {
                        batch.e[batch.len] = e;
                        batch.k[batch.len] = k;
                        batch.g[batch.len] = g;
                        batch.len += 1;
                        if batch.len == LANE_COUNT {
                            self.evaluate::<DEFER>(w, &batch, &mut out, &mut sums);
                            batch.len = 0;
                        }
                    }
                    None => {
                        out.0[e] = History::default();
                        out.1[e] = 0;
                    }
                }
            }
            if batch.len > 0 {
                // Pad with the last contact: the same history in, the
                // same values out, and only `len` lanes are kept.
                for l in batch.len..LANE_COUNT {
                    batch.e[l] = batch.e[batch.len - 1];
                    batch.k[l] = batch.k[batch.len - 1];
                    batch.g[l] = batch.g[batch.len - 1];
                }
                self.evaluate::<DEFER>(w, &batch, &mut out, &mut sums);
            }
        }
    }

    /// Evaluates `batch` on wall `w` and writes its first `batch.len`
    /// contacts, in order; `sums` are the chunk's force on each wall and
    /// normal load on it.
    #[inline(always)]
    #[allow(clippy::type_complexity)]
    fn evaluate<const DEFER: bool>(
        &self,
        w: usize,
        batch: &WallBatch,
        (history, touching, f, t): &mut (
            &mut [History],
            &mut [u8],
            &mut [Vector3<f64>],
            &mut [Vector3<f64>],
        ),
        sums: &mut (&mut [Vector3<f64>], &mut [f64]),
    ) {
        let g = ContactGeometry::<Lanes>::gather(&batch.g);
        let mut h = [Lanes::splat(0.0); HISTORY_LEN];
        for (l, &e) in batch.e.iter().enumerate() {
            for (h, &v) in h.iter_mut().zip(&self.history[e]) {
                h.0[l] = v;
            }
        }
        let model = &self.params.walls[w].model;
        let cf = model.evaluate(&g, self.params.dt_s, &mut h);
        for l in 0..batch.len {
            let (e, k) = (batch.e[l], batch.k[l]);
            history[e] = h.map(|c| c.0[l]);
            touching[e] = 1;
            let cf = cf.lane(l);
            let r = self.sphere[k].radius_m();
            let torque = cf.torque_per_radius_n * r + cf.rolling_torque_n_m;
            if DEFER {
                f[e] = cf.force_n;
                t[e] = torque;
            } else {
                f[k] += cf.force_n;
                t[k] += torque;
            }
            sums.0[w] -= cf.force_n;
            // The push along the contact normal (wall → particle).
            sums.1[w] += cf.force_n.dot(&batch.g[l].normal);
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn run_avx2<const DEFER: bool>(&self, out: WallOut) {
        self.run::<DEFER>(out)
    }

    /// [`WallChunk::run`] with the instruction set chosen at start-up.
    fn run_with<const DEFER: bool>(&self, simd: Simd, out: WallOut) {
        #[cfg(target_arch = "x86_64")]
        if simd == Simd::Avx2 {
            // SAFETY: `Simd::Avx2` is chosen only where the CPU has AVX2.
            return unsafe { self.run_avx2::<DEFER>(out) };
        }
        let _ = simd;
        self.run::<DEFER>(out)
    }
}

/// The first sweep's share of the wall contacts for one of its tasks
/// ([`WallContacts::sweep_pieces`]).
pub(crate) struct SweepWalls<'a> {
    params: &'a Params,
    /// Whether to add the pending contributions first.
    apply: bool,
    /// Whether to evaluate the contacts after the drift.
    evaluate: bool,
    /// The task's first wall chunk.
    first_chunk: usize,
    /// The task's entries' particles, histories and touching flags, and
    /// each wall chunk's entries per wall (as `WallContacts::start`).
    particle: &'a [u32],
    start: &'a [usize],
    history: &'a [History],
    touching: &'a [u8],
    /// Its entries' next histories, touching flags, forces and torques
    /// (the pending ones until added), and its chunks' sums per wall.
    out: WallOut<'a>,
}

impl<'a> SweepWalls<'a> {
    /// Number of the task's wall chunks.
    fn chunk_count(&self) -> usize {
        (self.start.len() - 1) / self.params.walls.len().max(1)
    }

    /// The task's wall chunk c (its first particle `c * WALL_CHUNK` into
    /// the task's), with the range of its entries among the task's.
    fn chunk(&self, c: usize) -> (Entries<'a>, Range<usize>) {
        let lo = (self.first_chunk + c) * WALL_CHUNK;
        Entries::chunk(self.particle, self.start, self.params.walls.len(), c, lo)
    }

    /// Adds the pending contributions of the task's particles, whose sums
    /// are `f`, `t` (from the task's first particle), if there are any.
    pub(crate) fn add_pending(&self, f: &mut [Vector3<f64>], t: &mut [Vector3<f64>]) {
        if !self.apply || self.params.walls.is_empty() {
            return;
        }
        for c in 0..self.chunk_count() {
            let (entries, es) = self.chunk(c);
            let from = c * WALL_CHUNK;
            let to = (from + WALL_CHUNK).min(f.len());
            let (fe, te) = (&self.out.f[es.clone()], &self.out.t[es.clone()]);
            let (f, t) = (&mut f[from..to], &mut t[from..to]);
            entries.add(&self.touching[es], fe, te, f, t);
        }
    }

    /// Evaluates the task's contacts, if asked to, from the rows of its
    /// particles (`sphere`, `motion` from its first particle), just
    /// drifted.
    pub(crate) fn evaluate(&mut self, sphere: &[Sphere], motion: &[Motion]) {
        if !self.evaluate || self.params.walls.is_empty() {
            return;
        }
        let simd = simd();
        let stride = self.params.walls.len().max(1);
        for c in 0..self.chunk_count() {
            let (entries, es) = self.chunk(c);
            let from = c * WALL_CHUNK;
            let to = (from + WALL_CHUNK).min(sphere.len());
            let ps = c * stride..(c + 1) * stride;
            let chunk = WallChunk {
                params: self.params,
                entries,
                history: &self.history[es.clone()],
                sphere: &sphere[from..to],
                motion: &motion[from..to],
            };
            let out = WallOut {
                history: &mut self.out.history[es.clone()],
                touching: &mut self.out.touching[es.clone()],
                f: &mut self.out.f[es.clone()],
                t: &mut self.out.t[es],
                wp: &mut self.out.wp[ps.clone()],
                wn: &mut self.out.wn[ps],
            };
            chunk.run_with::<true>(simd, out);
        }
    }
}

/// Adds, per particle, its wall contacts to `p.force_n`/`p.torque_n_m`,
/// keeping the contacts' histories and each chunk's force on each wall in
/// `walls`; `packed` is the particles' current state. No contributions
/// may be pending.
pub(crate) fn wall_forces(
    params: &Params,
    p: &mut Particles,
    packed: &Packed,
    walls: &mut WallContacts,
    team: &Team,
) {
    debug_assert!(!walls.pending, "wall contributions pending");
    if params.walls.is_empty() {
        return;
    }
    let simd = simd();
    let wall_count = params.walls.len();
    let (n, stride) = (p.len(), wall_count.max(1));
    let chunk_count = chunks(n);
    let entries_of = |c: usize| walls.start[c * wall_count]..walls.start[(c + 1) * wall_count];
    let lens: Vec<usize> = (0..chunk_count).map(|c| entries_of(c).len()).collect();
    let mut history = split_lengths(&mut walls.next_history, lens.iter().copied()).into_iter();
    let mut touching = split_lengths(&mut walls.next_touching, lens.iter().copied()).into_iter();
    let mut wp = walls.partial.chunks_mut(stride);
    let mut wn = walls.partial_normal.chunks_mut(stride);
    let mut t = p.torque_n_m.chunks_mut(WALL_CHUNK);
    let pieces = (p.force_n.chunks_mut(WALL_CHUNK))
        .map_while(|f| {
            Some(WallOut {
                history: history.next()?,
                touching: touching.next()?,
                f,
                t: t.next()?,
                wp: wp.next()?,
                wn: wn.next()?,
            })
        })
        .collect();
    let (particle, start, current) = (&walls.particle, &walls.start, &walls.history);
    team.map(pieces, |c, out| {
        let (entries, es) = Entries::chunk(particle, start, wall_count, c, c * WALL_CHUNK);
        let rows = c * WALL_CHUNK..((c + 1) * WALL_CHUNK).min(n);
        let chunk = WallChunk {
            params,
            entries,
            history: &current[es],
            sphere: &packed.sphere[rows.clone()],
            motion: &packed.motion[rows],
        };
        chunk.run_with::<false>(simd, out);
    });
    walls.swap();
}
