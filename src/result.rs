//! The result file (`result.json`, schema `mapgauge.result/1`) and its renderings:
//! a terminal report, the paper's Tables I/II as text, Markdown, LaTeX and CSV.
//!
//! The JSON keys are a contract read by scripts and by `mapgauge table`; keys may be
//! added, never renamed.

use crate::metrics::{Dim, Summary};
use crate::survey::{Geodetic, Role, SurveyFrame};
use crate::{Error, Result};
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;
use std::path::Path;

/// Schema identifier written into every result file.
pub const SCHEMA: &str = "mapgauge.result/1";

/// A position in a result file (z absent when unknown).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Xyz {
    /// x (m).
    pub x: f64,
    /// y (m).
    pub y: f64,
    /// z (m), `null` when the source had no height.
    pub z: Option<f64>,
}

/// The fitted map → survey transform as written to the result.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AlignmentOut {
    /// Method name (`rigid2d`, ...).
    pub method: String,
    /// Yaw of the map → survey rotation, degrees.
    pub rotation_deg: f64,
    /// Translation (m).
    pub translation: [f64; 3],
    /// Scale factor.
    pub scale: f64,
    /// Scale deviation, parts per million.
    #[serde(default)]
    pub scale_ppm: f64,
    /// Full rotation matrix, row-major.
    #[serde(default)]
    pub rotation_matrix: [[f64; 3]; 3],
    /// Number of targets the fit used.
    #[serde(default)]
    pub n_used: usize,
    /// Iterations (robust2d), 0 for closed forms.
    #[serde(default)]
    pub iterations: usize,
}

impl AlignmentOut {
    /// The transform this line describes, to map further points.
    pub fn to_alignment(&self) -> crate::align::Alignment {
        let m = self.rotation_matrix;
        crate::align::Alignment {
            method: self.method.parse().unwrap_or_default(),
            rotation: nalgebra::Matrix3::new(
                m[0][0], m[0][1], m[0][2], m[1][0], m[1][1], m[1][2], m[2][0], m[2][1], m[2][2],
            ),
            translation: nalgebra::Vector3::from(self.translation),
            scale: self.scale,
            iterations: self.iterations,
        }
    }
}

/// One target's line in the result.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TargetOut {
    /// Target id.
    pub id: String,
    /// `ok`, `not_found` or `excluded`.
    pub status: String,
    /// Why, when not ok.
    pub reason: Option<String>,
    /// Surveyed reference point (survey frame, antenna height removed).
    pub survey: Xyz,
    /// Estimated position, map frame.
    pub map: Option<Xyz>,
    /// Estimate mapped into the survey frame.
    pub aligned: Option<Xyz>,
    /// Absolute error (m) in the chosen dimension.
    pub abs_error: Option<f64>,
    /// Error when this target is left out of the alignment fit.
    #[serde(default)]
    pub loo_error: Option<f64>,
    /// Control or check, when the survey says.
    #[serde(default)]
    pub role: Option<Role>,
}

/// Absolute error statistics (the paper's Table II).
pub type AbsoluteStats = Summary;

/// One pair's relative error (the paper's Table I).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Pair {
    /// First target id.
    pub a: String,
    /// Second target id.
    pub b: String,
    /// Distance between the surveyed points (m).
    pub survey_distance: f64,
    /// Distance between the map estimates (m).
    pub map_distance: f64,
    /// | map_distance − survey_distance | (m).
    pub error: f64,
    /// The error per 100 m of survey distance (m), for comparing short and long
    /// pairs; `null` for coincident survey points.
    #[serde(default)]
    pub error_per_100m: Option<f64>,
}

/// Relative error statistics and every pair.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RelativeStats {
    /// Number of pairs.
    pub n: usize,
    /// Mean (E_rel).
    pub mean: f64,
    /// Population standard deviation (σ_rel).
    pub std: f64,
    /// RMS of pair errors.
    #[serde(default)]
    pub rmse: f64,
    /// Median pair error.
    #[serde(default)]
    pub median: f64,
    /// Largest pair error.
    #[serde(default)]
    pub max: f64,
    /// Every pair, i < j in survey order.
    pub pairs: Vec<Pair>,
}

/// One held-out target's error.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HeldOutTarget {
    /// Target id.
    pub id: String,
    /// Error (m) under an alignment that did not see this target.
    pub error: f64,
}

/// Errors of targets not used in the fit that scores them (honest errors).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HeldOut {
    /// Statistics of the held-out errors.
    #[serde(flatten)]
    pub summary: Summary,
    /// Per target.
    pub targets: Vec<HeldOutTarget>,
}

/// Fit on control targets, score on check targets.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ControlCheck {
    /// Control target ids (used in the fit).
    pub control: Vec<String>,
    /// The control-only alignment.
    pub alignment: AlignmentOut,
    /// Errors of the check targets.
    pub check: HeldOut,
}

/// σ̂ = √(SSE / dof): the residual scale corrected for fitted parameters.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SigmaHat {
    /// σ̂ (m).
    pub value: f64,
    /// Sum of squared residuals (m²).
    pub sse: f64,
    /// Degrees of freedom (e.g. 2n − 3 for rigid2d).
    pub dof: usize,
}

/// Bias, sample std and RMSE of one axis.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct AxisStats {
    /// Mean residual (aligned − survey).
    pub bias: f64,
    /// Sample standard deviation (n − 1).
    pub std: f64,
    /// Root mean square residual.
    pub rmse: f64,
}

/// ASPRS Positional Accuracy Standards (Ed. 2, 2023) figures and NSSDA lines.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Asprs {
    /// Checkpoints used.
    pub n_checkpoints: usize,
    /// True when the checkpoints were not used to fit the alignment.
    pub independent: bool,
    /// x axis.
    pub x: AxisStats,
    /// y axis.
    pub y: AxisStats,
    /// z axis, when heights were fitted.
    pub z: Option<AxisStats>,
    /// RMSE_x (m).
    pub rmse_x: f64,
    /// RMSE_y (m).
    pub rmse_y: f64,
    /// RMSE_H = √(RMSE_x² + RMSE_y²), survey error folded in when given (m).
    pub rmse_h: f64,
    /// RMSE_V, survey error folded in when given (m).
    pub rmse_v: Option<f64>,
    /// RMSE_3D = √(RMSE_H² + RMSE_V²) (m).
    pub rmse_3d: Option<f64>,
    /// RMSE_H of the data alone (m).
    pub rmse_h_measured: f64,
    /// RMSE_V of the data alone (m).
    pub rmse_v_measured: Option<f64>,
    /// Survey horizontal σ folded in (m).
    pub survey_sigma_h: Option<f64>,
    /// Survey vertical σ folded in (m).
    pub survey_sigma_v: Option<f64>,
    /// 1.7308 · RMSE_H (m).
    pub nssda_horizontal_95: f64,
    /// 1.96 · RMSE_V (m).
    pub nssda_vertical_95: Option<f64>,
    /// The NSSDA statements, ready to paste into a report.
    pub nssda_lines: Vec<String>,
    /// Caveats (too few checkpoints, not independent).
    pub warnings: Vec<String>,
}

/// Ids present on one side only.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Unmatched {
    /// In the survey, not in the estimates.
    pub survey_only: Vec<String>,
    /// In the estimates, not in the survey.
    pub estimates_only: Vec<String>,
}

/// Everything one evaluation produced: the content of `result.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunResult {
    /// Always [`SCHEMA`].
    pub schema: String,
    /// Version of mapgauge that wrote the file.
    pub mapgauge_version: String,
    /// Error dimension.
    #[serde(default)]
    pub dim: Dim,
    /// Frame of the survey coordinates.
    #[serde(default = "local")]
    pub survey_frame: SurveyFrame,
    /// ENU origin for lat/lon surveys.
    #[serde(default)]
    pub origin: Option<Geodetic>,
    /// The map → survey alignment.
    pub alignment: AlignmentOut,
    /// Every survey target, located or not.
    pub targets: Vec<TargetOut>,
    /// Absolute error statistics.
    pub absolute: AbsoluteStats,
    /// Relative error statistics.
    pub relative: RelativeStats,
    /// Leave-one-out absolute errors (≥ 3 targets).
    #[serde(default)]
    pub leave_one_out: Option<HeldOut>,
    /// Control/check split, when the survey has roles.
    #[serde(default)]
    pub control_check: Option<ControlCheck>,
    /// σ̂ of the fit.
    #[serde(default)]
    pub sigma_hat: Option<SigmaHat>,
    /// Survey-standard statistics.
    pub asprs: Asprs,
    /// Ids on one side only.
    #[serde(default)]
    pub unmatched: Unmatched,
    /// Caveats for the reader.
    #[serde(default)]
    pub warnings: Vec<String>,
    /// Provenance and per-target details of a map evaluation (`eval` only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub eval: Option<crate::eval::EvalInfo>,
}

fn local() -> SurveyFrame {
    SurveyFrame::Local
}

impl RunResult {
    /// Reads a result file, checking its schema.
    pub fn from_json_file(path: &Path) -> Result<RunResult> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        let r: RunResult = serde_json::from_str(&text).map_err(|e| {
            Error::table(path, e.line() as u64, format!("not a mapgauge result: {e}"))
        })?;
        if r.schema != SCHEMA {
            return Err(Error::format(
                path,
                format!("schema `{}`, expected `{SCHEMA}`", r.schema),
            ));
        }
        Ok(r)
    }
    /// Pretty JSON, ending in a newline.
    pub fn to_json(&self) -> String {
        // Serialising plain data cannot fail; NaN becomes null.
        let mut s = serde_json::to_string_pretty(self).unwrap_or_default();
        s.push('\n');
        s
    }
}

/// Output flavours of the tables.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TableFormat {
    /// Aligned plain text for the terminal.
    Text,
    /// GitHub Markdown.
    Markdown,
    /// LaTeX with booktabs.
    Latex,
    /// CSV.
    Csv,
    /// An HTML `<table>` (a fragment; `mapgauge table` wraps it in a page).
    Html,
}

/// Parses a `--format` value: `None` means JSON, otherwise a table flavour.
pub fn parse_output_format(s: &str) -> Result<Option<TableFormat>> {
    match s.to_ascii_lowercase().as_str() {
        "table" | "text" => Ok(Some(TableFormat::Text)),
        "markdown" | "md" => Ok(Some(TableFormat::Markdown)),
        "latex" | "tex" => Ok(Some(TableFormat::Latex)),
        "csv" => Ok(Some(TableFormat::Csv)),
        "html" => Ok(Some(TableFormat::Html)),
        "json" => Ok(None),
        other => Err(Error::Param(format!(
            "unknown --format `{other}` (table, json, csv, markdown, latex, html)"
        ))),
    }
}

/// A header and rows of cells, rendered in any [`TableFormat`].
#[derive(Debug, Clone, Default)]
pub struct Grid {
    /// Column names.
    pub header: Vec<String>,
    /// Rows of cells, each as long as the header.
    pub rows: Vec<Vec<String>>,
    /// Columns shown bold in Markdown/LaTeX (the paper's E and σ).
    pub bold: Vec<usize>,
}

fn csv_cell(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

fn latex_escape(s: &str) -> String {
    let mut o = String::new();
    for c in s.chars() {
        match c {
            '&' | '%' | '$' | '#' | '_' | '{' | '}' => {
                o.push('\\');
                o.push(c);
            }
            'σ' => o.push_str("$\\sigma$"),
            '→' => o.push_str("$\\to$"),
            '\\' => o.push_str("\\textbackslash{}"),
            '<' => o.push_str("\\textless{}"),
            '>' => o.push_str("\\textgreater{}"),
            '^' => o.push_str("\\^{}"),
            '~' => o.push_str("\\~{}"),
            _ => o.push(c),
        }
    }
    o
}

impl Grid {
    /// Renders the grid.
    pub fn render(&self, fmt: TableFormat) -> String {
        let mut o = String::new();
        match fmt {
            TableFormat::Text => {
                let ncol = self.header.len();
                let mut w = vec![0; ncol];
                for r in std::iter::once(&self.header).chain(&self.rows) {
                    for (i, c) in r.iter().enumerate().take(ncol) {
                        w[i] = w[i].max(c.chars().count());
                    }
                }
                for r in std::iter::once(&self.header).chain(&self.rows) {
                    let cells: Vec<String> = r
                        .iter()
                        .enumerate()
                        .map(|(i, c)| {
                            if i == 0 {
                                format!("{c:<width$}", width = w[i])
                            } else {
                                format!("{c:>width$}", width = w[i])
                            }
                        })
                        .collect();
                    let _ = writeln!(o, "{}", cells.join("  ").trim_end());
                }
            }
            TableFormat::Markdown => {
                let h: Vec<String> = self.header.iter().map(|c| c.replace('|', "\\|")).collect();
                let _ = writeln!(o, "| {} |", h.join(" | "));
                let seps: Vec<&str> = (0..self.header.len())
                    .map(|i| if i == 0 { ":--" } else { "--:" })
                    .collect();
                let _ = writeln!(o, "| {} |", seps.join(" | "));
                for r in &self.rows {
                    let cells: Vec<String> = r
                        .iter()
                        .enumerate()
                        .map(|(i, c)| {
                            let c = c.replace('|', "\\|");
                            if self.bold.contains(&i) && !c.is_empty() && c != "–" {
                                format!("**{c}**")
                            } else {
                                c
                            }
                        })
                        .collect();
                    let _ = writeln!(o, "| {} |", cells.join(" | "));
                }
            }
            TableFormat::Latex => {
                let cols: String = (0..self.header.len())
                    .map(|i| if i == 0 { 'l' } else { 'r' })
                    .collect();
                let _ = writeln!(o, "\\begin{{tabular}}{{{cols}}}");
                let _ = writeln!(o, "\\toprule");
                let h: Vec<String> = self.header.iter().map(|c| latex_header(c)).collect();
                let _ = writeln!(o, "{} \\\\", h.join(" & "));
                let _ = writeln!(o, "\\midrule");
                for r in &self.rows {
                    let cells: Vec<String> = r
                        .iter()
                        .enumerate()
                        .map(|(i, c)| {
                            let e = latex_escape(c);
                            if self.bold.contains(&i) && !c.is_empty() && c != "–" {
                                format!("\\textbf{{{e}}}")
                            } else {
                                e
                            }
                        })
                        .collect();
                    let _ = writeln!(o, "{} \\\\", cells.join(" & "));
                }
                let _ = writeln!(o, "\\bottomrule");
                let _ = writeln!(o, "\\end{{tabular}}");
            }
            TableFormat::Csv => {
                for r in std::iter::once(&self.header).chain(&self.rows) {
                    let cells: Vec<String> = r.iter().map(|c| csv_cell(c)).collect();
                    let _ = writeln!(o, "{}", cells.join(","));
                }
            }
            TableFormat::Html => {
                use crate::report::html::escape;
                o.push_str("<table class=\"grid\">\n<thead><tr>");
                for h in &self.header {
                    let _ = write!(o, "<th>{}</th>", escape(h));
                }
                o.push_str("</tr></thead>\n<tbody>\n");
                for r in &self.rows {
                    o.push_str("<tr>");
                    for (i, c) in r.iter().enumerate() {
                        let e = escape(c);
                        // Numbers align right (the stylesheet's default), words left.
                        let num = c.is_empty()
                            || c == "–"
                            || c.chars()
                                .all(|ch| ch.is_ascii_digit() || "+-.eE".contains(ch));
                        let class = if num || i == 0 { "" } else { " class=\"t\"" };
                        if self.bold.contains(&i) && !c.is_empty() && c != "–" {
                            let _ = write!(o, "<td{class}><strong>{e}</strong></td>");
                        } else {
                            let _ = write!(o, "<td{class}>{e}</td>");
                        }
                    }
                    o.push_str("</tr>\n");
                }
                o.push_str("</tbody>\n</table>\n");
            }
        }
        o
    }
}

fn latex_header(c: &str) -> String {
    match c {
        "E_rel" => "$E_{rel}$".into(),
        "σ_rel" => "$\\sigma_{rel}$".into(),
        "E_abs" => "$E_{abs}$".into(),
        "σ_abs" => "$\\sigma_{abs}$".into(),
        _ => latex_escape(c),
    }
}

/// The paper's label for a target: `t3` for id `3`, the id itself otherwise.
pub fn target_label(id: &str) -> String {
    if !id.is_empty() && id.chars().all(|c| c.is_ascii_digit()) {
        format!("t{id}")
    } else {
        id.to_string()
    }
}

fn f4(v: f64) -> String {
    if v.is_finite() {
        format!("{v:.4}")
    } else {
        "–".into()
    }
}

/// Target ids of several runs in one order: each run's survey order, a target
/// first seen in a later run placed right after its predecessor there. One run
/// keeps its survey order; runs with different target sets line up.
pub fn merged_ids(runs: &[(String, &RunResult)]) -> Vec<String> {
    let mut ids: Vec<String> = Vec::new();
    for (_, r) in runs {
        let mut after: Option<usize> = None;
        for t in &r.targets {
            match ids.iter().position(|i| i == &t.id) {
                Some(p) => after = Some(p),
                None => {
                    let at = after.map(|p| p + 1).unwrap_or(0);
                    ids.insert(at, t.id.clone());
                    after = Some(at);
                }
            }
        }
    }
    ids
}

/// A missing cell: blank when the run has no such target (or pair) at all,
/// "–" when it has the target but could not score it (not found, excluded).
fn missing_cell(r: &RunResult, ids: &[&str]) -> String {
    if ids.iter().all(|id| r.targets.iter().any(|t| t.id == *id)) {
        "–".into()
    } else {
        String::new()
    }
}

/// Table I (relative errors) over several runs: E_rel, σ_rel, then every pair
/// "t1 & t2" in target order, columns keyed by id so different target sets
/// line up. A pair the run lacks is blank; one it could not score is "–".
pub fn relative_grid(runs: &[(String, &RunResult)]) -> Grid {
    let ids = merged_ids(runs);
    let mut keys: Vec<(String, String)> = Vec::new();
    for (i, a) in ids.iter().enumerate() {
        for b in &ids[i + 1..] {
            // Pairs no run could score would be columns of dashes: Table II
            // already shows which targets were not found.
            let present = runs.iter().any(|(_, r)| {
                r.relative
                    .pairs
                    .iter()
                    .any(|p| (&p.a == a && &p.b == b) || (&p.a == b && &p.b == a))
            });
            if present {
                keys.push((a.clone(), b.clone()));
            }
        }
    }
    let mut header = vec!["Run".to_string(), "E_rel".into(), "σ_rel".into()];
    header.extend(
        keys.iter()
            .map(|(a, b)| format!("{} & {}", target_label(a), target_label(b))),
    );
    let rows = runs
        .iter()
        .map(|(name, r)| {
            let mut row = vec![name.clone(), f4(r.relative.mean), f4(r.relative.std)];
            for (a, b) in &keys {
                let v = r
                    .relative
                    .pairs
                    .iter()
                    .find(|p| (&p.a == a && &p.b == b) || (&p.a == b && &p.b == a))
                    .map(|p| p.error);
                row.push(v.map(f4).unwrap_or_else(|| missing_cell(r, &[a, b])));
            }
            row
        })
        .collect();
    Grid {
        header,
        rows,
        bold: vec![1, 2],
    }
}

/// Table II (absolute errors) over several runs: E_abs, σ_abs, then each target.
/// A target the run lacks is blank; one it could not locate is "–".
pub fn absolute_grid(runs: &[(String, &RunResult)]) -> Grid {
    let ids = merged_ids(runs);
    let mut header = vec!["Run".to_string(), "E_abs".into(), "σ_abs".into()];
    header.extend(ids.iter().map(|i| target_label(i)));
    let rows = runs
        .iter()
        .map(|(name, r)| {
            let mut row = vec![name.clone(), f4(r.absolute.mean), f4(r.absolute.std)];
            for id in &ids {
                let v = r
                    .targets
                    .iter()
                    .find(|t| &t.id == id)
                    .and_then(|t| t.abs_error);
                row.push(v.map(f4).unwrap_or_else(|| missing_cell(r, &[id])));
            }
            row
        })
        .collect();
    Grid {
        header,
        rows,
        bold: vec![1, 2],
    }
}

/// Per-target detail of one run.
pub fn targets_grid(r: &RunResult) -> Grid {
    let header = [
        "id",
        "status",
        "reason",
        "survey_x",
        "survey_y",
        "survey_z",
        "map_x",
        "map_y",
        "map_z",
        "aligned_x",
        "aligned_y",
        "aligned_z",
        "abs_error",
        "loo_error",
    ];
    let o = |v: Option<f64>| v.map(|v| format!("{v:.6}")).unwrap_or_default();
    let rows = r
        .targets
        .iter()
        .map(|t| {
            let mut row = vec![
                t.id.clone(),
                t.status.clone(),
                t.reason.clone().unwrap_or_default(),
            ];
            for p in [Some(t.survey), t.map, t.aligned] {
                row.push(o(p.map(|p| p.x)));
                row.push(o(p.map(|p| p.y)));
                row.push(o(p.and_then(|p| p.z)));
            }
            row.push(o(t.abs_error));
            row.push(o(t.loo_error));
            row
        })
        .collect();
    Grid {
        header: header.iter().map(|s| s.to_string()).collect(),
        rows,
        bold: vec![],
    }
}

/// Per-pair detail of one run.
pub fn pairs_grid(r: &RunResult) -> Grid {
    let header = [
        "a",
        "b",
        "survey_distance",
        "map_distance",
        "error",
        "error_per_100m",
    ];
    let rows = r
        .relative
        .pairs
        .iter()
        .map(|p| {
            vec![
                p.a.clone(),
                p.b.clone(),
                format!("{:.6}", p.survey_distance),
                format!("{:.6}", p.map_distance),
                format!("{:.6}", p.error),
                p.error_per_100m
                    .map(|v| format!("{v:.6}"))
                    .unwrap_or_default(),
            ]
        })
        .collect();
    Grid {
        header: header.iter().map(|s| s.to_string()).collect(),
        rows,
        bold: vec![],
    }
}

/// The statistics beyond the paper (alignment, RMSE, honest errors, ASPRS), one
/// `name, value, unit` row each.
pub fn extra_grid(r: &RunResult) -> Grid {
    let mut rows: Vec<Vec<String>> = Vec::new();
    let mut add = |k: &str, v: String, u: &str| rows.push(vec![k.to_string(), v, u.to_string()]);
    let a = &r.alignment;
    add("alignment", format!("{} (n={})", a.method, a.n_used), "");
    add(
        "rotation (map→survey)",
        format!("{:.4}", a.rotation_deg),
        "deg",
    );
    add(
        "translation",
        format!(
            "({:.4}, {:.4}, {:.4})",
            a.translation[0], a.translation[1], a.translation[2]
        ),
        "m",
    );
    if a.method.starts_with("similarity") {
        add("scale", format!("{:.1}", a.scale_ppm), "ppm");
    }
    add("abs RMSE", f4(r.absolute.rmse), "m");
    add("abs median", f4(r.absolute.median), "m");
    add("abs max", f4(r.absolute.max), "m");
    add("rel max", f4(r.relative.max), "m");
    if let Some(l) = &r.leave_one_out {
        add("leave-one-out mean", f4(l.summary.mean), "m");
        add("leave-one-out RMSE", f4(l.summary.rmse), "m");
        add("leave-one-out max", f4(l.summary.max), "m");
    }
    if let Some(s) = &r.sigma_hat {
        add("sigma_hat", f4(s.value), &format!("m (dof {})", s.dof));
    }
    if let Some(c) = &r.control_check {
        add(
            "check mean (fit on control)",
            f4(c.check.summary.mean),
            &format!("m (n={})", c.check.summary.n),
        );
        add("check RMSE (fit on control)", f4(c.check.summary.rmse), "m");
    }
    let s = &r.asprs;
    add(
        "ASPRS checkpoints",
        format!(
            "{}{}",
            s.n_checkpoints,
            if s.independent { "" } else { " (fit targets)" }
        ),
        "",
    );
    add(
        "bias x / y",
        format!("{:.4} / {:.4}", s.x.bias, s.y.bias),
        "m",
    );
    add(
        "std x / y (sample)",
        format!("{:.4} / {:.4}", s.x.std, s.y.std),
        "m",
    );
    add(
        "RMSE_x / RMSE_y",
        format!("{:.4} / {:.4}", s.rmse_x, s.rmse_y),
        "m",
    );
    add("RMSE_H", f4(s.rmse_h), "m");
    if let Some(z) = &s.z {
        add(
            "bias z / std z",
            format!("{:.4} / {:.4}", z.bias, z.std),
            "m",
        );
    }
    if let Some(v) = s.rmse_v {
        add("RMSE_V", f4(v), "m");
    }
    if let Some(v) = s.rmse_3d {
        add("RMSE_3D", f4(v), "m");
    }
    Grid {
        header: vec!["statistic".into(), "value".into(), "unit".into()],
        rows,
        bold: vec![],
    }
}

fn with_caption(o: &mut String, fmt: TableFormat, caption: &str, g: &Grid) {
    match fmt {
        TableFormat::Text => {
            let _ = writeln!(o, "{caption}");
        }
        TableFormat::Markdown => {
            let _ = writeln!(o, "**{caption}**\n");
        }
        TableFormat::Latex => {
            let _ = writeln!(o, "% {caption}");
        }
        TableFormat::Html => {
            let _ = writeln!(o, "<h3>{}</h3>", crate::report::html::escape(caption));
        }
        TableFormat::Csv => {}
    }
    o.push_str(&g.render(fmt));
    o.push('\n');
}

/// A complete human-readable report of one run in Text, Markdown or LaTeX.
pub fn render_report(r: &RunResult, fmt: TableFormat) -> String {
    if fmt == TableFormat::Csv {
        return render_csv(r);
    }
    let runs = [("result".to_string(), r)];
    let dim = match r.dim {
        Dim::D2 => "2D",
        Dim::D3 => "3D",
    };
    let mut o = String::new();
    with_caption(
        &mut o,
        fmt,
        &format!("Relative error (m, {dim}) — paper Table I layout"),
        &relative_grid(&runs),
    );
    with_caption(
        &mut o,
        fmt,
        &format!("Absolute error (m, {dim}) — paper Table II layout"),
        &absolute_grid(&runs),
    );
    with_caption(&mut o, fmt, "Statistics", &extra_grid(r));
    if fmt == TableFormat::Text {
        with_caption(&mut o, fmt, "Pairs", &pairs_grid(r));
    }
    let mut notes: Vec<String> = r.asprs.nssda_lines.clone();
    notes.extend(r.asprs.warnings.iter().map(|w| format!("warning: {w}")));
    notes.extend(r.warnings.iter().map(|w| format!("warning: {w}")));
    for t in r.targets.iter().filter(|t| t.status != "ok") {
        notes.push(format!(
            "target {} {}: {}",
            t.id,
            t.status,
            t.reason.as_deref().unwrap_or("")
        ));
    }
    for n in notes {
        let _ = match fmt {
            TableFormat::Latex => writeln!(o, "% {n}"),
            TableFormat::Markdown => writeln!(o, "- {n}"),
            TableFormat::Html => writeln!(o, "<p>{}</p>", crate::report::html::escape(&n)),
            _ => writeln!(o, "{n}"),
        };
    }
    o
}

/// One machine-readable CSV of one run: `table,item,value` rows (absolute,
/// relative, alignment and ASPRS figures).
pub fn render_csv(r: &RunResult) -> String {
    let mut g = Grid {
        header: vec!["table".into(), "item".into(), "value".into()],
        ..Default::default()
    };
    let mut add = |t: &str, k: &str, v: f64| g.rows.push(vec![t.into(), k.into(), format!("{v}")]);
    add("absolute", "mean", r.absolute.mean);
    add("absolute", "std", r.absolute.std);
    add("absolute", "rmse", r.absolute.rmse);
    add("absolute", "median", r.absolute.median);
    add("absolute", "max", r.absolute.max);
    for t in &r.targets {
        if let Some(e) = t.abs_error {
            add("absolute", &t.id, e);
        }
    }
    add("relative", "mean", r.relative.mean);
    add("relative", "std", r.relative.std);
    for p in &r.relative.pairs {
        add("relative", &format!("{}&{}", p.a, p.b), p.error);
    }
    add("alignment", "rotation_deg", r.alignment.rotation_deg);
    add("alignment", "tx", r.alignment.translation[0]);
    add("alignment", "ty", r.alignment.translation[1]);
    add("alignment", "tz", r.alignment.translation[2]);
    add("alignment", "scale", r.alignment.scale);
    if let Some(l) = &r.leave_one_out {
        add("leave_one_out", "mean", l.summary.mean);
        add("leave_one_out", "rmse", l.summary.rmse);
    }
    if let Some(s) = &r.sigma_hat {
        add("sigma_hat", "value", s.value);
    }
    add("asprs", "rmse_x", r.asprs.rmse_x);
    add("asprs", "rmse_y", r.asprs.rmse_y);
    add("asprs", "rmse_h", r.asprs.rmse_h);
    if let Some(v) = r.asprs.rmse_v {
        add("asprs", "rmse_v", v);
    }
    if let Some(v) = r.asprs.rmse_3d {
        add("asprs", "rmse_3d", v);
    }
    add("asprs", "nssda_horizontal_95", r.asprs.nssda_horizontal_95);
    g.render(TableFormat::Csv)
}

/// Writes `result.json`, `targets.csv` and `pairs.csv` into `dir` (created if
/// needed), each atomically (temporary file + rename).
pub fn write_outputs(r: &RunResult, dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    write_atomic(&dir.join("result.json"), r.to_json().as_bytes())?;
    write_atomic(
        &dir.join("targets.csv"),
        targets_grid(r).render(TableFormat::Csv).as_bytes(),
    )?;
    write_atomic(
        &dir.join("pairs.csv"),
        pairs_grid(r).render(TableFormat::Csv).as_bytes(),
    )?;
    Ok(())
}

/// Writes `bytes` to `path` so readers never see a half-written file.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    let tmp = path.with_file_name(format!(".{name}.tmp{}", std::process::id()));
    std::fs::write(&tmp, bytes).map_err(|e| {
        // A disk that filled up must not be left holding a partial temporary.
        let _ = std::fs::remove_file(&tmp);
        Error::io(path, e)
    })?;
    std::fs::rename(&tmp, path).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        Error::io(path, e)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_escapes_per_format() {
        let g = Grid {
            header: vec!["id".into(), "E_rel".into()],
            rows: vec![vec!["a|b,c_\"d\"".into(), "0.1".into()]],
            bold: vec![1],
        };
        let md = g.render(TableFormat::Markdown);
        assert!(md.contains("a\\|b") && md.contains("**0.1**"), "{md}");
        let tex = g.render(TableFormat::Latex);
        assert!(
            tex.contains("$E_{rel}$") && tex.contains("c\\_") && tex.contains("\\textbf{0.1}"),
            "{tex}"
        );
        assert!(tex.contains("\\toprule") && tex.contains("\\bottomrule"));
        let csv = g.render(TableFormat::Csv);
        assert_eq!(csv.lines().nth(1), Some("\"a|b,c_\"\"d\"\"\",0.1"), "{csv}");
        let txt = g.render(TableFormat::Text);
        assert_eq!(txt.lines().count(), 2);
        assert_eq!(target_label("3"), "t3");
        let html = g.render(TableFormat::Html);
        assert!(
            html.contains("<td>a|b,c_&quot;d&quot;</td><td><strong>0.1</strong></td>"),
            "{html}"
        );
        assert_eq!(target_label("T3"), "T3");
    }

    fn run(ids: &[&str], found: &[&str]) -> RunResult {
        let mut r: RunResult = serde_json::from_str(&format!(
            r#"{{"schema":"{SCHEMA}","mapgauge_version":"0","alignment":{{"method":"rigid2d","rotation_deg":0,"translation":[0,0,0],"scale":1}},
            "targets":[],"absolute":{{"n":0,"mean":0.01,"std":0.0,"rmse":0,"median":0,"max":0}},
            "relative":{{"n":0,"mean":0.02,"std":0,"pairs":[]}},
            "asprs":{{"n_checkpoints":0,"independent":false,"x":{{"bias":0,"std":0,"rmse":0}},"y":{{"bias":0,"std":0,"rmse":0}},"z":null,
            "rmse_x":0,"rmse_y":0,"rmse_h":0,"rmse_v":null,"rmse_3d":null,"rmse_h_measured":0,"rmse_v_measured":null,
            "survey_sigma_h":null,"survey_sigma_v":null,"nssda_horizontal_95":0,"nssda_vertical_95":null,"nssda_lines":[],"warnings":[]}}}}"#
        ))
        .unwrap();
        for id in ids {
            let ok = found.contains(id);
            r.targets.push(TargetOut {
                id: id.to_string(),
                status: if ok { "ok" } else { "not_found" }.into(),
                reason: None,
                survey: Xyz {
                    x: 0.0,
                    y: 0.0,
                    z: None,
                },
                map: None,
                aligned: None,
                abs_error: ok.then_some(0.005),
                loo_error: None,
                role: None,
            });
        }
        for (i, a) in found.iter().enumerate() {
            for b in &found[i + 1..] {
                r.relative.pairs.push(Pair {
                    a: a.to_string(),
                    b: b.to_string(),
                    survey_distance: 1.0,
                    map_distance: 1.0,
                    error: 0.001,
                    error_per_100m: None,
                });
            }
        }
        r
    }

    #[test]
    fn runs_with_different_targets_line_up() {
        let a = run(&["1", "2", "4"], &["1", "2", "4"]);
        let b = run(&["1", "2", "3", "4"], &["1", "3", "4"]);
        let runs = [("A".to_string(), &a), ("B".to_string(), &b)];
        assert_eq!(merged_ids(&runs), vec!["1", "2", "3", "4"]);
        let g = absolute_grid(&runs);
        assert_eq!(
            g.header,
            vec!["Run", "E_abs", "σ_abs", "t1", "t2", "t3", "t4"]
        );
        // A lacks t3 entirely (blank); B has t2 but did not find it ("–").
        assert_eq!(g.rows[0][5], "");
        assert_eq!(g.rows[1][4], "–");
        assert_eq!(g.rows[1][5], "0.0050");
        let r = relative_grid(&runs);
        assert_eq!(
            r.header[3..],
            ["t1 & t2", "t1 & t3", "t1 & t4", "t2 & t4", "t3 & t4"]
        );
        assert_eq!(r.rows[0][4], "", "A has no t3");
        assert_eq!(r.rows[1][3], "–", "B has t2 but no pair with it");
        assert_eq!(r.header.len(), 8, "t2 & t3 was scored by no run");
        let tex = r.render(TableFormat::Latex);
        assert!(tex.contains("\\textbf{0.0200}") && tex.contains("\\toprule"));
    }
}
