//! Driving the coupled run: the zone inflated by injected volume at a
//! constant rate until its mid-length diameter reaches a target, sampling
//! D, p_i, p_e, p_h and the skin stress along the way.

use super::{Coupling, Sample};
use dem::{step, DemError, Params, State};
use fem::{FemError, VolumeControl};
use skin::StrainEnergy;

/// Why an expansion stopped early.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ExpansionError {
    /// The DEM step failed.
    #[error("DEM: {0}")]
    Dem(#[from] DemError),
    /// The skin failed.
    #[error("skin: {0}")]
    Fem(#[from] FemError),
    /// A parameter is out of range.
    #[error("expansion parameter {name} = {value} is out of range")]
    Param {
        /// Which parameter.
        name: &'static str,
        /// Its value.
        value: f64,
    },
    /// The step budget ran out before the target diameter.
    #[error("the diameter reached only {reached_m} m of {target_m} m in {steps} steps")]
    NotReached {
        /// Diameter reached (m).
        reached_m: f64,
        /// Target diameter (m).
        target_m: f64,
        /// Steps taken.
        steps: usize,
    },
}

/// How to inflate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Expansion {
    /// Stop when the outer diameter at mid-length reaches this (m).
    pub final_diameter_m: f64,
    /// Injection rate (m³/s).
    pub volume_rate_m3_s: f64,
    /// Penalty bulk modulus of the fluid (Pa), ≫ the pressures reached.
    pub bulk_modulus_pa: f64,
    /// A sample every this many DEM steps (and one at the end).
    pub sample_every: usize,
    /// Step budget.
    pub max_steps: usize,
    /// The head drawn back by the body as the zone swells (a skin with a
    /// free [`fem::Head`] only); `None`: the head moves as the
    /// forces on it say (or as it is driven already).
    pub head_draw: Option<HeadDraw>,
}

/// The head drawn back along the axis in step with the swelling: D_r
/// (from [`fem::Head::origin_m`]) grows as the square of the
/// diameter's rise, as the chord of a meridian that keeps its length
/// shortens as it bulges, reaching `final_receding_m` at
/// `final_diameter_m` (and following the same law beyond). The head never
/// comes forward: the law follows the largest diameter reached.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HeadDraw {
    /// Outer diameter at mid-length where the draw starts (m).
    pub start_diameter_m: f64,
    /// Outer diameter at mid-length where D_r reaches `final_receding_m` (m).
    pub final_diameter_m: f64,
    /// D_r at `final_diameter_m` (m).
    pub final_receding_m: f64,
}

impl HeadDraw {
    /// The draw of a zone of length `length_m` (m) whose meridians keep
    /// their length, bulging from `start_diameter_m` to
    /// `final_diameter_m` (m) in a cosine profile with flat ends: the
    /// chord shortens by π² δ² / (4 L) for a radial rise δ = ΔD / 2.
    pub fn meridian(start_diameter_m: f64, final_diameter_m: f64, length_m: f64) -> HeadDraw {
        let rise = 0.5 * (final_diameter_m - start_diameter_m);
        HeadDraw {
            start_diameter_m,
            final_diameter_m,
            final_receding_m: std::f64::consts::PI.powi(2) * rise * rise / (4.0 * length_m),
        }
    }

    /// D_r (m) the law asks for at outer diameter `d_m` (m): 0 up to the
    /// start diameter.
    pub fn receding_at_m(&self, d_m: f64) -> f64 {
        let f = ((d_m - self.start_diameter_m) / (self.final_diameter_m - self.start_diameter_m))
            .max(0.0);
        self.final_receding_m * f * f
    }

    fn check(&self) -> Result<(), ExpansionError> {
        let bad = |name, value| ExpansionError::Param { name, value };
        if !(self.start_diameter_m > 0.0 && self.start_diameter_m.is_finite()) {
            return Err(bad("head_draw.start_diameter_m", self.start_diameter_m));
        }
        if !(self.final_diameter_m > self.start_diameter_m && self.final_diameter_m.is_finite()) {
            return Err(bad("head_draw.final_diameter_m", self.final_diameter_m));
        }
        if !(self.final_receding_m >= 0.0 && self.final_receding_m.is_finite()) {
            return Err(bad("head_draw.final_receding_m", self.final_receding_m));
        }
        Ok(())
    }
}

/// Inflates `coupling.skin` by volume from its current state while `state`
/// steps under `params`, until [`Expansion::final_diameter_m`]; returns
/// the samples (first at the start, last at the target), each also handed
/// to `on_sample` as it is taken (progress bars, files).
pub fn expand<S: StrainEnergy>(
    params: &Params,
    state: &mut State,
    coupling: &mut Coupling<S>,
    e: &Expansion,
    mut on_sample: impl FnMut(&Sample),
) -> Result<Vec<Sample>, ExpansionError> {
    let bad = |name, value| ExpansionError::Param { name, value };
    if !(e.volume_rate_m3_s > 0.0 && e.volume_rate_m3_s.is_finite()) {
        return Err(bad("volume_rate_m3_s", e.volume_rate_m3_s));
    }
    if !(e.bulk_modulus_pa > 0.0 && e.bulk_modulus_pa.is_finite()) {
        return Err(bad("bulk_modulus_pa", e.bulk_modulus_pa));
    }
    if e.sample_every == 0 {
        return Err(bad("sample_every", 0.0));
    }
    if let Some(d) = &e.head_draw {
        d.check()?;
        if coupling.skin.head.is_none() {
            return Err(bad(
                "head_draw (a skin without a free head)",
                d.final_receding_m,
            ));
        }
    }
    let skin = &mut coupling.skin;
    // Start from the fluid volume of the present state (its pressure kept).
    let v = skin.enclosed_volume_m3();
    let start = v * (1.0 + skin.pressure_pa / e.bulk_modulus_pa);
    skin.volume_control = Some(VolumeControl {
        target_volume_m3: start,
        bulk_modulus_pa: e.bulk_modulus_pa,
    });
    let mut samples = Vec::new();
    let mut take = |c: &Coupling<S>, out: &mut Vec<Sample>| -> Result<(), FemError> {
        let s = c.sample()?;
        on_sample(&s);
        out.push(s);
        Ok(())
    };
    take(coupling, &mut samples)?;
    let mut reached_m = coupling.skin.outer_diameter_at_mid_length_m();
    for steps in 1..=e.max_steps {
        if let Some(vc) = &mut coupling.skin.volume_control {
            vc.target_volume_m3 += e.volume_rate_m3_s * params.dt_s;
        }
        if let (Some(draw), Some(head)) = (&e.head_draw, &mut coupling.skin.head) {
            // Driven to where the law puts it by the end of this step.
            let to = head.origin_m - draw.receding_at_m(reached_m);
            head.driven_m_s = Some((to - head.displacement_m) / params.dt_s);
        }
        step(params, state, coupling)?;
        if let Some(err) = coupling.error() {
            return Err(err.clone().into());
        }
        let d = coupling.skin.outer_diameter_at_mid_length_m();
        reached_m = reached_m.max(d);
        let done = d >= e.final_diameter_m;
        if done || steps % e.sample_every == 0 {
            take(coupling, &mut samples)?;
        }
        if done {
            return Ok(samples);
        }
    }
    Err(ExpansionError::NotReached {
        reached_m: coupling.skin.outer_diameter_at_mid_length_m(),
        target_m: e.final_diameter_m,
        steps: e.max_steps,
    })
}
