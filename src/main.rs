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
    /// Locate the L-target corner in tight crops (the paper's k-means → RANSAC → SVD).
    Locate(cmd::locate::Args),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result: mapgauge::Result<()> = match cli.command {
        Command::Locate(a) => cmd::locate::run(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
