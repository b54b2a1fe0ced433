//! The DEM throughput benchmark of `shared/bench/` (`host-sim bench dem`):
//! 20,000 spheres (r = 1 mm, ρ = 2920 kg/m³) on a jittered simple-cubic
//! lattice settling in a 60 × 60 mm open-top box, Hertz–Mindlin with
//! history, E = 1e7 Pa, ν = 0.3, e = 0.5, μ = 0.25, dt = 1.5e-5 s; timed
//! phases of 1,000 warm-up, 20,000 settling and 10,000 packed-bed steps.
//! The figure of merit is particle-steps per second, N × steps / wall time.

use std::fmt::Write as _;
use std::time::Instant;

use anyhow::{Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use nalgebra::Vector3;
use rand::{RngExt, SeedableRng};

use crate::{self as dem, ContactSpec, Material, Params, Particles, State, Wall};

/// Lattice pitch (m): 1.2 d.
pub const PITCH_M: f64 = 2.4e-3;
/// Uniform jitter of each coordinate (m): ± this.
pub const JITTER_M: f64 = 0.15e-3;
/// Lattice counts along x, y, z.
pub const LATTICE: [usize; 3] = [25, 25, 32];
/// Grain radius (m).
pub const RADIUS_M: f64 = 1.0e-3;
/// Box side (m).
pub const BOX_M: f64 = 60.0e-3;
/// Gravity (m/s², along −z): in.liggghts's `fix gravity`.
pub const GRAVITY_M_S2: f64 = 9.81;
/// Lattice seed of gen_lattice.py.
pub const SEED: u64 = 12345;
/// Steps of the three timed phases (warm-up, settling, packed bed).
pub const PHASES: [(&str, u64); 3] = [("warm-up", 1_000), ("settling", 20_000), ("packed", 10_000)];

/// Grain material: E = 1e7 Pa, ν = 0.3, ρ = 2920 kg/m³ (walls alike).
pub fn material() -> Material {
    Material {
        youngs_modulus_pa: 1.0e7,
        poisson_ratio: 0.3,
        density_kg_m3: 2920.0,
    }
}

/// Start positions (m) as gen_lattice.py makes them: x fastest, then y,
/// then z; each coordinate 1.2 mm + pitch × index + U(−jitter, jitter),
/// then kept 0.05 mm off the side walls and the floor. Same distribution
/// and counts; a different random stream.
pub fn lattice(seed: u64) -> Vec<Vector3<f64>> {
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    let margin = RADIUS_M + 5e-5;
    let mut out = Vec::with_capacity(LATTICE.iter().product());
    for k in 0..LATTICE[2] {
        for j in 0..LATTICE[1] {
            for m in 0..LATTICE[0] {
                let mut jit = || rng.random_range(-JITTER_M..=JITTER_M);
                let x = 1.2e-3 + PITCH_M * m as f64 + jit();
                let y = 1.2e-3 + PITCH_M * j as f64 + jit();
                let z = 1.2e-3 + PITCH_M * k as f64 + jit();
                out.push(Vector3::new(
                    x.clamp(margin, BOX_M - margin),
                    y.clamp(margin, BOX_M - margin),
                    z.max(margin),
                ));
            }
        }
    }
    out
}

/// The benchmark's parameters and initial state (the same contact
/// equations as LIGGGHTS' `hertz tangential history`).
pub fn problem() -> Result<(Params, State)> {
    Ok((params()?, State::new(grains()?)))
}

/// The benchmark's parameters: contact law, time step, gravity, skin and
/// the box's five walls (four sides, then the floor).
pub fn params() -> Result<Params> {
    let mat = material();
    let spec = ContactSpec {
        restitution: 0.5,
        friction: 0.25,
        rolling_friction: 0.0,
    };
    let mut params = Params::new(&mat, &spec, 1.5e-5)?;
    params.gravity_m_s2 = Vector3::new(0.0, 0.0, -GRAVITY_M_S2);
    params.skin_m = 2.0e-4;
    let planes = [
        (Vector3::zeros(), Vector3::x()),
        (Vector3::new(BOX_M, 0.0, 0.0), -Vector3::x()),
        (Vector3::zeros(), Vector3::y()),
        (Vector3::new(0.0, BOX_M, 0.0), -Vector3::y()),
        (Vector3::zeros(), Vector3::z()),
    ];
    for (point, normal) in planes {
        params
            .walls
            .push(Wall::plane(point, normal, &mat, &mat, &spec)?);
    }
    Ok(params)
}

/// The benchmark's grains at rest on their jittered lattice.
pub fn grains() -> Result<Particles> {
    let mut particles = Particles::new();
    for x in lattice(SEED) {
        particles.push(x, Vector3::zeros(), RADIUS_M, material().density_kg_m3)?;
    }
    Ok(particles)
}

/// Options of a benchmark run.
#[derive(Clone, Copy, Debug)]
pub struct BenchOptions {
    /// Worker threads (≥ 1).
    pub workers: usize,
    /// Multiplies every phase's step count (1 = the full benchmark).
    pub steps_scale: f64,
    /// Show a progress bar on stderr.
    pub progress: bool,
    /// Vector instructions of the contact pass (set process-wide).
    pub simd: dem::Simd,
}

/// One timed phase.
#[derive(Clone, Debug)]
pub struct PhaseResult {
    /// Name.
    pub name: &'static str,
    /// Steps run.
    pub steps: u64,
    /// Wall time (s).
    pub wall_s: f64,
    /// N × steps / wall time.
    pub particle_steps_per_s: f64,
}

/// The benchmark's result.
#[derive(Clone, Debug)]
pub struct BenchReport {
    /// Particles.
    pub particles: usize,
    /// Worker threads.
    pub workers: usize,
    /// The timed phases.
    pub phases: Vec<PhaseResult>,
    /// Over all phases: N × steps / wall time.
    pub overall_particle_steps_per_s: f64,
    /// Mean particle–particle contacts per particle at the end.
    pub mean_contacts: f64,
    /// Highest particle centre at the end (m).
    pub z_max_m: f64,
    /// Mean particle centre height at the end (m).
    pub z_mean_m: f64,
    /// Neighbour-list builds.
    pub list_builds: u64,
    /// Vector instructions the contact pass ran with.
    pub simd: dem::Simd,
}

impl BenchReport {
    /// A plain-text table, one line per phase and an overall line, with
    /// machine-readable `key=value` lines at the end.
    pub fn table(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "DEM bench: {} particles, {} worker(s), contact pass {:?}",
            self.particles, self.workers, self.simd
        );
        for p in &self.phases {
            let _ = writeln!(
                s,
                "  {:<9} {:>6} steps {:>8.2} s  {:>7.2} M particle-steps/s",
                p.name,
                p.steps,
                p.wall_s,
                p.particle_steps_per_s / 1e6
            );
        }
        let _ = writeln!(
            s,
            "  overall {:.2} M particle-steps/s; mean contacts {:.3}; z_max {:.2} mm; z_mean {:.2} mm; {} list builds",
            self.overall_particle_steps_per_s / 1e6,
            self.mean_contacts,
            self.z_max_m * 1e3,
            self.z_mean_m * 1e3,
            self.list_builds
        );
        let _ = writeln!(
            s,
            "RESULT workers={} overall_psps={:.0} mean_contacts={:.4} simd={:?}",
            self.workers, self.overall_particle_steps_per_s, self.mean_contacts, self.simd
        );
        s
    }
}

/// Steps a progress bar forward every 100 steps.
struct Progress(ProgressBar);

impl dem::Sink for Progress {
    fn adds_external_forces(&self) -> bool {
        false
    }

    fn step_done(&mut self, state: &State) {
        if state.step_count.is_multiple_of(100) {
            self.0.set_position(state.step_count);
        }
    }
}

/// Runs the benchmark with `opts`.
pub fn run(opts: &BenchOptions) -> Result<BenchReport> {
    anyhow::ensure!(opts.workers >= 1, "--workers must be at least 1");
    anyhow::ensure!(
        opts.steps_scale > 0.0 && opts.steps_scale.is_finite(),
        "--steps-scale must be positive, got {}",
        opts.steps_scale
    );
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(opts.workers)
        .build()
        .context("starting the worker threads")?;
    let simd = dem::use_simd(opts.simd);
    let (params, mut state) = problem()?;
    let n = state.particles.len();
    let phases: Vec<(&'static str, u64)> = PHASES
        .iter()
        .map(|&(name, steps)| {
            (
                name,
                ((steps as f64 * opts.steps_scale).round() as u64).max(1),
            )
        })
        .collect();
    let total: u64 = phases.iter().map(|p| p.1).sum();
    let bar = if opts.progress {
        ProgressBar::new(total)
    } else {
        ProgressBar::hidden()
    };
    bar.set_style(
        ProgressStyle::with_template("{msg:>9} [{bar:40}] {pos}/{len} steps, {eta} left")
            .context("progress bar template")?
            .progress_chars("=> "),
    );
    let mut sink = Progress(bar.clone());
    let mut results = Vec::new();
    pool.install(|| -> Result<()> {
        for &(name, steps) in &phases {
            bar.set_message(name);
            let t0 = Instant::now();
            // Up to each hundredth step at a time: the progress bar's
            // pace, and the steps in between fused (`dem::advance`).
            let mut left = steps;
            while left > 0 {
                let run = left.min(100 - state.step_count % 100);
                dem::advance(&params, &mut state, &mut sink, run)?;
                left -= run;
            }
            let wall_s = t0.elapsed().as_secs_f64();
            results.push(PhaseResult {
                name,
                steps,
                wall_s,
                particle_steps_per_s: n as f64 * steps as f64 / wall_s,
            });
        }
        Ok(())
    })?;
    bar.finish_and_clear();
    let wall: f64 = results.iter().map(|p| p.wall_s).sum();
    let z = state.particles.position_m.iter().map(|x| x.z);
    Ok(BenchReport {
        particles: n,
        workers: opts.workers,
        overall_particle_steps_per_s: n as f64 * total as f64 / wall,
        phases: results,
        mean_contacts: pool.install(|| state.mean_contacts()),
        z_max_m: z.clone().fold(f64::NEG_INFINITY, f64::max),
        z_mean_m: z.sum::<f64>() / n as f64,
        list_builds: state.neighbours().builds,
        simd,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lattice_matches_gen_lattice_counts_and_bounds() {
        let x = lattice(SEED);
        assert_eq!(x.len(), 20_000);
        let margin = RADIUS_M + 5e-5;
        for (idx, p) in x.iter().enumerate() {
            let (m, j, k) = (idx % 25, (idx / 25) % 25, idx / 625);
            let ideal =
                Vector3::new(m as f64, j as f64, k as f64) * PITCH_M + Vector3::repeat(1.2e-3);
            assert!((p - ideal).amax() <= JITTER_M + 1e-12);
            assert!(p.x >= margin && p.x <= BOX_M - margin && p.z >= margin);
        }
        // No initial overlaps: nearest neighbours are ≥ pitch − 2 jitter apart.
        assert!((x[0] - x[1]).norm() >= PITCH_M - 2.0 * JITTER_M - 1e-12);
    }
}
