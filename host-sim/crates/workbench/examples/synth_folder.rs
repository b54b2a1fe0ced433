//! Writes a synthetic experiment folder with hidden effects, to try the
//! workbench loop by hand (the workbench README) or to time `diagnose`.
//!
//! `cargo run --profile sim --target host-tuple -p workbench --example synth_folder -- [--repeat N] OUT DT_S [EFFECT ...]`
//! (three runs of ~52 s in all: DT_S = 0.00173 gives ~30,000 samples;
//! `--repeat 40` writes them 40 times as separate runs, ~1.2 M samples).

use anyhow::{Context, Result};
use rig::PressureSource;
use workbench::synth::{case, typical};

fn main() -> Result<()> {
    let mut args = std::env::args().skip(1).peekable();
    let repeat: usize = if args.peek().map(String::as_str) == Some("--repeat") {
        args.next();
        args.next()
            .context("--repeat N")?
            .parse()
            .context("--repeat N")?
    } else {
        1
    };
    let out = args
        .next()
        .context("usage: synth_folder [--repeat N] OUT DT_S [EFFECT ...]")?;
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
    let mut exp = synth.generate()?;
    if repeat > 1 {
        let one = std::mem::take(&mut exp.runs);
        exp.runs = (1..=repeat)
            .flat_map(|k| {
                one.iter().map(move |r| rig::Run {
                    id: format!("{}_r{k}", r.id),
                    ..r.clone()
                })
            })
            .collect();
    }
    exp.write(std::path::Path::new(&out))?;
    let n: usize = exp.runs.iter().map(|r| r.samples.len()).sum();
    println!("wrote {out}: {} runs, {n} samples", exp.runs.len());
    Ok(())
}
