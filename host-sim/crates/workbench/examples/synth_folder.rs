//! Writes a synthetic experiment folder with hidden effects, to try the
//! workbench loop by hand (the workbench README) or to time `diagnose`.
//!
//! `cargo run --profile sim --target host-tuple -p workbench --example synth_folder -- [--repeat N | --cycles N] OUT DT_S [EFFECT ...]`
//! (three runs of ~52 s in all: DT_S = 0.00173 gives ~30,000 samples;
//! `--repeat 40` writes them 40 times as separate runs, ~1.2 M samples;
//! `--cycles 210` makes each run go through its cycles 210 times in one
//! recording, the model's state carried through: at DT_S = 0.01, three
//! runs of an hour, ~1.1 M samples).

use anyhow::{Context, Result};
use rig::PressureSource;
use workbench::synth::{case, typical};

fn main() -> Result<()> {
    let mut args = std::env::args().skip(1).peekable();
    let (mut repeat, mut cycles) = (1usize, 1usize);
    if let Some(flag) = args.next_if(|a| a == "--repeat" || a == "--cycles") {
        let n = args
            .next()
            .with_context(|| format!("{flag} N"))?
            .parse()
            .with_context(|| format!("{flag} N"))?;
        if flag == "--repeat" {
            repeat = n;
        } else {
            cycles = n;
        }
    }
    let out = args
        .next()
        .context("usage: synth_folder [--repeat N | --cycles N] OUT DT_S [EFFECT ...]")?;
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
    for plan in &mut synth.runs {
        plan.flows_ml_s = plan.flows_ml_s.repeat(cycles);
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
