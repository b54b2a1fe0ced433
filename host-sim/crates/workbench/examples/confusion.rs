//! The workbench's confusion matrix over the effect library: one synthetic
//! experiment per hidden effect (plus a control with none and one effect
//! outside the library), each diagnosed; prints which effect was ranked
//! first and which were selected, the primary parameter's recovery, the
//! final RMSE against the noise floor, and the time taken.
//!
//! `cargo run --profile sim --target host-tuple -p workbench --example confusion [-- SEEDS]`

use std::time::Instant;

use anyhow::Result;
use model::effects::REGISTRY;
use rig::PressureSource;
use workbench::diagnose::{diagnose, DiagnoseOptions};
use workbench::synth::{case, typical, Outside};

fn main() -> Result<()> {
    let seeds: u64 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(1);
    let mut names: Vec<&str> = vec!["none"];
    names.extend(REGISTRY.iter().map(|s| s.name));
    names.push("outside:temperature_drift");
    println!("hidden | seed | ranked first | selected | primary true→fit | final/noise | unexplained | s");
    for seed in 0..seeds {
        for name in &names {
            let mut synth = match *name {
                "none" | "outside:temperature_drift" => case(Vec::new(), 0.02, 100 + seed),
                n => case(vec![typical(n)?], 0.02, 100 + seed),
            };
            if *name == "piston_friction" {
                synth.rig.measurement.pressure_source = PressureSource::PistonForce;
            }
            if *name == "skin_shape" {
                // The harder case: the skin's scale is fitted beside its
                // shape.
                synth.rig.skin = None;
            }
            if name.starts_with("outside") {
                synth.outside = Some(Outside::TemperatureDrift {
                    amplitude_kpa: 0.25,
                    period_s: 7.0,
                });
            }
            let exp = synth.generate()?;
            let t0 = Instant::now();
            let d = diagnose(&exp, &DiagnoseOptions::default())?;
            let secs = t0.elapsed().as_secs_f64();
            let primary = synth.effects.first().map(|e| {
                let p = e.spec.params[0].name;
                let key = format!("{}.{}", e.spec.name, p);
                let fit = d.params.iter().find(|q| q.name == key).map(|q| q.value);
                format!(
                    "{:.4}→{}",
                    e.values[0],
                    fit.map_or("-".into(), |v| format!("{v:.4}"))
                )
            });
            println!(
                "{name} | {seed} | {} ({:.1}) | {} | {} | {:.3}/{:.3} | {} | {secs:.1}",
                d.candidates.first().map_or("-", |c| c.effect.as_str()),
                d.candidates.first().map_or(0.0, |c| c.score),
                if d.selected.is_empty() {
                    "-".into()
                } else {
                    d.selected.join("+")
                },
                primary.unwrap_or("-".into()),
                d.final_rmse_kpa,
                d.noise_floor_kpa,
                d.unexplained.as_deref().map_or("null", |_| "set"),
            );
        }
    }
    Ok(())
}
