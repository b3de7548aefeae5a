//! The `mapgauge` command line: parses flags, calls the library, prints.

use clap::{Parser, Subcommand};
use std::process::ExitCode;

mod cmd;

/// Measure the accuracy of a LiDAR SLAM point-cloud map with surveyed L-shaped targets.
#[derive(Parser)]
#[command(name = "mapgauge", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Generate a synthetic map of L-targets with known truth.
    Synth(cmd::synth::Args),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result: mapgauge::Result<()> = match cli.command {
        Command::Synth(a) => cmd::synth::run(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
