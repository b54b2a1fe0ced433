//! The solver's seam to the outside: observers of each step and forces
//! from other solvers (the FEM skin), ripgrep-`Sink`-style with no-op
//! defaults and a `()` implementation that costs nothing.

use super::particles::Particles;
use super::State;

/// Receives the solver's steps; every method defaults to doing nothing.
pub trait Sink {
    /// Called inside each step after the contact and body forces are in
    /// `particles.force_n`/`torque_n_m` and before the closing half kick:
    /// add forces from outside the DEM (e.g. skin contact) here. `time_s`
    /// (s) is the time the forces are for.
    fn add_external_forces(&mut self, _time_s: f64, _particles: &mut Particles) {}

    /// Whether [`Sink::add_external_forces`] does anything (default: yes).
    /// A sink that says no is not called for forces, and between the steps
    /// of an [`crate::advance`] the solver then keeps the particles' motion
    /// in its packed rows alone, writing `Particles` back once at the end
    /// (one copy of the moving state a step fewer to read and write).
    fn adds_external_forces(&self) -> bool {
        true
    }

    /// Called at the end of each [`crate::step`], and once at the end of
    /// an [`crate::advance`] over several steps.
    fn step_done(&mut self, _state: &State) {}
}

impl Sink for () {
    fn adds_external_forces(&self) -> bool {
        false
    }
}
