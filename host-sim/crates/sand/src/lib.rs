//! The sand's pressure on the expanding zone, p_e(D, h), behind one
//! interface, [`SandLaw`]:
//!
//! - [`parametric`]: a documented parametric law, [`ParametricSand`],
//!   calibrated to the paper's balloon experiment (the emulator's plant and
//!   the workbench use it);
//! - [`solver`]: [`SolverSand`], p_e(D, h) read from the FEM–DEM solver's
//!   stored results (`host-sim/data/sand/solver-pe.csv`; the firmware
//!   tables use it; `host-sim solver-sand`, in the burrow crate, runs the
//!   solver at each depth and writes that file).
//!
//! Both laws are a lateral pressure coefficient K = p_e/σ'v of the
//! vertical effective stress at the actuator's axis, σ'v = γ'·h (pore
//! water pressure acts equally inside and outside, and the pressure sensor
//! is zeroed in free water, so only the effective stress of the grains
//! loads the skin). They differ only in the loading branch; how a cycle
//! starts and how the sand answers a shrinking zone is one shared rule,
//! [`Unloading`] and [`SandHistory::at_rest`]:
//!
//! - **loading** (the zone grows past anything reached this cycle): the
//!   law's own K(D);
//! - **unloading** (the zone shrinks from its peak, or regrows up to it):
//!   elastic, K = K_peak − s·(D_peak − D), floored at the active
//!   coefficient Ka (the sand follows the skin in but cannot pull on it);
//!   [`Unloading::curvature`] bends that line into a curve with the same
//!   initial slope and floor, for a model trying another form;
//! - **fresh cycle**: the animal advances about 1 mm per cycle into sand the
//!   last expansion did not touch, so each cycle starts at rest (D0, K0).

pub mod parametric;
pub mod solver;

use serde::Serialize;

pub use parametric::{
    calibrate_limit_coefficient, fit_rise, BalloonPoint, Calibration, ParametricSand, RiseFit,
    SandParams, BALLOON_FINAL_DIAMETER_MM, BALLOON_FREE_PRESSURE_KPA, BALLOON_FREE_SD_KPA,
    BALLOON_TABLE, FRICTION_ANGLE_DEG, RISE_DONE_DIAMETER_MM,
};
pub use solver::SolverSand;

/// What the sand remembers within one expansion cycle.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct SandHistory {
    /// Largest outer diameter reached this cycle (mm).
    pub peak_diameter_mm: f64,
    /// Lateral coefficient K = p_e/σ'v reached there.
    pub peak_coefficient: f64,
}

impl SandHistory {
    /// A fresh cycle in undisturbed sand: at rest at diameter
    /// `initial_diameter_mm` (D0) with coefficient `at_rest_coefficient` (K0).
    pub fn at_rest(initial_diameter_mm: f64, at_rest_coefficient: f64) -> Self {
        Self {
            peak_diameter_mm: initial_diameter_mm,
            peak_coefficient: at_rest_coefficient,
        }
    }
}

/// The path rule every law shares: loading past the cycle's peak follows
/// the law's loading branch and moves the peak; below the peak the sand
/// unloads elastically along a straight line, floored at Ka.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Unloading {
    /// Unloading slope s = dK/dD below the peak (1/mm).
    pub slope_per_mm: f64,
    /// Active coefficient Ka, the floor while the zone shrinks.
    pub active_coefficient: f64,
    /// Shape c of the branch between the peak and the floor, with
    /// x = s·(D_peak − D)/(K_peak − Ka): K = Ka + (K_peak − Ka)·(1 − c·x)^(1/c).
    /// 1 is the straight line of both laws; 0 an exponential approach,
    /// exp(−x); below 0 a longer tail. Always the same initial slope s.
    pub curvature: f64,
}

impl Unloading {
    /// K at outer diameter `diameter_mm`, advancing `history`;
    /// `loading(D)` is the law's loading-branch K, called only when the
    /// zone is at or past its peak.
    pub fn coefficient(
        &self,
        history: &mut SandHistory,
        diameter_mm: f64,
        loading: impl FnOnce(f64) -> f64,
    ) -> f64 {
        if diameter_mm >= history.peak_diameter_mm {
            let k = loading(diameter_mm);
            *history = SandHistory {
                peak_diameter_mm: diameter_mm,
                peak_coefficient: k,
            };
            k
        } else {
            let back = history.peak_diameter_mm - diameter_mm;
            let span = history.peak_coefficient - self.active_coefficient;
            if self.curvature == 1.0 || span <= 0.0 {
                return (history.peak_coefficient - self.slope_per_mm * back)
                    .max(self.active_coefficient);
            }
            let x = self.slope_per_mm * back / span;
            let c = self.curvature;
            let left = if c.abs() < 1e-9 {
                (-x).exp()
            } else {
                (1.0 - c * x).max(0.0).powf(1.0 / c)
            };
            self.active_coefficient + span * left
        }
    }
}

/// A model of the sand's pressure on the zone; callers only see this
/// interface.
pub trait SandLaw {
    /// History at the start of a cycle, in undisturbed sand at rest.
    fn fresh_cycle(&self) -> SandHistory;
    /// p_e (kPa) at outer diameter `diameter_mm` and depth `depth_mm`,
    /// advancing `history` (the path matters: loading vs unloading).
    fn external_pressure_kpa(
        &self,
        history: &mut SandHistory,
        diameter_mm: f64,
        depth_mm: f64,
    ) -> f64;
    /// One line saying what the law is and where its numbers come from
    /// (goes into the generated firmware table's header).
    fn describe(&self) -> String;
    /// p_e (kPa) on the loading branch of a fresh cycle.
    fn loading_pressure_kpa(&self, diameter_mm: f64, depth_mm: f64) -> f64 {
        let mut history = self.fresh_cycle();
        self.external_pressure_kpa(&mut history, diameter_mm, depth_mm)
    }
}
