//! Renderings of result files: grids of cells (the paper's Tables I and II,
//! per-target and per-pair tables, statistics) and their encoders to plain
//! text, Markdown, LaTeX, CSV, HTML and JSON.

mod gates;
mod html;
mod numbers;
mod page;
mod scores;
mod summary;
mod tables;
mod text;

pub(crate) use gates::{evidence as gate_evidence, headline as gates_headline};
pub use gates::{gate_lines, junit_error, junit_xml};
pub use html::{CSS, page};
pub use numbers::mm;
pub(crate) use numbers::{fixed, signed_ppm};
pub use page::{Which, tables_page};
pub use scores::{score_lines, scores_grid, stored_scores};
pub use summary::{OUTPUT_FILES, refuse_overwriting_inputs, render_report, write_outputs};
pub use tables::{absolute_grid, relative_grid, survey_mismatches, surveyed_elsewhere};
pub(crate) use tables::{extra_grid, target_label};
pub use text::render_text;
pub(crate) use text::{PAPER_TABLES_UP_TO, iso_line};

use crate::{Error, Result};
use std::fmt::Write as _;

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

/// What a command prints on stdout: a table flavour or the JSON result.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OutputFormat {
    /// Tables in this flavour.
    Table(TableFormat),
    /// JSON.
    Json,
}

impl std::str::FromStr for OutputFormat {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        Ok(match s.to_ascii_lowercase().as_str() {
            "table" | "text" => OutputFormat::Table(TableFormat::Text),
            "markdown" | "md" => OutputFormat::Table(TableFormat::Markdown),
            "latex" | "tex" => OutputFormat::Table(TableFormat::Latex),
            "csv" => OutputFormat::Table(TableFormat::Csv),
            "html" => OutputFormat::Table(TableFormat::Html),
            "json" => OutputFormat::Json,
            other => {
                return Err(Error::Param(format!(
                    "unknown --format `{other}` (table, json, csv, markdown, latex, html)"
                )));
            }
        })
    }
}

/// Escapes text for HTML/XML content and attribute values.
pub fn escape(s: &str) -> String {
    let mut o = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => o.push_str("&amp;"),
            '<' => o.push_str("&lt;"),
            '>' => o.push_str("&gt;"),
            '"' => o.push_str("&quot;"),
            '\'' => o.push_str("&#39;"),
            _ => o.push(c),
        }
    }
    o
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
    /// The numbers behind the cells, where a cell shows one (same shape as
    /// `rows`, or empty): what JSON writes, so nothing is parsed back out of
    /// rounded text.
    pub values: Vec<Vec<Option<f64>>>,
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
            TableFormat::Text => self.text(&mut o),
            TableFormat::Markdown => self.markdown(&mut o),
            TableFormat::Latex => self.latex(&mut o),
            TableFormat::Csv => self.csv(&mut o),
            TableFormat::Html => self.html(&mut o),
        }
        o
    }

    /// Aligned columns for the terminal: the first column left, the others
    /// right, each as wide as its widest cell.
    fn text(&self, o: &mut String) {
        let ncol = self.header.len();
        let mut w = vec![0; ncol];
        for r in std::iter::once(&self.header).chain(&self.rows) {
            for (i, c) in r.iter().enumerate().take(ncol) {
                w[i] = w[i].max(c.chars().count());
            }
        }
        // A last column of sentences (a not-found reason) is left
        // unpadded: right-aligned, one long reason pushed every row
        // past the terminal's width. Short cells (units) stay aligned.
        let last_words = ncol > 1 && w[ncol - 1] > 40;
        for r in std::iter::once(&self.header).chain(&self.rows) {
            let cells: Vec<String> = r
                .iter()
                .enumerate()
                .map(|(i, c)| {
                    if last_words && i + 1 == ncol {
                        c.clone()
                    } else if i == 0 {
                        format!("{c:<width$}", width = w[i])
                    } else {
                        format!("{c:>width$}", width = w[i])
                    }
                })
                .collect();
            let _ = writeln!(o, "{}", cells.join("  ").trim_end());
        }
    }

    /// A GitHub Markdown table: `|` escaped in cells, the bold columns in `**`.
    fn markdown(&self, o: &mut String) {
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

    /// A booktabs `tabular`: the paper's headers in math mode, the bold
    /// columns in `\textbf`.
    fn latex(&self, o: &mut String) {
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

    /// CSV rows, the header first, cells quoted only where they must be.
    fn csv(&self, o: &mut String) {
        for r in std::iter::once(&self.header).chain(&self.rows) {
            let cells: Vec<String> = r.iter().map(|c| csv_cell(c)).collect();
            let _ = writeln!(o, "{}", cells.join(","));
        }
    }

    /// An HTML `<table>` fragment, each column classed as numbers or words.
    fn html(&self, o: &mut String) {
        // Alignment by column, not by cell: a column of numbers aligns
        // right (the stylesheet's default) even where one cell is a
        // word; a column of words aligns left, its header too.
        let number = |c: &str| c.starts_with(|ch: char| ch.is_ascii_digit() || "+-(".contains(ch));
        let text_col: Vec<bool> = (0..self.header.len())
            .map(|i| {
                i > 0
                    && self
                        .rows
                        .iter()
                        .any(|r| r.get(i).is_some_and(|c| !c.is_empty() && c != "–"))
                    && !self
                        .rows
                        .iter()
                        .any(|r| r.get(i).is_some_and(|c| number(c)))
            })
            .collect();
        o.push_str("<table class=\"grid\">\n<thead><tr>");
        for (i, h) in self.header.iter().enumerate() {
            let class = if text_col[i] { " class=\"t\"" } else { "" };
            let _ = write!(o, "<th{class}>{}</th>", escape(h));
        }
        o.push_str("</tr></thead>\n<tbody>\n");
        for r in &self.rows {
            o.push_str("<tr>");
            for (i, c) in r.iter().enumerate() {
                let e = escape(c);
                let class = if text_col.get(i).copied().unwrap_or(false) {
                    " class=\"t\""
                } else {
                    ""
                };
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

fn latex_header(c: &str) -> String {
    match c {
        "E_rel" => "$E_{rel}$".into(),
        "σ_rel" => "$\\sigma_{rel}$".into(),
        "E_abs" => "$E_{abs}$".into(),
        "σ_abs" => "$\\sigma_{abs}$".into(),
        _ => latex_escape(c),
    }
}

impl Grid {
    /// The grid as JSON rows keyed by column: numbers as numbers (full
    /// precision, from `values`), blank and "–" cells as null, words as strings.
    pub fn to_json(&self) -> serde_json::Value {
        let rows = self
            .rows
            .iter()
            .enumerate()
            .map(|(r, row)| {
                let mut m = serde_json::Map::new();
                for (c, (h, cell)) in self.header.iter().zip(row).enumerate() {
                    let number = self.values.get(r).and_then(|v| v.get(c)).copied().flatten();
                    let v = match number {
                        Some(x) if x.is_finite() => serde_json::json!(x),
                        _ if cell.is_empty() || cell == "–" => serde_json::Value::Null,
                        _ => serde_json::Value::String(cell.clone()),
                    };
                    m.insert(h.clone(), v);
                }
                serde_json::Value::Object(m)
            })
            .collect();
        serde_json::Value::Array(rows)
    }
}
