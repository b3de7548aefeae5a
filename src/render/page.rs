//! The page `mapgauge table` prints (and Python's `mapgauge.table` returns):
//! the paper's Tables I and II over several runs, in any output format.

use super::{Grid, OutputFormat, TableFormat, absolute_grid, relative_grid};
use crate::record::ResultFile;
use crate::scores::ScoreKind;
use crate::{Error, Result};

/// Which of the paper's tables a page holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Which {
    /// Table I, relative errors.
    Relative,
    /// Table II, absolute errors.
    Absolute,
    /// Both, Table I first.
    Both,
}

impl std::str::FromStr for Which {
    type Err = Error;
    fn from_str(s: &str) -> Result<Which> {
        match s {
            "both" => Ok(Which::Both),
            "relative" => Ok(Which::Relative),
            "absolute" => Ok(Which::Absolute),
            w => Err(Error::Param(format!(
                "--which `{w}`: relative, absolute or both"
            ))),
        }
    }
}

/// The tables of `runs` (name, result; one row each) as `fmt`: JSON an
/// object `{"relative": …, "absolute": …}`, HTML a standalone page, the
/// others the tables one after the other (Markdown with their captions).
/// `stats` appends the mean and 95 % interval of every column over the runs.
/// With `scores`, a third table gives each run's benchmark scores (JSON key
/// `scores`).
pub fn tables_page(
    runs: &[(String, &ResultFile)],
    fmt: OutputFormat,
    which: Which,
    stats: bool,
    scores: &[ScoreKind],
) -> String {
    let st = |g: Grid| if stats { with_stats(g) } else { g };
    let mut tables: Vec<(&str, &str, Grid)> = Vec::new();
    if which != Which::Absolute {
        let g = st(relative_grid(runs));
        tables.push(("relative", "Relative error (m) — Table I", g));
    }
    if which != Which::Relative {
        let g = st(absolute_grid(runs));
        tables.push(("absolute", "Absolute error (m) — Table II", g));
    }
    if !scores.is_empty() {
        let g = st(super::scores::scores_grid(runs, scores));
        tables.push(("scores", "Benchmark scores (0–100)", g));
    }
    let fmt = match fmt {
        OutputFormat::Table(f) => f,
        OutputFormat::Json => {
            let mut o = serde_json::Map::new();
            for (key, _, g) in &tables {
                o.insert((*key).into(), g.to_json());
            }
            let mut s =
                serde_json::to_string_pretty(&serde_json::Value::Object(o)).unwrap_or_default();
            s.push('\n');
            return s;
        }
    };
    if fmt == TableFormat::Html {
        let mut body = String::from("<h1>Map accuracy</h1>\n");
        for (_, caption, g) in &tables {
            body.push_str(&format!(
                "<h2>{}</h2>\n<div class=\"scroll\">{}</div>\n",
                super::escape(caption),
                g.render(fmt)
            ));
        }
        body.push_str(
            "<p class=\"sub\">Means and standard deviations in bold as in the paper; \
             a blank cell: the run has no such target; –: it has, but could not locate it.</p>",
        );
        return super::page("mapgauge tables", &body, &[]);
    }
    let mut out = String::new();
    for (k, (_, caption, g)) in tables.iter().enumerate() {
        if k > 0 {
            out.push('\n');
        }
        if fmt == TableFormat::Markdown {
            out.push_str(&format!("**{caption}**\n\n"));
        }
        out.push_str(&g.render(fmt));
    }
    out
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
        let s = crate::compare::across_runs(&vals);
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
