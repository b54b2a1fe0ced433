//! Writes a synthetic experiment folder with hidden effects, to try the
//! workbench loop by hand (the workbench README) or to time `diagnose`.
//!
//! `cargo run --profile sim --target host-tuple -p workbench --example synth_folder -- OUT DT_S [EFFECT ...]`
//! (three runs of ~52 s in all: DT_S = 0.00173 gives ~30,000 samples).

use anyhow::{Context, Result};
use rig::PressureSource;
use workbench::synth::{case, typical};

fn main() -> Result<()> {
    let mut args = std::env::args().skip(1);
    let out = args
        .next()
        .context("usage: synth_folder OUT DT_S [EFFECT ...]")?;
    let dt: f64 = args.next().context("DT_S")?.parse().context("DT_S")?;
    let effects = args.map(|n| typical(&n)).collect::<Result<Vec<_>>>()?;
    let mut synth = case(effects, dt, 42);
    if synth
        .effects
        .iter()
        .any(|e| e.spec.name == "piston_friction")
    {
        synth.rig.measurement.pressure_source = PressureSource::PistonForce;
    }
    let exp = synth.generate()?;
    exp.write(std::path::Path::new(&out))?;
    let n: usize = exp.runs.iter().map(|r| r.samples.len()).sum();
    println!("wrote {out}: {} runs, {n} samples", exp.runs.len());
    Ok(())
}
