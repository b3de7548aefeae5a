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
    /// Align estimated target positions to the survey and report every error (steps 6–7).
    Errors(cmd::errors::Args),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result: mapgauge::Result<()> = match cli.command {
        Command::Errors(a) => cmd::errors::run(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
