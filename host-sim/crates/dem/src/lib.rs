//! # Discrete-element sand
//!
//! Spheres with Hertz–Mindlin contacts (history, Coulomb cap), damping set
//! from a restitution coefficient, optional rolling resistance, gravity with
//! buoyancy, plane and cylinder walls (fixed, translating or growing),
//! periodic axes ([`periodic`]); a Verlet neighbour list on a cell grid;
//! velocity-Verlet integration; parallel with rayon and bit-for-bit
//! deterministic whatever the thread count (every particle sums its forces
//! in a fixed order, the `forces` module).
//!
//! The API follows rapier: all state is explicit and one call advances it,
//! [`step`]`(&Params, &mut State, &mut impl Sink)`. Contact laws are one
//! trait per family in [`contact`], composed in LAMMPS' order by
//! [`contact::ContactModel`]. Outputs and coupling forces go through a
//! [`Sink`], with `()` as the no-op.
//!
//! ```
//! use dem::{step, Params, State, Particles, contact::{Material, ContactSpec}};
//! use nalgebra::Vector3;
//! let sand = Material { youngs_modulus_pa: 1e7, poisson_ratio: 0.3, density_kg_m3: 2920.0 };
//! let mut params = Params::new(&sand, &ContactSpec::default(), 1.5e-5).unwrap();
//! params.gravity_m_s2 = Vector3::new(0.0, 0.0, -9.81);
//! let mut p = Particles::new();
//! p.push(Vector3::new(0.0, 0.0, 0.01), Vector3::zeros(), 1e-3, 2920.0).unwrap();
//! let mut state = State::new(p);
//! step(&params, &mut state, &mut ()).unwrap();
//! assert!(state.particles.velocity_m_s[0].z < 0.0);
//! ```

pub mod benchmark;
pub mod contact;
mod forces;
pub mod integrate;
pub mod neighbour;
pub mod particles;
pub mod periodic;
mod runs;
pub mod scaling;
pub mod sink;
mod team;
mod wall_contacts;
pub mod walls;

use nalgebra::Vector3;
use rayon::prelude::*;

pub use contact::{ContactModel, ContactSpec, Material};
pub use forces::{best_simd, simd, use_simd, Simd};
pub use neighbour::NeighbourList;
pub use particles::Particles;
use particles::Sphere;
pub use periodic::{Images, PeriodicAxis};
pub use sink::Sink;
pub use walls::{CylinderSide, Wall, WallShape};

/// What can go wrong in the solver.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum DemError {
    /// A parameter is out of its range.
    #[error("DEM parameter {name} = {value} is out of range")]
    Param {
        /// Which parameter.
        name: &'static str,
        /// Its value.
        value: f64,
    },
    /// A particle's position or velocity is not finite (the time step is
    /// probably too large for the stiffness).
    #[error("particle {particle} has a non-finite position or velocity (time step too large?)")]
    NonFinite {
        /// Its index.
        particle: usize,
    },
}

impl DemError {
    pub(crate) fn param(name: &'static str, value: f64) -> DemError {
        DemError::Param { name, value }
    }
}

/// Everything that stays fixed during a run. Units in the names; defaults
/// from [`Params::new`].
#[derive(Clone, Debug, PartialEq)]
pub struct Params {
    /// Time step (s). No default: it must be a fraction (≈ 0.1–0.2) of the
    /// Rayleigh time 0.1631 d √(ρ/G) / (0.1631 ν + 0.8766).
    pub dt_s: f64,
    /// Gravitational acceleration (m/s²). Default (0, 0, −9.81).
    pub gravity_m_s2: Vector3<f64>,
    /// Density of the fluid the grains are immersed in (kg/m³); the body
    /// force is m g (1 − ρ_f/ρ_s) (Archimedes, no drag or added mass).
    /// Default 0 (dry).
    pub fluid_density_kg_m3: f64,
    /// Grain density ρ_s (kg/m³) for the buoyancy ratio; the masses are
    /// set per particle at creation. Default: the material's.
    pub particle_density_kg_m3: f64,
    /// Verlet skin (m): pairs closer than this (surface to surface) are
    /// listed; the list is rebuilt when a particle has moved skin/2.
    /// Default 2e-4 (0.1 d for 1 mm grains).
    pub skin_m: f64,
    /// Particle–particle contact law.
    pub pair_model: ContactModel,
    /// Walls, with their own contact laws. Default none. A wall must not
    /// vary along a periodic axis (a plane across it, a cylinder whose
    /// axis crosses it).
    pub walls: Vec<Wall>,
    /// Periodic axes (x, y, z; `None`: not periodic, the default).
    pub periodic: [Option<PeriodicAxis>; 3],
}

impl Params {
    /// Grains of `material` with contacts `spec` (Hertz–Mindlin), time step
    /// `dt_s` (s), dry, no walls and no gravity: a body force is the
    /// caller's to set in [`Params::gravity_m_s2`], as LIGGGHTS asks for a
    /// `fix gravity`.
    pub fn new(material: &Material, spec: &ContactSpec, dt_s: f64) -> Result<Params, DemError> {
        let params = Params {
            dt_s,
            gravity_m_s2: Vector3::zeros(),
            fluid_density_kg_m3: 0.0,
            particle_density_kg_m3: material.density_kg_m3,
            skin_m: 2e-4,
            pair_model: ContactModel::hertz_mindlin(material, material, spec)?,
            walls: Vec::new(),
            periodic: [None; 3],
        };
        params.validate()?;
        Ok(params)
    }

    /// Checks the ranges of the scalar fields.
    pub fn validate(&self) -> Result<(), DemError> {
        if !(self.dt_s > 0.0 && self.dt_s.is_finite()) {
            return Err(DemError::param("dt_s", self.dt_s));
        }
        if !(self.skin_m > 0.0 && self.skin_m.is_finite()) {
            return Err(DemError::param("skin_m", self.skin_m));
        }
        if !(self.fluid_density_kg_m3 >= 0.0 && self.fluid_density_kg_m3.is_finite()) {
            return Err(DemError::param(
                "fluid_density_kg_m3",
                self.fluid_density_kg_m3,
            ));
        }
        if !(self.particle_density_kg_m3 > 0.0 && self.particle_density_kg_m3.is_finite()) {
            return Err(DemError::param(
                "particle_density_kg_m3",
                self.particle_density_kg_m3,
            ));
        }
        if !self.gravity_m_s2.iter().all(|g| g.is_finite()) {
            return Err(DemError::param("gravity_m_s2", f64::NAN));
        }
        for axis in self.periodic.iter().flatten() {
            PeriodicAxis::new(axis.lo_m, axis.length_m)?;
        }
        Ok(())
    }

    /// 1 − ρ_f/ρ_s: the fraction of the weight left after buoyancy.
    pub fn buoyancy_factor(&self) -> f64 {
        1.0 - self.fluid_density_kg_m3 / self.particle_density_kg_m3
    }
}

/// The evolving state: particles, time, neighbour list with contact
/// history, wall-contact history and per-step results.
#[derive(Clone, Debug)]
pub struct State {
    /// The particles.
    pub particles: Particles,
    /// Simulated time (s).
    pub time_s: f64,
    /// Steps taken.
    pub step_count: u64,
    neighbours: NeighbourList,
    schedule: forces::Schedule,
    wall_contacts: wall_contacts::WallContacts,
    wall_force_n: Vec<Vector3<f64>>,
    wall_normal_load_n: Vec<f64>,
    forces_ready: bool,
    /// The particles' state packed for the pair pass, written by each
    /// step's first sweep (inside [`advance`], with a sink that adds no
    /// forces, the only current copy of their motion: [`Motion::Rows`]).
    packed: particles::Packed,
    /// Where the particles' current positions, velocities and spins are.
    motion: Motion,
    /// The periodic axes of the last step's parameters.
    images: Images,
}

/// Where a [`State`] keeps its particles' current positions, velocities and
/// spins: the rows are the only copy between the steps of an [`advance`]
/// whose sink adds no forces; `particles` must be brought up to them
/// before anything else reads it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Motion {
    /// In `particles` alone (the packed rows are stale).
    Particles,
    /// In both `particles` and the packed rows.
    Both,
    /// In the packed rows alone (`particles` is behind).
    Rows,
}

impl State {
    /// A state at t = 0 holding `particles`.
    pub fn new(particles: Particles) -> State {
        State {
            particles,
            time_s: 0.0,
            step_count: 0,
            neighbours: NeighbourList::default(),
            schedule: forces::Schedule::default(),
            wall_contacts: wall_contacts::WallContacts::default(),
            wall_force_n: Vec::new(),
            wall_normal_load_n: Vec::new(),
            forces_ready: false,
            packed: particles::Packed::default(),
            motion: Motion::Particles,
            images: Images::default(),
        }
    }

    /// Force the particles exert on each wall at the last evaluation (N),
    /// in `Params::walls` order.
    pub fn wall_forces_n(&self) -> &[Vector3<f64>] {
        &self.wall_force_n
    }

    /// Normal load on each wall at the last evaluation (N): the sum over
    /// its contacts of the force along the contact normal, compression
    /// positive (on a cylinder, the radial load whose mean over the
    /// surface is the pressure on it), in `Params::walls` order.
    pub fn wall_normal_loads_n(&self) -> &[f64] {
        &self.wall_normal_load_n
    }

    /// The neighbour list (pairs, rebuild count).
    pub fn neighbours(&self) -> &NeighbourList {
        &self.neighbours
    }

    /// Number of touching particle pairs at the current positions.
    pub fn contact_pairs(&self) -> usize {
        let p = &self.particles;
        let l = &self.neighbours;
        (0..l.pair_count())
            .into_par_iter()
            .filter(|&k| {
                let (i, j) = (l.pair_i[k] as usize, l.pair_j[k] as usize);
                let sphere = |i: usize| Sphere::new(&p.position_m[i], p.radius_m[i]);
                sphere(i).overlaps_in(&sphere(j), &self.images)
            })
            .count()
    }

    /// Mean particle–particle contacts per particle (2 × pairs / N), as
    /// LIGGGHTS' `contact/atom` summed over atoms.
    pub fn mean_contacts(&self) -> f64 {
        if self.particles.is_empty() {
            return 0.0;
        }
        2.0 * self.contact_pairs() as f64 / self.particles.len() as f64
    }

    /// Sizes the per-wall arrays for `walls` walls (resetting wall history
    /// when the count changed) and rebuilds a stale neighbour list.
    fn prepare(&mut self, params: &Params, team: &team::Team) -> Result<(), DemError> {
        let n = self.particles.len();
        let walls = params.walls.len();
        let images = Images::new(&params.periodic);
        if images != self.images {
            self.images = images;
            // New periods: the list's pairs and their images are stale.
            self.neighbours = NeighbourList::default();
            // Its build count starts again: the split must not be taken
            // for the old list's.
            self.schedule = forces::Schedule::default();
            self.forces_ready = false;
        }
        if !self.wall_contacts.fits(n, walls) || self.wall_force_n.len() != walls {
            self.wall_contacts.reset(n, walls);
            self.wall_force_n = vec![Vector3::zeros(); walls];
            self.wall_normal_load_n = vec![0.0; walls];
            self.forces_ready = false;
        }
        if self.neighbours.is_stale(n, params.skin_m) {
            self.rebuild(params, team)?;
            self.forces_ready = false;
        }
        Ok(())
    }

    /// Brings `particles`' positions, velocities and spins up to the
    /// packed rows, if they are behind.
    fn catch_up(&mut self) {
        if self.motion == Motion::Rows {
            self.packed.unpack_into(&mut self.particles);
            self.motion = Motion::Both;
        }
    }

    /// The closing half kick, on `particles` (brought up to date first).
    fn closing_kick(&mut self, dt_s: f64) {
        self.catch_up();
        let p = &mut self.particles;
        self.wall_contacts.settle(&mut p.force_n, &mut p.torque_n_m);
        integrate::kick(&mut self.particles, dt_s);
        self.motion = Motion::Particles;
    }

    fn rebuild(&mut self, params: &Params, team: &team::Team) -> Result<(), DemError> {
        self.catch_up();
        // Back into the box along periodic axes (the separations are
        // minimum images, so nothing else changes). The rows keep the
        // positions they had (this step's pass reads them as they were
        // packed), so the next first sweep starts from `particles`.
        for (a, axis) in params.periodic.iter().enumerate() {
            if let Some(axis) = axis {
                self.motion = Motion::Particles;
                for x in &mut self.particles.position_m {
                    x[a] = axis.wrap(x[a]);
                }
            }
        }
        self.neighbours.build_with(
            &self.particles.position_m,
            &self.particles.radius_m,
            params.skin_m,
            &params.periodic,
            team,
        )?;
        Ok(())
    }

    /// Culls the wall contacts for the current list and walls (a no-op
    /// unless the list was rebuilt or a wall moved since the last cull).
    fn cull_walls(&mut self, params: &Params, team: &team::Team) {
        let (p, list) = (&self.particles, &self.neighbours);
        (self.wall_contacts).cull(&params.walls, p, list, params.skin_m, team);
    }

    /// Contact, wall and body forces at the current positions, then the
    /// sink's external forces. `packed_current`: the integrator has just
    /// packed the state and set the sums to the body force (else both are
    /// done here); `walls_swept`: it has evaluated the wall contacts too,
    /// to be added in the next sweep.
    fn evaluate_forces(
        &mut self,
        params: &Params,
        sink: &mut impl Sink,
        (packed_current, walls_swept): (bool, bool),
        team: &team::Team,
    ) {
        if !packed_current {
            self.catch_up();
            self.particles.pack_into(&mut self.packed);
            self.motion = Motion::Both;
        }
        forces::pair_forces(
            params,
            &mut self.particles,
            (&mut self.neighbours, &mut self.schedule),
            (&self.packed, packed_current),
            &self.images,
            team,
        );
        if walls_swept {
            self.wall_contacts.commit_sweep();
        } else {
            self.cull_walls(params, team);
            wall_contacts::wall_forces(
                params,
                &mut self.particles,
                &self.packed,
                &mut self.wall_contacts,
                team,
            );
        }
        self.wall_contacts
            .totals(&mut self.wall_force_n, &mut self.wall_normal_load_n);
        if sink.adds_external_forces() {
            self.catch_up();
            sink.add_external_forces(self.time_s, &mut self.particles);
        }
    }
}

/// `s` cut into consecutive pieces of lengths `lens` (which must not sum
/// past its length), for handing disjoint parts to parallel tasks.
pub(crate) fn split_lengths<T>(
    mut s: &mut [T],
    lens: impl Iterator<Item = usize>,
) -> Vec<&mut [T]> {
    lens.map(|len| {
        let (piece, rest) = std::mem::take(&mut s).split_at_mut(len);
        s = rest;
        piece
    })
    .collect()
}

/// Advances `state` by one step `params.dt_s` (velocity Verlet), calling
/// `sink` for external forces and at the end.
pub fn step(params: &Params, state: &mut State, sink: &mut impl Sink) -> Result<(), DemError> {
    advance(params, state, sink, 1)
}

/// Advances `state` by `steps` steps of `params.dt_s`, with the same bits
/// as as many calls of [`step`], calling `sink` for external forces every
/// step but [`Sink::step_done`] only once, at the end (none for zero
/// steps): the state between two steps is never shown, so each step's
/// closing half kick is done in the next step's first sweep (one pass over
/// the particles fewer per step).
pub fn advance(
    params: &Params,
    state: &mut State,
    sink: &mut impl Sink,
    steps: u64,
) -> Result<(), DemError> {
    if steps == 0 {
        return Ok(());
    }
    params.validate()?;
    // The caller may have changed the particles since the last call
    // (which left them current).
    state.catch_up();
    state.motion = Motion::Particles;
    team::with_team(|team| advance_with(params, state, sink, steps, team))?;
    sink.step_done(state);
    Ok(())
}

/// [`advance`] by `steps` (at least one) with `team`, but for the final
/// [`Sink::step_done`].
fn advance_with(
    params: &Params,
    state: &mut State,
    sink: &mut impl Sink,
    steps: u64,
    team: &team::Team,
) -> Result<(), DemError> {
    // Whether the first sweep may take the motion from the packed rows
    // alone: nothing outside reads the particles until the end.
    let rows_only = !sink.adds_external_forces();
    // Whether the first sweep evaluates the wall contacts, leaving them to
    // be added in the next: only where nothing else adds forces after
    // them (the sink's would come first).
    let sweep_walls = rows_only && !params.walls.is_empty();
    // Whether the last step's closing half kick is still to be applied.
    let mut pending = false;
    for left in (0..steps).rev() {
        if let Err(e) = state.prepare(params, team) {
            if pending {
                state.closing_kick(params.dt_s);
            }
            return Err(e);
        }
        if !state.forces_ready {
            // The forces are re-evaluated from the velocities after the
            // closing kick.
            if pending {
                state.closing_kick(params.dt_s);
                pending = false;
            }
            state.evaluate_forces(params, sink, (false, false), team);
            state.forces_ready = true;
        }
        let from_rows = rows_only && state.motion != Motion::Particles;
        if !from_rows {
            state.catch_up();
        }
        if sweep_walls {
            // Culled for this list and these walls before the sweep uses
            // the entries (a no-op but after a build or a wall's move).
            state.cull_walls(params, team);
        }
        let body = params.gravity_m_s2 * params.buoyancy_factor();
        let reference = &state.neighbours.reference_m;
        let (p, packed) = (&mut state.particles, &mut state.packed);
        let flags = (pending, from_rows);
        let walls = (params, &mut state.wall_contacts, sweep_walls);
        let step = (params.dt_s, body);
        let max2 = integrate::kick_drift(p, step, reference, packed, walls, flags, team);
        state.motion = if from_rows {
            Motion::Rows
        } else {
            Motion::Both
        };
        // The sums now hold only the body force: until the pass below has
        // run, the state's forces are not its forces.
        state.forces_ready = false;
        if !max2.is_finite() {
            state.catch_up();
            let bad = state
                .particles
                .position_m
                .iter()
                .position(|x| !x.iter().all(|v| v.is_finite()))
                .unwrap_or(0);
            return Err(DemError::NonFinite { particle: bad });
        }
        let half_skin = 0.5 * params.skin_m;
        // A rebuilt list may have new wall candidates: the sweep's wall
        // contacts are then evaluated again, after the pair pass.
        let mut walls_swept = sweep_walls;
        if max2 > half_skin * half_skin {
            walls_swept = false;
            state.rebuild(params, team)?;
        }
        state.time_s += params.dt_s;
        // Nothing moved the particles since kick_drift packed them.
        state.evaluate_forces(params, sink, (true, walls_swept), team);
        state.forces_ready = true;
        state.step_count += 1;
        pending = left > 0;
        if !pending {
            state.closing_kick(params.dt_s);
        }
    }
    Ok(())
}
