//! The element tests: isotropic consolidation, drained triaxial
//! compression and the K0 (oedometer) loading, each on a [`Cell`].

use anyhow::{ensure, Result};
use serde::{Deserialize, Serialize};

use super::cell::{Axis, Cell};

/// Inertial number the tests shear at: I = ε̇ d √(ρ/p) (−). Below about
/// 1e-3 a granular sample responds quasi-statically (GDR MiDi 2004).
pub const INERTIAL_NUMBER: f64 = 1e-3;

/// Steps between two records of a test.
const RECORD_EVERY: u64 = 200;

/// The strain rate (1/s) at which `cell` shears quasi-statically under
/// mean stress `p_pa` (Pa): [`INERTIAL_NUMBER`] / (d √(ρ/p)).
pub fn quasi_static_rate(cell: &Cell, p_pa: f64) -> f64 {
    let d = 2.0 * cell.grains.radius_m;
    INERTIAL_NUMBER / (d * (cell.grains.material.density_kg_m3 / p_pa).sqrt())
}

/// Brings `cell` to an isotropic stress `p_pa` (Pa): every axis servo-held
/// until each is within 2 % of it, and the sample quiet, three records in
/// a row.
pub fn consolidate(cell: &mut Cell, p_pa: f64) -> Result<()> {
    let mut settled = 0;
    for _ in 0..2_000 {
        cell.advance([Axis::Stress(p_pa); 3], RECORD_EVERY)?;
        let s = cell.stress_pa();
        let even = s.iter().all(|&x| (x / p_pa - 1.0).abs() < 0.02);
        settled = if even && cell.kinetic_ratio(p_pa) < 1e-4 {
            settled + 1
        } else {
            0
        };
        if settled == 3 {
            return Ok(());
        }
    }
    let s = cell.stress_pa();
    anyhow::bail!("the sample did not settle at {p_pa} Pa: stresses {s:?} Pa")
}

/// One record of a test.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Record {
    /// Axial strain, compression positive (−): 1 − L_z/L_z0.
    pub axial_strain: f64,
    /// Volumetric strain, compression positive (−): 1 − V/V0.
    pub volumetric_strain: f64,
    /// Stresses σ_xx, σ_yy, σ_zz (Pa).
    pub stress_pa: [f64; 3],
    /// Mean contacts per grain.
    pub coordination: f64,
}

impl Record {
    /// Axial stress σ_1 (Pa).
    pub fn axial_pa(&self) -> f64 {
        self.stress_pa[2]
    }

    /// Lateral stress σ_3, the mean of x and y (Pa).
    pub fn lateral_pa(&self) -> f64 {
        0.5 * (self.stress_pa[0] + self.stress_pa[1])
    }

    /// Mobilised friction angle asin((σ1 − σ3)/(σ1 + σ3)) (degrees).
    pub fn friction_angle_deg(&self) -> f64 {
        let (a, l) = (self.axial_pa(), self.lateral_pa());
        ((a - l) / (a + l)).clamp(-1.0, 1.0).asin().to_degrees()
    }
}

fn record(cell: &Cell, l0: f64, v0: f64) -> Record {
    Record {
        axial_strain: 1.0 - cell.lengths_m()[2] / l0,
        volumetric_strain: 1.0 - cell.volume_m3() / v0,
        stress_pa: cell.stress_pa(),
        coordination: cell.coordination(),
    }
}

/// A drained triaxial compression: what it measured.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Triaxial {
    /// Confining stress σ_3 (Pa).
    pub confining_pa: f64,
    /// Solid fraction at the start of shearing.
    pub initial_solid_fraction: f64,
    /// The records.
    pub records: Vec<Record>,
    /// Peak mobilised friction angle (degrees).
    pub peak_deg: f64,
    /// Critical-state friction angle: the mean over the last
    /// [`CRITICAL_SPAN`] of axial strain (degrees).
    pub critical_deg: f64,
    /// Largest dilatancy angle, from dε_v/dε_a over [`DILATANCY_SPAN`] of
    /// axial strain: sin ψ = −r/(2 − r), r = dε_v/dε_a (degrees).
    pub dilatancy_deg: f64,
}

/// Axial strain span at the end of a triaxial test whose mean friction
/// angle is the critical-state one.
pub const CRITICAL_SPAN: f64 = 0.05;

/// Axial strain span of the slope dε_v/dε_a for the dilatancy angle.
pub const DILATANCY_SPAN: f64 = 0.02;

/// Shears a consolidated `cell` at confining stress `confining_pa` (Pa)
/// to axial strain `final_strain` (−), the lateral walls servo-held.
pub fn triaxial(cell: &mut Cell, confining_pa: f64, final_strain: f64) -> Result<Triaxial> {
    ensure!(
        final_strain > CRITICAL_SPAN,
        "strain {final_strain} too small"
    );
    let rate = quasi_static_rate(cell, confining_pa);
    let (l0, v0) = (cell.lengths_m()[2], cell.volume_m3());
    let initial_solid_fraction = cell.solid_fraction();
    let mut records = vec![record(cell, l0, v0)];
    while records
        .last()
        .is_some_and(|r| r.axial_strain < final_strain)
    {
        cell.advance(
            [
                Axis::Stress(confining_pa),
                Axis::Stress(confining_pa),
                Axis::StrainRate(rate),
            ],
            RECORD_EVERY,
        )?;
        records.push(record(cell, l0, v0));
    }
    let peak_deg = records
        .iter()
        .map(Record::friction_angle_deg)
        .fold(f64::MIN, f64::max);
    let tail: Vec<f64> = records
        .iter()
        .filter(|r| r.axial_strain >= final_strain - CRITICAL_SPAN)
        .map(Record::friction_angle_deg)
        .collect();
    let critical_deg = tail.iter().sum::<f64>() / tail.len().max(1) as f64;
    let dilatancy_deg = records
        .iter()
        .enumerate()
        .filter_map(|(k, a)| {
            let b = records[k..]
                .iter()
                .find(|b| b.axial_strain >= a.axial_strain + DILATANCY_SPAN)?;
            let r = (b.volumetric_strain - a.volumetric_strain) / (b.axial_strain - a.axial_strain);
            Some((-r / (2.0 - r)).clamp(-1.0, 1.0).asin().to_degrees())
        })
        .fold(f64::MIN, f64::max);
    Ok(Triaxial {
        confining_pa,
        initial_solid_fraction,
        records,
        peak_deg,
        critical_deg,
        dilatancy_deg,
    })
}

/// A K0 (oedometer) loading: the lateral walls fixed, the axial ones
/// closing in until the axial stress reaches the last of
/// [`OEDOMETER_STRESSES_PA`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Oedometer {
    /// The records.
    pub records: Vec<Record>,
    /// K0 = σ_h/σ_v where σ_v first reaches each of
    /// [`OEDOMETER_STRESSES_PA`] (interpolated between records).
    pub k0: Vec<(f64, f64)>,
}

/// The axial stresses at which K0 is reported (Pa): the problem's range.
pub const OEDOMETER_STRESSES_PA: [f64; 4] = [1_000.0, 2_000.0, 5_000.0, 10_000.0];

/// Loads a consolidated `cell` in one-dimensional compression.
pub fn oedometer(cell: &mut Cell) -> Result<Oedometer> {
    let top = OEDOMETER_STRESSES_PA[OEDOMETER_STRESSES_PA.len() - 1];
    let (l0, v0) = (cell.lengths_m()[2], cell.volume_m3());
    let mut records = vec![record(cell, l0, v0)];
    let mut guard = 0;
    while records.last().is_some_and(|r| r.axial_pa() < top) {
        guard += 1;
        ensure!(guard < 20_000, "the oedometer did not reach {top} Pa");
        // Slow enough at the stress reached so far.
        let p = records.last().map_or(top, |r| r.axial_pa().max(200.0));
        let rate = 0.25 * quasi_static_rate(cell, p);
        cell.advance(
            [
                Axis::StrainRate(0.0),
                Axis::StrainRate(0.0),
                Axis::StrainRate(rate),
            ],
            RECORD_EVERY,
        )?;
        records.push(record(cell, l0, v0));
    }
    let k0 = OEDOMETER_STRESSES_PA
        .iter()
        .filter_map(|&s| {
            let k = records.windows(2).position(|w| w[1].axial_pa() >= s)?;
            let (a, b) = (&records[k], &records[k + 1]);
            let t = ((s - a.axial_pa()) / (b.axial_pa() - a.axial_pa())).clamp(0.0, 1.0);
            let h = a.lateral_pa() + t * (b.lateral_pa() - a.lateral_pa());
            Some((s, h / s))
        })
        .collect();
    Ok(Oedometer { records, k0 })
}
