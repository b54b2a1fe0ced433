//! `host-sim board` and `host-sim virtual-board`: the arguments into
//! [`boardlink`] and [`vboard`] calls, and the printing of what they return.

use std::io::Write;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use anyhow::{Context, Result};
use boardlink::link::{ERASE_TIMEOUT_MS, REPLY_TIMEOUT_MS};
use boardlink::{expect_ack, Link, RunOptions};
use indicatif::{ProgressBar, ProgressStyle};
use urechis::protocol::HostCommand;

use crate::args::{BoardAction, BoardArgs, ParamsAction, VirtualBoardArgs};

/// Set by Ctrl-C (installed once per process).
fn interrupt_flag() -> Result<Arc<AtomicBool>> {
    let flag = Arc::new(AtomicBool::new(false));
    let f = Arc::clone(&flag);
    ctrlc::set_handler(move || f.store(true, Ordering::Relaxed))
        .context("installing the Ctrl-C handler")?;
    Ok(flag)
}

pub fn board(a: BoardArgs) -> Result<()> {
    let port = match a.port {
        Some(p) => p,
        None => boardlink::find_stlink_port()?,
    };
    let mut link = Link::open(&port)?;
    let info = link.connect()?;
    match a.action {
        BoardAction::Info => {
            let params = link.params()?;
            print!(
                "{}",
                boardlink::info_text(&port, &info, &params, link.errors())
            );
        }
        BoardAction::Params { action } => match action {
            ParamsAction::Get { out } => {
                let text = boardlink::params_to_toml(&link.params()?)?;
                match out {
                    Some(path) => {
                        datafile::write_atomic(&path, text.as_bytes())?;
                        println!("wrote {}", path.display());
                    }
                    None => print!("{text}"),
                }
            }
            ParamsAction::Set { file } => {
                let text = std::fs::read_to_string(&file)
                    .with_context(|| format!("reading {}", file.display()))?;
                let name = file.display().to_string();
                let params = boardlink::params_from_toml(&name, &text)?;
                expect_ack(&mut link, HostCommand::SetParams(params), REPLY_TIMEOUT_MS)
                    .with_context(|| format!("setting the parameters of {name}"))?;
                println!("parameters set from {name}");
            }
        },
        BoardAction::Run {
            cycles,
            depth_mm,
            rig,
            out,
            run_id,
        } => {
            let stop = interrupt_flag()?;
            let bar = ProgressBar::new_spinner();
            bar.set_style(
                ProgressStyle::with_template("{spinner} {elapsed} {msg}")
                    .unwrap_or_else(|_| ProgressStyle::default_spinner()),
            );
            bar.enable_steady_tick(Duration::from_millis(200));
            let options = RunOptions {
                cycles,
                depth_mm,
                rig,
                out,
                run_id,
            };
            let result = boardlink::run(&mut link, &options, &stop, &mut |t| {
                bar.set_message(format!(
                    "{:?}  p {:.3} kPa  V {:.3} mL  cycle {}/{}{}",
                    t.state,
                    t.pressure_kpa,
                    t.volume_ml,
                    t.cycle,
                    cycles,
                    t.fault
                        .map(|f| format!("  FAULT {f:?}"))
                        .unwrap_or_default()
                ));
            });
            bar.finish_and_clear();
            let outcome = result?;
            for n in &outcome.notes {
                eprintln!("note: {n}");
            }
            println!(
                "{} sample(s) recorded, {} written, {} cycle(s), {} frame(s) failed their CRC; \
                 wrote {}{}",
                outcome.samples,
                outcome.samples_written,
                outcome.cycles,
                outcome.crc_errors,
                outcome.folder.display(),
                if outcome.partial { " (partial)" } else { "" }
            );
            if let Some(f) = outcome.fault {
                anyhow::bail!(
                    "port {port}: the board stopped the run with fault {f:?} (data kept in {})",
                    outcome.folder.display()
                );
            }
        }
        BoardAction::Stop => {
            expect_ack(&mut link, HostCommand::Stop, REPLY_TIMEOUT_MS)?;
            println!("stopped");
        }
        BoardAction::Reset => {
            expect_ack(&mut link, HostCommand::Reset, REPLY_TIMEOUT_MS)?;
            println!("reset: Idle");
        }
        BoardAction::Tare => {
            expect_ack(&mut link, HostCommand::Tare, ERASE_TIMEOUT_MS)?;
            let info = link.connect()?;
            println!(
                "pressure zero {:.3} kPa absolute, stored on the board",
                info.pressure_zero_kpa
            );
        }
        BoardAction::PushTable { file } => {
            let (bytes, checksum) = boardlink::read_table_image(&file)?;
            let bar = ProgressBar::new(bytes.len() as u64);
            boardlink::push_table(&mut link, &bytes, &mut |sent, _| {
                bar.set_position(sent as u64)
            })?;
            bar.finish_and_clear();
            println!(
                "table {checksum:#010x} ({} bytes) stored on the board: in use from its next boot",
                bytes.len()
            );
        }
    }
    let errors = link.errors();
    if errors.crc + errors.other > 0 {
        eprintln!(
            "note: {} board frame(s) failed their CRC, {} other damaged frame(s) (dropped, counted)",
            errors.crc, errors.other
        );
    }
    Ok(())
}

pub fn virtual_board(a: VirtualBoardArgs) -> Result<()> {
    let scenario = a.scenario.as_deref().map(emulator::named).transpose()?;
    let stop = interrupt_flag()?;
    let vb = vboard::VirtualBoard::start(&vboard::Options {
        scenario,
        depth_mm: a.depth_mm,
        seed: a.seed,
        speed: a.speed,
    })?;
    println!("port: {}", vb.port());
    std::io::stdout().flush().context("writing to stdout")?;
    while !stop.load(Ordering::Relaxed) {
        std::thread::sleep(Duration::from_millis(50));
    }
    vb.shutdown();
    Ok(())
}
