//! The problem of `shared/cavity/README.md` as the DEM's parameters, and
//! its run.
//!
//! Where this DEM's conventions differ from the LAMMPS build the problem
//! was written for, the difference is chosen to match what LAMMPS does:
//! - LAMMPS' `damping tsuji` at e = 0.5 has a true restitution of 0.616;
//!   this DEM's damping is set from the true restitution, so 0.616;
//! - LAMMPS' walls take E*_wall = E/(2(1 − ν)), not the pair law's
//!   E/(2(1 − ν²)): the walls here are of a material with Young's modulus
//!   E(1 + ν)/(1 − ν), which gives the grains that E* against them. Their
//!   tangential stiffness (8 G* a from the two materials) stays this
//!   DEM's, 2.1 × LAMMPS' E(2 − ν)(1 + ν)/4 · a: in a quasi-static
//!   problem the Coulomb limit governs the tangential force, not the
//!   spring.

use anyhow::{Context, Result};
use dem::contact::{ContactSpec, Material};
use dem::{step, CylinderSide, Params, Particles, PeriodicAxis, State, Wall};
use nalgebra::Vector3;

use super::bed::Bed;
use super::curve::{rest_mean_kpa, Curve, Window};

/// The box, grains, contact law and cylinder of the problem (SI units).
#[derive(Clone, Debug, PartialEq)]
pub struct Cavity {
    /// Side walls at x = 0 and x = `width_m` (m).
    pub width_m: f64,
    /// Period along y, the cylinder's axis (m): L in p_e = ΣF_n/(π·2R·L).
    pub period_m: f64,
    /// The cylinder's axis: x and z (m).
    pub axis_xz_m: [f64; 2],
    /// Radius before and after the expansion (m).
    pub radius_m: [f64; 2],
    /// The grains' material.
    pub grain: Material,
    /// Coulomb friction, everywhere (−).
    pub friction: f64,
    /// True normal restitution of the contacts (−).
    pub restitution: f64,
    /// Gravity (m/s², down −z) and the pore water's density (kg/m³): the
    /// grains feel g (1 − ρ_w/ρ_s).
    pub gravity_m_s2: f64,
    /// See `gravity_m_s2`.
    pub water_density_kg_m3: f64,
    /// Time step (s).
    pub dt_s: f64,
    /// Neighbour-list skin (m).
    pub skin_m: f64,
    /// Rest at the start radius before the expansion (s).
    pub relax_s: f64,
    /// The span before the expansion whose mean is the at-rest value (s).
    pub rest_mean_s: f64,
}

impl Default for Cavity {
    /// The problem as `shared/cavity/README.md` states it.
    fn default() -> Self {
        Cavity {
            width_m: 0.080,
            period_m: 0.030,
            axis_xz_m: [0.040, 0.030],
            radius_m: [9.35e-3, 12.5e-3],
            grain: Material {
                youngs_modulus_pa: 1.0e7,
                poisson_ratio: 0.3,
                density_kg_m3: 2920.0,
            },
            friction: 0.25,
            restitution: 0.616,
            gravity_m_s2: 9.81,
            water_density_kg_m3: 1025.0,
            dt_s: 1.5e-5,
            skin_m: 2.0e-4,
            relax_s: 0.1,
            rest_mean_s: 0.05,
        }
    }
}

/// The expansion's schedule in steps, the same integers as `in.expand`:
/// an output window every `window_steps` (1 % of the expansion), the
/// expansion from step `start_step` for `expansion_steps` steps.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Schedule {
    /// Steps per 1 % window.
    pub window_steps: u64,
    /// Steps of the expansion (100 windows).
    pub expansion_steps: u64,
    /// Step at which the expansion starts (a whole number of windows).
    pub start_step: u64,
}

/// Steps between two samples of the windows' averages (LAMMPS' `fix
/// ave/time 10 …`).
pub const SAMPLE_EVERY: u64 = 10;

impl Schedule {
    /// The schedule of an expansion lasting about `expansion_s` (s) after
    /// `relax_s` (s) at rest, with step `dt_s` (s).
    pub fn new(expansion_s: f64, relax_s: f64, dt_s: f64) -> Result<Schedule> {
        anyhow::ensure!(
            expansion_s > 0.0 && expansion_s.is_finite() && relax_s >= 0.0 && dt_s > 0.0,
            "expansion {expansion_s} s, rest {relax_s} s, step {dt_s} s: not a schedule"
        );
        let window_steps = 10 * (expansion_s / dt_s / 1000.0).round() as u64;
        anyhow::ensure!(
            window_steps > 0,
            "expansion of {expansion_s} s is too short"
        );
        let start_step = window_steps * (relax_s / (dt_s * window_steps as f64)).round() as u64;
        Ok(Schedule {
            window_steps,
            expansion_steps: 100 * window_steps,
            start_step,
        })
    }

    /// The last step.
    pub fn end_step(&self) -> u64 {
        self.start_step + self.expansion_steps
    }

    /// Fraction of the expansion done at `step` (0 before, 1 after).
    pub fn fraction(&self, step: u64) -> f64 {
        (step.saturating_sub(self.start_step) as f64 / self.expansion_steps as f64).min(1.0)
    }

    /// Whether the radius grows during the step that ends at `step`.
    pub fn growing(&self, step: u64) -> bool {
        step > self.start_step && step <= self.end_step()
    }
}

impl Cavity {
    /// The cylinder's radius at `step` (m).
    pub fn radius_at(&self, schedule: &Schedule, step: u64) -> f64 {
        let [r0, r1] = self.radius_m;
        r0 + (r1 - r0) * schedule.fraction(step)
    }

    /// The DEM's parameters: the grains, the walls (x = 0 and x = width,
    /// the floor z = 0, the cylinder at its start radius, last) and the
    /// period along y.
    pub fn params(&self) -> Result<Params> {
        let spec = ContactSpec {
            restitution: self.restitution,
            friction: self.friction,
            rolling_friction: 0.0,
        };
        let mut params = Params::new(&self.grain, &spec, self.dt_s)?;
        params.gravity_m_s2 = Vector3::new(0.0, 0.0, -self.gravity_m_s2);
        params.fluid_density_kg_m3 = self.water_density_kg_m3;
        params.skin_m = self.skin_m;
        params.periodic = [None, Some(PeriodicAxis::new(0.0, self.period_m)?), None];
        let nu = self.grain.poisson_ratio;
        let wall = Material {
            youngs_modulus_pa: self.grain.youngs_modulus_pa * (1.0 + nu) / (1.0 - nu),
            ..self.grain
        };
        let plane = |point: Vector3<f64>, normal: Vector3<f64>| {
            Wall::plane(point, normal, &self.grain, &wall, &spec)
        };
        params.walls = vec![
            plane(Vector3::zeros(), Vector3::x())?,
            plane(Vector3::new(self.width_m, 0.0, 0.0), -Vector3::x())?,
            plane(Vector3::zeros(), Vector3::z())?,
            Wall::cylinder(
                Vector3::new(self.axis_xz_m[0], 0.0, self.axis_xz_m[1]),
                Vector3::y(),
                self.radius_m[0],
                CylinderSide::Outside,
                &self.grain,
                &wall,
                &spec,
            )?,
        ];
        Ok(params)
    }

    /// Index of the cylinder in [`Cavity::params`]' walls.
    pub const CYLINDER: usize = 3;

    /// The bed's spheres as DEM particles at rest; a sphere outside the
    /// box (beyond a side wall, below the floor, inside the cylinder) is
    /// an error naming it.
    pub fn particles(&self, bed: &Bed) -> Result<Particles> {
        let mut p = Particles::new();
        for (k, (x, &r)) in bed.position_m.iter().zip(&bed.radius_m).enumerate() {
            let to_axis =
                ((x.x - self.axis_xz_m[0]).powi(2) + (x.z - self.axis_xz_m[1]).powi(2)).sqrt();
            anyhow::ensure!(
                x.x > 0.0 && x.x < self.width_m && x.z > 0.0 && to_axis > self.radius_m[0],
                "sphere {} (row {}) at ({:.5}, {:.5}, {:.5}) m is outside the box (0 < x < {} m, z > 0, outside the cylinder)",
                k + 1,
                k + 2,
                x.x,
                x.y,
                x.z,
                self.width_m
            );
            p.push(*x, Vector3::zeros(), r, self.grain.density_kg_m3)
                .with_context(|| format!("sphere {}", k + 1))?;
        }
        Ok(p)
    }
}

/// Runs the expansion of `bed` over about `expansion_s` (s) and returns
/// the windows' p_e; `progress` is called after every step with the
/// step and the last.
pub fn run(
    cavity: &Cavity,
    bed: &Bed,
    expansion_s: f64,
    progress: impl FnMut(u64, u64),
) -> Result<Curve> {
    let schedule = Schedule::new(expansion_s, cavity.relax_s, cavity.dt_s)?;
    let windows = simulate(cavity, bed, &schedule, schedule.end_step(), progress)?;
    Curve::new(windows, &schedule, cavity)
}

/// Only the rest before an expansion of `expansion_s` (s): p_e at rest
/// (kPa), the mean of the same windows as [`Curve::at_rest_kpa`].
pub fn at_rest_kpa(cavity: &Cavity, bed: &Bed, expansion_s: f64) -> Result<f64> {
    let schedule = Schedule::new(expansion_s, cavity.relax_s, cavity.dt_s)?;
    let windows = simulate(cavity, bed, &schedule, schedule.start_step, |_, _| {})?;
    rest_mean_kpa(&windows, &schedule, cavity)
}

/// Steps `bed` through `schedule` up to step `end`; the windows so far.
fn simulate(
    cavity: &Cavity,
    bed: &Bed,
    schedule: &Schedule,
    end: u64,
    mut progress: impl FnMut(u64, u64),
) -> Result<Vec<Window>> {
    let mut params = cavity.params()?;
    let mut state = State::new(cavity.particles(bed)?);
    let area = |r: f64| std::f64::consts::PI * 2.0 * r * cavity.period_m;
    let mut windows = Vec::with_capacity((end / schedule.window_steps) as usize);
    let (mut sum_pe, mut sum_d, mut samples) = (0.0, 0.0, 0u64);
    let rate =
        (cavity.radius_m[1] - cavity.radius_m[0]) / (schedule.expansion_steps as f64 * cavity.dt_s);
    for k in 1..=end {
        // The forces that close step k see the radius of step k, as the
        // LAMMPS variable `rcyl` does.
        let r = cavity.radius_at(schedule, k);
        let cylinder = &mut params.walls[Cavity::CYLINDER];
        if let dem::WallShape::Cylinder { radius_m, .. } = &mut cylinder.shape {
            *radius_m = r;
        }
        cylinder.normal_velocity_m_s = if schedule.growing(k) { rate } else { 0.0 };
        step(&params, &mut state, &mut ())?;
        if k % SAMPLE_EVERY == 0 {
            sum_pe += state.wall_normal_loads_n()[Cavity::CYLINDER] / area(r) / 1e3;
            sum_d += 2.0 * r * 1e3;
            samples += 1;
        }
        if k % schedule.window_steps == 0 {
            let n = samples.max(1) as f64;
            windows.push(Window {
                end_step: k,
                d_mm: sum_d / n,
                pe_kpa: sum_pe / n,
            });
            (sum_pe, sum_d, samples) = (0.0, 0.0, 0);
        }
        progress(k, end);
    }
    Ok(windows)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_schedule_has_the_steps_of_in_expand() {
        // in.expand at T = 1 s and 2 s (shared/cavity/README.md).
        let one = Schedule::new(1.0, 0.1, 1.5e-5).unwrap();
        assert_eq!(
            (one.window_steps, one.expansion_steps, one.start_step),
            (670, 67_000, 6_700)
        );
        let two = Schedule::new(2.0, 0.1, 1.5e-5).unwrap();
        assert_eq!(
            (two.window_steps, two.expansion_steps, two.start_step),
            (1_330, 133_000, 6_650)
        );
        let c = Cavity::default();
        assert_eq!(c.radius_at(&one, 6_700), 9.35e-3);
        assert!((c.radius_at(&one, 6_700 + 33_500) - 10.925e-3).abs() < 1e-15);
        assert_eq!(c.radius_at(&one, 80_000), 12.5e-3);
        assert!(!one.growing(6_700) && one.growing(6_701) && one.growing(73_700));
        assert!(!one.growing(73_701));
    }

    #[test]
    fn spheres_outside_the_box_are_refused_by_row() {
        let c = Cavity::default();
        let bed = Bed {
            position_m: vec![
                Vector3::new(0.01, 0.0, 0.01),
                Vector3::new(0.04, 0.01, 0.031),
            ],
            radius_m: vec![1e-3, 1e-3],
        };
        let e = c.particles(&bed).unwrap_err().to_string();
        assert!(e.contains("sphere 2 (row 3)"), "{e}");
    }
}
