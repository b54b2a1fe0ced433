//! Force evaluation, particle by particle in a fixed order: body force,
//! then each listed pair in ascending pair order (the pairs where it is the
//! second particle come first: their first particle is lower), then its
//! wall contacts. The particles are split into blocks of consecutive
//! indices (one per worker, sized by the work they took before); a block's
//! pairs are evaluated and summed by one task as it goes, four touching
//! pairs at a time (SIMD). A pair that straddles two blocks is evaluated by
//! both, each from its own copy of the same history (copied from the list
//! when the blocks were split, then kept equal by evaluating the same pair
//! from the same state), each adding its own particle's share. Each
//! particle so sums the same terms in the same order whatever the blocks,
//! and the results do not depend on the thread count.

use nalgebra::Vector3;

use super::contact::{
    ContactForce, ContactGeometry, ContactModel, History, Lanes, Real, HISTORY_LEN, LANE_COUNT,
};
use super::neighbour::NeighbourList;
use super::particles::{Packed, Particles, Sphere};
use super::periodic::Images;
use super::team::Team;
use super::{split_lengths, Params};

/// Pairs gathered and evaluated together (sized for the L1 cache).
const PAIR_CHUNK: usize = 256;
/// Listed pairs ahead of the overlap test whose second sphere's rows are
/// prefetched. Within a block the first particles run in order and the
/// hardware's stream prefetchers follow them, but each pair's second
/// particle lies a few hundred rows on, reached out of order: on a bed
/// larger than the caches those rows came from memory, one miss at a
/// time (measured: `bench scaling`, 980,000 grains, 1 worker, 181 →
/// 139 ns a particle-step at 64 pairs; 16 pairs 171, 128 pairs 138).
const PREFETCH_PAIRS: usize = 64;
/// Particles from which the bed counts as larger than the caches: the pass
/// prefetches and the first sweep streams its rows past the caches. Below,
/// the rows stay in the caches and the prefetches cost ≈ 5 % (the walled
/// benchmark's 20,000 grains, packed phase 5.59 → 5.89 s).
const FAR_FROM: usize = 100_000;

/// Whether a bed of `n` particles is larger than the caches ([`FAR_FROM`]).
pub(crate) fn far(n: usize) -> bool {
    n >= FAR_FROM
}
/// Blocks per worker: one, so that as few pairs as possible straddle two
/// blocks (each is evaluated by both); the measured times even out what the
/// work estimate misses ([`Blocks::split`]).
const BLOCKS_PER_WORKER: usize = 1;
/// Cost of a touching pair in the pass, in listed pairs apart (measured:
/// ≈ 25 ns against ≈ 5 ns); only the first split of a run relies on it.
const TOUCHING_WEIGHT: f64 = 5.0;

/// Asks the cache for the line that holds the start of `rows[k]` (a
/// sphere or motion row is one aligned line; a 24-byte force or torque
/// may reach into the next, which is left to the hardware); a hint only,
/// nothing happens off the x86-64 or out of range.
#[inline(always)]
fn prefetch<T>(rows: &[T], k: usize) {
    #[cfg(target_arch = "x86_64")]
    if let Some(row) = rows.get(k) {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        // SAFETY: a prefetch never faults, and the pointer is into `rows`.
        unsafe { _mm_prefetch::<_MM_HINT_T0>((row as *const T).cast::<i8>()) }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (rows, k);
}

/// Whether the spheres i and j overlap (with `PERIODIC`, j at its
/// nearest image: the pass is compiled once for each, so that a box with
/// no periodic axis pays nothing for them).
#[inline(always)]
fn overlapping<const PERIODIC: bool>(p: &[Sphere], i: usize, j: usize, images: &Images) -> bool {
    if PERIODIC {
        p[i].overlaps_nearest(&p[j], images)
    } else {
        p[i].overlaps(&p[j])
    }
}

/// Geometry of the overlapping pairs (i[l], j[l]), one per lane (with
/// `PERIODIC`, each j at its nearest image).
#[inline(always)]
fn pair_geometry_lanes<const PERIODIC: bool>(
    p: &Packed,
    i: &[usize; LANE_COUNT],
    j: &[usize; LANE_COUNT],
    images: &Images,
) -> ContactGeometry<Lanes> {
    let row = |k: &[usize; LANE_COUNT]| {
        (
            k.map(|k| &p.sphere[k].0),
            k.map(|k| &p.motion[k].0[0]),
            k.map(|k| &p.motion[k].0[1]),
        )
    };
    let ((xi, vi, wi), (xj, vj, wj)) = (row(i), row(j));
    let vec = |q: &[&[f64; 4]; LANE_COUNT]| {
        Vector3::new(
            Lanes(q.map(|q| q[0])),
            Lanes(q.map(|q| q[1])),
            Lanes(q.map(|q| q[2])),
        )
    };
    let fourth = |q: &[&[f64; 4]; LANE_COUNT]| Lanes(q.map(|q| q[3]));
    let mut xj_m = vec(&xj);
    if PERIODIC {
        for l in 0..LANE_COUNT {
            let d = [0, 1, 2].map(|a| xj[l][a] - xi[l][a]);
            let shift = images.shift(d);
            for (a, s) in shift.iter().enumerate() {
                xj_m[a].0[l] += s;
            }
        }
    }
    ContactGeometry::spheres(
        [&vec(&xi), &xj_m],
        [&vec(&vi), &vec(&vj)],
        [&vec(&wi), &vec(&wj)],
        [fourth(&xi), fourth(&xj)],
        [fourth(&vi), fourth(&vj)],
    )
}

/// The pairs of one block (slot s is pair `first + s` of the list), with
/// their histories and open flags (1 while the history holds a contact).
struct PairRun<'a> {
    pi: &'a [u32],
    pj: &'a [u32],
    history: &'a mut [History],
    open: &'a mut [u8],
}

impl<'a> PairRun<'a> {
    /// The pairs `ks` of the list `pi`, `pj`, with their `history` and
    /// `open` flags (already cut to `ks`).
    fn of(
        pi: &'a [u32],
        pj: &'a [u32],
        ks: std::ops::Range<usize>,
        history: &'a mut [History],
        open: &'a mut [u8],
    ) -> Self {
        PairRun {
            pi: &pi[ks.clone()],
            pj: &pj[ks],
            history,
            open,
        }
    }

    /// The overlapping pairs of the run's `slots` into `touching`,
    /// returning how many; pairs apart are marked closed. No branch on the
    /// outcome: which pairs touch is a coin toss to the branch predictor.
    #[inline(always)]
    fn sort_out<const PERIODIC: bool>(
        &mut self,
        packed: &Packed,
        images: &Images,
        slots: std::ops::Range<usize>,
        touching: &mut [u32; PAIR_CHUNK],
        far: bool,
    ) -> usize {
        let p = &packed.sphere[..];
        let last = self.pj.len().saturating_sub(1);
        let mut count = 0;
        for s in slots {
            // The sphere row for this test and the motion row for the
            // touching pair's evaluation, `PREFETCH_PAIRS` pairs on.
            if far {
                let ahead = self.pj[(s + PREFETCH_PAIRS).min(last)] as usize;
                prefetch(p, ahead);
                prefetch(&packed.motion, ahead);
            }
            let on = overlapping::<PERIODIC>(p, self.pi[s] as usize, self.pj[s] as usize, images);
            touching[count] = s as u32;
            count += usize::from(on);
            self.open[s] &= u8::from(on);
        }
        count
    }

    /// Evaluates the overlapping pairs `which` (the run's slots), four at
    /// a time, calling `put(i, j, force)` for each pair (i, j) in order (the
    /// batch's own indices: looking them up again in `put` cost ≈ 4 %); a
    /// closed pair's history starts from zero. The last batch repeats its
    /// last pair (the same history in, the same values out).
    #[inline(always)]
    fn evaluate<const PERIODIC: bool>(
        &mut self,
        p: &Packed,
        images: &Images,
        model: &ContactModel,
        dt_s: f64,
        which: &[u32],
        mut put: impl FnMut(usize, usize, ContactForce),
    ) {
        let zero = Lanes::splat(0.0);
        let last = which.len().saturating_sub(1);
        #[cfg(feature = "pass-parts")]
        if pass_parts::left_out().evaluation {
            return;
        }
        for first in (0..which.len()).step_by(LANE_COUNT) {
            let batch: [usize; LANE_COUNT] =
                std::array::from_fn(|l| which[(first + l).min(last)] as usize);
            let i = batch.map(|s| self.pi[s] as usize);
            let j = batch.map(|s| self.pj[s] as usize);
            let g = pair_geometry_lanes::<PERIODIC>(p, &i, &j, images);
            // Plain loops: the `array::from_fn` form was left out of line
            // (a call per history component, outside the AVX2 copy).
            let mut h = [zero; HISTORY_LEN];
            for (l, &s) in batch.iter().enumerate() {
                let (stored, open) = (&self.history[s], self.open[s] != 0);
                for (h, &v) in h.iter_mut().zip(stored) {
                    h.0[l] = if open { v } else { 0.0 };
                }
            }
            #[cfg(feature = "pass-parts")]
            let parts = pass_parts::left_out();
            #[cfg(feature = "pass-parts")]
            let f = if parts.law {
                pass_parts::no_law(&g)
            } else {
                model.evaluate(&g, dt_s, &mut h)
            };
            #[cfg(not(feature = "pass-parts"))]
            let f = model.evaluate(&g, dt_s, &mut h);
            for (l, &s) in batch.iter().enumerate().take(which.len() - first) {
                self.history[s] = h.map(|c| c.0[l]);
                self.open[s] = 1;
                #[cfg(feature = "pass-parts")]
                if parts.sums {
                    std::hint::black_box(f.lane(l));
                    continue;
                }
                put(i[l], j[l], f.lane(l));
            }
        }
    }
}

/// Parts of the pair pass that a measurement can leave out (feature
/// `pass-parts`, for `pass_parts_alone` only: the forces are then wrong),
/// to see what each costs on a frozen bed.
#[cfg(feature = "pass-parts")]
pub(crate) mod pass_parts {
    use super::{ContactForce, ContactGeometry, Lanes};
    use std::sync::atomic::{AtomicU8, Ordering::Relaxed};

    /// Bit 1: the contact law; bit 2: the sums into the particles; bit 4:
    /// the whole evaluation of touching pairs (overlap test only).
    static LEFT_OUT: AtomicU8 = AtomicU8::new(0);

    /// What is left out now.
    pub(crate) struct Parts {
        /// The contact law ([`no_law`] stands in).
        pub law: bool,
        /// The sums into the particles.
        pub sums: bool,
        /// Every touching pair's evaluation.
        pub evaluation: bool,
    }

    /// Leaves out the parts in `bits` (see [`LEFT_OUT`]) from now on.
    #[cfg_attr(not(test), allow(dead_code))]
    pub(crate) fn leave_out(bits: u8) {
        LEFT_OUT.store(bits, Relaxed);
    }

    /// What is left out now.
    #[inline(always)]
    pub(crate) fn left_out() -> Parts {
        let b = LEFT_OUT.load(Relaxed);
        Parts {
            law: b & 1 != 0,
            sums: b & 2 != 0,
            evaluation: b & 4 != 0,
        }
    }

    /// A stand-in for the law that reads the geometry and costs little.
    #[inline(always)]
    pub(crate) fn no_law(g: &ContactGeometry<Lanes>) -> ContactForce<Lanes> {
        ContactForce {
            force_n: g.normal * g.overlap_m,
            torque_per_radius_n: g.tangential_velocity_m_s,
            rolling_torque_n_m: g.relative_spin_rad_s,
        }
    }
}

/// The split of the particles into blocks for one list build, and the
/// pairs that straddle two blocks.
#[derive(Clone, Debug, Default)]
pub(crate) struct Blocks {
    /// The list build and block count this split was made for.
    made_for: (u64, usize),
    /// Block b holds particles `first[b]..first[b + 1]`.
    first: Vec<usize>,
    /// Estimated work of each block at the split (listed pairs, touching
    /// ones weighted, scaled by the last split's measured cost rates).
    work: Vec<f64>,
    /// Wall time each block's task took since the split (ns).
    spent_ns: Vec<u64>,
    /// Each particle's cost per unit of estimated work, as learnt from the
    /// blocks' times (1 until timed).
    rate: Vec<f64>,
    /// `incoming_start[b]..incoming_start[b + 1]`: the pairs whose second
    /// particle lies in block b and whose first lies in an earlier one, in
    /// pair order, as indices into the `incoming_*` rows below.
    incoming_start: Vec<usize>,
    /// Their first and second particles.
    incoming_i: Vec<u32>,
    incoming_j: Vec<u32>,
    /// Their list indices.
    incoming_k: Vec<u32>,
    /// Their histories and open flags, the later block's own copy (the
    /// block of the first particle updates the list's; both evolve alike).
    incoming_history: Vec<History>,
    incoming_open: Vec<u8>,
}

impl Blocks {
    /// Splits the particles of `list` into `count` blocks of about equal
    /// work, unless already split so for this build. A particle's work is
    /// its listed pairs, touching ones weighted by [`TOUCHING_WEIGHT`],
    /// times its learnt rate: at each split the rates of a block's
    /// particles are scaled by the square root of how long the block took
    /// since the last split against its estimate (relative to the mean), so
    /// a block that ran long gives up particles until the times agree.
    /// Timing only moves the split, and the forces do not depend on it: the
    /// results stay the same bits.
    fn split(&mut self, list: &NeighbourList, count: usize) {
        let n = list.start.len().saturating_sub(1);
        let count = count.clamp(1, n.max(1));
        if self.made_for == (list.builds, count) && self.first.len() == count + 1 {
            return;
        }
        match self.measured_rates(n) {
            Some((ends, ratio)) => {
                let mut b = 0;
                for (i, rate) in self.rate.iter_mut().enumerate() {
                    while i >= ends[b] {
                        b += 1;
                    }
                    // Half the correction (in logs) per split: the times
                    // are noisy, and a full step overshoots.
                    *rate = (*rate * ratio[b].sqrt()).clamp(0.25, 4.0);
                }
            }
            None if self.rate.len() != n => self.rate = vec![1.0; n],
            None => {}
        }
        self.made_for = (list.builds, count);
        let mut work = Vec::with_capacity(n + 1);
        work.push(0.0f64);
        let mut total = 0.0f64;
        for (i, &rate) in self.rate.iter().enumerate() {
            let ks = list.start[i] as usize..list.start[i + 1] as usize;
            let open: usize = list.open[ks.clone()].iter().map(|&o| usize::from(o)).sum();
            total += rate * (ks.len() as f64 + (TOUCHING_WEIGHT - 1.0) * open as f64);
            work.push(total);
        }
        self.first.clear();
        self.first.push(0);
        for b in 1..count {
            let target = total * b as f64 / count as f64;
            let at = work[..n].partition_point(|&w| w < target);
            let prev = self.first.last().copied().unwrap_or(0);
            self.first.push(at.max(prev));
        }
        self.first.push(n);
        self.work = (0..count)
            .map(|b| work[self.first[b + 1]] - work[self.first[b]])
            .collect();
        self.spent_ns.clear();
        self.spent_ns.resize(count, 0);
        let mut block = vec![0u32; n];
        for b in 0..count {
            block[self.first[b]..self.first[b + 1]].fill(b as u32);
        }
        self.incoming_start.clear();
        self.incoming_start.resize(count + 1, 0);
        let crossing = || {
            (list.pair_i.iter().zip(&list.pair_j).enumerate())
                .filter(|&(_, (&i, &j))| block[i as usize] != block[j as usize])
        };
        for (_, (_, &j)) in crossing() {
            self.incoming_start[block[j as usize] as usize + 1] += 1;
        }
        for b in 0..count {
            self.incoming_start[b + 1] += self.incoming_start[b];
        }
        let n_incoming = self.incoming_start[count];
        let mut fill = self.incoming_start[..count].to_vec();
        for v in [
            &mut self.incoming_i,
            &mut self.incoming_j,
            &mut self.incoming_k,
        ] {
            v.clear();
            v.resize(n_incoming, 0);
        }
        // Pair order within each block: the list is in pair order.
        for (k, (&i, &j)) in crossing() {
            let slot = &mut fill[block[j as usize] as usize];
            self.incoming_i[*slot] = i;
            self.incoming_j[*slot] = j;
            self.incoming_k[*slot] = k as u32;
            *slot += 1;
        }
        // The histories as the list holds them now; from here on each
        // block's pass keeps its copy equal to the list's, evaluating the
        // same pairs from the same state in the same operations.
        self.incoming_history.clear();
        (self.incoming_history).extend(self.incoming_k.iter().map(|&k| list.history[k as usize]));
        self.incoming_open.clear();
        (self.incoming_open).extend(self.incoming_k.iter().map(|&k| list.open[k as usize]));
    }

    /// Number of blocks.
    fn count(&self) -> usize {
        self.first.len() - 1
    }

    /// The last split's block ends and each block's time per unit of
    /// estimated work relative to the mean, if it was for `n` particles,
    /// had more than one block and was timed.
    fn measured_rates(&self, n: usize) -> Option<(Vec<usize>, Vec<f64>)> {
        let count = self.work.len();
        if count < 2
            || self.first.len() != count + 1
            || self.first[count] != n
            || self.rate.len() != n
        {
            return None;
        }
        let spent: u64 = self.spent_ns.iter().sum();
        let work: f64 = self.work.iter().sum();
        if spent == 0 || work <= 0.0 || self.work.iter().any(|&w| w <= 0.0) {
            return None;
        }
        let mean = spent as f64 / work;
        let rates = (self.spent_ns.iter().zip(&self.work))
            .map(|(&t, &w)| t as f64 / w / mean)
            .collect();
        Some((self.first[1..].to_vec(), rates))
    }
}

/// Adds contact `cf` (from the first particle's point of view) to a
/// particle of radius `r_m`, the pair's first or (`second`) its second.
#[inline(always)]
fn add_contact(
    f: &mut Vector3<f64>,
    t: &mut Vector3<f64>,
    cf: &ContactForce,
    r_m: f64,
    second: bool,
) {
    if second {
        *f -= cf.force_n;
        *t += cf.torque_per_radius_n * r_m - cf.rolling_torque_n_m;
    } else {
        *f += cf.force_n;
        *t += cf.torque_per_radius_n * r_m + cf.rolling_torque_n_m;
    }
}

/// The vector instructions the pair pass runs with.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Simd {
    /// What every x86-64 (or other) machine has: SSE2, two lanes per
    /// instruction.
    Baseline,
    /// AVX2 (x86-64, detected at run time): four lanes per instruction.
    Avx2,
}

/// The pair pass's instruction set: 0 = not chosen yet, else `Simd as u8 + 1`.
static SIMD: std::sync::atomic::AtomicU8 = std::sync::atomic::AtomicU8::new(0);

/// The instruction set the pair pass and the solid skin's element loop
/// use: AVX2 where the CPU has it (detected once), unless the environment
/// variable `URECHIS_DEM_SIMD=baseline` or [`use_simd`] asks for the
/// baseline. Either gives the same bits.
pub fn simd() -> Simd {
    use std::sync::atomic::Ordering::Relaxed;
    match SIMD.load(Relaxed) {
        1 => Simd::Baseline,
        2 => Simd::Avx2,
        _ => {
            let level = if std::env::var("URECHIS_DEM_SIMD").is_ok_and(|v| v == "baseline") {
                Simd::Baseline
            } else {
                best_simd()
            };
            SIMD.store(level as u8 + 1, Relaxed);
            level
        }
    }
}

/// The best instruction set this CPU offers the pair pass.
pub fn best_simd() -> Simd {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        return Simd::Avx2;
    }
    Simd::Baseline
}

/// Makes the pair pass use `level` from now on, process-wide (benchmarks
/// compare the two; results are the same bits). A level the CPU lacks is
/// refused: the best one is used and returned instead.
pub fn use_simd(level: Simd) -> Simd {
    let level = if level == Simd::Avx2 {
        best_simd()
    } else {
        level
    };
    SIMD.store(level as u8 + 1, std::sync::atomic::Ordering::Relaxed);
    level
}

/// What every block's task reads.
struct Inputs<'a> {
    p: &'a Particles,
    packed: &'a Packed,
    images: &'a Images,
    model: &'a ContactModel,
    dt_s: f64,
    body_accel: Vector3<f64>,
    /// Whether the bed is too large for the caches, so that the pass
    /// prefetches what it will reach out of order ([`FAR_FROM`]).
    far: bool,
    /// Whether the sums already hold the body force and no torque (the
    /// integrator's sweep set them, in the same operations).
    preset: bool,
}

/// Runs `$call` on `$run` in its AVX2 copy when `$simd` says so (the
/// method's body is inlined into a function compiled for AVX2), else in
/// the baseline one.
macro_rules! dispatch {
    ($simd:expr, $run:ident . $avx2:ident / $any:ident ( $($arg:expr),* )) => {{
        #[cfg(target_arch = "x86_64")]
        if $simd == $crate::Simd::Avx2 {
            // SAFETY: `Simd::Avx2` is chosen only where the CPU has AVX2.
            unsafe { $run.$avx2($($arg),*) }
        } else {
            $run.$any($($arg),*)
        }
        #[cfg(not(target_arch = "x86_64"))]
        $run.$any($($arg),*)
    }};
}

impl PairRun<'_> {
    /// The forces on block `lo..hi` (`f`, `t` from `lo`): body force, the
    /// pairs `incoming` from earlier blocks (to their second particle
    /// only, from the block's own copy of their histories: their first
    /// particle's block updates the list's), then this run's pairs (to
    /// their second particle only if it lies in the block).
    #[inline(always)]
    fn block(
        &mut self,
        x: &Inputs,
        range: (usize, usize),
        incoming: &mut PairRun,
        f: &mut [Vector3<f64>],
        t: &mut [Vector3<f64>],
    ) {
        if x.images.any() {
            self.block_in::<true>(x, range, incoming, f, t)
        } else {
            self.block_in::<false>(x, range, incoming, f, t)
        }
    }

    /// [`PairRun::block`] for a box with (`PERIODIC`) or without periodic
    /// axes.
    #[inline(always)]
    fn block_in<const PERIODIC: bool>(
        &mut self,
        x: &Inputs,
        (lo, hi): (usize, usize),
        incoming: &mut PairRun,
        f: &mut [Vector3<f64>],
        t: &mut [Vector3<f64>],
    ) {
        let p = x.p;
        if f.is_empty() {
            // No particles, so no pairs and nothing incoming.
            return;
        }
        if !x.preset {
            for (k, (f, t)) in f.iter_mut().zip(t.iter_mut()).enumerate() {
                *f = x.body_accel * p.mass_kg[lo + k];
                *t = Vector3::zeros();
            }
        }
        let radius = |i: usize| x.packed.sphere[i].0[3];
        // A particle's pairs from earlier blocks come first in its sum:
        // their first particles are lower.
        incoming.each_contact::<PERIODIC>(x, lo, f, t, |f, t, _, j, cf| {
            add_contact(&mut f[j - lo], &mut t[j - lo], &cf, radius(j), true);
        });
        // Each pair's result goes straight to both particles, in pair
        // order: a particle's sum sees the same terms in the same order as
        // if the pairs were taken one by one. A pair whose second particle
        // lies in a later block is that block's incoming pair.
        self.each_contact::<PERIODIC>(x, lo, f, t, |f, t, i, j, cf| {
            add_contact(&mut f[i - lo], &mut t[i - lo], &cf, radius(i), false);
            if j < hi {
                add_contact(&mut f[j - lo], &mut t[j - lo], &cf, radius(j), true);
            }
        });
    }

    /// Tests the run's pairs for overlap and evaluates the touching ones,
    /// a chunk at a time, calling `put(f, t, i, j, force)` for each in pair
    /// order (`f`, `t`: the sums of the block from particle `lo` on).
    #[inline(always)]
    fn each_contact<const PERIODIC: bool>(
        &mut self,
        x: &Inputs,
        lo: usize,
        f: &mut [Vector3<f64>],
        t: &mut [Vector3<f64>],
        mut put: impl FnMut(&mut [Vector3<f64>], &mut [Vector3<f64>], usize, usize, ContactForce),
    ) {
        let mut touching = [0u32; PAIR_CHUNK];
        let pj = self.pj;
        let len = pj.len();
        for s0 in (0..len).step_by(PAIR_CHUNK) {
            let slots = s0..(s0 + PAIR_CHUNK).min(len);
            // The next chunk's second particles' force and torque: the
            // block's sums were set at its start, long evicted on a large
            // bed (980,000 grains: 131 → 125 ns a particle-step).
            if x.far {
                for &j in &pj[(s0 + PAIR_CHUNK).min(len)..(s0 + 2 * PAIR_CHUNK).min(len)] {
                    if let Some(k) = (j as usize).checked_sub(lo).filter(|&k| k < f.len()) {
                        prefetch(f, k);
                        prefetch(t, k);
                    }
                }
            }
            let count = self.sort_out::<PERIODIC>(x.packed, x.images, slots, &mut touching, x.far);
            let which = &touching[..count];
            self.evaluate::<PERIODIC>(x.packed, x.images, x.model, x.dt_s, which, |i, j, cf| {
                put(f, t, i, j, cf)
            });
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn block_avx2(
        &mut self,
        x: &Inputs,
        range: (usize, usize),
        incoming: &mut PairRun,
        f: &mut [Vector3<f64>],
        t: &mut [Vector3<f64>],
    ) {
        self.block(x, range, incoming, f, t)
    }
}

/// Body force and every pair contact of each particle into `p.force_n` and
/// `p.torque_n_m` (overwritten), updating the pairs' histories; `packed`
/// is `p`'s current state packed ([`Particles::pack_into`]); with
/// `preset`, the sums already hold the body force (the first sweep set
/// them).
pub(crate) fn pair_forces(
    params: &Params,
    p: &mut Particles,
    (list, blocks): (&mut NeighbourList, &mut Blocks),
    (packed, preset): (&Packed, bool),
    images: &Images,
    team: &Team,
) {
    let simd = simd();
    blocks.split(list, team.workers() * BLOCKS_PER_WORKER);
    let mut force = std::mem::take(&mut p.force_n);
    let mut torque = std::mem::take(&mut p.torque_n_m);
    let nb = blocks.count();
    let first = &blocks.first;
    let start = &list.start;
    // Pair range of block b.
    let pairs_of = |b: usize| start[first[b]] as usize..start[first[b + 1]] as usize;
    let (pi, pj) = (&list.pair_i[..], &list.pair_j[..]);
    let x = Inputs {
        p,
        packed,
        images,
        model: &params.pair_model,
        dt_s: params.dt_s,
        body_accel: params.gravity_m_s2 * params.buoyancy_factor(),
        far: far(p.len()),
        preset,
    };
    let incoming_start = &blocks.incoming_start;
    let incoming_of = |b: usize| incoming_start[b]..incoming_start[b + 1];
    let (incoming_i, incoming_j) = (&blocks.incoming_i[..], &blocks.incoming_j[..]);
    let incoming_lens = || (0..nb).map(|b| incoming_of(b).len());
    let incoming_histories = split_lengths(&mut blocks.incoming_history, incoming_lens());
    let incoming_opens = split_lengths(&mut blocks.incoming_open, incoming_lens());
    let block_lens = || (0..nb).map(|b| first[b + 1] - first[b]);
    let histories = split_lengths(&mut list.history, (0..nb).map(|b| pairs_of(b).len()));
    let opens = split_lengths(&mut list.open, (0..nb).map(|b| pairs_of(b).len()));
    let forces = split_lengths(&mut force, block_lens());
    let torques = split_lengths(&mut torque, block_lens());
    let mut incoming = incoming_histories.into_iter().zip(incoming_opens);
    let parts = (histories.into_iter().zip(opens))
        .zip(forces.into_iter().zip(torques))
        .map_while(|(own, sums)| Some((own, sums, incoming.next()?)))
        .collect();
    let spent_ns = team.map(
        parts,
        |b, ((history, open), (f, t), (in_history, in_open))| {
            let started = std::time::Instant::now();
            let mut run = PairRun::of(pi, pj, pairs_of(b), history, open);
            let ks = incoming_of(b);
            let mut incoming = PairRun::of(incoming_i, incoming_j, ks, in_history, in_open);
            let range = (first[b], first[b + 1]);
            dispatch!(simd, run.block_avx2 / block(&x, range, &mut incoming, f, t));
            u64::try_from(started.elapsed().as_nanos()).unwrap_or(u64::MAX)
        },
    );
    for (total, t) in blocks.spent_ns.iter_mut().zip(spent_ns) {
        *total = total.saturating_add(t);
    }
    p.force_n = force;
    p.torque_n_m = torque;
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A row of 200 touching spheres (r = 1 mm, 1.9 mm apart) and its list.
    fn row() -> NeighbourList {
        let x: Vec<_> = (0..200)
            .map(|i| Vector3::new(i as f64 * 1.9e-3, 0.0, 0.0))
            .collect();
        let r = vec![1e-3; x.len()];
        let mut list = NeighbourList::default();
        list.build(&x, &r, 2e-4).unwrap();
        list
    }

    #[test]
    fn equal_work_splits_a_uniform_row_in_the_middle() {
        let list = row();
        let mut blocks = Blocks::default();
        blocks.split(&list, 2);
        assert_eq!(blocks.first, vec![0, 100, 200]);
        // Straddling: only the pair (99, 100), incoming to block 1.
        assert_eq!(blocks.incoming_start, vec![0, 0, 1]);
        assert_eq!((blocks.incoming_i[0], blocks.incoming_j[0]), (99, 100));
    }

    #[test]
    fn a_block_that_ran_long_gives_up_particles_at_the_next_split() {
        let mut list = row();
        let mut blocks = Blocks::default();
        blocks.split(&list, 2);
        // Block 0 took twice as long per unit of work as block 1.
        blocks.spent_ns = vec![2_000, 1_000];
        list.builds += 1;
        blocks.split(&list, 2);
        let b = blocks.first[1];
        // Rates √(4/3) and √(2/3): with one listed pair per particle (none
        // for the last) the halves balance where 1.155 b = 0.816 (199 − b),
        // b ≈ 85.
        assert!((84..=86).contains(&b), "split at {b}");
        // Untimed, the same build keeps its split; a new build with equal
        // times keeps the learnt rates.
        blocks.spent_ns = vec![1_000, 1_000];
        list.builds += 1;
        blocks.split(&list, 2);
        assert!(blocks.first[1] < 100);
    }
}

/// What each part of the pair pass costs: the benchmark's bed settled
/// (all 31,000 steps of its three phases, scaled by `PASS_PARTS_SCALE`,
/// default 0.3),
/// then the pass alone, positions frozen, with the parts of
/// [`pass_parts`] left out in turn (best of five rounds of 300 passes,
/// each pass from the settled histories). Prints ns per particle.
#[cfg(all(test, feature = "pass-parts"))]
mod pass_parts_alone {
    use super::*;
    use crate::{advance, benchmark};

    #[test]
    #[ignore = "cargo test --profile sim --target host-tuple -p dem --features pass-parts --lib pass_parts_alone -- --ignored --nocapture"]
    fn pass_parts_alone() {
        let scale: f64 = std::env::var("PASS_PARTS_SCALE")
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(0.3);
        let (params, mut state) = benchmark::problem().unwrap();
        advance(&params, &mut state, &mut (), (31_000.0 * scale) as u64).unwrap();
        state.particles.pack_into(&mut state.packed);
        let (history, open) = (
            state.neighbours.history.clone(),
            state.neighbours.open.clone(),
        );
        let n = state.particles.len() as f64;
        println!(
            "{} particles, mean contacts {:.4}; ns per particle for the pass:",
            n,
            state.mean_contacts()
        );
        for (label, bits) in [
            ("whole pass", 0),
            ("without the law", 1),
            ("without the sums", 2),
            ("without law and sums", 3),
            ("overlap test only", 4),
        ] {
            pass_parts::leave_out(bits);
            let mut best = f64::MAX;
            for _ in 0..5 {
                // Every pass from the settled histories (frozen positions
                // would otherwise stretch the springs pass after pass),
                // the copy back untimed.
                let mut spent = 0.0;
                for _ in 0..300 {
                    state.neighbours.history.copy_from_slice(&history);
                    state.neighbours.open.copy_from_slice(&open);
                    let started = std::time::Instant::now();
                    pair_forces(
                        &params,
                        &mut state.particles,
                        (&mut state.neighbours, &mut state.blocks),
                        (&state.packed, false),
                        &state.images,
                        &Team::alone(),
                    );
                    spent += started.elapsed().as_secs_f64();
                }
                best = best.min(spent / 300.0);
            }
            println!("  {label:<22} {:6.2}", best * 1e9 / n);
        }
        pass_parts::leave_out(0);
    }
}
