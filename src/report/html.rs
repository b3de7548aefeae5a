//! HTML: escaping, the shared stylesheet, standalone pages (`mapgauge table
//! --format html`) and the report page itself. No script and no external
//! resource: the page reads the same offline, printed, or with JavaScript off.

use super::figure::Figure;
use super::plots::{fmt_len, survey_in_map};
use super::{Report, svg};
use crate::accuracy::Dim;
use crate::render::{Grid, TableFormat, absolute_grid, extra_grid, relative_grid, target_label};
use std::fmt::Write as _;

pub use crate::render::escape;

/// The stylesheet shared by every page mapgauge writes.
pub const CSS: &str = "
:root{--ink:#222;--muted:#666;--line:#ddd;--bg:#f6f7f9;--card:#fff;--accent:#1f77b4;--bad:#8e44ad}
*{box-sizing:border-box}
body{margin:0;background:var(--bg);color:var(--ink);font:15px/1.45 'DejaVu Sans',Verdana,Arial,sans-serif}
main{max-width:1000px;margin:0 auto;padding:24px 20px 48px}
h1{font-size:26px;margin:0 0 4px}
h2{font-size:19px;margin:32px 0 10px;padding-bottom:4px;border-bottom:2px solid var(--line)}
h3{font-size:16px;margin:0 0 6px}
p.sub{color:var(--muted);margin:0 0 8px;overflow-wrap:anywhere}
.cards{display:flex;flex-wrap:wrap;gap:10px}
.card{background:var(--card);border:1px solid var(--line);border-radius:8px;padding:10px 14px;min-width:150px;flex:1}
.card .k{color:var(--muted);font-size:12px;text-transform:uppercase;letter-spacing:.04em}
.card .v{font-size:22px;font-weight:bold}
.card .s{color:var(--muted);font-size:12px}
figure{margin:10px 0;background:var(--card);border:1px solid var(--line);border-radius:8px;padding:8px;overflow-x:auto}
figure svg{display:block;max-width:100%;height:auto}
figcaption{color:var(--muted);font-size:13px;margin-top:4px}
.target{background:var(--card);border:1px solid var(--line);border-radius:8px;padding:12px 14px;margin:14px 0}
.target figure{border:none;padding:0;margin:6px 0 0}
.target.failed{border-left:5px solid var(--bad)}
.badge{display:inline-block;border-radius:10px;padding:1px 9px;font-size:12px;font-weight:bold;color:#fff;background:#27ae60;vertical-align:middle}
.failed .badge{background:var(--bad)}
.facts{color:var(--muted);font-size:13px;margin:2px 0}
.reason{color:var(--bad);font-weight:bold}
table.grid{border-collapse:collapse;margin:8px 0 16px;background:var(--card);font-size:13px}
table.grid th,table.grid td{border-bottom:1px solid var(--line);padding:4px 10px;text-align:right;white-space:nowrap}
table.grid th:first-child,table.grid td:first-child,table.grid td.t,table.grid th.t{text-align:left}
table.grid td.t,table.grid td.w{white-space:normal;min-width:8em}
table.grid thead th{border-bottom:2px solid #999}
.scroll{overflow-x:auto}
ul.warn{color:#a04000}
code,pre{font-family:'DejaVu Sans Mono',Menlo,Consolas,monospace;font-size:12px}
pre{background:var(--card);border:1px solid var(--line);padding:10px;overflow-x:auto}
table.grid td.hash{font-family:'DejaVu Sans Mono',Menlo,Consolas,monospace;font-size:11px;text-align:left;white-space:normal;word-break:break-all;min-width:24em}
table.grid td.path{text-align:left;white-space:normal;word-break:break-all}
footer{color:var(--muted);font-size:12px;margin-top:36px}
@media print{body{background:#fff}.target,figure,.card{break-inside:avoid}}
";

/// A complete page around `body` (already HTML).
pub fn page(title: &str, body: &str, meta: &[(&str, String)]) -> String {
    let mut o = String::with_capacity(body.len() + CSS.len() + 512);
    o.push_str("<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n");
    o.push_str("<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n");
    let _ = writeln!(
        o,
        "<meta name=\"generator\" content=\"mapgauge {}\">",
        env!("CARGO_PKG_VERSION")
    );
    for (k, v) in meta {
        let _ = writeln!(o, "<meta name=\"{}\" content=\"{}\">", escape(k), escape(v));
    }
    let _ = writeln!(o, "<title>{}</title>", escape(title));
    let _ = writeln!(o, "<style>{CSS}</style>\n</head>\n<body>\n<main>");
    o.push_str(body);
    o.push_str("\n</main>\n</body>\n</html>\n");
    o
}

/// Millimetres with the unit, as the terminal rounds them (never "-0.0").
fn mm(v: f64) -> String {
    if v.is_finite() {
        format!("{} mm", crate::render::mm(v))
    } else {
        "–".into()
    }
}

fn card(o: &mut String, k: &str, v: &str, s: &str) {
    let _ = write!(
        o,
        "<div class=\"card\"><div class=\"k\">{}</div><div class=\"v\">{}</div><div class=\"s\">{}</div></div>",
        escape(k),
        escape(v),
        escape(s)
    );
}

fn figure(o: &mut String, f: &Figure, caption: &str) {
    let _ = write!(
        o,
        "<figure id=\"fig-{}\">{}<figcaption>{}</figcaption></figure>\n",
        escape(&f.name),
        svg::render(f),
        caption
    );
}

/// How the map's frame was found: the transform, its residual, the levelling,
/// detections left unmatched.
fn frame_section(
    o: &mut String,
    f: &crate::record::FrameInfo,
    doubling: Option<&crate::locate::DoublingLimit>,
) {
    o.push_str("<section id=\"frame\"><h2>Map frame</h2><table class=\"grid\"><tbody>");
    let mut row = |k: &str, v: String| {
        let _ = write!(
            o,
            "<tr><th>{}</th><td class=\"w\" style=\"text-align:left\">{}</td></tr>",
            escape(k),
            escape(&v)
        );
    };
    let how = match f.how.as_str() {
        "survey" => {
            "the targets were where the survey says: the map is in the survey frame".to_string()
        }
        "init" => "given with --init".to_string(),
        "hints" => "fitted to --hints (approximate map positions of targets)".to_string(),
        "detect" => match &f.detection {
            Some(d) => format!(
                "detected {} target-shaped object(s) map-wide and matched {} to the survey (RMS {:.3} m; the best other frame matched {})",
                d.detections,
                d.matched.len(),
                d.rms,
                d.runner_up
            ),
            None => "detected and matched".to_string(),
        },
        other => other.to_string(),
    };
    row("how it was found", how);
    row(
        "map → survey used to crop",
        format!(
            "x {:.3} m, y {:.3} m, yaw {:.3}°, z offset {:.3} m",
            f.init[0], f.init[1], f.init[2], f.dz
        ),
    );
    // Three angles, each with the sentence that relates it to the others:
    // the ground's lean and the plumb lines' are two estimates of the
    // vertical, the turn is what was applied.
    let l = &f.levelling;
    if let (Some(t), Some(s)) = (l.ground_tilt_deg, l.ground_support) {
        row(
            "ground",
            format!(
                "leans {t:.2}° from the map's +z ({:.0} % of 2 m ground blocks agree). The first estimate of the vertical, from the lowest points of 2 m blocks across the map; a site's own slope is in it too, so it turns a map only beyond frame.level_above_deg and when frame.level_min_support of the blocks agree, and never one whose header declares a CRS",
                100.0 * s
            ),
        );
    }
    row(
        "turned",
        if l.tilt_deg > 0.0 {
            format!(
                "by {:.2}° about ({:.1}, {:.1}, {:.1}). The rotation applied to the map: positions in this report are in that levelled frame, and the map as stored differs from it by this angle",
                l.tilt_deg, l.origin[0], l.origin[1], l.origin[2]
            )
        } else {
            "not at all. The map was read as it is (the ground and plumb-line rows, and the warnings above, say what it showed)".to_string()
        },
    );
    if let (Some(t), Some(s)) = (l.plumb_tilt_deg, l.plumb_se_deg) {
        row(
            "targets' plumb lines",
            format!(
                "lean {t:.2}° ± {s:.2}° from the vertical used to locate them{}. Each target's plates meet in a line built plumb: their weighted mean is a second estimate of the vertical, from the targets themselves. With the ground's (in a frame the ground turned) and the surveyed heights' (below), it turns a ground-levelled frame always, and a map read as it is when their combined lean exceeds 3 standard errors and 0.5° (0.1° with the surveyed heights)",
                if l.plumb_applied {
                    "; the frame was turned to them"
                } else {
                    ""
                }
            ),
        );
    }
    if let (Some(t), Some(s), Some(n)) = (l.heights_tilt_deg, l.heights_se_deg, l.heights_targets) {
        row(
            "surveyed heights",
            format!(
                "lean {t:.3}° ± {s:.3}° over {n} targets ({}). The located corners' heights less the surveyed ones, fitted as a plane over the site: a lean raises a corner by its distance times the angle, so heights hundreds of metres apart give it far more precisely than plumb lines. Combined with the plumb lines when the two agree within their uncertainties and the map itself shows a lean (the ground turned it, or its plumb lines lean beyond 2 standard errors): heights alone cannot tell a lean from a vertical drift{}",
                if l.heights_used == Some(true) {
                    "used"
                } else {
                    "not used"
                },
                l.vertical_se_deg
                    .map(|v| format!(
                        "; the vertical the frame was turned to is known to ±{v:.3}° (1σ)"
                    ))
                    .unwrap_or_default()
            ),
        );
    }
    if let Some(d) = doubling {
        row(
            "targets mapped twice",
            format!(
                "copies about {:.0} mm or more apart along a plate's normal are usually seen (reported ambiguous and left out of the fit; each copy needs a fifth of a plate's points, on plates of 120 or more points in their middle); this map's plates are {:.0} mm thick (1σ of their points along the normal, the median single target's thinner plate), and closer copies (a seam of a few centimetres) look like one plate and blend into one corner between them, unflagged",
                d.resolved_from_m * 1000.0,
                d.plate_thickness_m * 1000.0
            ),
        );
    }
    if let Some(d) = &f.detection
        && !d.unmatched.is_empty()
    {
        row(
            "detections left unmatched",
            d.unmatched
                .iter()
                .map(|c| format!("({:.2}, {:.2}, {:.2})", c[0], c[1], c[2]))
                .collect::<Vec<_>>()
                .join(", "),
        );
    }
    o.push_str("</tbody></table></section>\n");
}

/// Up to this many targets the report shows the paper's one-row Tables I and
/// II (as the terminal does); beyond, a pair matrix and a column.
const PAPER_TABLES_UP_TO: usize = 6;

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

/// The report page; `figs` are [`Report::figures`] (overview, relative, then
/// one per target).
pub fn report_page(rep: &Report, figs: &[Figure]) -> String {
    let r = rep.result;
    let p = &rep.provenance;
    let mut o = String::new();
    let map_name = r
        .eval
        .as_ref()
        .map(|e| e.map.clone())
        .or_else(|| {
            p.inputs
                .iter()
                .find(|i| i.role == "map")
                .map(|i| i.path.clone())
        })
        .unwrap_or_else(|| "result".into());
    let _ = writeln!(o, "<header><h1>Map accuracy report</h1>");
    let _ = writeln!(
        o,
        "<p class=\"sub\">{} · mapgauge {} · {}</p></header>",
        escape(&map_name),
        escape(&p.version),
        escape(&p.date_utc)
    );

    // Summary.
    let dim = match r.dim {
        Dim::D2 => "2D",
        Dim::D3 => "3D",
    };
    let n_ok = r.targets.iter().filter(|t| t.status == "ok").count();
    o.push_str("<section id=\"summary\"><h2>Summary</h2><div class=\"cards\">");
    card(
        &mut o,
        "E_abs (mean absolute error)",
        &mm(r.absolute.mean),
        &format!(
            "σ_abs {} · {dim} · n = {}",
            mm(r.absolute.std),
            r.absolute.n
        ),
    );
    card(
        &mut o,
        "E_rel (mean relative error)",
        &mm(r.relative.mean),
        &format!("σ_rel {} · {} pairs", mm(r.relative.std), r.relative.n),
    );
    card(
        &mut o,
        "RMSE_H",
        &mm(r.asprs.rmse_h),
        &format!("NSSDA 95 %: {}", mm(r.asprs.nssda_horizontal_95)),
    );
    let a = &r.alignment;
    card(
        &mut o,
        "Alignment",
        &format!("{}°", crate::render::fixed(a.rotation_deg, 3)),
        &format!(
            "{} · t = ({}, {}) m",
            a.method,
            crate::render::fixed(a.translation[0], 3),
            crate::render::fixed(a.translation[1], 3)
        ),
    );
    if let Some(sc) = &r.scale {
        let ppm = crate::render::signed_ppm;
        card(
            &mut o,
            "Scale",
            &format!("{} ppm", ppm(sc.ppm)),
            &format!(
                "95 % [{}, {}] · the map's distances against the survey's, {} targets",
                ppm(sc.ci95_ppm[0]),
                ppm(sc.ci95_ppm[1]),
                sc.n
            ),
        );
    }
    card(
        &mut o,
        "Targets found",
        &format!("{n_ok} / {}", r.targets.len()),
        if n_ok == r.targets.len() {
            "all located"
        } else {
            "see the failed panels below"
        },
    );
    o.push_str("</div>");
    let mut warn: Vec<String> = r.caveats().cloned().collect();
    for t in r.targets.iter().filter(|t| t.status != "ok") {
        warn.push(format!(
            "target {} {}: {}",
            target_label(&t.id),
            t.status.replace('_', " "),
            t.reason.as_deref().unwrap_or("")
        ));
    }
    if !warn.is_empty() {
        o.push_str("<ul class=\"warn\">");
        for w in &warn {
            let _ = write!(o, "<li>{}</li>", escape(w));
        }
        o.push_str("</ul>");
    }
    o.push_str("</section>\n");

    if let Some(e) = &r.eval {
        frame_section(&mut o, &e.frame, e.doubling.as_ref());
    }

    let mut figs = figs.iter().peekable();
    if let Some(f) = figs.next() {
        o.push_str("<section id=\"overview\"><h2>Target positions</h2>");
        figure(
            &mut o,
            f,
            "Survey frame. Each arrow runs from a surveyed position to the aligned map estimate, lengthened by the factor in the legend so that centimetre errors are visible on a plan of tens of metres.",
        );
        o.push_str("</section>\n");
    }
    if let Some(f) = figs.next() {
        o.push_str("<section id=\"relative\"><h2>Relative error against distance</h2>");
        figure(
            &mut o,
            f,
            "Every pair of located targets: | map distance − surveyed distance | against the surveyed distance. Relative errors need no alignment; a rising line means the map stretches or drifts with distance.",
        );
        o.push_str("</section>\n");
    }
    while let Some(f) = figs.next_if(|f| f.name.starts_with("error-")) {
        let (h, cap) = if f.name == "error-route" {
            (
                "Error against distance driven",
                "Each located target's absolute error against the distance along the trajectory (given with --trajectory) to its closest point: SLAM drift grows with the distance driven, and a slope says by how much.",
            )
        } else {
            (
                "How the errors are distributed",
                "The share of located targets whose absolute error is at most each value. NSSDA's 95 % figure assumes normal errors: about 95 % of the targets should lie left of its line, and a last step far to its right is a target worth checking.",
            )
        };
        let _ = write!(o, "<section id=\"{}\"><h2>{h}</h2>", escape(&f.name));
        figure(&mut o, f, cap);
        o.push_str("</section>\n");
    }

    // Per target.
    o.push_str("<section id=\"targets\"><h2>Targets</h2>");
    let details = r.eval.as_ref().map(|e| &e.targets);
    for (i, (t, f)) in r.targets.iter().zip(figs).enumerate() {
        let ok = t.status == "ok";
        let _ = write!(
            o,
            "<div class=\"target{}\" id=\"target-{i}\"><h3>{} <span class=\"badge\">{}</span>{}</h3>",
            if ok { "" } else { " failed" },
            escape(&target_label(&t.id)),
            escape(&t.status.replace('_', " ")),
            t.abs_error
                .map(|e| format!(" · absolute error {}", escape(&fmt_len(e))))
                .unwrap_or_default()
        );
        let d = details.and_then(|v| v.iter().find(|d| d.id == t.id));
        let mut facts: Vec<String> = Vec::new();
        if let Some(d) = d {
            facts.push(format!(
                "{} loose / {} tight points",
                d.loose_points, d.tight_points
            ));
            if d.attempts > 0 {
                facts.push(format!(
                    "{} of {} attempts accepted",
                    d.accepted, d.attempts
                ));
            }
            if let Some(a) = d.plate_angle_deg {
                facts.push(format!("plates {a:.2}° apart"));
            }
            if let Some(s) = d.spread {
                facts.push(format!(
                    "sample σ = ({:.1}, {:.1}, {:.1}) mm",
                    s[0] * 1000.0,
                    s[1] * 1000.0,
                    s[2] * 1000.0
                ));
            }
            if d.pass > 1 {
                facts.push("found in the second pass".into());
            }
        }
        if let (Some(m), true) = (t.map, ok) {
            let s = survey_in_map(&rep.alignment, t);
            facts.push(format!(
                "survey − estimate (map frame) = ({:.1}, {:.1}) mm",
                (s.x - m.x) * 1000.0,
                (s.y - m.y) * 1000.0
            ));
        }
        if !facts.is_empty() {
            let _ = write!(o, "<p class=\"facts\">{}</p>", escape(&facts.join(" · ")));
        }
        if let Some(reason) = t.reason.as_deref().filter(|_| !ok) {
            let _ = write!(o, "<p class=\"reason\">{}</p>", escape(reason));
        }
        let cap = if ok {
            "Tight crop coloured by the reference sample's plate inliers and outliers; dark lines are the fitted plate planes seen from above; the right view shows every accepted sample around the mean corner."
        } else {
            "The loose crop (grey) around where the target was looked for, and the tight crop (orange) when one was made."
        };
        figure(&mut o, f, cap);
        o.push_str("</div>\n");
    }
    o.push_str("</section>\n");

    // Tables.
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
    if !r.asprs.nssda_lines.is_empty() {
        o.push_str("<ul>");
        for l in &r.asprs.nssda_lines {
            let _ = write!(o, "<li>{}</li>", escape(l));
        }
        o.push_str("</ul>");
    }
    o.push_str("</section>\n");

    // Provenance.
    o.push_str("<section id=\"provenance\"><h2>Parameters and provenance</h2><table class=\"grid\"><tbody>");
    let mut row = |k: &str, v: &str| {
        let _ = write!(
            o,
            "<tr><th>{}</th><td class=\"w\" style=\"text-align:left\">{}</td></tr>",
            escape(k),
            escape(v)
        );
    };
    row("mapgauge version", &p.version);
    row("report written", &p.date_utc);
    row(
        "seed",
        &p.seed.map(|s| s.to_string()).unwrap_or_else(|| "–".into()),
    );
    row(
        "alignment",
        &format!("{} ({} targets)", r.alignment.method, r.alignment.n_used),
    );
    row("error dimension", dim);
    if let Some(e) = &r.eval {
        row(
            "map points read",
            &format!(
                "{} ({} non-finite skipped)",
                e.map_points, e.skipped_nonfinite
            ),
        );
    }
    o.push_str("</tbody></table>");
    if !p.inputs.is_empty() {
        o.push_str("<h3>Input files</h3><div class=\"scroll\"><table class=\"grid\"><thead><tr><th>role</th><th class=\"t\">file</th><th>bytes</th><th class=\"t\">BLAKE3</th></tr></thead><tbody>");
        for f in &p.inputs {
            let _ = write!(
                o,
                "<tr><td>{}</td><td class=\"path\">{}</td><td>{}</td><td class=\"hash\">{}</td></tr>",
                escape(&f.role),
                escape(&f.path),
                f.bytes,
                escape(&f.blake3)
            );
        }
        o.push_str("</tbody></table></div>");
    }
    if let Some(c) = &p.config_toml {
        let _ = write!(
            o,
            "<details><summary>Every parameter (TOML for <code>--config</code>)</summary><pre>{}</pre></details>",
            escape(c)
        );
    }
    o.push_str("</section>\n");
    let _ = write!(
        o,
        "<footer>Written by mapgauge {} — the method of Hahn et al., ICCAS 2024, without its manual step. Numbers are metres unless marked.</footer>",
        escape(&p.version)
    );

    let n_svg = o.matches("<svg ").count();
    page(
        &format!("mapgauge report — {map_name}"),
        &o,
        &[("mapgauge-figures", n_svg.to_string())],
    )
}

#[cfg(test)]
pub(crate) mod tests {
    use super::super::{Provenance, Report};
    use super::*;
    use crate::Point;
    use crate::accuracy::{ScoreOptions, score};
    use crate::survey::{Estimate, EstimateStatus, Survey, SurveyFrame, SurveyTarget};

    /// A result with 4 targets at tens of metres, the fourth not found.
    pub(crate) fn result(ids: &[&str]) -> crate::record::ResultFile {
        let pos = [(0.0, 0.0), (30.0, 1.0), (12.0, 25.0), (-14.0, 18.0)];
        let targets: Vec<SurveyTarget> = ids
            .iter()
            .zip(pos)
            .enumerate()
            .map(|(i, (id, p))| SurveyTarget {
                id: id.to_string(),
                position: Point::new(p.0, p.1, 0.0),
                has_z: false,
                role: None,
                antenna_height: 0.0,
                line: i as u64 + 2,
            })
            .collect();
        let survey = Survey {
            targets,
            frame: SurveyFrame::Local,
            origin: None,
        };
        let est: Vec<Estimate> = survey
            .targets
            .iter()
            .enumerate()
            .map(|(i, t)| Estimate {
                id: t.id.clone(),
                status: if i == 3 {
                    EstimateStatus::NotFound {
                        reason: "too few points <here> & there".into(),
                    }
                } else {
                    EstimateStatus::Found(
                        t.position + nalgebra::Vector3::new(0.01 * i as f64, -0.02, 0.0),
                    )
                },
                has_z: false,
            })
            .collect();
        let opts = ScoreOptions {
            method: Default::default(),
            dim: Dim::D2,
            survey_sigma: None,
            vertical: None,
        };
        crate::record::ResultFile::from_accuracy(&score(&survey, &est, &opts).unwrap(), &survey)
    }

    #[test]
    fn report_page_is_self_contained() {
        let r = result(&["<t&1>", "2", "3", "4"]);
        let mut prov = Provenance::new(Some(7), Some("[locate]\nseed = 7\n".into()));
        prov.date_utc = "2026-01-01 00:00:00 UTC".into();
        let rep = Report::from_result(&r, prov);
        let figs = rep.figures();
        assert_eq!(figs.len(), 3 + 4);
        let html = rep.html();
        // One panel per target, one figure each plus overview, relative and
        // the errors' CDF.
        assert_eq!(html.matches("<div class=\"target").count(), 4);
        assert_eq!(html.matches("<svg ").count(), 7);
        assert!(html.contains("<meta name=\"mapgauge-figures\" content=\"7\">"));
        assert_eq!(html.matches("class=\"target failed\"").count(), 1);
        // Ids and reasons are escaped everywhere.
        assert!(!html.contains("<t&1>"), "raw id in the page");
        assert!(html.contains("&lt;t&amp;1&gt;"));
        assert!(html.contains("too few points &lt;here&gt; &amp; there"));
        // No network: `http` appears only in SVG namespace declarations.
        let http = html.matches("http").count();
        let ns = html.matches("xmlns=\"http://www.w3.org/2000/svg\"").count();
        assert_eq!(http, ns, "external reference in the page");
        assert!(!html.contains("<script") && !html.contains("<link") && !html.contains("url("));
        crate::report::tests::check_xmlish(&html[html.find("<html").unwrap()..]);
        for f in &figs {
            crate::report::tests::check_xmlish(&svg::render(f));
        }
        assert!(html.contains("2026-01-01 00:00:00 UTC") && html.contains("seed = 7"));
    }

    /// Past 6 targets the paper's one-row tables (66 pair columns at 12)
    /// give way to a pair matrix and a column, and the targets table to mm.
    #[test]
    fn many_targets_get_tables_that_fit() {
        let ids: Vec<String> = (1..=12).map(|i| i.to_string()).collect();
        let targets: Vec<SurveyTarget> = ids
            .iter()
            .enumerate()
            .map(|(i, id)| SurveyTarget {
                id: id.clone(),
                position: Point::new(10.0 * i as f64, (i % 3) as f64 * 7.0, 0.0),
                has_z: false,
                role: None,
                antenna_height: 0.0,
                line: i as u64 + 2,
            })
            .collect();
        let survey = Survey {
            targets,
            frame: SurveyFrame::Local,
            origin: None,
        };
        let est: Vec<Estimate> = survey
            .targets
            .iter()
            .enumerate()
            .map(|(i, t)| Estimate {
                id: t.id.clone(),
                status: EstimateStatus::Found(
                    t.position + nalgebra::Vector3::new(0.002 * (i % 4) as f64, 0.001, 0.0),
                ),
                has_z: false,
            })
            .collect();
        let r = crate::record::ResultFile::from_accuracy(
            &score(&survey, &est, &ScoreOptions::default()).unwrap(),
            &survey,
        );
        let rep = Report::from_result(&r, Provenance::new(None, None));
        let html = rep.html();
        let tables = &html[html.find("<section id=\"tables\">").unwrap()..];
        assert!(!tables.contains("t1 &amp; t2"), "no 66-column Table I");
        assert!(tables.contains("Relative error of every pair (mm, 2D)"));
        // The matrix: 11 rows (t1..t11) under a header t2..t12.
        let matrix = &tables[..tables.find("Absolute error").unwrap()];
        assert_eq!(matrix.matches("<tr>").count(), 1 + 11);
        assert!(matrix.contains("<th>t12</th>") && !matrix.contains("<th>t1</th>"));
        assert!(
            !tables.contains("survey_x"),
            "coordinates stay in targets.csv"
        );
        assert!(tables.contains("z is not fitted by a 2D alignment"));
        // A few targets keep the paper's layout.
        let few = result(&["1", "2", "3", "4"]);
        let html = Report::from_result(&few, Provenance::new(None, None)).html();
        assert!(html.contains("t1 &amp; t2") && html.contains("the paper's Table I"));
    }

    #[test]
    fn escape_all_specials() {
        assert_eq!(
            escape("<a href='x'>&\"</a>"),
            "&lt;a href=&#39;x&#39;&gt;&amp;&quot;&lt;/a&gt;"
        );
    }
}
