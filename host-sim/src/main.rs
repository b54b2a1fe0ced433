//! `host-sim`: one command line over the library; parsing and dispatch only.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Result;
use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(
    name = "host-sim",
    version,
    about = "Physics, tables and tools for the urechis burrowing actuator"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Regenerate the firmware's pressure→diameter table (src/table/generated.rs).
    Tables {
        /// Repository root (where the firmware's Cargo.toml is).
        #[arg(long, default_value_os_t = default_repo_root())]
        repo: PathBuf,
        /// Only compare with the committed file; fail if it is stale.
        #[arg(long)]
        check: bool,
    },
}

fn default_repo_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Tables { repo, check } => {
            let (path, outcome) =
                host_sim::tables::regenerate(&repo, &host_sim::physics_model(), check)?;
            println!("{}: {:?}", path.display(), outcome);
        }
    }
    Ok(())
}

fn main() -> ExitCode {
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
