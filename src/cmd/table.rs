//! `mapgauge table`: the paper's Tables I and II, one row per result file
//! (and benchmark scores when asked or stored).

use mapgauge::record::ResultFile;
use mapgauge::render::{OutputFormat, Which, survey_mismatches, tables_page};
use mapgauge::{Error, Result};
use std::path::PathBuf;

/// Paper-style tables across runs (one row per result.json).
#[derive(clap::Args)]
#[command(allow_negative_numbers = true)]
pub struct Args {
    /// result.json files written by `eval` or `errors --out`.
    #[arg(required = true)]
    results: Vec<PathBuf>,
    /// Row names, comma-separated [default: each file's parent directory name].
    #[arg(long)]
    names: Option<String>,
    /// Output: markdown, latex, csv, html (a standalone page), json or text.
    #[arg(long, default_value = "markdown")]
    format: OutputFormat,
    /// Which table: relative (Table I), absolute (Table II) or both.
    #[arg(long, default_value = "both")]
    which: String,
    /// Add the mean and 95 % interval of every column across the runs (runs of
    /// one system: mean ± t·s/√n over runs).
    #[arg(long)]
    stats: bool,
    /// Add a table of benchmark scores (0-100): hilti2022, hilti2023,
    /// hilti2026, repeatable or comma-separated; computed from each result's
    /// targets, so results written without --score are scored too
    /// [default: the rules the results were scored by].
    #[arg(long = "score", value_name = "RULE", value_delimiter = ',')]
    score: Vec<mapgauge::scores::ScoreKind>,
}

/// Runs `table`.
pub fn run(a: Args) -> Result<()> {
    let results: Vec<ResultFile> = a
        .results
        .iter()
        .map(|p| ResultFile::from_json_file(p))
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
    let runs: Vec<(String, &ResultFile)> = names.into_iter().zip(results.iter()).collect();
    for w in survey_mismatches(&runs) {
        errln!("warning: {w}");
    }
    let which: Which = a.which.parse()?;
    let scores = if a.score.is_empty() {
        mapgauge::render::stored_scores(&runs)
    } else {
        a.score.clone()
    };
    out!("{}", tables_page(&runs, a.format, which, a.stats, &scores));
    Ok(())
}
