//! One run's whole report as text, Markdown, LaTeX, HTML or CSV, and the
//! table files `eval` and `errors` write beside `result.json`.

use super::tables::{absolute_grid, extra_grid, pairs_grid, relative_grid, targets_grid};
use super::{Grid, TableFormat};
use crate::record::{ResultFile, write_atomic};
use crate::{Error, Result};
use std::fmt::Write as _;
use std::path::Path;

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
            let _ = writeln!(o, "<h3>{}</h3>", super::escape(caption));
        }
        TableFormat::Csv => {}
    }
    o.push_str(&g.render(fmt));
    o.push('\n');
}

/// A complete human-readable report of one run: Markdown, LaTeX, HTML and
/// CSV in the paper's layout; text is [`super::render_text`] (not verbose).
pub fn render_report(r: &ResultFile, fmt: TableFormat) -> String {
    if fmt == TableFormat::Csv {
        return render_csv(r);
    }
    if fmt == TableFormat::Text {
        return super::render_text(r, false);
    }
    let runs = [("this run".to_string(), r)];
    let dim = r.dim.label();
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
    notes.extend(r.caveats().map(|w| format!("warning: {w}")));
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
            TableFormat::Html => writeln!(o, "<p>{}</p>", super::escape(&n)),
            _ => writeln!(o, "{n}"),
        };
    }
    o
}

/// One machine-readable CSV of one run: `table,item,value` rows (absolute,
/// relative, alignment and ASPRS figures).
pub(crate) fn render_csv(r: &ResultFile) -> String {
    let mut g = Grid {
        header: vec!["table".into(), "item".into(), "value".into()],
        ..Default::default()
    };
    // A value, or an empty cell for an item that has none (a target not scored).
    let mut add = |t: &str, k: &str, v: Option<f64>| {
        g.rows.push(vec![
            t.into(),
            k.into(),
            v.map(|v| format!("{v}")).unwrap_or_default(),
        ])
    };
    add("absolute", "mean", Some(r.absolute.mean));
    add("absolute", "std", Some(r.absolute.std));
    add("absolute", "rmse", Some(r.absolute.rmse));
    add("absolute", "median", Some(r.absolute.median));
    add("absolute", "max", Some(r.absolute.max));
    for t in &r.targets {
        // Not scored: listed with an empty value, not left out.
        add("absolute", &t.id, t.abs_error);
    }
    add("relative", "mean", Some(r.relative.mean));
    add("relative", "std", Some(r.relative.std));
    for p in &r.relative.pairs {
        add("relative", &format!("{}&{}", p.a, p.b), Some(p.error));
    }
    add("alignment", "rotation_deg", Some(r.alignment.rotation_deg));
    add("alignment", "tx", Some(r.alignment.translation[0]));
    add("alignment", "ty", Some(r.alignment.translation[1]));
    add("alignment", "tz", Some(r.alignment.translation[2]));
    add("alignment", "scale", Some(r.alignment.scale));
    if let Some(l) = &r.leave_one_out {
        add("leave_one_out", "mean", Some(l.summary.mean));
        add("leave_one_out", "rmse", Some(l.summary.rmse));
    }
    if let Some(s) = &r.sigma_hat {
        add("sigma_hat", "value", Some(s.value));
    }
    add("asprs", "rmse_x", Some(r.asprs.rmse_x));
    add("asprs", "rmse_y", Some(r.asprs.rmse_y));
    add("asprs", "rmse_h", Some(r.asprs.rmse_h));
    if let Some(v) = r.asprs.rmse_v {
        add("asprs", "rmse_v", Some(v));
    }
    if let Some(v) = r.asprs.rmse_3d {
        add("asprs", "rmse_3d", Some(v));
    }
    add(
        "asprs",
        "nssda_horizontal_95",
        Some(r.asprs.nssda_horizontal_95),
    );
    g.render(TableFormat::Csv)
}

/// The files [`write_outputs`] writes into a run's directory.
pub const OUTPUT_FILES: [&str; 3] = ["result.json", "targets.csv", "pairs.csv"];

/// Refuses (before any work) when writing [`OUTPUT_FILES`] into `dir` would
/// overwrite one of `inputs`.
pub fn refuse_overwriting_inputs(dir: &Path, inputs: &[&Path]) -> Result<()> {
    for name in OUTPUT_FILES {
        crate::record::refuse_overwrite(&dir.join(name), inputs)?;
    }
    Ok(())
}

/// Writes [`OUTPUT_FILES`] (`result.json`, `targets.csv`, `pairs.csv`) into
/// `dir` (created if needed), each atomically (temporary file + rename).
pub fn write_outputs(r: &ResultFile, dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let [json, targets, pairs] = OUTPUT_FILES;
    write_atomic(&dir.join(json), r.to_json().as_bytes())?;
    write_atomic(
        &dir.join(targets),
        targets_grid(r).render(TableFormat::Csv).as_bytes(),
    )?;
    write_atomic(
        &dir.join(pairs),
        pairs_grid(r).render(TableFormat::Csv).as_bytes(),
    )?;
    Ok(())
}
