//! `mapgauge table`: the paper's Tables I and II, one row per result file.

use mapgauge::record::ResultFile;
use mapgauge::render::{
    Grid, OutputFormat, TableFormat, absolute_grid, relative_grid, survey_mismatches,
};
use mapgauge::report::html;
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
}

/// `g` with three rows appended: the mean of every numeric column over the
/// runs, and the low and high ends of its 95 % interval (blank where fewer
/// than 2 runs have a value).
fn with_stats(mut g: Grid) -> Grid {
    let cols = g.header.len();
    let mut out: [(Vec<String>, Vec<Option<f64>>); 3] = Default::default();
    let n = g.rows.len();
    for (k, label) in [
        format!("mean ({n} runs)"),
        "95 % CI low".into(),
        "95 % CI high".into(),
    ]
    .into_iter()
    .enumerate()
    {
        out[k].0.push(label);
        out[k].1.push(None);
    }
    for c in 1..cols {
        let vals: Vec<f64> = g
            .values
            .iter()
            .filter_map(|r| r.get(c).copied().flatten())
            .collect();
        let s = mapgauge::compare::across_runs(&vals);
        for (k, v) in [
            s.map(|s| s.mean),
            s.map(|s| s.ci95[0]),
            s.map(|s| s.ci95[1]),
        ]
        .into_iter()
        .enumerate()
        {
            out[k]
                .0
                .push(v.map(|v| format!("{v:.4}")).unwrap_or_default());
            out[k].1.push(v);
        }
    }
    if g.values.len() < g.rows.len() {
        g.values.resize(g.rows.len(), vec![None; cols]);
    }
    for (row, vals) in out {
        g.rows.push(row);
        g.values.push(vals);
    }
    g
}

/// Runs `table`.
pub fn run(a: Args) -> Result<()> {
    let fmt = match a.format {
        OutputFormat::Table(f) => Some(f),
        OutputFormat::Json => None,
    };
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
        eprintln!("warning: {w}");
    }
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
    let st = |g: Grid| if a.stats { with_stats(g) } else { g };
    let mut tables: Vec<(&str, Grid)> = Vec::new();
    if rel {
        tables.push(("Relative error (m) — Table I", st(relative_grid(&runs))));
    }
    if abs {
        tables.push(("Absolute error (m) — Table II", st(absolute_grid(&runs))));
    }
    let Some(fmt) = fmt else {
        let mut o = serde_json::Map::new();
        if rel {
            o.insert("relative".into(), st(relative_grid(&runs)).to_json());
        }
        if abs {
            o.insert("absolute".into(), st(absolute_grid(&runs)).to_json());
        }
        let text = serde_json::to_string_pretty(&serde_json::Value::Object(o)).unwrap_or_default();
        outln!("{text}");
        return Ok(());
    };
    if fmt == TableFormat::Html {
        let mut body = String::from("<h1>Map accuracy</h1>\n");
        for (caption, g) in &tables {
            body.push_str(&format!(
                "<h2>{}</h2>\n<div class=\"scroll\">{}</div>\n",
                html::escape(caption),
                g.render(fmt)
            ));
        }
        body.push_str(
            "<p class=\"sub\">Means and standard deviations in bold as in the paper; \
             a blank cell: the run has no such target; –: it has, but could not locate it.</p>",
        );
        out!("{}", html::page("mapgauge tables", &body, &[]));
        return Ok(());
    }
    for (k, (caption, g)) in tables.iter().enumerate() {
        if k > 0 {
            outln!();
        }
        if fmt == TableFormat::Markdown {
            outln!("**{caption}**\n");
        }
        out!("{}", g.render(fmt));
    }
    Ok(())
}
