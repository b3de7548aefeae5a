//! `mapgauge table`: the paper's Tables I and II, one row per result file.

use mapgauge::result::{RunResult, TableFormat, absolute_grid, relative_grid};
use mapgauge::{Error, Result};
use std::path::PathBuf;

/// Paper-style tables across runs (one row per result.json).
#[derive(clap::Args)]
pub struct Args {
    /// result.json files written by `eval` or `errors --out`.
    #[arg(required = true)]
    results: Vec<PathBuf>,
    /// Row names, comma-separated [default: each file's parent directory name].
    #[arg(long)]
    names: Option<String>,
    /// Output: markdown, latex, csv or text.
    #[arg(long, default_value = "markdown")]
    format: String,
    /// Which table: relative (Table I), absolute (Table II) or both.
    #[arg(long, default_value = "both")]
    which: String,
}

/// Runs `table`.
pub fn run(a: Args) -> Result<()> {
    let fmt = match mapgauge::result::parse_output_format(&a.format)? {
        Some(f) => f,
        None => {
            return Err(Error::Param(
                "--format json is not a table; use the result files themselves".into(),
            ));
        }
    };
    let results: Vec<RunResult> = a
        .results
        .iter()
        .map(|p| RunResult::from_json_file(p))
        .collect::<Result<_>>()?;
    let names: Vec<String> = match &a.names {
        Some(n) => {
            let v: Vec<String> = n.split(',').map(|s| s.trim().to_string()).collect();
            if v.len() != results.len() {
                return Err(Error::Param(format!(
                    "--names has {} names for {} result files",
                    v.len(),
                    results.len()
                )));
            }
            v
        }
        None => a
            .results
            .iter()
            .map(|p| {
                p.parent()
                    .and_then(|d| d.file_name())
                    .map(|d| d.to_string_lossy().into_owned())
                    .unwrap_or_else(|| p.display().to_string())
            })
            .collect(),
    };
    let runs: Vec<(String, &RunResult)> = names.into_iter().zip(results.iter()).collect();
    let (rel, abs) = match a.which.as_str() {
        "both" => (true, true),
        "relative" => (true, false),
        "absolute" => (false, true),
        w => {
            return Err(Error::Param(format!(
                "--which `{w}`: relative, absolute or both"
            )));
        }
    };
    if rel {
        if fmt == TableFormat::Markdown {
            println!("**Relative error (m)**\n");
        }
        print!("{}", relative_grid(&runs).render(fmt));
    }
    if rel && abs {
        println!();
    }
    if abs {
        if fmt == TableFormat::Markdown {
            println!("**Absolute error (m)**\n");
        }
        print!("{}", absolute_grid(&runs).render(fmt));
    }
    Ok(())
}
