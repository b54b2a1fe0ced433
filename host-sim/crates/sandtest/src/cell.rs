//! A cuboid cell of six frictionless plane walls around a DEM sample, no
//! gravity: each axis either held at a stress by servo-controlled walls
//! or strained at a set rate. The stresses are the walls' normal loads
//! over the faces' current areas.

use anyhow::{ensure, Result};
use dem::contact::{ContactSpec, Material};
use dem::{step, Params, Particles, State, Wall, WallShape};
use nalgebra::Vector3;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64Mcg;

/// The grains of a test: material, contact law and time step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Grains {
    /// Material.
    pub material: Material,
    /// Grain–grain contacts (friction, rolling resistance, restitution).
    pub contacts: ContactSpec,
    /// Radius (m), one size as in the scenario.
    pub radius_m: f64,
    /// Time step (s).
    pub dt_s: f64,
    /// Grain friction while the scenario deposits its bed (−): a sample
    /// is prepared with it, as the bed was.
    pub deposition_friction: f64,
}

impl Grains {
    /// The scenario's grains (`burrow::ScenarioSpec::paper`) at radius
    /// `radius_m` (m): the same material, contacts and time step as the
    /// expansion meets.
    pub fn scenario(radius_m: f64) -> Grains {
        let spec = burrow::ScenarioSpec::paper(0.04, radius_m);
        let (material, contacts, dt_s) = spec.grains();
        Grains {
            material,
            contacts,
            radius_m,
            dt_s,
            deposition_friction: spec.deposition_friction,
        }
    }

    /// Mass of one grain (kg).
    pub fn mass_kg(&self) -> f64 {
        4.0 / 3.0 * std::f64::consts::PI * self.radius_m.powi(3) * self.material.density_kg_m3
    }
}

/// What an axis of the cell does.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Axis {
    /// Its walls are servo-controlled to hold this normal stress (Pa).
    Stress(f64),
    /// Its walls close in at this strain rate (1/s; compression positive).
    StrainRate(f64),
}

/// Wall order in the DEM's parameters: −x, +x, −y, +y, −z, +z.
const WALLS: usize = 6;

/// The cell and its sample.
pub struct Cell {
    /// The grains.
    pub grains: Grains,
    params: Params,
    /// The sample's state.
    pub state: State,
    /// Lower and upper face of each axis (m).
    pub faces_m: [[f64; 2]; 3],
    /// Largest wall speed of a servo (m/s).
    servo_speed_m_s: f64,
    /// Each axis' stress as its servo sees it: low-passed over
    /// [`SERVO_FILTER_STEPS`] (Pa).
    servo_stress_pa: [f64; 3],
    /// Each axis' current inward wall speed (m/s).
    inward_m_s: [f64; 3],
}

/// Fraction of the cube their centres can reach that a loose sample's
/// grains fill at the start (random sequential addition jams near 0.38).
const LOOSE_FILL: f64 = 0.30;

impl Cell {
    /// `count` grains placed at random without overlap (seed `seed`),
    /// filling 0.30 of the cube their centres can reach; walls
    /// frictionless, the grains' friction set to `friction` (the scenario
    /// deposits its bed frictionless, so dense). `servo_strain_rate` (1/s) caps how fast a
    /// servo may move its walls, as a strain rate of the cell.
    pub fn loose(
        grains: Grains,
        count: usize,
        seed: u64,
        friction: f64,
        servo_strain_rate: f64,
    ) -> Result<Cell> {
        ensure!(count >= 8, "an element test needs grains: {count}");
        let r = grains.radius_m;
        let solid = count as f64 * 4.0 / 3.0 * std::f64::consts::PI * r.powi(3);
        // The centres keep a radius from the walls: the fill is of the
        // cube they can reach, so that a small sample places as a large one.
        let side = (solid / LOOSE_FILL).cbrt() + 2.0 * r;
        let mut rng = Pcg64Mcg::seed_from_u64(seed);
        let mut p = Particles::new();
        let mut tries = 0usize;
        // Random sequential addition on a grid of cells one diameter wide.
        let n_cells = ((side / (2.0 * r)).floor() as usize).max(1);
        let mut grid: Vec<Vec<usize>> = vec![Vec::new(); n_cells.pow(3)];
        let cell_of = |x: &Vector3<f64>| {
            let c = |v: f64| ((v / side * n_cells as f64) as usize).min(n_cells - 1);
            (c(x.z) * n_cells + c(x.y)) * n_cells + c(x.x)
        };
        while p.len() < count {
            tries += 1;
            ensure!(tries < 1000 * count, "could not place {count} grains");
            let x = Vector3::new(
                rng.random_range(r..side - r),
                rng.random_range(r..side - r),
                rng.random_range(r..side - r),
            );
            let c = cell_of(&x);
            let (cx, cy, cz) = (
                c % n_cells,
                (c / n_cells) % n_cells,
                c / (n_cells * n_cells),
            );
            let near = |a: usize| a.saturating_sub(1)..=(a + 1).min(n_cells - 1);
            let free = near(cz).all(|z| {
                near(cy).all(|y| {
                    near(cx).all(|xx| {
                        grid[(z * n_cells + y) * n_cells + xx]
                            .iter()
                            .all(|&k| (p.position_m[k] - x).norm() >= 2.0 * r)
                    })
                })
            });
            if free {
                grid[c].push(p.len());
                p.push(x, Vector3::zeros(), r, grains.material.density_kg_m3)?;
            }
        }
        Cell::around(grains, p, side, friction, servo_strain_rate)
    }

    /// `per_side`³ grains on a simple cubic lattice, touching one another
    /// and the walls: a sample whose stress under a load follows from
    /// Hertz's law in closed form, for checking the cell.
    pub fn lattice(
        grains: Grains,
        per_side: usize,
        friction: f64,
        servo_strain_rate: f64,
    ) -> Result<Cell> {
        ensure!(per_side >= 1, "a lattice needs grains");
        let r = grains.radius_m;
        let mut p = Particles::new();
        for k in 0..per_side {
            for j in 0..per_side {
                for i in 0..per_side {
                    let at = |n: usize| r * (2 * n + 1) as f64;
                    p.push(
                        Vector3::new(at(i), at(j), at(k)),
                        Vector3::zeros(),
                        r,
                        grains.material.density_kg_m3,
                    )?;
                }
            }
        }
        Cell::around(
            grains,
            p,
            2.0 * r * per_side as f64,
            friction,
            servo_strain_rate,
        )
    }

    /// The cell of side `side` (m) around the grains `p`: six frictionless
    /// plane walls, the grains' friction `friction`.
    fn around(
        grains: Grains,
        p: Particles,
        side: f64,
        friction: f64,
        servo_strain_rate: f64,
    ) -> Result<Cell> {
        let mut params = Params::new(
            &grains.material,
            &ContactSpec {
                friction,
                ..grains.contacts
            },
            grains.dt_s,
        )?;
        let smooth = ContactSpec {
            friction: 0.0,
            rolling_friction: 0.0,
            ..grains.contacts
        };
        let faces_m = [[0.0, side]; 3];
        for a in 0..3 {
            for (k, sign) in [1.0, -1.0].into_iter().enumerate() {
                let mut point = Vector3::zeros();
                point[a] = faces_m[a][k];
                let mut normal = Vector3::zeros();
                normal[a] = sign;
                params.walls.push(Wall::plane(
                    point,
                    normal,
                    &grains.material,
                    &grains.material,
                    &smooth,
                )?);
            }
        }
        Ok(Cell {
            grains,
            params,
            state: State::new(p),
            faces_m,
            servo_speed_m_s: servo_strain_rate * side / 2.0,
            servo_stress_pa: [0.0; 3],
            inward_m_s: [0.0; 3],
        })
    }

    /// Sets the grain–grain friction (−).
    pub fn set_friction(&mut self, friction: f64) -> Result<()> {
        let spec = ContactSpec {
            friction,
            ..self.grains.contacts
        };
        self.params.pair_model =
            dem::ContactModel::hertz_mindlin(&self.grains.material, &self.grains.material, &spec)?;
        Ok(())
    }

    /// Edge lengths (m).
    pub fn lengths_m(&self) -> [f64; 3] {
        self.faces_m.map(|f| f[1] - f[0])
    }

    /// Volume of the cell (m³).
    pub fn volume_m3(&self) -> f64 {
        self.lengths_m().iter().product()
    }

    /// Solid fraction (−).
    pub fn solid_fraction(&self) -> f64 {
        self.state.particles.len() as f64 * 4.0 / 3.0
            * std::f64::consts::PI
            * self.grains.radius_m.powi(3)
            / self.volume_m3()
    }

    /// Normal stress on each axis (Pa, compression positive): the mean of
    /// its two walls' normal loads over the face's area.
    pub fn stress_pa(&self) -> [f64; 3] {
        let l = self.lengths_m();
        let loads = self.state.wall_normal_loads_n();
        if loads.len() < WALLS {
            return [0.0; 3];
        }
        [0, 1, 2].map(|a| {
            let area = l[(a + 1) % 3] * l[(a + 2) % 3];
            0.5 * (loads[2 * a] + loads[2 * a + 1]) / area
        })
    }

    /// Mean contacts per grain.
    pub fn coordination(&self) -> f64 {
        self.state.mean_contacts()
    }

    /// Advances `steps` steps with each axis as `axes` says.
    ///
    /// A servo reads its axis' stress low-passed and changes its walls'
    /// speed by at most [`SERVO_RAMP_STEPS`]-th of the largest per step:
    /// the walls' speed enters the contacts' damping, so a servo acting on
    /// the raw stress at full speed chatters between pushing and pulling
    /// each step, each reading a load its own motion made.
    pub fn advance(&mut self, axes: [Axis; 3], steps: u64) -> Result<()> {
        let dt = self.grains.dt_s;
        let filter = 1.0 / SERVO_FILTER_STEPS;
        let ramp = self.servo_speed_m_s / SERVO_RAMP_STEPS;
        for _ in 0..steps {
            let stress = self.stress_pa();
            let lengths = self.lengths_m();
            for a in 0..3 {
                self.servo_stress_pa[a] += filter * (stress[a] - self.servo_stress_pa[a]);
                // Inward speed of each of the axis' two walls (m/s).
                let inward = match axes[a] {
                    Axis::StrainRate(rate) => rate * lengths[a] / 2.0,
                    Axis::Stress(target) => {
                        let error = (target - self.servo_stress_pa[a]) / target.abs().max(1e-9);
                        let wanted = self.servo_speed_m_s * (SERVO_GAIN * error).clamp(-1.0, 1.0);
                        let now = self.inward_m_s[a];
                        now + (wanted - now).clamp(-ramp, ramp)
                    }
                };
                self.inward_m_s[a] = inward;
                self.faces_m[a][0] += inward * dt;
                self.faces_m[a][1] -= inward * dt;
                for k in 0..2 {
                    let wall = &mut self.params.walls[2 * a + k];
                    if let WallShape::Plane { point_m, .. } = &mut wall.shape {
                        point_m[a] = self.faces_m[a][k];
                    }
                    wall.normal_velocity_m_s = inward;
                }
            }
            step(&self.params, &mut self.state, &mut ())?;
        }
        Ok(())
    }

    /// Kinetic energy per grain over the elastic energy scale of a grain
    /// at mean stress `p` (−): how far from quasi-static the sample is.
    pub fn kinetic_ratio(&self, p_pa: f64) -> f64 {
        let ke = self.state.particles.kinetic_energy_j() / self.state.particles.len() as f64;
        ke / (p_pa.max(1.0) * (2.0 * self.grains.radius_m).powi(3))
    }
}

/// Steps over which a servo low-passes its axis' stress.
pub const SERVO_FILTER_STEPS: f64 = 50.0;

/// Steps a servo takes to go from rest to its largest speed.
pub const SERVO_RAMP_STEPS: f64 = 200.0;

/// Servo gain: the wall speed saturates when the stress is off by 1/gain
/// of its target.
pub const SERVO_GAIN: f64 = 4.0;
