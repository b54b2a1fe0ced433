//! How the cost per particle-step grows with the bed (`host-sim bench
//! scaling`): the benchmark's grains ([`crate::benchmark`]) settled once in
//! its 60 × 60 mm box made periodic across (x and y, the floor kept), then
//! tiled k × k side by side. A periodic settled bed tiles seamlessly: every
//! copy is the same settled bed, with the same density of contacts, so
//! 20,000 grains become 180,000 at k = 3 and 980,000 at k = 7 without
//! settling again. Each size runs a short untimed warm-up (the tiles'
//! contact history starts afresh), then a timed packed phase.

use std::fmt::Write as _;
use std::time::Instant;

use anyhow::{ensure, Context, Result};
use nalgebra::Vector3;

use crate::benchmark::{self, material, BOX_M};
use crate::{self as dem, Params, Particles, PeriodicAxis, State, WallShape};

/// Steps the 20,000-grain bed settles before it is tiled: the benchmark's
/// warm-up and settling phases.
pub const SETTLE_STEPS: u64 = 21_000;

/// Untimed steps after tiling, while the tiles' contact history builds.
pub const WARM_UP_STEPS: u64 = 200;

/// Untimed steps before each timed round, so that a size starts its round
/// with its own data in the caches and its workers awake, as it would
/// timed alone, not with what the size before it left there.
pub const REWARM_STEPS: u64 = 20;

/// Rounds the timed steps are split into, the sizes and worker counts
/// taking turns within each; the median round's rate is reported, so that
/// a moment of load from elsewhere on a shared machine does not decide a
/// size's figure (the 20,000-grain size runs only a second or two).
pub const ROUNDS: u64 = 5;

/// What to measure.
#[derive(Clone, Debug)]
pub struct ScalingOptions {
    /// Tiles per side (k: k² copies of the 20,000-grain bed).
    pub tiles: Vec<usize>,
    /// Timed steps at each size.
    pub steps: u64,
    /// Worker thread counts.
    pub workers: Vec<usize>,
}

/// One size at one worker count.
#[derive(Clone, Debug)]
pub struct ScalingRow {
    /// Particles.
    pub particles: usize,
    /// Worker threads.
    pub workers: usize,
    /// N × steps / wall time of the timed steps: the median of
    /// [`ROUNDS`] rounds.
    pub particle_steps_per_s: f64,
    /// Mean particle–particle contacts per particle after the timed steps.
    pub mean_contacts: f64,
    /// Listed pairs (touching or within the skin) per particle after the
    /// timed steps: what the pair pass sweeps.
    pub listed_pairs_per_particle: f64,
    /// What setting this size up and warming it up added to the process'
    /// peak resident memory (Linux's VmHWM), per particle (bytes), when
    /// the system says: the bed's own footprint, the settled 20,000-grain
    /// bed and the program not counted.
    pub peak_bytes_per_particle: Option<f64>,
    /// Time of the closing half kick alone, per particle (ns): a pass
    /// with no neighbours that only streams the particles' arrays, so its
    /// growth with N is the memory system's, not the contact search's.
    pub kick_ns_per_particle: f64,
}

/// Bytes the closing half kick moves per particle: it reads velocity,
/// spin, force, torque (4 × 24 B) and the two inverse inertias (2 × 8 B)
/// and writes velocity and spin back (2 × 24 B).
pub const KICK_BYTES_PER_PARTICLE: f64 = 160.0;

/// The benchmark's parameters with the box periodic across, `tiles`
/// boxes wide along x and y: its side walls gone, the floor kept.
fn params(tiles: usize) -> Result<Params> {
    let mut p = benchmark::params()?;
    p.walls
        .retain(|w| matches!(w.shape, WallShape::Plane { normal, .. } if normal == Vector3::z()));
    let axis = PeriodicAxis::new(0.0, BOX_M * tiles as f64)?;
    p.periodic = [Some(axis), Some(axis), None];
    Ok(p)
}

/// The settled periodic 20,000-grain bed.
pub fn settled_bed(steps: u64) -> Result<State> {
    let params = params(1)?;
    let mut state = State::new(benchmark::grains()?);
    dem::advance(&params, &mut state, &mut (), steps)?;
    Ok(state)
}

/// `bed` (periodic across one box) copied `tiles` × `tiles` times side by
/// side, velocities kept.
pub fn tiled(bed: &State, tiles: usize) -> Result<State> {
    let p = &bed.particles;
    let mut out = Particles::new();
    for j in 0..tiles {
        for i in 0..tiles {
            let shift = Vector3::new(i as f64 * BOX_M, j as f64 * BOX_M, 0.0);
            for k in 0..p.len() {
                // Back into the one box first: positions may stand up to
                // half the skin outside it between list builds.
                let mut x = p.position_m[k];
                x.x = x.x.rem_euclid(BOX_M);
                x.y = x.y.rem_euclid(BOX_M);
                out.push(
                    x + shift,
                    p.velocity_m_s[k],
                    p.radius_m[k],
                    material().density_kg_m3,
                )?;
            }
        }
    }
    Ok(State::new(out))
}

/// Peak resident memory of this process (bytes), from /proc/self/status.
fn peak_rss_bytes() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024.0)
}

/// Settles the bed once, sets up every size (increasing), then times the
/// sizes and worker counts in turn, round by round ([`ROUNDS`]), so that
/// a change in the machine's load over the run falls on all of them alike
/// instead of on whichever size ran then.
pub fn run(opts: &ScalingOptions, progress: impl Fn(&str)) -> Result<Vec<ScalingRow>> {
    ensure!(!opts.tiles.is_empty(), "no bed size given");
    ensure!(
        opts.tiles.iter().all(|&k| (1..=20).contains(&k)),
        "tiles per side: 1 to 20"
    );
    ensure!(opts.steps >= 1, "at least one timed step");
    ensure!(
        !opts.workers.is_empty() && opts.workers.iter().all(|&w| w >= 1),
        "worker counts must be at least 1"
    );
    let mut tiles = opts.tiles.clone();
    tiles.sort_unstable();
    tiles.dedup();
    let pools = (opts.workers.iter())
        .map(|&w| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(w).build();
            Ok((w, pool.context("starting the worker threads")?))
        })
        .collect::<Result<Vec<_>>>()?;
    let most = &pools
        .iter()
        .max_by_key(|(w, _)| *w)
        .context("no worker count")?
        .1;
    progress("settling the 20,000-grain periodic bed");
    let bed = most.install(|| settled_bed(SETTLE_STEPS))?;
    // Each size once, warmed up; its peak memory is what setting it up
    // added to the process's peak.
    let mut sizes = Vec::new();
    for &k in &tiles {
        let before = peak_rss_bytes();
        let params = params(k)?;
        let mut state = tiled(&bed, k)?;
        progress(&format!("{} particles: warming up", state.particles.len()));
        most.install(|| dem::advance(&params, &mut state, &mut (), WARM_UP_STEPS))?;
        let n = state.particles.len() as f64;
        let peak = peak_rss_bytes()
            .zip(before)
            .map(|(after, before)| (after - before) / n);
        sizes.push((params, state, peak));
    }
    let mut rates = vec![Vec::new(); sizes.len() * pools.len()];
    for r in 0..ROUNDS {
        progress(&format!("round {} of {ROUNDS}", r + 1));
        let steps = opts.steps * (r + 1) / ROUNDS - opts.steps * r / ROUNDS;
        if steps == 0 {
            continue;
        }
        for (s, (params, state, _)) in sizes.iter_mut().enumerate() {
            for (q, (_, pool)) in pools.iter().enumerate() {
                let n = state.particles.len() as f64;
                pool.install(|| dem::advance(params, state, &mut (), REWARM_STEPS))?;
                let t0 = Instant::now();
                pool.install(|| dem::advance(params, state, &mut (), steps))?;
                rates[s * pools.len() + q].push(n * steps as f64 / t0.elapsed().as_secs_f64());
            }
        }
    }
    let mut rows = Vec::new();
    for (s, (params, state, peak)) in sizes.iter().enumerate() {
        let n = state.particles.len();
        for (q, (w, pool)) in pools.iter().enumerate() {
            let mut r = rates[s * pools.len() + q].clone();
            r.sort_unstable_by(f64::total_cmp);
            let kick_s = pool.install(|| {
                let mut p = state.particles.clone();
                let t0 = Instant::now();
                for _ in 0..opts.steps {
                    dem::integrate::kick(&mut p, params.dt_s);
                }
                t0.elapsed().as_secs_f64()
            });
            rows.push(ScalingRow {
                particles: n,
                workers: *w,
                particle_steps_per_s: r[r.len() / 2],
                mean_contacts: state.mean_contacts(),
                listed_pairs_per_particle: state.neighbours().pair_count() as f64 / n as f64,
                peak_bytes_per_particle: *peak,
                kick_ns_per_particle: kick_s * 1e9 / (n as f64 * opts.steps as f64),
            });
        }
    }
    Ok(rows)
}

/// The rows as a table, with the cost per particle-step against the
/// smallest size's at the same worker count.
pub fn table(rows: &[ScalingRow]) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "particles  workers  M particle-steps/s  ns per particle-step  vs smallest  contacts  listed pairs/particle  peak B/particle  kick ns/particle  kick GB/s"
    );
    for r in rows {
        let first = rows
            .iter()
            .find(|x| x.workers == r.workers)
            .map_or(r.particle_steps_per_s, |x| x.particle_steps_per_s);
        let _ = writeln!(
            s,
            "{:>9}  {:>7}  {:>18.2}  {:>20.1}  {:>10.2}×  {:>8.3}  {:>21.3}  {:>15}  {:>16.2}  {:>9.1}",
            r.particles,
            r.workers,
            r.particle_steps_per_s / 1e6,
            1e9 / r.particle_steps_per_s,
            first / r.particle_steps_per_s,
            r.mean_contacts,
            r.listed_pairs_per_particle,
            r.peak_bytes_per_particle
                .map_or("-".to_string(), |b| format!("{b:.0}")),
            r.kick_ns_per_particle,
            KICK_BYTES_PER_PARTICLE / r.kick_ns_per_particle
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_tiled_bed_is_the_bed_repeated() {
        // A bed settled a little, tiled 2 × 2: four times the grains, each
        // copy shifted by whole boxes, and the same contacts per grain
        // (the periodic seams join copies as the period joined the bed).
        let bed = settled_bed(1_500).unwrap();
        let n = bed.particles.len();
        let t = tiled(&bed, 2).unwrap();
        assert_eq!(t.particles.len(), 4 * n);
        let d = t.particles.position_m[3 * n + 17] - t.particles.position_m[17];
        assert!((d.x - BOX_M).abs() < 1e-12 && (d.y - BOX_M).abs() < 1e-12 && d.z == 0.0);
        let contacts = |s: &mut State, k: usize| {
            dem::step(&params(k).unwrap(), s, &mut ()).unwrap();
            s.mean_contacts()
        };
        let (mut one, mut four) = (tiled(&bed, 1).unwrap(), t);
        let (c1, c4) = (contacts(&mut one, 1), contacts(&mut four, 2));
        assert!(c1 > 0.1, "{c1} contacts per grain: the bed has not landed");
        assert!((c1 - c4).abs() < 1e-12, "{c1} against {c4}");
    }
}
