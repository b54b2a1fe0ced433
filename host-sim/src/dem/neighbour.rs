//! Verlet neighbour list built on a cell grid.
//!
//! Each pair (i, j) with j > i whose surfaces are closer than the skin is
//! stored once, in i's run of a flat list (CSR), j ascending, so the pairs
//! are ordered by first particle, then second. The list is rebuilt when a
//! particle has moved more than half the skin; the contact history of
//! every pair still listed is carried over (matched by the particle pair).

use nalgebra::Vector3;
use rayon::prelude::*;

use super::contact::History;
use super::DemError;

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
    /// carrying over the history of pairs that stay listed.
    pub fn build(
        &mut self,
        position_m: &[Vector3<f64>],
        radius_m: &[f64],
        skin_m: f64,
    ) -> Result<(), DemError> {
        let n = position_m.len();
        let grid = Grid::new(position_m, radius_m, skin_m)?;
        let old_valid = self.start.len() == n + 1;
        let old_start = &self.start;
        let old_j = &self.pair_j;
        let old_hist = &self.history;
        let old_open = &self.open;
        type Chunk = (Vec<u32>, Vec<u32>, Vec<History>, Vec<u8>);
        let chunks: Vec<Chunk> = (0..n.div_ceil(BUILD_CHUNK))
            .into_par_iter()
            .map(|c| {
                let lo = c * BUILD_CHUNK;
                let hi = (lo + BUILD_CHUNK).min(n);
                let mut counts = Vec::with_capacity(hi - lo);
                let mut js = Vec::with_capacity((hi - lo) * 8);
                let mut hist = Vec::with_capacity((hi - lo) * 8);
                let mut open = Vec::with_capacity((hi - lo) * 8);
                for i in lo..hi {
                    let first = js.len();
                    grid.for_each_near(i, position_m, radius_m, skin_m, |j| js.push(j as u32));
                    js[first..].sort_unstable();
                    counts.push((js.len() - first) as u32);
                    // Carry history: both lists are sorted by j.
                    if old_valid {
                        let (a, b) = (old_start[i] as usize, old_start[i + 1] as usize);
                        let mut k = a;
                        for &j in &js[first..] {
                            while k < b && old_j[k] < j {
                                k += 1;
                            }
                            if k < b && old_j[k] == j && old_open[k] != 0 {
                                hist.push(old_hist[k]);
                                open.push(1);
                            } else {
                                hist.push(History::default());
                                open.push(0);
                            }
                        }
                    } else {
                        hist.resize(js.len(), History::default());
                        open.resize(js.len(), 0);
                    }
                }
                (counts, js, hist, open)
            })
            .collect();

        self.start.clear();
        self.pair_i.clear();
        self.pair_j.clear();
        self.history.clear();
        self.open.clear();
        self.start.push(0);
        let mut i = 0u32;
        for (counts, js, hist, open) in chunks {
            for c in counts {
                let s = *self.start.last().unwrap_or(&0);
                self.start.push(s + c);
                self.pair_i.extend(std::iter::repeat_n(i, c as usize));
                i += 1;
            }
            self.pair_j.extend_from_slice(&js);
            self.history.extend_from_slice(&hist);
            self.open.extend_from_slice(&open);
        }

        self.reference_m.clear();
        self.reference_m.extend_from_slice(position_m);
        self.skin_m = skin_m;
        self.builds += 1;
        Ok(())
    }
}

/// A uniform cell grid over the particles' bounding box, cells at least
/// one interaction range wide, particles sorted by cell.
struct Grid {
    origin: Vector3<f64>,
    inv_cell: f64,
    dims: [usize; 3],
    cell_start: Vec<u32>,
    cell_particles: Vec<u32>,
}

impl Grid {
    fn new(position_m: &[Vector3<f64>], radius_m: &[f64], skin_m: f64) -> Result<Grid, DemError> {
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
        let mut cell = (2.0 * r_max + skin_m).max(f64::MIN_POSITIVE);
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
        let dims = [0, 1, 2].map(|a| ((extent[a] / cell).floor() as usize) + 1);
        let inv_cell = 1.0 / cell;
        let cell_of = |x: &Vector3<f64>| {
            let c = [0, 1, 2].map(|a| (((x[a] - lo[a]) * inv_cell) as usize).min(dims[a] - 1));
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
        Ok(Grid {
            origin: lo,
            inv_cell,
            dims,
            cell_start,
            cell_particles,
        })
    }

    /// Calls `f(j)` for each j > i whose surface is within `skin_m` of i's.
    #[inline]
    fn for_each_near(
        &self,
        i: usize,
        position_m: &[Vector3<f64>],
        radius_m: &[f64],
        skin_m: f64,
        mut f: impl FnMut(usize),
    ) {
        let x = position_m[i];
        let c = [0, 1, 2]
            .map(|a| (((x[a] - self.origin[a]) * self.inv_cell) as usize).min(self.dims[a] - 1));
        let range = |a: usize| c[a].saturating_sub(1)..=(c[a] + 1).min(self.dims[a] - 1);
        for cz in range(2) {
            for cy in range(1) {
                let row = (cz * self.dims[1] + cy) * self.dims[0];
                let xs = range(0);
                let (a, b) = (
                    self.cell_start[row + xs.start()] as usize,
                    self.cell_start[row + xs.end() + 1] as usize,
                );
                // Cells of a row are contiguous in the sorted order.
                for &p in &self.cell_particles[a..b] {
                    let j = p as usize;
                    if j <= i {
                        continue;
                    }
                    let cut = radius_m[i] + radius_m[j] + skin_m;
                    if (position_m[j] - x).norm_squared() < cut * cut {
                        f(j);
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_the_same_pairs_as_brute_force() {
        // A small irregular cloud.
        let mut x = Vec::new();
        let mut s = 1u64;
        for _ in 0..300 {
            let mut r = || {
                s = s
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                (s >> 11) as f64 / (1u64 << 53) as f64
            };
            x.push(Vector3::new(r(), r(), r()) * 0.02);
        }
        let r = vec![1e-3; x.len()];
        let mut list = NeighbourList::default();
        list.build(&x, &r, 2e-4).unwrap();
        let mut want = Vec::new();
        for i in 0..x.len() {
            for j in i + 1..x.len() {
                if (x[i] - x[j]).norm() < 2.2e-3 {
                    want.push((i as u32, j as u32));
                }
            }
        }
        let got: Vec<(u32, u32)> = list
            .pair_i
            .iter()
            .copied()
            .zip(list.pair_j.iter().copied())
            .collect();
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
