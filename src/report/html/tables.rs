//! The report's tables: the paper's Tables I and II (or, past a few
//! targets, the same numbers in a shape that fits), the statistics and the
//! per-target errors.

use super::*;

// Up to this many targets the report shows the paper's one-row Tables I and
// II (as the terminal does); beyond, a pair matrix and a column.
use crate::render::PAPER_TABLES_UP_TO;

/// Millimetres with one decimal for a table cell, "–" when absent.
fn mm_cell(v: Option<f64>) -> String {
    v.map(crate::render::mm).unwrap_or_else(|| "–".into())
}

/// Every pair's relative error (mm) as an upper-triangular matrix: row `a`,
/// column `b`; n − 1 columns instead of the n(n−1)/2 of Table I.
fn pair_matrix(r: &crate::record::ResultFile) -> Grid {
    let ids: Vec<&str> = r.targets.iter().map(|t| t.id.as_str()).collect();
    let mut g = Grid {
        header: std::iter::once(String::new())
            .chain(ids[1..].iter().map(|i| target_label(i)))
            .collect(),
        ..Default::default()
    };
    for (i, a) in ids[..ids.len().saturating_sub(1)].iter().enumerate() {
        let mut row = vec![target_label(a)];
        for (j, b) in ids[1..].iter().enumerate() {
            if j < i {
                row.push(String::new());
                continue;
            }
            let e = r
                .relative
                .pairs
                .iter()
                .find(|p| (p.a == *a && p.b == *b) || (p.a == *b && p.b == *a))
                .map(|p| p.error);
            row.push(mm_cell(e));
        }
        g.rows.push(row);
    }
    g
}

/// Table II turned on its side: E_abs, σ_abs, then one row per target (mm).
fn absolute_column(r: &crate::record::ResultFile) -> Grid {
    let mut g = Grid {
        header: vec![String::new(), "this run".into()],
        bold: vec![],
        ..Default::default()
    };
    g.rows
        .push(vec!["E_abs".into(), mm_cell(Some(r.absolute.mean))]);
    g.rows
        .push(vec!["σ_abs".into(), mm_cell(Some(r.absolute.std))]);
    for t in &r.targets {
        g.rows.push(vec![target_label(&t.id), mm_cell(t.abs_error)]);
    }
    g
}

/// The per-target table of the report: errors and uncertainties in mm, the
/// reason wrapped; the coordinates stay in targets.csv (17 columns of metres
/// to six decimals do not fit a page).
fn targets_mm(r: &crate::record::ResultFile) -> Grid {
    let mut g = Grid {
        header: [
            "id",
            "status",
            "error",
            "leave-one-out",
            "σx, σy, σz",
            "aligned − survey",
            "reason",
        ]
        .map(String::from)
        .to_vec(),
        ..Default::default()
    };
    let z_fitted = r
        .alignment
        .method
        .parse::<crate::align::AlignMethod>()
        .is_ok_and(|m| m.uses_z());
    for t in &r.targets {
        let sigma = t.map_covariance.map(|c| {
            (0..3)
                .map(|i| crate::render::mm(c[i][i].max(0.0).sqrt()))
                .collect::<Vec<_>>()
                .join(", ")
        });
        let d = t.aligned.filter(|_| t.abs_error.is_some()).map(|a| {
            let mut v = vec![
                crate::render::mm(a.x - t.survey.x),
                crate::render::mm(a.y - t.survey.y),
            ];
            // Heights only where the alignment fitted them (a 2D fit leaves
            // the map's own height offset in z).
            if let (true, Some(az), Some(sz)) = (z_fitted, a.z, t.survey.z) {
                v.push(crate::render::mm(az - sz));
            }
            format!("({})", v.join(", "))
        });
        g.rows.push(vec![
            t.id.clone(),
            t.status.replace('_', " "),
            mm_cell(t.abs_error),
            mm_cell(t.loo_error),
            sigma.unwrap_or_else(|| "–".into()),
            d.unwrap_or_else(|| "–".into()),
            t.reason.clone().unwrap_or_default(),
        ]);
    }
    g
}
/// The paper's tables (or, past a few targets, the same numbers in a shape
/// that fits), the statistics and the per-target errors.
pub(super) fn tables_section(o: &mut String, rep: &Report, dim: &str) {
    let r = rep.result;
    let runs = [("this run".to_string(), r)];
    o.push_str("<section id=\"tables\"><h2>Tables</h2>");
    if r.targets.len() <= PAPER_TABLES_UP_TO {
        let _ = write!(
            o,
            "<h3>Relative error (m, {dim}) — the paper's Table I</h3><div class=\"scroll\">{}</div>",
            relative_grid(&runs).render(TableFormat::Html)
        );
        let _ = write!(
            o,
            "<h3>Absolute error (m, {dim}) — the paper's Table II</h3><div class=\"scroll\">{}</div>",
            absolute_grid(&runs).render(TableFormat::Html)
        );
    } else {
        // The paper's one-row tables have n(n−1)/2 and n columns: past a few
        // targets they run off the page. The same numbers, in a shape that fits.
        let _ = write!(
            o,
            "<h3>Relative error of every pair (mm, {dim})</h3><p class=\"facts\">E_rel {} · σ_rel {} over {} pairs. The paper's Table I layout: <code>mapgauge table --format markdown|latex result.json</code>; every pair with its distances: <code>pairs.csv</code>.</p><div class=\"scroll\">{}</div>",
            mm(r.relative.mean),
            mm(r.relative.std),
            r.relative.n,
            pair_matrix(r).render(TableFormat::Html)
        );
        let _ = write!(
            o,
            "<h3>Absolute error (mm, {dim})</h3><p class=\"facts\">The paper's Table II, one row per target: <code>mapgauge table --format markdown|latex result.json</code>.</p><div class=\"scroll\">{}</div>",
            absolute_column(r).render(TableFormat::Html)
        );
    }
    let _ = write!(
        o,
        "<h3>Statistics</h3><div class=\"scroll\">{}</div>",
        extra_grid(r).render(TableFormat::Html)
    );
    let _ = write!(
        o,
        "<h3>Targets</h3><p class=\"facts\">Errors in mm (aligned − survey: x, y{}); every coordinate (survey, map, aligned) is in <code>targets.csv</code> and <code>result.json</code>.</p><div class=\"scroll\">{}</div>",
        if rep.alignment.method.uses_z() {
            ", z"
        } else {
            "; z is not fitted by a 2D alignment"
        },
        targets_mm(r).render(TableFormat::Html)
    );
    let iso = crate::render::iso_line(r);
    if !r.asprs.nssda_lines.is_empty() || iso.is_some() {
        o.push_str("<ul>");
        for l in &r.asprs.nssda_lines {
            // The test's date is the report's (result.json stays reproducible).
            let day = rep.provenance.date_utc.get(..10).unwrap_or_default();
            let _ = write!(
                o,
                "<li>NSSDA (legacy): {}, test dated {}</li>",
                escape(l),
                escape(day)
            );
        }
        if let Some(l) = iso {
            let _ = write!(o, "<li>{}</li>", escape(&l));
        }
        o.push_str("</ul>");
    }
    o.push_str("</section>\n");
}
