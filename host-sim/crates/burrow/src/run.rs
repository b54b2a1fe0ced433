//! Running a scenario: settle the bed round the pressurised zone, then
//! inflate it by injected volume to the final diameter, in chunks of equal
//! diameter steps so the caller can save a frame between them.

use anyhow::{Context, Result};
use indicatif::{ProgressBar, ProgressStyle};

use super::scenario::{grain_contacts, wall, Bed, HeadSupport, FLUID_BULK_MODULUS_PA, RELAX_S};
use crate::coupling::{expand, Expansion, Sample};
use dem::step;

/// Velocity relaxation time of the settling drag (s).
const SETTLE_DRAG_S: f64 = 0.02;

/// The bed at the end of settling.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Settled {
    /// Force the grains put on the floor, upwards positive (N), averaged
    /// over the last quarter of settling (the skin rings, so single steps
    /// scatter).
    pub floor_force_n: f64,
    /// Vertical support from everything (floor, side-wall friction, skin)
    /// (N), averaged likewise: equals the buoyant weight at rest.
    pub support_n: f64,
    /// Sand pressure on the skin p_e (Pa), averaged likewise.
    pub sand_pressure_pa: f64,
    /// Sand pressure on the front face p_h (Pa), averaged likewise.
    pub face_pressure_pa: f64,
    /// Buoyant weight of all grains, the surcharge's included (N).
    pub buoyant_weight_n: f64,
    /// Highest grain top of the slab (m above the axis).
    pub slab_top_m: f64,
    /// Settled sand surface (m above the axis): the highest slab grain
    /// top in each 4 r × 4 r column of the box's plan, averaged.
    pub surface_m: f64,
    /// The state at the last step: D, p_i, p_e, p_h.
    pub sample: Sample,
    /// Kinetic energy left (J).
    pub kinetic_energy_j: f64,
    /// How far the head receded while the bed settled (m): the sand ahead
    /// pushes it back against the skin's axial stiffness.
    pub head_settling_m: f64,
}

/// Vertical support of the grains by walls and skin (N).
fn support_n(bed: &Bed) -> f64 {
    let walls: f64 = bed.state.wall_forces_n().iter().map(|f| -f.y).sum();
    walls + bed.coupling.last_exchange().on_particles_n.y
}

/// Lets the grains settle for `spec.settle_s` round the zone holding its
/// resting fluid volume, at the deposition modulus, then stiffens them to
/// the sand's (`stiffen`) when that differs. A solid skin's mass is
/// scaled to the DEM step meanwhile ([`super::ScenarioSpec::skin_mass_scaling`])
/// and given back at the end.
pub fn settle(bed: &mut Bed, bar: &ProgressBar) -> Result<Settled> {
    let steps = (bed.spec.settle_s / bed.params.dt_s).ceil() as u64;
    bar.set_length(steps);
    bar.set_position(0);
    bar.set_message("settling");
    // Water drag stand-in while settling only: velocities relax with a
    // time constant of SETTLE_DRAG_S, so the heavy surcharge layer stops
    // bouncing on the soft bed (contact damping alone left it ≈ 9 % off
    // its weight after 0.2 s).
    let keep = (-bed.params.dt_s / SETTLE_DRAG_S).exp();
    let from = steps - steps / 4;
    let mut sums = [0.0f64; 4];
    // Deposition with its own friction for the first half, then the sand's.
    let sand_model = bed.params.pair_model;
    bed.params.pair_model = grain_contacts(&bed.spec, bed.spec.deposition_friction)?;
    for k in 0..steps {
        if k == steps / 2 {
            bed.params.pair_model = sand_model;
        }
        dragged_step(bed, keep).context("settling the bed")?;
        if k >= from {
            let c = &bed.coupling;
            let face = c.face.as_ref().map_or(0.0, |f| f.pressure_pa());
            let area = c.skin.outer_area_m2()?;
            let now = [
                -bed.state.wall_forces_n()[wall::FLOOR].y,
                support_n(bed),
                c.last_exchange().normal_force_n / area,
                face,
            ];
            sums.iter_mut().zip(now).for_each(|(s, v)| *s += v);
        }
        if k % 100 == 0 {
            bar.set_position(k);
        }
    }
    bar.set_position(steps);
    let mean = sums.map(|s| s / (steps - from).max(1) as f64);
    if bed.spec.grain_modulus_pa != bed.spec.deposition_modulus_pa {
        stiffen(bed, bar)?;
    }
    // The advance and the expansion, where the skin is measured, run at
    // the wall's own mass.
    bed.coupling.set_mass_scaling(false)?;
    let p = &bed.state.particles;
    let slab_top_m = (0..bed.slab_grains)
        .map(|i| p.position_m[i].y + p.radius_m[i])
        .fold(f64::NEG_INFINITY, f64::max);
    let surface_m = surface_m(bed);
    Ok(Settled {
        surface_m,
        floor_force_n: mean[0],
        support_n: mean[1],
        sand_pressure_pa: mean[2],
        face_pressure_pa: mean[3],
        buoyant_weight_n: bed.buoyant_weight_n(),
        slab_top_m,
        sample: bed.coupling.sample()?,
        kinetic_energy_j: p.kinetic_energy_j(),
        head_settling_m: bed.coupling.skin.head.map_or(0.0, |h| h.receding_m()),
    })
}

/// One step of the bed, then the settling drag: every velocity times
/// `keep`.
fn dragged_step(bed: &mut Bed, keep: f64) -> Result<()> {
    step(&bed.params, &mut bed.state, &mut bed.coupling)?;
    let p = &mut bed.state.particles;
    p.velocity_m_s.iter_mut().for_each(|v| *v *= keep);
    p.angular_velocity_rad_s.iter_mut().for_each(|w| *w *= keep);
    if let Some(e) = bed.coupling.error() {
        return Err(e.clone()).context("skin");
    }
    Ok(())
}

/// Gives the settled bed the sand's modulus and lets it relax for
/// [`RELAX_S`] under the settling drag: the stiffer contacts push the
/// grains apart by most of their soft overlaps.
fn stiffen(bed: &mut Bed, bar: &ProgressBar) -> Result<()> {
    bed.set_grain_modulus(bed.spec.grain_modulus_pa)?;
    let steps = (RELAX_S / bed.params.dt_s).ceil() as u64;
    bar.set_message("stiffening");
    bar.set_length(steps);
    bar.set_position(0);
    let keep = (-bed.params.dt_s / SETTLE_DRAG_S).exp();
    for k in 0..steps {
        dragged_step(bed, keep).context("relaxing the stiffened bed")?;
        if k % 100 == 0 {
            bar.set_position(k);
        }
    }
    bar.set_position(steps);
    Ok(())
}

/// Advances the actuator `spec.advance_m` into the settled sand over
/// `spec.advance_s`: the head and the zone's back ring move together (the
/// whole body advancing, the skin unstrained), the zone holding its
/// volume; then the body stops, holds the head for `spec.advance_hold_s`
/// and frees it, unless [`HeadSupport::Held`] (then it holds it
/// throughout; [`inflate`] draws a [`HeadSupport::Drawn`] head).
pub fn advance(bed: &mut Bed, bar: &ProgressBar) -> Result<()> {
    let spec = &bed.spec;
    if spec.advance_m <= 0.0 {
        if let (HeadSupport::Held, Some(h)) = (spec.head, &mut bed.coupling.skin.head) {
            h.driven_m_s = Some(0.0);
        }
        return Ok(());
    }
    let steps = (spec.advance_s / bed.params.dt_s).ceil() as u64;
    let v = spec.advance_m / (steps as f64 * bed.params.dt_s);
    bar.set_message("advancing");
    if let Some(h) = &mut bed.coupling.skin.head {
        h.driven_m_s = Some(v);
    }
    bed.coupling.skin.body_velocity_m_s = v;
    for _ in 0..steps {
        step(&bed.params, &mut bed.state, &mut bed.coupling).context("advancing the head")?;
        if let Some(e) = bed.coupling.error() {
            return Err(e.clone()).context("skin while advancing");
        }
    }
    bed.coupling.skin.body_velocity_m_s = 0.0;
    let hold = (spec.advance_hold_s / bed.params.dt_s).ceil() as u64;
    if let Some(h) = &mut bed.coupling.skin.head {
        h.driven_m_s = Some(0.0);
        h.velocity_m_s = 0.0;
    }
    for _ in 0..hold {
        step(&bed.params, &mut bed.state, &mut bed.coupling).context("holding the head")?;
        if let Some(e) = bed.coupling.error() {
            return Err(e.clone()).context("skin while holding the head");
        }
    }
    if let Some(h) = &mut bed.coupling.skin.head {
        if spec.head != HeadSupport::Held {
            h.driven_m_s = None;
        }
        h.velocity_m_s = 0.0;
    }
    Ok(())
}

/// The slab's surface height (m above the axis), see [`Settled::surface_m`].
fn surface_m(bed: &Bed) -> f64 {
    let p = &bed.state.particles;
    let cell = 4.0 * bed.spec.grain_radius_m;
    let mut tops: std::collections::BTreeMap<(i64, i64), f64> = Default::default();
    for i in 0..bed.slab_grains {
        let x = p.position_m[i];
        let key = ((x.x / cell).floor() as i64, (x.z / cell).floor() as i64);
        let top = tops.entry(key).or_insert(f64::NEG_INFINITY);
        *top = top.max(x.y + p.radius_m[i]);
    }
    tops.values().sum::<f64>() / tops.len().max(1) as f64
}

/// Inflates the zone from its settled state to `spec.final_diameter_m` in
/// `spec.frames` equal diameter steps, the injection rate set so the whole
/// takes about `spec.expansion_s`; `on_frame(bed, frame)` runs before the
/// first chunk and after each. Returns the samples in order.
pub fn inflate(
    bed: &mut Bed,
    bar: &ProgressBar,
    mut on_frame: impl FnMut(&Bed, usize) -> Result<()>,
) -> Result<Vec<Sample>> {
    let spec = bed.spec.clone();
    let d0 = bed.coupling.skin.outer_diameter_at_mid_length_m();
    let d1 = spec.final_diameter_m;
    anyhow::ensure!(
        d0 < d1,
        "the settled zone is already {:.2} mm across",
        d0 * 1e3
    );
    // Volume to inject: a cylinder of the zone's length from D0 to D1
    // times 0.6 for the clamped ends' bulge (only sets the rate).
    let len = bed.coupling.skin.spec.length_m;
    let dv = 0.6 * std::f64::consts::PI / 4.0 * len * (d1 * d1 - d0 * d0);
    let dt = bed.params.dt_s;
    let total_steps = (spec.expansion_s / dt).ceil() as usize;
    let sample_every = (total_steps / spec.samples).max(1);
    bar.set_length(1000);
    bar.set_position(0);
    bar.set_message("expanding");
    // The draw is a law of D from the zone's rest diameter, shared with
    // the free-skin reference; D_r counts from where the head would sit at
    // rest, so the settled head (at the law's D_r for the settled D, a few
    // µm at most) is not jolted at the first step.
    let head_draw = spec.expansion_head_draw();
    if let Some(head) = &mut bed.coupling.skin.head {
        head.origin_m = head.displacement_m + head_draw.map_or(0.0, |d| d.receding_at_m(d0));
    }
    let mut samples: Vec<Sample> = Vec::new();
    on_frame(bed, 0)?;
    for frame in 1..=spec.frames {
        let target = d0 + (d1 - d0) * frame as f64 / spec.frames as f64;
        let e = Expansion {
            final_diameter_m: target,
            volume_rate_m3_s: dv / spec.expansion_s,
            bulk_modulus_pa: FLUID_BULK_MODULUS_PA,
            sample_every,
            max_steps: 4 * total_steps,
            head_draw,
        };
        let chunk = expand(&bed.params, &mut bed.state, &mut bed.coupling, &e, |s| {
            let done = (s.outer_diameter_m - d0) / (d1 - d0);
            bar.set_position((1000.0 * done.clamp(0.0, 1.0)) as u64);
        })
        .with_context(|| format!("expanding to {:.2} mm", target * 1e3))?;
        // Each chunk starts with the previous one's last state. `expand`
        // draws the head to the largest D reached within its call; that
        // carries across chunks because a chunk ends at its first step
        // past a target above every earlier D, so its last D is the
        // largest so far (a step moves D by nanometres, a frame by
        // (d1 − d0) / frames).
        let skip = usize::from(!samples.is_empty());
        samples.extend(chunk.into_iter().skip(skip));
        on_frame(bed, frame)?;
    }
    Ok(samples)
}

/// A progress bar on stderr (hidden when `show` is false).
pub fn progress_bar(show: bool) -> Result<ProgressBar> {
    let bar = if show {
        ProgressBar::new(1)
    } else {
        ProgressBar::hidden()
    };
    bar.set_style(
        ProgressStyle::with_template("{msg:>10} [{bar:40}] {percent:>3}% {elapsed} ({eta} left)")
            .context("progress bar template")?
            .progress_chars("=> "),
    );
    Ok(bar)
}
