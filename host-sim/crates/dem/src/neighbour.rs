//! Verlet neighbour list built on a cell grid.
//!
//! Each pair (i, j) with j > i whose surfaces are closer than the skin is
//! stored once, in i's run of a flat list (CSR), j ascending, so the pairs
//! are ordered by first particle, then second. The list is rebuilt when a
//! particle has moved more than half the skin; the contact history of
//! every pair still listed is carried over (matched by the particle pair).

use nalgebra::Vector3;

use super::contact::History;
use super::periodic::{check_fits, Images, PeriodicAxis};
use super::team::{with_team, Team};
use super::{split_lengths, DemError};

/// Particles per parallel task when building.
const BUILD_CHUNK: usize = 512;

/// The half neighbour list with per-pair contact history.
#[derive(Clone, Debug, Default)]
pub struct NeighbourList {
    /// start[i]..start[i+1] are i's pairs (len n + 1).
    pub(crate) start: Vec<u32>,
    /// First particle of each pair.
    pub(crate) pair_i: Vec<u32>,
    /// Second particle of each pair (> first).
    pub(crate) pair_j: Vec<u32>,
    /// Contact history of each pair, meaningful while its `open` flag is 1.
    pub(crate) history: Vec<History>,
    /// 1 while the pair's history holds an open contact, else 0 (its
    /// history then counts as zero).
    pub(crate) open: Vec<u8>,
    /// Positions at the last build (m).
    pub(crate) reference_m: Vec<Vector3<f64>>,
    /// Skin used at the last build (m).
    pub(crate) skin_m: f64,
    /// Number of builds so far.
    pub builds: u64,
    /// The arrays the last build replaced, refilled by the next one (fresh
    /// allocations of this size would cost a page fault per 4 KiB).
    spare: Spare,
}

/// Buffers of a previous build, kept for their capacity.
#[derive(Clone, Debug, Default)]
struct Spare {
    start: Vec<u32>,
    pair_i: Vec<u32>,
    pair_j: Vec<u32>,
    history: Vec<History>,
    open: Vec<u8>,
}

/// `v` cut or grown to `len` in its own allocation, the elements it
/// already had left as they were (the build overwrites every one, in its
/// parallel pass rather than in a serial fill first).
fn resized<T: Clone + Default>(mut v: Vec<T>, len: usize) -> Vec<T> {
    v.truncate(len);
    v.resize(len, T::default());
    v
}

impl NeighbourList {
    /// Number of listed pairs.
    pub fn pair_count(&self) -> usize {
        self.pair_j.len()
    }

    /// Whether the list must be rebuilt for `n` particles with `skin_m`.
    pub fn is_stale(&self, n: usize, skin_m: f64) -> bool {
        self.start.len() != n + 1 || self.skin_m != skin_m
    }

    /// Rebuilds the list for `position_m`/`radius_m` with `skin_m` (m),
    /// carrying over the history of pairs that stay listed; no periodic
    /// axis ([`NeighbourList::build_periodic`]).
    pub fn build(
        &mut self,
        position_m: &[Vector3<f64>],
        radius_m: &[f64],
        skin_m: f64,
    ) -> Result<(), DemError> {
        self.build_periodic(position_m, radius_m, skin_m, &[None; 3])
    }

    /// As [`NeighbourList::build`], with `periodic` axes (x, y, z): a pair
    /// is listed when its nearest images are within the skin.
    ///
    /// Two parallel passes over chunks of particles: the first finds each
    /// particle's partners (scanning the grid's cell-sorted copy of the
    /// positions, without branches on the distance test), the second writes
    /// the chunks into the flat arrays at their offsets and carries the
    /// history over. The list is the same whatever the chunking.
    pub fn build_periodic(
        &mut self,
        position_m: &[Vector3<f64>],
        radius_m: &[f64],
        skin_m: f64,
        periodic: &[Option<PeriodicAxis>; 3],
    ) -> Result<(), DemError> {
        with_team(|team| self.build_with(position_m, radius_m, skin_m, periodic, team))
    }

    /// [`NeighbourList::build_periodic`] on `team`.
    pub(crate) fn build_with(
        &mut self,
        position_m: &[Vector3<f64>],
        radius_m: &[f64],
        skin_m: f64,
        periodic: &[Option<PeriodicAxis>; 3],
        team: &Team,
    ) -> Result<(), DemError> {
        let n = position_m.len();
        let grid = Grid::new(position_m, radius_m, skin_m, periodic)?;
        let chunk_count = n.div_ceil(BUILD_CHUNK);
        let chunk_range = |c: usize| c * BUILD_CHUNK..((c + 1) * BUILD_CHUNK).min(n);

        // Pass 1: each chunk's partners, j ascending within each particle.
        let found: Vec<(Vec<u32>, Vec<u32>)> =
            team.map((0..chunk_count).collect(), |_, c: usize| {
                let range = chunk_range(c);
                let mut counts = Vec::with_capacity(range.len());
                let mut js = Vec::with_capacity(range.len() * 8);
                for i in range {
                    let first = js.len();
                    grid.near_into(i, position_m[i], radius_m[i], skin_m, &mut js);
                    js[first..].sort_unstable();
                    counts.push((js.len() - first) as u32);
                }
                (counts, js)
            });

        // Pass 2: into the flat arrays, the old ones kept for the carry.
        let old_start = std::mem::take(&mut self.start);
        let old_j = std::mem::take(&mut self.pair_j);
        let old_hist = std::mem::take(&mut self.history);
        let old_open = std::mem::take(&mut self.open);
        let old_valid = old_start.len() == n + 1;
        let mut offset = Vec::with_capacity(chunk_count + 1);
        offset.push(0usize);
        for (_, js) in &found {
            offset.push(offset[offset.len() - 1] + js.len());
        }
        let total = offset[chunk_count];
        let spare = std::mem::take(&mut self.spare);
        let mut start = resized(spare.start, n + 1);
        start[0] = 0;
        let mut pair_i = resized(spare.pair_i, total);
        let mut pair_j = resized(spare.pair_j, total);
        let mut history = resized(spare.history, total);
        let mut open = resized(spare.open, total);
        let pair_lens: Vec<usize> = found.iter().map(|(_, js)| js.len()).collect();
        let particle_lens: Vec<usize> = (0..chunk_count).map(|c| chunk_range(c).len()).collect();
        let mut st = split_lengths(&mut start[1..], particle_lens.iter().copied()).into_iter();
        let mut pi = split_lengths(&mut pair_i, pair_lens.iter().copied()).into_iter();
        let mut pj = split_lengths(&mut pair_j, pair_lens.iter().copied()).into_iter();
        let mut hist = split_lengths(&mut history, pair_lens.iter().copied()).into_iter();
        let mut op = split_lengths(&mut open, pair_lens.iter().copied()).into_iter();
        let pieces = (found.iter())
            .map_while(|f| {
                Some((
                    f,
                    st.next()?,
                    pi.next()?,
                    pj.next()?,
                    hist.next()?,
                    op.next()?,
                ))
            })
            .collect();
        team.map(pieces, |c, ((counts, js), st, pi, pj, hist, op)| {
            pj.copy_from_slice(js);
            hist.fill(History::default());
            op.fill(0);
            let mut k = 0usize;
            for (q, (&count, end)) in counts.iter().zip(st.iter_mut()).enumerate() {
                let i = c * BUILD_CHUNK + q;
                let run = k..k + count as usize;
                k = run.end;
                *end = (offset[c] + k) as u32;
                pi[run.clone()].fill(i as u32);
                if !old_valid {
                    continue;
                }
                // Carry history: both runs are sorted by j.
                let (mut o, b) = (old_start[i] as usize, old_start[i + 1] as usize);
                for p in run {
                    let j = pj[p];
                    while o < b && old_j[o] < j {
                        o += 1;
                    }
                    if o < b && old_j[o] == j && old_open[o] != 0 {
                        hist[p] = old_hist[o];
                        op[p] = 1;
                    }
                }
            }
        });
        self.spare = Spare {
            start: old_start,
            pair_i: std::mem::replace(&mut self.pair_i, pair_i),
            pair_j: old_j,
            history: old_hist,
            open: old_open,
        };
        self.start = start;
        self.pair_j = pair_j;
        self.history = history;
        self.open = open;

        self.reference_m.clear();
        self.reference_m.extend_from_slice(position_m);
        self.skin_m = skin_m;
        self.builds += 1;
        Ok(())
    }
}

/// A uniform cell grid over the particles' bounding box, cells at least
/// one interaction range wide, with the particles' positions and radii
/// copied in cell order (a row of cells is one contiguous run to scan).
struct Grid {
    origin: Vector3<f64>,
    /// Inverse cell width along each axis (1/m).
    inv_cell: [f64; 3],
    dims: [usize; 3],
    /// The periodic axes (their cells wrap around) and their images.
    periodic: [Option<PeriodicAxis>; 3],
    images: Images,
    cell_start: Vec<u32>,
    /// Particle index of each cell-sorted slot.
    cell_particles: Vec<u32>,
    /// (x, y, z, radius) of each cell-sorted slot (m).
    cell_sphere_m: Vec<[f64; 4]>,
}

impl Grid {
    fn new(
        position_m: &[Vector3<f64>],
        radius_m: &[f64],
        skin_m: f64,
        periodic: &[Option<PeriodicAxis>; 3],
    ) -> Result<Grid, DemError> {
        let n = position_m.len();
        let mut lo = Vector3::repeat(f64::INFINITY);
        let mut hi = Vector3::repeat(f64::NEG_INFINITY);
        for (k, x) in position_m.iter().enumerate() {
            if !x.iter().all(|v| v.is_finite()) {
                return Err(DemError::NonFinite { particle: k });
            }
            lo = lo.inf(x);
            hi = hi.sup(x);
        }
        if n == 0 {
            lo = Vector3::zeros();
            hi = Vector3::zeros();
        }
        let r_max = radius_m.iter().copied().fold(0.0, f64::max);
        let range = (2.0 * r_max + skin_m).max(f64::MIN_POSITIVE);
        check_fits(periodic, range)?;
        for (a, axis) in periodic.iter().enumerate() {
            if let Some(axis) = axis {
                lo[a] = axis.lo_m;
                hi[a] = axis.lo_m + axis.length_m;
            }
        }
        let mut cell = range;
        let extent = hi - lo;
        // Bound the cell count (a particle flung far away must not make a
        // huge grid): at most ~4 cells per particle.
        let cap = (4 * n + 64) as f64;
        loop {
            let cells: f64 = extent.iter().map(|e| (e / cell).floor() + 1.0).product();
            if cells <= cap {
                break;
            }
            cell *= 1.26;
        }
        // A periodic axis is cut into whole cells of at least `cell`; the
        // others cover the particles' extent.
        let dims = [0, 1, 2].map(|a| match periodic[a] {
            // Never fewer than three (the grown `cell` may not fit three
            // times; `range` does, by `check_fits`).
            Some(axis) => ((axis.length_m / cell).floor() as usize).max(3),
            None => ((extent[a] / cell).floor() as usize) + 1,
        });
        let inv_cell = [0, 1, 2].map(|a| match periodic[a] {
            Some(axis) => dims[a] as f64 / axis.length_m,
            None => 1.0 / cell,
        });
        let coord = |x: &Vector3<f64>, a: usize| match periodic[a] {
            Some(axis) => axis.wrap(x[a]),
            None => x[a],
        };
        let cell_of = |x: &Vector3<f64>| {
            let c = [0, 1, 2]
                .map(|a| (((coord(x, a) - lo[a]) * inv_cell[a]) as usize).min(dims[a] - 1));
            (c[2] * dims[1] + c[1]) * dims[0] + c[0]
        };
        let ncell = dims[0] * dims[1] * dims[2];
        let mut cell_start = vec![0u32; ncell + 1];
        let ids: Vec<usize> = position_m.iter().map(cell_of).collect();
        for &c in &ids {
            cell_start[c + 1] += 1;
        }
        for c in 0..ncell {
            cell_start[c + 1] += cell_start[c];
        }
        let mut fill = cell_start[..ncell].to_vec();
        let mut cell_particles = vec![0u32; n];
        for (p, &c) in ids.iter().enumerate() {
            cell_particles[fill[c] as usize] = p as u32;
            fill[c] += 1;
        }
        let cell_sphere_m = cell_particles
            .iter()
            .map(|&p| {
                let (x, r) = (position_m[p as usize], radius_m[p as usize]);
                [x.x, x.y, x.z, r]
            })
            .collect();
        Ok(Grid {
            origin: lo,
            inv_cell,
            dims,
            periodic: *periodic,
            images: Images::new(periodic),
            cell_start,
            cell_particles,
            cell_sphere_m,
        })
    }

    /// Appends to `out` each j > i whose surface is within `skin_m` of
    /// particle i's (at `x`, radius `r_m`), in cell order; across a
    /// periodic face, by the nearest image.
    #[inline]
    fn near_into(&self, i: usize, x: Vector3<f64>, r_m: f64, skin_m: f64, out: &mut Vec<u32>) {
        if self.images.any() {
            self.near_periodic_into(i, x, r_m, skin_m, out);
            return;
        }
        let c = [0, 1, 2]
            .map(|a| (((x[a] - self.origin[a]) * self.inv_cell[a]) as usize).min(self.dims[a] - 1));
        let range = |a: usize| c[a].saturating_sub(1)..=(c[a] + 1).min(self.dims[a] - 1);
        let mut spans = Spans::default();
        for cz in range(2) {
            for cy in range(1) {
                let row = (cz * self.dims[1] + cy) * self.dims[0];
                let xs = range(0);
                spans.push(self.span(row, (*xs.start(), *xs.end())));
            }
        }
        self.scan::<false>(i as u32, x, [r_m, skin_m], &spans, out);
    }

    /// [`Grid::near_into`] in a box with periodic axes.
    fn near_periodic_into(
        &self,
        i: usize,
        x: Vector3<f64>,
        r_m: f64,
        skin_m: f64,
        out: &mut Vec<u32>,
    ) {
        let c = [0, 1, 2].map(|a| {
            let xa = self.periodic[a].map_or(x[a], |axis| axis.wrap(x[a]));
            (((xa - self.origin[a]) * self.inv_cell[a]) as usize).min(self.dims[a] - 1)
        });
        // The neighbour cells along an axis: wrapped on a periodic one
        // (three distinct cells: `check_fits`), clipped on the others.
        let cells = |a: usize| -> ([usize; 3], usize) {
            let d = self.dims[a];
            if self.periodic[a].is_some() && d >= 3 {
                ([(c[a] + d - 1) % d, c[a], (c[a] + 1) % d], 3)
            } else {
                let lo = c[a].saturating_sub(1);
                let hi = (c[a] + 1).min(d - 1);
                let mut v = [0; 3];
                for (k, cell) in (lo..=hi).enumerate() {
                    v[k] = cell;
                }
                (v, hi - lo + 1)
            }
        };
        // Runs of consecutive x cells (one, or two where x wraps).
        let (xs, nx) = cells(0);
        let mut runs = [(0usize, 0usize); 3];
        let mut nruns = 0;
        let mut sorted = xs;
        sorted[..nx].sort_unstable();
        for &cx in &sorted[..nx] {
            if nruns > 0 && runs[nruns - 1].1 + 1 == cx {
                runs[nruns - 1].1 = cx;
            } else {
                runs[nruns] = (cx, cx);
                nruns += 1;
            }
        }
        let (ys, ny) = cells(1);
        let (zs, nz) = cells(2);
        let mut spans = Spans::default();
        for &cz in &zs[..nz] {
            for &cy in &ys[..ny] {
                let row = (cz * self.dims[1] + cy) * self.dims[0];
                for &run in &runs[..nruns] {
                    spans.push(self.span(row, run));
                }
            }
        }
        self.scan::<true>(i as u32, x, [r_m, skin_m], &spans, out);
    }

    /// The cell-sorted slots of the cells `x0..=x1` of the row starting at
    /// cell `row` (a row's cells are contiguous in the sorted order).
    #[inline(always)]
    fn span(&self, row: usize, (x0, x1): (usize, usize)) -> (usize, usize) {
        (
            self.cell_start[row + x0] as usize,
            self.cell_start[row + x1 + 1] as usize,
        )
    }

    /// Appends to `out` each j > i in the slots `spans` whose surface is
    /// within the skin of particle i's (at `x`; `[radius, skin]` in m),
    /// the separation taken by the nearest image with `PERIODIC`.
    #[inline(always)]
    fn scan<const PERIODIC: bool>(
        &self,
        i: u32,
        x: Vector3<f64>,
        [r_m, skin_m]: [f64; 2],
        spans: &Spans,
        out: &mut Vec<u32>,
    ) {
        // Every candidate is written, the count advances only for the kept
        // ones: no branch on the (unpredictable) test. Room for all of
        // them is made once per particle, not once per row (nine zero
        // fills and `memset` calls a particle).
        let spans = &spans.span[..spans.len];
        let total: usize = spans.iter().map(|&(a, b)| b - a).sum();
        let first = out.len();
        out.resize(first + total, 0);
        let kept = &mut out[first..];
        let mut m = 0;
        for &(a, b) in spans {
            for (&j, s) in self.cell_particles[a..b]
                .iter()
                .zip(&self.cell_sphere_m[a..b])
            {
                let y = Vector3::new(s[0], s[1], s[2]);
                let d = if PERIODIC {
                    self.images.separation(&x, &y)
                } else {
                    y - x
                };
                let cut = r_m + s[3] + skin_m;
                kept[m] = j;
                m += usize::from((j > i) & (d.norm_squared() < cut * cut));
            }
        }
        out.truncate(first + m);
    }
}

/// The slot ranges of the cells a particle's partners can lie in: at most
/// three rows of three along y and z, each in up to two runs (where a
/// periodic x wraps).
#[derive(Default)]
struct Spans {
    span: [(usize, usize); 18],
    len: usize,
}

impl Spans {
    #[inline(always)]
    fn push(&mut self, span: (usize, usize)) {
        self.span[self.len] = span;
        self.len += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every pair (i, j > i) of `x` closer than `range_m` (m), in order.
    fn brute_force_pairs(x: &[Vector3<f64>], range_m: f64) -> Vec<(u32, u32)> {
        let mut pairs = Vec::new();
        for i in 0..x.len() {
            for j in i + 1..x.len() {
                if (x[i] - x[j]).norm() < range_m {
                    pairs.push((i as u32, j as u32));
                }
            }
        }
        pairs
    }

    #[test]
    fn finds_the_same_pairs_as_brute_force() {
        // An irregular cloud of three build chunks, the last one partial.
        let mut x = Vec::new();
        let mut s = 1u64;
        for _ in 0..2 * BUILD_CHUNK + 300 {
            let mut r = || {
                s = s
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                (s >> 11) as f64 / (1u64 << 53) as f64
            };
            x.push(Vector3::new(r(), r(), r()) * 0.03);
        }
        let r = vec![1e-3; x.len()];
        let mut list = NeighbourList::default();
        list.build(&x, &r, 2e-4).unwrap();
        let want = brute_force_pairs(&x, 2.2e-3);
        let got: Vec<(u32, u32)> = list
            .pair_i
            .iter()
            .copied()
            .zip(list.pair_j.iter().copied())
            .collect();
        assert_eq!(got, want);
        for c in 0..3 {
            let (a, b) = (c * BUILD_CHUNK, ((c + 1) * BUILD_CHUNK).min(x.len()));
            assert!(list.start[b] > list.start[a] + 20, "chunk {c} has pairs");
        }
        for i in 0..x.len() {
            let run = list.start[i] as usize..list.start[i + 1] as usize;
            assert!(list.pair_i[run].iter().all(|&p| p as usize == i));
        }
        // Open contacts keep their history through a rebuild in every chunk.
        for (k, h) in list.history.iter_mut().enumerate() {
            *h = [k as f64, 1.0, 2.0];
        }
        list.open.fill(1);
        let before = list.history.clone();
        list.build(&x, &r, 2e-4).unwrap();
        assert_eq!(list.history, before);
        assert!(list.open.iter().all(|&o| o == 1));
    }

    #[test]
    fn a_bed_numbered_layer_by_layer_lists_the_same_pairs_as_brute_force() {
        // Numbered by height, as lattices and pluviated beds are: most
        // candidates below each particle are dropped for their index.
        let mut s = 7u64;
        let mut r = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut x: Vec<Vector3<f64>> = (0..1500)
            .map(|_| Vector3::new(r() * 0.02, r() * 0.02, r() * 0.02))
            .collect();
        x.sort_by(|a, b| (a.z, a.y, a.x).partial_cmp(&(b.z, b.y, b.x)).unwrap());
        let radius = vec![1e-3; x.len()];
        let mut list = NeighbourList::default();
        list.build(&x, &radius, 2e-4).unwrap();
        let want = brute_force_pairs(&x, 2.2e-3);
        let got: Vec<(u32, u32)> = (list.pair_i.iter().copied())
            .zip(list.pair_j.iter().copied())
            .collect();
        assert!(
            want.len() > 3 * x.len(),
            "a dense bed: {} pairs",
            want.len()
        );
        assert_eq!(got, want);
    }

    #[test]
    fn history_follows_the_pair_across_rebuilds() {
        let x = vec![
            Vector3::new(0.0, 0.0, 0.0),
            Vector3::new(1.9e-3, 0.0, 0.0),
            Vector3::new(3.8e-3, 0.0, 0.0),
        ];
        let r = vec![1e-3; 3];
        let mut list = NeighbourList::default();
        list.build(&x, &r, 2e-4).unwrap();
        assert_eq!(list.pair_count(), 2);
        list.history[1] = [7.0, 8.0, 9.0]; // pair (1, 2), open
        list.open[1] = 1;
        // Particle 0 moves away: pair (0, 1) drops, (1, 2) keeps its history.
        let y = vec![Vector3::new(-1.0e-2, 0.0, 0.0), x[1], x[2]];
        list.build(&y, &r, 2e-4).unwrap();
        assert_eq!(list.pair_count(), 1);
        assert_eq!((list.pair_i[0], list.pair_j[0]), (1, 2));
        assert_eq!(list.history[0], [7.0, 8.0, 9.0]);
        assert_eq!(list.open[0], 1);
        // A closed pair's stale history is not carried.
        list.open[0] = 0;
        list.build(&x, &r, 2e-4).unwrap();
        assert_eq!(list.history[1], History::default());
        assert_eq!(list.open, vec![0, 0]);
    }
}
