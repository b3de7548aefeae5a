//! `mapgauge batch`: many maps from a manifest, in parallel, resumable.

use mapgauge::batch::{Manifest, Status, leaderboard_grid, run_all, summarise, write_summary};
use mapgauge::render::TableFormat;
use mapgauge::{Error, Result};
use std::path::PathBuf;

/// Evaluate methods × sequences from a manifest: tables, leaderboard, comparisons.
#[derive(clap::Args)]
pub struct Args {
    /// The manifest (TOML): `[[run]]` tables with `method`, `sequence`, `map`,
    /// `survey` and optional `config` (a TOML file as `eval --config`) and
    /// `overrides` (tables of config sections); top-level `baseline`, `config`,
    /// `overrides`, `jobs`, `out`. Paths are relative to the manifest.
    pub manifest: PathBuf,
    /// Output directory: each run's files in OUT/<sequence>/<method>/, the
    /// summary (batch.json, leaderboard.csv/.md, index.html, per sequence
    /// tables.md and compare.md) in OUT [default: the manifest's `out`].
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Runs evaluated at once, so at most this many maps are open at once
    /// (each run's passes use every core as eval does) [default: the
    /// manifest's `jobs`, else the number of cores].
    #[arg(long, short, value_parser = clap::value_parser!(u32).range(1..))]
    pub jobs: Option<u32>,
}

/// Runs `batch`; `Ok` holds the exit code: 4 when a run failed, else the
/// worst of the runs' gates (1 fail, 3 undecided), else 0.
pub fn run(a: Args) -> Result<u8> {
    let m = Manifest::read(&a.manifest)?;
    let out = a
        .out
        .clone()
        .or_else(|| m.out.clone())
        .ok_or_else(|| Error::Param("batch needs --out (or `out` in the manifest)".into()))?;
    super::check_out_dir(&out)?;
    let jobs = match a.jobs.map(|j| j as usize).or(m.jobs) {
        Some(j) => j,
        None => std::thread::available_parallelism().map_or(2, |n| n.get()),
    };
    let t0 = std::time::Instant::now();
    let pb = super::runs_bar(m.runs.len() as u64);
    let records = run_all(&m, &out, jobs, |r| {
        let line = match (&r.status, &r.error) {
            (_, Some(e)) => format!("{}/{}: failed: {e}", r.sequence, r.method),
            (s, None) => {
                format!(
                    "{}/{}: {} in {:.1} s",
                    r.sequence,
                    r.method,
                    format!("{s:?}").to_lowercase(),
                    r.seconds
                )
            }
        };
        match &pb {
            Some(pb) => {
                pb.println(&line);
                pb.inc(1);
            }
            None => errln!("{line}"),
        }
    });
    if let Some(pb) = pb {
        pb.finish_and_clear();
    }
    let summary = summarise(&m, &records);
    write_summary(&out, &summary, &records)?;
    let n = |s: Status| records.iter().filter(|r| r.status == s).count();
    outln!(
        "{} runs in {:.1} s ({} at once): {} evaluated, {} reused, {} failed",
        records.len(),
        t0.elapsed().as_secs_f64(),
        jobs.min(records.len()),
        n(Status::Evaluated),
        n(Status::Reused),
        n(Status::Failed)
    );
    outln!();
    outln!("Leaderboard (mean over sequences, 95 % interval over sequences)");
    out!("{}", leaderboard_grid(&summary).render(TableFormat::Text));
    for v in &summary.comparisons {
        outln!("{} on {}: {}", v.method, v.sequence, v.verdict);
    }
    errln!(
        "summary written to {} (index.html, batch.json, leaderboard.csv)",
        out.display()
    );
    Ok(summary.exit_code)
}
