//! The zone's own pressure–diameter curve with no sand around it, from the
//! same FEM skin with the same ends and head kinematics as the run it is
//! subtracted from: the back ring on the body, the front ring on the head,
//! the head drawn back by the run's law of D
//! ([`ScenarioSpec::expansion_head_draw`]) or held. What the balloon
//! experiment subtracts as its h = 0 run. The sand's share of the internal
//! pressure, Δp_i = p_i − p_free(D), is the quantity the experiment's p_e
//! measures; the contact pressure averaged over the whole skin (`Sample`'s
//! p_e) is another, smaller one (it counts the end regions that barely
//! move).
//!
//! A free head ([`crate::HeadSupport::Free`]) has no law of D: its
//! reference holds the head where it is (the run's head moves under the
//! sand on its face, which a sand-free reference cannot reproduce).

use anyhow::{ensure, Result};

use super::scenario::ScenarioSpec;
use fem::Ends;

/// Pressure steps of the curve (Pa). Against 50 Pa steps relaxed to
/// 1e-7 N, this step and [`TOLERANCE`] move
/// p_free by at most 0.8 Pa from 19 to 25.5 mm on the paper's wall, 0.04 %
/// of the sand's share at 40 mm, at a third of the cost (18 → 5.6 s).
const STEP_PA: f64 = 100.0;
/// Relaxation tolerance, as a fraction of one pressure step's load on a
/// node (the step times the outer area over the nodes of a layer): 3e-6 N
/// on the paper's wall.
const TOLERANCE: f64 = 0.013;

/// Passes of relaxation and head placement per pressure step at most: the
/// head's place depends on the D it yields; D_r moves by ≪ 1 µm after the
/// second pass on the paper's zone.
const HEAD_PASSES: usize = 4;
/// Head placement converged: D_r changed by less than this (m).
const HEAD_TOLERANCE_M: f64 = 1e-8;

/// p_free(D) of the scenario's zone, sampled by quasi-static relaxation.
#[derive(Clone, Debug, PartialEq)]
pub struct FreeCurve {
    /// (outer diameter at mid-length (m), internal pressure (Pa)), D
    /// increasing.
    points: Vec<(f64, f64)>,
    /// How far the head was drawn back at each point, D_r (m).
    receding_m: Vec<f64>,
}

/// Puts `skin`'s head, and its ring, `receding_m` (m) behind rest (a
/// skin with [`Ends::Head`]): the ring is held in [`fem::Skin::relax`],
/// so this is where it stays.
pub fn place_head(skin: &mut fem::Skin<skin::SkinLaw>, receding_m: f64) {
    let front = skin.mesh.along;
    let ring: Vec<usize> = skin.ring_nodes(front).collect();
    for a in ring {
        skin.position_m[a].z = skin.rest_m[a].z - receding_m;
    }
    if let Some(head) = &mut skin.head {
        head.displacement_m = -receding_m;
    }
}

impl FreeCurve {
    /// The curve of `spec`'s skin from rest to past its final diameter,
    /// with the run's ends ([`Ends::Head`]: the head's ring held by the
    /// head) and the run's head draw ([`ScenarioSpec::expansion_head_draw`]).
    pub fn of(spec: &ScenarioSpec) -> Result<FreeCurve> {
        let draw = spec.expansion_head_draw();
        let mut skin = spec.skin(Ends::Head)?;
        let mut points = vec![(skin.outer_diameter_at_mid_length_m(), 0.0)];
        let mut receding_m = vec![0.0];
        let mut previous: Option<Vec<nalgebra::Vector3<f64>>> = None;
        let tolerance_n =
            TOLERANCE * STEP_PA * skin.outer_area_m2()? / skin.mesh.rest_m.len() as f64;
        while points
            .last()
            .is_some_and(|p| p.0 < spec.final_diameter_m + 0.5e-3)
        {
            let p = points.len() as f64 * STEP_PA;
            ensure!(
                p < 50e3,
                "the free skin did not reach {:.1} mm below 50 kPa",
                spec.final_diameter_m * 1e3
            );
            skin.pressure_pa = p;
            // Start from the line through the last two states (equal
            // pressure steps): the relaxation then only corrects the
            // curvature, about halving its steps for a solid wall.
            let here = skin.position_m.clone();
            if let Some(before) = &previous {
                for ((x, now), was) in skin.position_m.iter_mut().zip(&here).zip(before) {
                    *x = 2.0 * now - was;
                }
            }
            previous = Some(here);
            // The head where the law puts it for the D this step yields:
            // a fixed point, started from the extrapolated state's D.
            let mut d_r = draw.map_or(0.0, |law| {
                law.receding_at_m(skin.outer_diameter_at_mid_length_m())
            });
            let mut d = f64::NAN;
            for _ in 0..HEAD_PASSES {
                place_head(&mut skin, d_r);
                skin.relax(tolerance_n, 400_000)?;
                d = skin.outer_diameter_at_mid_length_m();
                let Some(law) = draw else { break };
                let want = law.receding_at_m(d);
                let moved = (want - d_r).abs();
                d_r = want;
                if moved < HEAD_TOLERANCE_M {
                    break;
                }
            }
            ensure!(
                points.last().is_some_and(|q| d > q.0),
                "the free skin's diameter stopped growing at {p} Pa (a limit point)"
            );
            points.push((d, p));
            receding_m.push(skin.head.map_or(0.0, |h| -h.displacement_m));
        }
        Ok(FreeCurve { points, receding_m })
    }

    /// The relaxed states: (outer diameter at mid-length (m), internal
    /// pressure (Pa), head drawn back D_r (m)), D increasing.
    pub fn states(&self) -> impl Iterator<Item = (f64, f64, f64)> + '_ {
        self.points
            .iter()
            .zip(&self.receding_m)
            .map(|(&(d, p), &r)| (d, p, r))
    }

    /// p_free (Pa) at outer diameter `d_m` (m), linear between the
    /// relaxed states; `None` outside the sampled range.
    pub fn pressure_pa(&self, d_m: f64) -> Option<f64> {
        let k = self
            .points
            .windows(2)
            .position(|w| d_m >= w[0].0 && d_m <= w[1].0)?;
        let ((d0, p0), (d1, p1)) = (self.points[k], self.points[k + 1]);
        Some(p0 + (p1 - p0) * (d_m - d0) / (d1 - d0))
    }
}

/// Largest relative miss of [`FreeCurve::matched`]'s free pressure at the
/// final diameter; one rescale lands within about 0.1 % (the curve is
/// sampled at fixed pressure steps, so p_free is only nearly ∝ scale).
pub const MATCH_TOLERANCE: f64 = 2e-3;

impl FreeCurve {
    /// `spec` with its skin's stiffness scale
    /// ([`ScenarioSpec::skin_stiffness_scale`]) set so that the zone with
    /// no sand needs `free_pressure_pa` (Pa) at its final diameter, and
    /// that skin's curve. This is how a balloon's measured pressure at
    /// h = 0 (at the injected volume) sets its skin: W is scaled (every
    /// modulus of the law), so at a given shape every stress and p_free
    /// scale with it, and one rescale from the first curve lands within
    /// [`MATCH_TOLERANCE`] (a second one is taken if it does not).
    pub fn matched(
        spec: &ScenarioSpec,
        free_pressure_pa: f64,
    ) -> Result<(ScenarioSpec, FreeCurve)> {
        ensure!(
            free_pressure_pa.is_finite() && free_pressure_pa > 0.0,
            "the skin's free pressure to match must be > 0 Pa (got {free_pressure_pa})"
        );
        let mut spec = spec.clone();
        let mut curve = FreeCurve::of(&spec)?;
        for _ in 0..3 {
            let p = curve.pressure_pa(spec.final_diameter_m).ok_or_else(|| {
                anyhow::anyhow!("the free skin's curve does not reach the final diameter")
            })?;
            if (p / free_pressure_pa - 1.0).abs() <= MATCH_TOLERANCE {
                return Ok((spec, curve));
            }
            spec.skin_stiffness_scale *= free_pressure_pa / p;
            curve = FreeCurve::of(&spec)?;
        }
        anyhow::bail!(
            "the skin's scale did not converge to a free pressure of {:.3} kPa at {:.2} mm",
            free_pressure_pa * 1e-3,
            spec.final_diameter_m * 1e3
        )
    }
}
