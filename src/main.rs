//! The `mapgauge` command line: parses flags, calls the library, prints.
//!
//! Exit codes: 0 success (every gate passed, or none was set); 1 a quality
//! gate failed (`--gate`); 2 bad command-line usage (from clap); 3 a gate was
//! undecided under `--gate-policy strict` (its 95 % interval straddles the
//! threshold); 4 the run could not produce a result (the reason is one line
//! on stderr, `error: ...`).

use clap::{Parser, Subcommand};
use std::process::ExitCode;

mod cmd;

/// Measure the accuracy of a LiDAR SLAM point-cloud map with surveyed L-shaped targets.
#[derive(Parser)]
#[command(
    name = "mapgauge",
    version,
    about,
    long_about = None,
    after_help = "Exit codes: 0 a result (every gate passed, or none set); 1 a gate failed; 2 usage error; 3 a gate undecided (--gate-policy strict); 4 no result could be produced (the reason on stderr)."
)]
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
    /// Many maps from a manifest (methods × sequences), in parallel and
    /// resumable: tables per sequence, a leaderboard, comparisons with a baseline.
    Batch(cmd::batch::Args),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let unit = |r: mapgauge::Result<()>| r.map(|()| 0);
    let result = match cli.command {
        Command::Eval(a) => cmd::eval::run(*a),
        Command::Crop(a) => unit(cmd::crop::run(a)),
        Command::Locate(a) => unit(cmd::locate::run(a)),
        Command::Detect(a) => unit(cmd::detect::run(a)),
        Command::Errors(a) => cmd::errors::run(a),
        Command::Table(a) => unit(cmd::table::run(a)),
        Command::Compare(a) => unit(cmd::compare::run(a)),
        Command::Synth(a) => unit(cmd::synth::run(a)),
        Command::Convert(a) => unit(cmd::convert::run(a)),
        Command::Demo(a) => unit(cmd::demo::run(a)),
        Command::Batch(a) => cmd::batch::run(a),
    };
    match result {
        Ok(code) => ExitCode::from(code),
        Err(e) => {
            cmd::write_stderr(format_args!("error: {e}\n"));
            ExitCode::from(COULD_NOT_EVALUATE)
        }
    }
}

/// The exit code of a run that could not produce a result: apart from a
/// failed gate's 1, so CI can tell "the map is not good enough" from "the
/// map was not measured".
const COULD_NOT_EVALUATE: u8 = 4;
