//! Force evaluation, particle by particle in a fixed order: body force,
//! then each listed pair in ascending pair order (the pairs where it is the
//! second particle come first: their first particle is lower), then its
//! wall contacts. The workers take the particles in runs of consecutive
//! indices, split between them as the step goes ([`crate::runs`]); a run's
//! pairs are evaluated and summed as it goes, four touching pairs at a time
//! (SIMD). A pair that crosses into a run that another split off is
//! evaluated by both, the later from a copy of its history taken before
//! the earlier changed it, each adding its own particle's share. Each
//! particle so sums the same terms in the same order whatever the runs,
//! and the results do not depend on the thread count or the timing.

use nalgebra::Vector3;

use super::contact::{
    ContactForce, ContactGeometry, HertzMindlin, History, Lanes, PairLaw, Real, HISTORY_LEN,
    LANE_COUNT,
};
use super::neighbour::NeighbourList;
use super::particles::{Packed, Particles};
use super::periodic::Images;
use super::runs::{Runs, Shares, Taken, NONE_RUN, UNIT};
use super::team::Team;
use super::Params;
use std::sync::atomic::{AtomicU64, Ordering};

/// Pairs gathered and evaluated together (sized for the L1 cache).
const PAIR_CHUNK: usize = 256;
/// Listed pairs ahead of the overlap test whose second sphere's rows are
/// prefetched. Within a run the first particles go in order and the
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
/// Cost of a touching pair in the pass, in listed pairs apart (measured:
/// ≈ 25 ns against ≈ 5 ns); only where the workers' first runs start
/// relies on it.
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

/// The first three values of the rows `q`, one row per lane.
#[inline(always)]
fn lanes3(q: &[&[f64; 4]; LANE_COUNT]) -> Vector3<Lanes> {
    Vector3::new(
        Lanes(q.map(|q| q[0])),
        Lanes(q.map(|q| q[1])),
        Lanes(q.map(|q| q[2])),
    )
}

/// The fourth value of the rows `q`, one row per lane.
#[inline(always)]
fn fourth(q: &[&[f64; 4]; LANE_COUNT]) -> Lanes {
    Lanes(q.map(|q| q[3]))
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
    let mut xj_m = lanes3(&xj);
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
        [&lanes3(&xi), &xj_m],
        [&lanes3(&vi), &lanes3(&vj)],
        [&lanes3(&wi), &lanes3(&wj)],
        [fourth(&xi), fourth(&xj)],
        [fourth(&vi), fourth(&vj)],
    )
}

/// The touching pairs of a chunk as the overlap test found them, in a box
/// with no periodic axis: i's position minus j's (x, y, z, m) and its
/// square (m²), a row per value, each pair at its place in the chunk's
/// touching pairs, so that a batch loads its four as lanes and its chain
/// starts at the square root, not at the index loads (BENCHMARKS.md, "The
/// pair pass's geometry"). A periodic pass takes its geometry from the
/// rows: its overlap test and its geometry find the nearest image by
/// different operations, and sharing one would change those beds' bits.
#[repr(C, align(32))]
struct Apart([[f64; PAIR_CHUNK + LANE_COUNT]; 4]);

/// What the overlap test leaves the evaluation of one chunk: the touching
/// pairs' slots in the run and their separations. One per run, reused by
/// its chunks (zeroed for each unit, it cost ≈ 1.5 % of the step).
struct Chunk {
    touching: [u32; PAIR_CHUNK],
    apart: Apart,
}

impl Chunk {
    fn new() -> Self {
        Chunk {
            touching: [0; PAIR_CHUNK],
            apart: Apart([[0.0; PAIR_CHUNK + LANE_COUNT]; 4]),
        }
    }
}

/// Geometry of the overlapping pairs (i[l], j[l]) from their separations
/// `apart[first..first + LANE_COUNT]`.
#[inline(always)]
fn pair_geometry_apart(
    p: &Packed,
    i: &[usize; LANE_COUNT],
    j: &[usize; LANE_COUNT],
    apart: &Apart,
    first: usize,
) -> ContactGeometry<Lanes> {
    let load = |c: usize| Lanes(std::array::from_fn(|l| apart.0[c][first + l]));
    let dx = Vector3::new(load(0), load(1), load(2));
    let d2 = load(3);
    let row = |k: &[usize; LANE_COUNT]| {
        (
            k.map(|k| &p.motion[k].0[0]),
            k.map(|k| &p.motion[k].0[1]),
            Lanes(k.map(|k| p.sphere[k].0[3])),
        )
    };
    let ((vi, wi, ri), (vj, wj, rj)) = (row(i), row(j));
    ContactGeometry::spheres_apart(
        dx,
        d2,
        [&lanes3(&vi), &lanes3(&vj)],
        [&lanes3(&wi), &lanes3(&wj)],
        [ri, rj],
        [fourth(&vi), fourth(&vj)],
    )
}

/// Listed pairs evaluated in order: one unit's of a run, or those crossing
/// into a run (a copy), with their histories and open flags (1 while the
/// history holds a contact).
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

    /// The overlapping pairs of the run's `slots` into `chunk`,
    /// returning how many; pairs apart are marked closed. No branch on the
    /// outcome: which pairs touch is a coin toss to the branch predictor.
    #[inline(always)]
    fn sort_out<L, const PERIODIC: bool>(
        &mut self,
        x: &Inputs<L>,
        slots: std::ops::Range<usize>,
        chunk: &mut Chunk,
    ) -> usize {
        let Chunk { touching, apart } = chunk;
        let (packed, images, far) = (x.packed, x.images, x.far);
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
            // The pass is compiled once with and once without periodic
            // axes, so that a box with none pays nothing for them.
            let (a, b) = (&p[self.pi[s] as usize], &p[self.pj[s] as usize]);
            let on = if PERIODIC {
                a.overlaps_nearest(b, images)
            } else {
                let (d, d2, on) = a.separation(b);
                apart.0[0][count] = d.x;
                apart.0[1][count] = d.y;
                apart.0[2][count] = d.z;
                apart.0[3][count] = d2;
                on
            };
            touching[count] = s as u32;
            count += usize::from(on);
            self.open[s] &= u8::from(on);
        }
        if !PERIODIC && count > 0 {
            for c in apart.0.iter_mut() {
                let v = c[count - 1];
                c[count..count + LANE_COUNT].fill(v);
            }
        }
        count
    }

    /// Evaluates the overlapping pairs `which` (the run's slots), four at
    /// a time, calling `put(i, j, force)` for each pair (i, j) in order (the
    /// batch's own indices: looking them up again in `put` cost ≈ 4 %); a
    /// closed pair's history starts from zero. The last batch repeats its
    /// last pair (the same history in, the same values out).
    #[inline(always)]
    fn evaluate<L: PairLaw, const PERIODIC: bool>(
        &mut self,
        x: &Inputs<L>,
        which: &[u32],
        apart: &Apart,
        mut put: impl FnMut(usize, usize, ContactForce),
    ) {
        let (p, images, law, dt_s) = (x.packed, x.images, x.law, x.dt_s);
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
            let g = if PERIODIC {
                pair_geometry_lanes::<PERIODIC>(p, &i, &j, images)
            } else {
                pair_geometry_apart(p, &i, &j, apart, first)
            };
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
                law.evaluate(&g, dt_s, &mut h)
            };
            #[cfg(not(feature = "pass-parts"))]
            let f = law.evaluate(&g, dt_s, &mut h);
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

/// How the pass shares the particles among workers: the work estimate of
/// the list's particles, how far its pairs reach, and each worker's share
/// learnt from the steps before.
#[derive(Clone, Debug, Default)]
pub(crate) struct Schedule {
    /// The list build the estimate was made for.
    made_for: Option<u64>,
    /// Cumulative estimated work of particles 0..i (len n + 1): listed
    /// pairs, touching ones weighted by [`TOUCHING_WEIGHT`].
    work: Vec<f64>,
    /// Largest j − i over the listed pairs (i, j).
    span: usize,
    /// Where each worker's first run starts.
    shares: Shares,
}

impl Schedule {
    /// Estimates the work and the reach of `list`'s pairs, unless done for
    /// this build.
    fn prepare(&mut self, list: &NeighbourList) {
        let n = list.start.len().saturating_sub(1);
        if self.made_for == Some(list.builds) && self.work.len() == n + 1 {
            return;
        }
        self.made_for = Some(list.builds);
        self.work.clear();
        self.work.push(0.0);
        let mut total = 0.0f64;
        for i in 0..n {
            let ks = list.start[i] as usize..list.start[i + 1] as usize;
            let open: usize = list.open[ks.clone()].iter().map(|&o| usize::from(o)).sum();
            total += ks.len() as f64 + (TOUCHING_WEIGHT - 1.0) * open as f64;
            self.work.push(total);
        }
        self.span = (list.pair_i.iter().zip(&list.pair_j))
            .map(|(&i, &j)| j.saturating_sub(i) as usize)
            .max()
            .unwrap_or(0);
    }
}

/// The sums and the pair histories of one pass, shared by its runs: each
/// run reaches them only for the units it holds ([`crate::runs`]), so no
/// two runs touch the same element but through a copy taken first.
struct Shared {
    force: *mut Vector3<f64>,
    torque: *mut Vector3<f64>,
    n: usize,
    history: *mut History,
    open: *mut u8,
    pairs: usize,
}

// SAFETY: the runs reach disjoint parts (see `Shared`).
unsafe impl Sync for Shared {}

impl Shared {
    /// The force and torque sums of particles `lo..hi`.
    ///
    /// # Safety
    /// The calling run holds every unit of `lo..hi`, and nothing else
    /// reaches them while the slices live.
    #[allow(clippy::mut_from_ref)]
    unsafe fn sums(&self, lo: usize, hi: usize) -> (&mut [Vector3<f64>], &mut [Vector3<f64>]) {
        assert!(lo <= hi && hi <= self.n, "sums {lo}..{hi} of {}", self.n);
        // SAFETY: in bounds (checked); exclusive by the caller's claims.
        unsafe {
            (
                std::slice::from_raw_parts_mut(self.force.add(lo), hi - lo),
                std::slice::from_raw_parts_mut(self.torque.add(lo), hi - lo),
            )
        }
    }

    /// The histories and open flags of pairs `ks`.
    ///
    /// # Safety
    /// The calling run holds the units of the pairs' first particles, and
    /// every run that copies some of them has done so.
    #[allow(clippy::mut_from_ref)]
    unsafe fn pairs(&self, ks: std::ops::Range<usize>) -> (&mut [History], &mut [u8]) {
        assert!(ks.start <= ks.end && ks.end <= self.pairs, "pairs {ks:?}");
        // SAFETY: in bounds (checked); exclusive by the caller's claims.
        unsafe {
            (
                std::slice::from_raw_parts_mut(self.history.add(ks.start), ks.len()),
                std::slice::from_raw_parts_mut(self.open.add(ks.start), ks.len()),
            )
        }
    }

    /// A copy of pair k's history and open flag.
    ///
    /// # Safety
    /// The run that holds the pair's first particle does not change it
    /// until told the copy is taken.
    unsafe fn pair(&self, k: usize) -> (History, u8) {
        assert!(k < self.pairs, "pair {k} of {}", self.pairs);
        // SAFETY: in bounds (checked); not written meanwhile (the caller).
        unsafe { (*self.history.add(k), *self.open.add(k)) }
    }
}

/// Adds contact `cf` (from the first particle's point of view) to a
/// particle of radius `r_m`, the pair's first or (`second`) its second;
/// its rolling torque only if the law `L` rolls ([`PairLaw::ROLLS`]: else
/// it is zero, and leaving it out changes at most the sign of a torque
/// sum that is exactly zero).
#[inline(always)]
fn add_contact<L: PairLaw>(
    f: &mut Vector3<f64>,
    t: &mut Vector3<f64>,
    cf: &ContactForce,
    r_m: f64,
    second: bool,
) {
    if second {
        *f -= cf.force_n;
    } else {
        *f += cf.force_n;
    }
    let spring = cf.torque_per_radius_n * r_m;
    match (second, L::ROLLS) {
        (true, true) => *t += spring - cf.rolling_torque_n_m,
        (false, true) => *t += spring + cf.rolling_torque_n_m,
        (_, false) => *t += spring,
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

/// What every run of the pass reads.
struct Inputs<'a, L> {
    p: &'a Particles,
    packed: &'a Packed,
    images: &'a Images,
    law: &'a L,
    dt_s: f64,
    body_accel: Vector3<f64>,
    /// Whether the bed is too large for the caches, so that the pass
    /// prefetches what it will reach out of order ([`FAR_FROM`]).
    far: bool,
    /// Whether the sums already hold the body force and no torque (the
    /// integrator's sweep set them, in the same operations).
    preset: bool,
}

/// Runs `$run.sums::<$g>(..)` in its AVX2 copy (`sums_avx2`, whose body
/// is `sums` inlined into a function compiled for AVX2) when `$simd` says
/// so, else in the baseline one.
macro_rules! dispatch {
    ($simd:expr, $run:ident . sums / < $($g:tt),* > ( $($arg:expr),* )) => {{
        #[cfg(target_arch = "x86_64")]
        if $simd == $crate::Simd::Avx2 {
            // SAFETY: `Simd::Avx2` is chosen only where the CPU has AVX2.
            unsafe { $run.sums_avx2::<$($g),*>($($arg),*) }
        } else {
            $run.sums::<$($g),*>($($arg),*)
        }
        #[cfg(not(target_arch = "x86_64"))]
        $run.sums::<$($g),*>($($arg),*)
    }};
}

impl PairRun<'_> {
    /// Adds the run's pairs to the particles of `lo..lo + f.len()` (`f`,
    /// `t`: their sums): with `OWN`, the run's own pairs, to their first
    /// particles and to their second where it lies in the range; without,
    /// the pairs crossing into a run from below, to their second
    /// particles only (all in the range).
    #[inline(always)]
    fn sums<L: PairLaw, const OWN: bool>(
        &mut self,
        x: &Inputs<L>,
        chunk: &mut Chunk,
        lo: usize,
        f: &mut [Vector3<f64>],
        t: &mut [Vector3<f64>],
    ) {
        if x.images.any() {
            self.sums_in::<L, OWN, true>(x, chunk, lo, f, t)
        } else {
            self.sums_in::<L, OWN, false>(x, chunk, lo, f, t)
        }
    }

    /// [`PairRun::sums`] for a box with (`PERIODIC`) or without periodic
    /// axes.
    #[inline(always)]
    fn sums_in<L: PairLaw, const OWN: bool, const PERIODIC: bool>(
        &mut self,
        x: &Inputs<L>,
        chunk: &mut Chunk,
        lo: usize,
        f: &mut [Vector3<f64>],
        t: &mut [Vector3<f64>],
    ) {
        let radius = |i: usize| x.packed.sphere[i].0[3];
        let hi = lo + f.len();
        // Each pair's result goes straight to both particles, in pair
        // order: a particle's sum sees the same terms in the same order as
        // if the pairs were taken one by one.
        self.each_contact::<L, PERIODIC>(
            x,
            chunk,
            lo,
            f,
            t,
            #[inline(always)]
            |f, t, i, j, cf| {
                if OWN {
                    add_contact::<L>(&mut f[i - lo], &mut t[i - lo], &cf, radius(i), false);
                }
                if !OWN || j < hi {
                    add_contact::<L>(&mut f[j - lo], &mut t[j - lo], &cf, radius(j), true);
                }
            },
        );
    }

    /// Tests the run's pairs for overlap and evaluates the touching ones,
    /// a chunk at a time, calling `put(f, t, i, j, force)` for each in pair
    /// order (`f`, `t`: the sums of the run from particle `lo` on).
    #[inline(always)]
    fn each_contact<L: PairLaw, const PERIODIC: bool>(
        &mut self,
        x: &Inputs<L>,
        chunk: &mut Chunk,
        lo: usize,
        f: &mut [Vector3<f64>],
        t: &mut [Vector3<f64>],
        mut put: impl FnMut(&mut [Vector3<f64>], &mut [Vector3<f64>], usize, usize, ContactForce),
    ) {
        let pj = self.pj;
        let len = pj.len();
        for s0 in (0..len).step_by(PAIR_CHUNK) {
            let slots = s0..(s0 + PAIR_CHUNK).min(len);
            // The next chunk's second particles' force and torque: the
            // run's sums were set at the step's start, long evicted on a large
            // bed (980,000 grains: 131 → 125 ns a particle-step).
            if x.far {
                for &j in &pj[(s0 + PAIR_CHUNK).min(len)..(s0 + 2 * PAIR_CHUNK).min(len)] {
                    if let Some(k) = (j as usize).checked_sub(lo).filter(|&k| k < f.len()) {
                        prefetch(f, k);
                        prefetch(t, k);
                    }
                }
            }
            let count = self.sort_out::<L, PERIODIC>(x, slots, chunk);
            let which = &chunk.touching[..count];
            self.evaluate::<L, PERIODIC>(
                x,
                which,
                &chunk.apart,
                #[inline(always)]
                |i, j, cf| put(f, t, i, j, cf),
            );
        }
    }

    /// [`PairRun::sums`] compiled for AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn sums_avx2<L: PairLaw, const OWN: bool>(
        &mut self,
        x: &Inputs<L>,
        chunk: &mut Chunk,
        lo: usize,
        f: &mut [Vector3<f64>],
        t: &mut [Vector3<f64>],
    ) {
        self.sums::<L, OWN>(x, chunk, lo, f, t)
    }
}

/// Body force and every pair contact of each particle into `p.force_n` and
/// `p.torque_n_m` (overwritten), updating the pairs' histories; `packed`
/// is `p`'s current state packed ([`Particles::pack_into`]); with
/// `preset`, the sums already hold the body force (the first sweep set
/// them). The workers share the particles in runs ([`crate::runs`]);
/// returns how many were split off others.
pub(crate) fn pair_forces(
    params: &Params,
    p: &mut Particles,
    list: (&mut NeighbourList, &mut Schedule),
    packed: (&Packed, bool),
    images: &Images,
    team: &Team,
) -> usize {
    // The sand's usual law gets a pass of its own, compiled for it.
    match HertzMindlin::of(&params.pair_model) {
        Some(law) => pair_forces_with(&law, params, p, list, packed, images, team),
        None => pair_forces_with(&params.pair_model, params, p, list, packed, images, team),
    }
}

/// [`pair_forces`] with the contact `law` (`params.pair_model`'s).
fn pair_forces_with<L: PairLaw>(
    law: &L,
    params: &Params,
    p: &mut Particles,
    (list, schedule): (&mut NeighbourList, &mut Schedule),
    (packed, preset): (&Packed, bool),
    images: &Images,
    team: &Team,
) -> usize {
    let simd = simd();
    let n = p.len();
    schedule.prepare(list);
    let workers = team.workers().max(1);
    let starts = schedule.shares.starts(workers, &schedule.work);
    let runs = Runs::new(n, &starts, schedule.span);
    let mut force = std::mem::take(&mut p.force_n);
    let mut torque = std::mem::take(&mut p.torque_n_m);
    force.resize(n, Vector3::zeros());
    torque.resize(n, Vector3::zeros());
    let x = Inputs {
        p,
        packed,
        images,
        law,
        dt_s: params.dt_s,
        body_accel: params.gravity_m_s2 * params.buoyancy_factor(),
        far: far(p.len()),
        preset,
    };
    let shared = Shared {
        force: force.as_mut_ptr(),
        torque: torque.as_mut_ptr(),
        n,
        history: list.history.as_mut_ptr(),
        open: list.open.as_mut_ptr(),
        pairs: list.history.len().min(list.open.len()),
    };
    let pass = Pass {
        x: &x,
        simd,
        list: (&list.start, &list.pair_i, &list.pair_j),
        span: schedule.span,
        runs: &runs,
        shared: &shared,
    };
    let work = &schedule.work;
    let done: Vec<AtomicU64> = (0..workers).map(|_| AtomicU64::new(0)).collect();
    let spent: Vec<AtomicU64> = (0..workers).map(|_| AtomicU64::new(0)).collect();
    team.run(workers, &|w| {
        let started = std::time::Instant::now();
        let mut did = 0.0;
        let mut next = runs.take_first(w);
        while let Some(taken) = next {
            let (lo, hi) = pass.run(taken);
            did += work[hi] - work[lo];
            next = runs.steal();
        }
        done[w].store(did.to_bits(), Ordering::Relaxed);
        let ns = u64::try_from(started.elapsed().as_nanos()).unwrap_or(u64::MAX);
        spent[w].store(ns, Ordering::Relaxed);
    });
    let done: Vec<(f64, u64)> = (done.iter().zip(&spent))
        .map(|(d, t)| {
            (
                f64::from_bits(d.load(Ordering::Relaxed)),
                t.load(Ordering::Relaxed),
            )
        })
        .collect();
    schedule.shares.learn(&done);
    p.force_n = force;
    p.torque_n_m = torque;
    runs.splits()
}

/// One step's pair pass, as its runs see it.
struct Pass<'a, L> {
    x: &'a Inputs<'a, L>,
    simd: Simd,
    /// The list's `start`, `pair_i` and `pair_j`.
    list: (&'a [u32], &'a [u32], &'a [u32]),
    /// Largest j − i over the listed pairs.
    span: usize,
    runs: &'a Runs,
    shared: &'a Shared,
}

impl<L: PairLaw> Pass<'_, L> {
    /// Runs `taken`: the pairs crossing into it from below (to their
    /// second particles only), then its units' pairs in order, answering
    /// split requests before each unit; returns the particles it ran.
    fn run(&self, taken: Taken) -> (usize, usize) {
        /// Tells the other runs to stop waiting if this one panics.
        struct Abort<'f>(&'f Runs);
        impl Drop for Abort<'_> {
            fn drop(&mut self) {
                if std::thread::panicking() {
                    self.0.abort();
                }
            }
        }
        let _abort = Abort(self.runs);
        let mut chunk = Chunk::new();
        let (start, pi, pj) = self.list;
        let (x, runs) = (self.x, self.runs);
        let n = x.p.len();
        let run = runs.get(taken.run);
        let first = run.first();
        let lo = first * UNIT;
        let end = |unit: usize| (unit * UNIT).min(n);
        let body = |from: usize, to: usize| {
            if !x.preset {
                // SAFETY: particles from..to are the run's own.
                let (f, t) = unsafe { self.shared.sums(from, to) };
                for (k, (f, t)) in f.iter_mut().zip(t.iter_mut()).enumerate() {
                    *f = x.body_accel * x.p.mass_kg[from + k];
                    *t = Vector3::zeros();
                }
            }
        };
        if runs.is_first(taken.run) {
            body(lo, end(run.limit().unit));
        }
        if first > 0 {
            // The pairs crossing into the run from the units whose pairs
            // its particles do not hold yet, in pair order, from a copy of
            // their histories (the run below keeps the list's, and waits
            // for this copy before changing them).
            let hi = end(run.limit().unit);
            let from = (taken.done * UNIT).max(lo.saturating_sub(self.span));
            let ks = start[from] as usize..start[lo] as usize;
            let most = ks.len();
            let ks = ks.filter(|&k| (lo..hi).contains(&(pj[k] as usize)));
            let (mut ci, mut cj) = (Vec::with_capacity(most), Vec::with_capacity(most));
            let (mut ch, mut co) = (Vec::with_capacity(most), Vec::with_capacity(most));
            for k in ks {
                // SAFETY: the run below waits for `set_copied`.
                let (h, o) = unsafe { self.shared.pair(k) };
                ci.push(pi[k]);
                cj.push(pj[k]);
                ch.push(h);
                co.push(o);
            }
            if !runs.is_first(taken.run) {
                // The run below may reach past this one, into the next,
                // which it does not wait for ([`crate::runs`]).
                runs.wait_copied(run.limit().run);
            }
            run.set_copied();
            let mut crossing = PairRun::of(&ci, &cj, 0..ci.len(), &mut ch, &mut co);
            // SAFETY: particles lo..hi are the run's own.
            let (f, t) = unsafe { self.shared.sums(lo, hi) };
            dispatch!(self.simd, crossing.sums / <L, false>(x, &mut chunk, lo, f, t));
        } else {
            run.set_copied();
        }
        let mut u = first;
        loop {
            let mut limit = run.before_unit(u, runs);
            let uhi = end(u + 1);
            if u < limit.unit && limit.run != NONE_RUN && uhi + self.span > end(limit.unit) {
                // This unit's pairs may reach the next run: take it over
                // if no worker has begun it, else wait for its copy.
                if let Some(units) = runs.absorb(taken.run, limit.run) {
                    body(end(units.start), end(units.end));
                    continue;
                }
                runs.wait_copied(limit.run);
                limit = run.limit();
            }
            if u >= limit.unit {
                break;
            }
            let ulo = u * UNIT;
            let ks = start[ulo] as usize..start[uhi] as usize;
            // SAFETY: particles ulo..limit are the run's own, and the next
            // run has copied the pairs that reach it.
            let ((f, t), (h, o)) = unsafe {
                (
                    self.shared.sums(ulo, end(limit.unit)),
                    self.shared.pairs(ks.clone()),
                )
            };
            let mut own = PairRun::of(pi, pj, ks, h, o);
            dispatch!(self.simd, own.sums / <L, true>(x, &mut chunk, ulo, f, t));
            u += 1;
        }
        run.finish();
        (lo, end(u))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_schedule_estimates_work_and_reach_per_build() {
        // A row of 200 touching spheres (r = 1 mm, 1.9 mm apart).
        let x: Vec<_> = (0..200)
            .map(|i| Vector3::new(i as f64 * 1.9e-3, 0.0, 0.0))
            .collect();
        let mut list = NeighbourList::default();
        list.build(&x, &vec![1e-3; x.len()], 2e-4).unwrap();
        let mut s = Schedule::default();
        s.prepare(&list);
        // One listed pair per particle but the last, none open yet.
        assert_eq!(s.work.len(), 201);
        assert_eq!(s.work[200], 199.0);
        assert_eq!(s.span, 1);
    }

    /// Runs the pass on 16 × 16 × 16 grains 1.98 mm apart (r = 1 mm: each
    /// touches six), moving every way, with `workers` workers for
    /// `passes` passes, each from the same histories, and checks that
    /// every one gives the bits of one worker; returns the runs split off
    /// others. The grains' layers are stored in the order `layers`, so a
    /// pair reaches from one layer to the next as far as their places in
    /// that order are apart (256 grains, two units, a place).
    fn same_bits_as_one_worker(workers: usize, layers: &[usize], passes: usize) -> usize {
        let params = crate::benchmark::params().unwrap();
        let mut p = Particles::new();
        for &k in layers {
            for j in 0..16 {
                for i in 0..16 {
                    let x = Vector3::new(i as f64, j as f64, k as f64) * 1.98e-3;
                    // Scattered velocities, up to 10 mm/s a component.
                    let q = (i + 16 * j + 256 * k) as f64;
                    let v = Vector3::new((1.3 * q).sin(), (0.7 * q).cos(), (2.1 * q).sin()) * 0.01;
                    p.push(x, v, 1.0e-3, 2920.0).unwrap();
                }
            }
        }
        let mut list = NeighbourList::default();
        list.build(&p.position_m, &p.radius_m, params.skin_m)
            .unwrap();
        let mut packed = Packed::default();
        p.pack_into(&mut packed);
        let images = Images::default();
        let pass = |p: &mut Particles, list: &mut NeighbourList, s: &mut Schedule, team: &Team| {
            pair_forces(&params, p, (list, s), (&packed, false), &images, team)
        };
        // Contacts opened and springs stretched, then the reference.
        let mut schedule = Schedule::default();
        for _ in 0..3 {
            pass(&mut p, &mut list, &mut schedule, &Team::alone());
        }
        let start = (list.history.clone(), list.open.clone());
        assert!(list.open.iter().filter(|&&o| o == 1).count() > 10_000);
        pass(&mut p, &mut list, &mut schedule, &Team::alone());
        let want = (
            p.force_n.clone(),
            p.torque_n_m.clone(),
            list.history.clone(),
        );
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(workers)
            .build()
            .unwrap();
        pool.install(|| {
            crate::team::with_team(|team| {
                let mut splits = 0;
                for pass_no in 0..passes {
                    (list.history, list.open) = start.clone();
                    splits += pass(&mut p, &mut list, &mut schedule, team);
                    let got = (&p.force_n, &p.torque_n_m, &list.history);
                    assert!(
                        got == (&want.0, &want.1, &want.2),
                        "a {workers}-worker pass differs (pass {pass_no})"
                    );
                }
                splits
            })
        })
    }

    /// The pass through the fixed law ([`HertzMindlin`]) and the
    /// separations of its overlap test gives the bits of the pass through
    /// the general model and through the spheres' rows (a periodic pass,
    /// its period far wider than the bed, takes its geometry from the
    /// rows): forces and torques equal (the fixed law adds no zero rolling
    /// torque, which may change the sign of a sum that is exactly zero),
    /// histories bit for bit.
    #[test]
    fn the_fixed_law_and_the_tests_separations_give_the_general_bits() {
        let params = crate::benchmark::params().unwrap();
        let law = HertzMindlin::of(&params.pair_model).expect("the benchmark's law is fixed");
        let mut p = Particles::new();
        for q in 0..16 * 16 * 16 {
            let (i, j, k) = (q % 16, q / 16 % 16, q / 256);
            let x = Vector3::new(i as f64, j as f64, k as f64) * 1.98e-3;
            let f = q as f64;
            let v = Vector3::new((1.3 * f).sin(), (0.7 * f).cos(), (2.1 * f).sin()) * 0.01;
            p.push(x, v, 1.0e-3, 2920.0).unwrap();
        }
        let mut list = NeighbourList::default();
        list.build(&p.position_m, &p.radius_m, params.skin_m)
            .unwrap();
        let mut packed = Packed::default();
        p.pack_into(&mut packed);
        let walled = Images::default();
        let axis = crate::periodic::PeriodicAxis::new(-1.0, 10.0).unwrap();
        let wide = Images::new(&[Some(axis), None, None]);
        let team = Team::alone();
        let mut schedule = Schedule::default();
        for _ in 0..3 {
            let list = (&mut list, &mut schedule);
            pair_forces(&params, &mut p, list, (&packed, false), &walled, &team);
        }
        assert!(list.open.iter().filter(|&&o| o == 1).count() > 10_000);
        let start = (list.history.clone(), list.open.clone());
        let mut pass = |fixed: bool, images: &Images| {
            (list.history, list.open) = start.clone();
            let lists = (&mut list, &mut schedule);
            let packed = (&packed, false);
            if fixed {
                pair_forces_with(&law, &params, &mut p, lists, packed, images, &team);
            } else {
                let model = &params.pair_model;
                pair_forces_with(model, &params, &mut p, lists, packed, images, &team);
            }
            let bits: Vec<[u64; 3]> = (list.history.iter()).map(|h| h.map(f64::to_bits)).collect();
            (p.force_n.clone(), p.torque_n_m.clone(), bits)
        };
        let want = pass(false, &wide);
        assert!(want.0.iter().all(|f| f.norm() > 0.0));
        for (fixed, images) in [(false, &walled), (true, &walled), (true, &wide)] {
            assert!(pass(fixed, images) == want, "fixed {fixed}, {images:?}");
        }
    }

    #[test]
    fn runs_split_within_the_pass_give_the_same_bits() {
        let layers: Vec<usize> = (0..16).collect();
        assert!(
            same_bits_as_one_worker(2, &layers, 500) > 0,
            "no run was split"
        );
    }

    #[test]
    fn runs_shorter_than_the_pairs_reach_give_the_same_bits() {
        // Even layers first, then odd ones: a pair reaches 16 units on,
        // past several workers' runs.
        let layers: Vec<usize> = (0..16).step_by(2).chain((1..16).step_by(2)).collect();
        // Sixteen workers on 32 units: the first runs are two units long
        // but for the merging of [`Runs::new`].
        for workers in [3, 8, 16] {
            same_bits_as_one_worker(workers, &layers, 500);
        }
        // Layer 1 stored last: the pairs reach across the bed, as a
        // periodic one's do, and the workers keep two first runs.
        let across: Vec<usize> = [0].into_iter().chain(2..16).chain([1]).collect();
        for workers in [3, 8] {
            same_bits_as_one_worker(workers, &across, 500);
        }
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
                        (&mut state.neighbours, &mut state.schedule),
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
