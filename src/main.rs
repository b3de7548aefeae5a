//! The `mapgauge` command line: parses flags, calls the library, prints.
//!
//! Exit codes: 0 success; 1 the run could not produce a result (the reason is
//! one line on stderr, `error: ...`); 2 bad command-line usage (from clap).

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
    /// The whole pipeline: map + survey → accuracy tables and result files.
    Eval(Box<cmd::eval::Args>),
    /// Loose crops around every surveyed target, for inspection or hand editing.
    Crop(cmd::crop::Args),
    /// Every target-shaped object in a map, without a survey (CSV and PLY).
    Detect(cmd::detect::Args),
    /// Locate targets in tight crops (the paper's k-means → RANSAC → SVD algorithm).
    Locate(cmd::locate::Args),
    /// Align estimated positions to the survey and report the errors.
    Errors(cmd::errors::Args),
    /// Paper-style tables (Table I relative, Table II absolute) across result files.
    Table(cmd::table::Args),
    /// Is B better than A? Paired differences of two result files, with 95 % intervals.
    Compare(cmd::compare::Args),
    /// Rewrite a map in another format (streamed).
    Convert(cmd::convert::Args),
    /// Generate a synthetic LiDAR map with surveyed targets and known truth.
    Synth(cmd::synth::Args),
    /// Synthesise a scene, evaluate it, and print the tables.
    Demo(cmd::demo::Args),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Eval(a) => cmd::eval::run(*a),
        Command::Crop(a) => cmd::crop::run(a),
        Command::Locate(a) => cmd::locate::run(a),
        Command::Detect(a) => cmd::detect::run(a),
        Command::Errors(a) => cmd::errors::run(a),
        Command::Table(a) => cmd::table::run(a),
        Command::Compare(a) => cmd::compare::run(a),
        Command::Synth(a) => cmd::synth::run(a),
        Command::Convert(a) => cmd::convert::run(a),
        Command::Demo(a) => cmd::demo::run(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
