//! Named, bounded parameters: the baseline's uncertain ones
//! ([`BASELINE_PARAMS`], [`Params`]) and the description every effect gives
//! of its own ([`ParamSpec`]).

use serde::{Deserialize, Serialize};

use sand::{ParametricSand, SolverSand};

/// One fitted parameter: name (the key in files and JSON), unit, bounds and
/// default (the start of a calibration).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ParamSpec {
    /// Key in `model.toml`, the JSON and the CLI.
    pub name: &'static str,
    /// Unit (`-` for a pure number).
    pub unit: &'static str,
    /// Smallest allowed value.
    pub lower: f64,
    /// Largest allowed value.
    pub upper: f64,
    /// Default value and calibration start.
    pub default: f64,
    /// The lower bound is a member of the law (its linear limit, say), not
    /// the edge of what is plausible: a fit that ends there is not "at a
    /// bound".
    pub lower_is_law: bool,
    /// What it is, in a few words.
    pub description: &'static str,
}

impl ParamSpec {
    /// `value` clamped into [lower, upper].
    pub fn clamp(&self, value: f64) -> f64 {
        value.clamp(self.lower, self.upper)
    }
}

/// Default rise length of the sand law (mm): ΔDc of the parametric law
/// fitted along D to the committed solver results
/// ([`ParametricSand::fitted_to_solver`]), the sand the firmware table is
/// made from; `None` if those results do not load.
pub fn default_sand_rise_mm() -> Option<f64> {
    let solver = SolverSand::committed().ok()?;
    Some(
        ParametricSand::fitted_to_solver(&solver)
            .params
            .characteristic_diameter_increase_mm,
    )
}

/// The baseline's uncertain parameters, in [`Params::to_vec`] order.
pub const BASELINE_PARAMS: [ParamSpec; 4] = [
    ParamSpec {
        name: "skin_stiffness_scale",
        unit: "-",
        lower: 0.05,
        upper: 20.0,
        default: 1.0,
        lower_is_law: false,
        description:
            "factor on the skin law's strain energy (every modulus); fitted only when the skin is not known (no [skin], no --skin-fit)",
    },
    ParamSpec {
        name: "sand_at_rest_factor",
        unit: "-",
        lower: 0.0,
        upper: 10.0,
        default: 1.0,
        lower_is_law: false,
        description: "factor on the sand's at-rest lateral coefficient K0",
    },
    ParamSpec {
        name: "sand_limit_factor",
        unit: "-",
        lower: 0.0,
        upper: 10.0,
        default: 1.0,
        lower_is_law: false,
        description:
            "factor on the sand's limit lateral coefficient N (fitted to the solver's sand)",
    },
    ParamSpec {
        name: "sand_rise_mm",
        unit: "mm",
        lower: 0.1,
        upper: 20.0,
        // The solver fit's ΔDc: a const cannot run the fit, so the test
        // below checks this against it; regenerating the solver's data
        // (`host-sim solver-sand`) changes it.
        default: 3.038_055_635_147_755,
        lower_is_law: false,
        description:
            "diameter increase over which the sand goes from at rest to its limit (tanh scale)",
    },
];

/// Values of the baseline's uncertain parameters.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Params {
    /// Factor on the skin's strain energy (every modulus of its law).
    pub skin_stiffness_scale: f64,
    /// Factor on the sand's at-rest coefficient K0.
    pub sand_at_rest_factor: f64,
    /// Factor on the sand's limit coefficient N.
    pub sand_limit_factor: f64,
    /// Rise length ΔDc of the sand law (mm).
    pub sand_rise_mm: f64,
}

impl Default for Params {
    fn default() -> Self {
        Self::from_slice(&BASELINE_PARAMS.map(|p| p.default))
    }
}

impl Params {
    /// Values in [`BASELINE_PARAMS`] order.
    pub fn to_vec(&self) -> Vec<f64> {
        vec![
            self.skin_stiffness_scale,
            self.sand_at_rest_factor,
            self.sand_limit_factor,
            self.sand_rise_mm,
        ]
    }

    /// From values in [`BASELINE_PARAMS`] order; missing ones take their
    /// defaults.
    pub fn from_slice(values: &[f64]) -> Self {
        let v = |i: usize| values.get(i).copied().unwrap_or(BASELINE_PARAMS[i].default);
        Self {
            skin_stiffness_scale: v(0),
            sand_at_rest_factor: v(1),
            sand_limit_factor: v(2),
            sand_rise_mm: v(3),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_rise_is_the_sand_laws() {
        let want = default_sand_rise_mm().expect("the committed solver data load");
        assert!(
            (BASELINE_PARAMS[3].default - want).abs() < 1e-9,
            "BASELINE_PARAMS' sand_rise_mm default must be the solver fit's {want}"
        );
        for p in BASELINE_PARAMS {
            assert!(p.lower <= p.default && p.default <= p.upper, "{}", p.name);
        }
        assert_eq!(
            Params::from_slice(&Params::default().to_vec()),
            Params::default()
        );
    }
}
