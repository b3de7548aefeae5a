//! What a batch says as a whole: every run's line, a leaderboard of the
//! methods across sequences, each method against the baseline, and the
//! files that hold them (`batch.json`, `leaderboard.csv`, per sequence
//! `tables.md` and `compare.md`, `index.html` linking every run's report).

use super::Manifest;
use super::one::{RunRecord, Status};
use crate::compare::{self, AcrossRuns, across_runs};
use crate::gate::Outcome;
use crate::record::{ResultFile, write_atomic};
use crate::render::{self, Grid, OutputFormat, TableFormat, Which, escape, mm};
use crate::scores::ScoreKind;
use crate::{Error, Result};
use serde::Serialize;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

/// One run as the summary lists it.
#[derive(Debug, Clone, Serialize)]
pub struct RunLine {
    /// Sequence.
    pub sequence: String,
    /// Method.
    pub method: String,
    /// Evaluated, reused or failed.
    pub status: Status,
    /// Why it failed.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
    /// Its folder, relative to the output directory.
    pub dir: String,
    /// E_abs (m).
    pub e_abs: Option<f64>,
    /// E_rel (m).
    pub e_rel: Option<f64>,
    /// Targets located, of those surveyed.
    pub found: Option<[usize; 2]>,
    /// What its gates decided, when it had any (and they were not report-only).
    pub gates: Option<Outcome>,
    /// Its benchmark scores' totals (0-100), when the config asked for any.
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub scores: BTreeMap<ScoreKind, f64>,
}

/// One method across the sequences.
#[derive(Debug, Clone, Serialize)]
pub struct Leader {
    /// Method.
    pub method: String,
    /// Sequences with a result.
    pub sequences: usize,
    /// Runs that failed.
    pub failed: usize,
    /// Mean of E_abs over its sequences (m) and its 95 % interval (Student's
    /// t over sequences); `None` without results.
    pub e_abs: Option<AcrossRuns>,
    /// The same for E_rel.
    pub e_rel: Option<AcrossRuns>,
    /// Targets located and surveyed, summed over its sequences.
    pub found: [usize; 2],
    /// Runs whose gates passed, failed, were undecided.
    pub gates: [usize; 3],
    /// Mean of each benchmark score over its sequences, with its 95 %
    /// interval as `e_abs`'s.
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub scores: BTreeMap<ScoreKind, AcrossRuns>,
}

/// One method against the baseline on one sequence.
#[derive(Debug, Clone, Serialize)]
pub struct Versus {
    /// Sequence.
    pub sequence: String,
    /// The baseline method (A).
    pub baseline: String,
    /// The method (B).
    pub method: String,
    /// B − A of E_abs on their common targets, with its 95 % interval.
    pub e_abs: Option<compare::Difference>,
    /// B − A of E_rel.
    pub e_rel: Option<compare::Difference>,
    /// The comparison's verdict in words, or why there is none.
    pub verdict: String,
}

/// The batch as a whole.
#[derive(Debug, Clone, Serialize)]
pub struct Summary {
    /// Runs, in the manifest's order.
    pub runs: Vec<RunLine>,
    /// Methods, best mean E_abs first; those with a failed run after the others.
    pub leaderboard: Vec<Leader>,
    /// Each method against the baseline, sequence by sequence.
    pub comparisons: Vec<Versus>,
    /// 4 when a run failed, else 1 when a run's gates failed, else 3 when
    /// undecided, else 0.
    pub exit_code: u8,
}

/// The summary of a batch's records.
pub fn summarise(m: &Manifest, records: &[RunRecord]) -> Summary {
    let runs: Vec<RunLine> = records.iter().map(run_line).collect();
    let mut leaderboard: Vec<Leader> = m
        .methods()
        .into_iter()
        .map(|method| leader(method, &runs))
        .collect();
    // A method with a failed run ranks after every method without one: its
    // mean is over fewer (perhaps the easier) sequences.
    leaderboard.sort_by(|a, b| {
        let key = |l: &Leader| (l.failed > 0, l.e_abs.map_or(f64::INFINITY, |e| e.mean));
        let (ka, kb) = (key(a), key(b));
        ka.0.cmp(&kb.0)
            .then(ka.1.total_cmp(&kb.1))
            .then_with(|| a.method.cmp(&b.method))
    });
    let comparisons = match &m.baseline {
        Some(b) => versus(m, b, records),
        None => Vec::new(),
    };
    let exit_code = if runs.iter().any(|r| r.status == Status::Failed) {
        4
    } else if runs.iter().any(|r| r.gates == Some(Outcome::Fail)) {
        1
    } else if runs.iter().any(|r| r.gates == Some(Outcome::Undecided)) {
        3
    } else {
        0
    };
    Summary {
        runs,
        leaderboard,
        comparisons,
        exit_code,
    }
}

fn run_line(r: &RunRecord) -> RunLine {
    let res = r.result.as_ref();
    RunLine {
        sequence: r.sequence.clone(),
        method: r.method.clone(),
        status: r.status,
        error: r.error.clone(),
        dir: format!("{}/{}", r.sequence, r.method),
        e_abs: res.map(|r| r.absolute.mean),
        e_rel: res.map(|r| r.relative.mean),
        found: res.map(|r| [r.found().0, r.targets.len()]),
        // Report-only gates decide nothing: not counted as passes.
        gates: res
            .and_then(|r| r.gate_outcome)
            .filter(|o| o.policy != crate::gate::Policy::ReportOnly)
            .map(|o| o.outcome),
        scores: res
            .map(|r| r.scores.iter().map(|(k, s)| (*k, s.total)).collect())
            .unwrap_or_default(),
    }
}

fn leader(method: &str, runs: &[RunLine]) -> Leader {
    let mine: Vec<&RunLine> = runs.iter().filter(|r| r.method == method).collect();
    let values =
        |f: fn(&RunLine) -> Option<f64>| -> Vec<f64> { mine.iter().filter_map(|r| f(r)).collect() };
    // One sequence has no spread: its mean is its value, with no interval.
    let across = |v: Vec<f64>| match v.len() {
        0 => None,
        1 => Some(AcrossRuns {
            n: 1,
            mean: v[0],
            ci95: [f64::NAN, f64::NAN],
        }),
        _ => across_runs(&v),
    };
    let count = |o: Outcome| mine.iter().filter(|r| r.gates == Some(o)).count();
    Leader {
        method: method.into(),
        sequences: mine.iter().filter(|r| r.e_abs.is_some()).count(),
        failed: mine.iter().filter(|r| r.status == Status::Failed).count(),
        e_abs: across(values(|r| r.e_abs)),
        e_rel: across(values(|r| r.e_rel)),
        found: mine
            .iter()
            .filter_map(|r| r.found)
            .fold([0, 0], |a, f| [a[0] + f[0], a[1] + f[1]]),
        gates: [
            count(Outcome::Pass),
            count(Outcome::Fail),
            count(Outcome::Undecided),
        ],
        scores: ScoreKind::ALL
            .into_iter()
            .filter_map(|k| {
                let v: Vec<f64> = mine
                    .iter()
                    .filter_map(|r| r.scores.get(&k).copied())
                    .collect();
                across(v).map(|a| (k, a))
            })
            .collect(),
    }
}

/// Every other method against `baseline` on each sequence both ran.
fn versus(m: &Manifest, baseline: &str, records: &[RunRecord]) -> Vec<Versus> {
    let find = |seq: &str, method: &str| {
        records
            .iter()
            .find(|r| r.sequence == seq && r.method == method)
            .and_then(|r| r.result.as_ref())
    };
    let mut out = Vec::new();
    for seq in m.sequences() {
        if !m
            .runs
            .iter()
            .any(|r| r.sequence == seq && r.method == baseline)
        {
            continue;
        }
        let a = find(seq, baseline);
        for method in m.methods().into_iter().filter(|x| *x != baseline) {
            if !m
                .runs
                .iter()
                .any(|r| r.sequence == seq && r.method == method)
            {
                continue;
            }
            out.push(one_versus(seq, baseline, method, a, find(seq, method)));
        }
    }
    out
}

fn one_versus(
    seq: &str,
    baseline: &str,
    method: &str,
    a: Option<&ResultFile>,
    b: Option<&ResultFile>,
) -> Versus {
    let mut v = Versus {
        sequence: seq.into(),
        baseline: baseline.into(),
        method: method.into(),
        e_abs: None,
        e_rel: None,
        verdict: String::new(),
    };
    let (Some(a), Some(b)) = (a, b) else {
        let which = if a.is_none() { baseline } else { method };
        v.verdict = format!("not compared: the run of `{which}` failed");
        return v;
    };
    let elsewhere = render::surveyed_elsewhere(a, b);
    if !elsewhere.is_empty() {
        v.verdict = format!(
            "not compared: scored against different surveys (targets {} surveyed elsewhere)",
            elsewhere.join(", ")
        );
        return v;
    }
    match compare::compare(a, b, [baseline.into(), method.into()]) {
        Ok(c) => {
            v.verdict = compare::verdict(&c, &c.e_abs, "E_abs");
            v.e_abs = Some(c.e_abs);
            v.e_rel = Some(c.e_rel);
        }
        Err(e) => v.verdict = format!("not compared: {e}"),
    }
    v
}

/// `mean [lo, hi]` in millimetres.
fn mean_ci(a: &Option<AcrossRuns>) -> (String, String) {
    match a {
        None => ("–".into(), "–".into()),
        Some(a) if a.n < 2 => (mm(a.mean), "– (1 sequence)".into()),
        Some(a) => (
            mm(a.mean),
            format!("[{}, {}]", mm(a.ci95[0]), mm(a.ci95[1])),
        ),
    }
}

/// A score's `mean` and `[lo, hi]` (0-100, one decimal).
fn score_ci(a: Option<&AcrossRuns>) -> (String, String) {
    let f = |v: f64| render::fixed(v, 1);
    match a {
        None => ("–".into(), "–".into()),
        Some(a) if a.n < 2 => (f(a.mean), "– (1 sequence)".into()),
        Some(a) => (f(a.mean), format!("[{}, {}]", f(a.ci95[0]), f(a.ci95[1]))),
    }
}

/// The leaderboard as a grid (millimetres; scores 0-100 after the errors).
pub fn leaderboard_grid(s: &Summary) -> Grid {
    let kinds: Vec<ScoreKind> = ScoreKind::ALL
        .into_iter()
        .filter(|k| s.leaderboard.iter().any(|l| l.scores.contains_key(k)))
        .collect();
    let header = [
        "rank",
        "method",
        "sequences",
        "E_abs mm",
        "E_abs 95 % mm",
        "E_rel mm",
        "E_rel 95 % mm",
        "found",
        "gates pass/fail/undecided",
        "failed runs",
    ];
    let rows = s
        .leaderboard
        .iter()
        .enumerate()
        .map(|(i, l)| {
            let (ea, eac) = mean_ci(&l.e_abs);
            let (er, erc) = mean_ci(&l.e_rel);
            let mut row = vec![
                (i + 1).to_string(),
                l.method.clone(),
                l.sequences.to_string(),
                ea,
                eac,
                er,
                erc,
                format!("{}/{}", l.found[0], l.found[1]),
                format!("{}/{}/{}", l.gates[0], l.gates[1], l.gates[2]),
                l.failed.to_string(),
            ];
            for k in &kinds {
                let (m, ci) = score_ci(l.scores.get(k));
                row.push(m);
                row.push(ci);
            }
            row
        })
        .collect();
    let mut header: Vec<String> = header.map(String::from).to_vec();
    for k in &kinds {
        header.push(format!("{} score", k.title()));
        header.push(format!("{} 95 %", k.title()));
    }
    Grid {
        header,
        rows,
        bold: Vec::new(),
        values: Vec::new(),
    }
}

/// The comparisons as a grid (millimetres).
fn versus_grid<'a>(comparisons: impl Iterator<Item = &'a Versus>) -> Grid {
    let d = |x: &Option<compare::Difference>| match x {
        Some(d) => (
            mm(d.diff),
            d.ci95
                .map_or("–".into(), |c| format!("[{}, {}]", mm(c[0]), mm(c[1]))),
        ),
        None => ("–".into(), "–".into()),
    };
    let rows = comparisons
        .map(|v| {
            let (ea, eac) = d(&v.e_abs);
            let (er, _) = d(&v.e_rel);
            vec![
                v.sequence.clone(),
                format!("{} − {}", v.method, v.baseline),
                ea,
                eac,
                er,
                v.verdict.clone(),
            ]
        })
        .collect();
    Grid {
        header: [
            "sequence",
            "B − A",
            "ΔE_abs mm",
            "95 % mm",
            "ΔE_rel mm",
            "verdict",
        ]
        .map(String::from)
        .to_vec(),
        rows,
        bold: Vec::new(),
        values: Vec::new(),
    }
}

/// The runs of one sequence that have a result, named by method.
fn of_sequence<'a>(records: &'a [RunRecord], seq: &str) -> Vec<(String, &'a ResultFile)> {
    records
        .iter()
        .filter(|r| r.sequence == seq)
        .filter_map(|r| r.result.as_ref().map(|res| (r.method.clone(), res)))
        .collect()
}

/// Writes the summary's files into `out`: `batch.json`, `leaderboard.csv`,
/// `leaderboard.md`, `<sequence>/tables.md`, `<sequence>/compare.md` (with
/// a baseline) and `index.html`.
pub fn write_summary(out: &Path, s: &Summary, records: &[RunRecord]) -> Result<()> {
    std::fs::create_dir_all(out).map_err(|e| Error::io(out, e))?;
    let json = serde_json::to_string_pretty(s).unwrap_or_default() + "\n";
    write_atomic(&out.join("batch.json"), json.as_bytes())?;
    let board = leaderboard_grid(s);
    write_atomic(
        &out.join("leaderboard.csv"),
        board.render(TableFormat::Csv).as_bytes(),
    )?;
    write_atomic(
        &out.join("leaderboard.md"),
        board.render(TableFormat::Markdown).as_bytes(),
    )?;
    let mut seqs: Vec<&str> = Vec::new();
    for r in &s.runs {
        if !seqs.contains(&r.sequence.as_str()) {
            seqs.push(&r.sequence);
        }
    }
    for seq in &seqs {
        let runs = of_sequence(records, seq);
        // An earlier batch's page of a sequence that now has no result (or
        // no comparison) would be read as this one's.
        let stale = |name: &str| {
            let _ = std::fs::remove_file(out.join(seq).join(name));
        };
        if runs.is_empty() {
            stale("tables.md");
            stale("compare.md");
            continue;
        }
        let dir = out.join(seq);
        std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
        let page = render::tables_page(
            &runs,
            OutputFormat::Table(TableFormat::Markdown),
            Which::Both,
            false,
            &render::stored_scores(&runs),
        );
        write_atomic(&out.join(seq).join("tables.md"), page.as_bytes())?;
        let mine = || s.comparisons.iter().filter(|v| v.sequence == *seq);
        if mine().next().is_some() {
            write_atomic(
                &out.join(seq).join("compare.md"),
                versus_grid(mine()).render(TableFormat::Markdown).as_bytes(),
            )?;
        } else {
            stale("compare.md");
        }
    }
    write_atomic(
        &out.join("index.html"),
        index_page(s, records, &seqs).as_bytes(),
    )
}

/// A folder name as one segment of a relative URL: unreserved characters
/// kept, every other byte percent-encoded.
fn url(s: &str) -> String {
    let mut o = String::with_capacity(s.len());
    for b in s.bytes() {
        if b.is_ascii_alphanumeric() || b"-._~".contains(&b) {
            o.push(b as char);
        } else {
            let _ = write!(o, "%{b:02X}");
        }
    }
    o
}

/// One page for the whole batch: the leaderboard, the comparisons, and per
/// sequence the paper's tables and a link to every run's report.
fn index_page(s: &Summary, records: &[RunRecord], seqs: &[&str]) -> String {
    let mut b = String::new();
    let failed = s.runs.iter().filter(|r| r.status == Status::Failed).count();
    let _ = write!(
        b,
        "<h1>Map accuracy: {} runs</h1>\n<p class=\"sub\">{} methods × {} sequences · {} failed · exit {}</p>\n",
        s.runs.len(),
        s.leaderboard.len(),
        seqs.len(),
        failed,
        s.exit_code
    );
    let _ = write!(
        b,
        "<h2>Leaderboard</h2>\n<p class=\"facts\">Mean over each method's sequences; 95 % interval from Student's t over sequences (blank with one).</p>\n<div class=\"scroll\">{}</div>\n",
        leaderboard_grid(s).render(TableFormat::Html)
    );
    if !s.comparisons.is_empty() {
        let _ = write!(
            b,
            "<h2>Against the baseline</h2>\n<div class=\"scroll\">{}</div>\n",
            versus_grid(s.comparisons.iter()).render(TableFormat::Html)
        );
    }
    for seq in seqs {
        let _ = write!(b, "<h2>{}</h2>\n<ul>\n", escape(seq));
        for r in s.runs.iter().filter(|r| r.sequence == *seq) {
            let what = match (&r.error, r.e_abs) {
                (Some(e), _) => format!("<span class=\"reason\">failed: {}</span>", escape(e)),
                (None, Some(e)) => format!(
                    "E_abs {} mm{}",
                    mm(e),
                    r.gates
                        .map_or(String::new(), |g| format!(" · gates {g:?}").to_lowercase())
                ),
                _ => String::new(),
            };
            let file = if r.status == Status::Failed {
                "error.txt"
            } else {
                "report.html"
            };
            let link = format!("{}/{}/{file}", url(seq), url(&r.method));
            let _ = writeln!(
                b,
                "<li><a href=\"{link}\">{}</a> ({:?}) — {what}</li>",
                escape(&r.method),
                r.status
            );
        }
        b.push_str("</ul>\n");
        let runs = of_sequence(records, seq);
        if !runs.is_empty() {
            for g in [render::relative_grid(&runs), render::absolute_grid(&runs)] {
                let _ = write!(
                    b,
                    "<div class=\"scroll\">{}</div>\n",
                    g.render(TableFormat::Html)
                );
            }
        }
    }
    render::page("mapgauge batch", &b, &[])
}
