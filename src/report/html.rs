//! HTML: escaping, the shared stylesheet, standalone pages (`mapgauge table
//! --format html`) and the report page itself. No script and no external
//! resource: the page reads the same offline, printed, or with JavaScript off.

mod frame;
mod tables;

use super::figure::Figure;
use super::plots::{fmt_len, survey_in_map};
use super::{Report, ResultFile, svg};
use crate::render::{Grid, TableFormat, absolute_grid, extra_grid, relative_grid, target_label};
use frame::frame_section;
use std::fmt::Write as _;
use tables::tables_section;

pub use crate::render::{CSS, escape, page};

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

/// The report page; `figs` are [`Report::figures`] (overview, relative, then
/// one per target).
pub(crate) fn report_page(rep: &Report, figs: &[Figure]) -> String {
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
    let dim = r.dim.label();
    gates_section(&mut o, r);
    summary_section(&mut o, r, dim);
    if let Some(e) = &r.eval {
        frame_section(&mut o, &e.frame, e.doubling.as_ref());
    }
    let mut figs = figs.iter().peekable();
    figure_sections(&mut o, &mut figs);
    targets_section(&mut o, rep, figs);
    tables_section(&mut o, rep, dim);
    provenance_section(&mut o, rep, dim);

    let n_svg = o.matches("<svg ").count();
    page(
        &format!("mapgauge report — {map_name}"),
        &o,
        &[("mapgauge-figures", n_svg.to_string())],
    )
}

/// The quality gates first, when the run was held to any: whether it
/// passed, then each gate with the value and interval that decided it.
fn gates_section(o: &mut String, r: &ResultFile) {
    let Some(head) = crate::render::gates_headline(r) else {
        return;
    };
    let failed = r.gate_outcome.is_some_and(|g| g.exit_code != 0);
    let _ = write!(
        o,
        "<section id=\"gates\"><h2>Gates</h2><p class=\"{}\">{}</p><div class=\"scroll\"><table class=\"grid\"><thead><tr><th>verdict</th><th class=\"t\">gate</th><th class=\"t\">what decided it</th></tr></thead><tbody>",
        if failed { "reason" } else { "facts" },
        escape(&head)
    );
    for g in &r.gates {
        let _ = write!(
            o,
            "<tr><td>{}</td><td class=\"t\"><code>{}</code></td><td class=\"t\">{}</td></tr>",
            g.verdict.word(),
            escape(&g.gate),
            escape(&crate::render::gate_evidence(g))
        );
    }
    o.push_str("</tbody></table></div></section>\n");
}

/// The headline numbers as cards, then every caveat and failed target.
fn summary_section(o: &mut String, r: &ResultFile, dim: &str) {
    let (n_found, excluded) = r.found();
    o.push_str("<section id=\"summary\"><h2>Summary</h2><div class=\"cards\">");
    card(
        o,
        "E_abs (mean absolute error)",
        &mm(r.absolute.mean),
        &format!(
            "σ_abs {} · {dim} · n = {}",
            mm(r.absolute.std),
            r.absolute.n
        ),
    );
    if let (Some(u), Some(share)) = (&r.unfitted, r.fit_absorbed) {
        card(
            o,
            "E_abs without a fit",
            &mm(u.mean),
            &format!(
                "the map as it is in the survey's frame · the {} fit {}",
                r.alignment.method,
                if share >= 0.0 {
                    format!(
                        "absorbed {} % of it",
                        crate::render::fixed(share * 100.0, 0)
                    )
                } else {
                    format!(
                        "made it {} % larger",
                        crate::render::fixed(-share * 100.0, 0)
                    )
                }
            ),
        );
    }
    card(
        o,
        "E_rel (mean relative error)",
        &mm(r.relative.mean),
        &format!("σ_rel {} · {} pairs", mm(r.relative.std), r.relative.n),
    );
    card(
        o,
        "RMSE_H",
        &mm(r.asprs.rmse_h),
        &format!("NSSDA 95 %: {}", mm(r.asprs.nssda_horizontal_95)),
    );
    for (k, s) in &r.scores {
        let range = if s.range95[0] == s.range95[1] {
            String::new()
        } else {
            format!(
                " · 95 %: {}–{}",
                crate::render::fixed(s.range95[0], 1),
                crate::render::fixed(s.range95[1], 1)
            )
        };
        card(
            o,
            &format!("{} score", k.title()),
            &crate::render::fixed(s.total, 1),
            &format!(
                "of 100{range} · {} of {} targets located",
                s.located, s.targets
            ),
        );
    }
    let a = &r.alignment;
    card(
        o,
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
            o,
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
        o,
        "Targets found",
        &format!("{n_found} / {}", r.targets.len()),
        &match (n_found == r.targets.len(), excluded) {
            (true, 0) => "all located".to_string(),
            (true, 1) => "all located; 1 excluded as a gross error".to_string(),
            (true, k) => format!("all located; {k} excluded as gross errors"),
            (false, 0) => "see the failed panels below".to_string(),
            (false, 1) => "1 excluded as a gross error; see the failed panels below".to_string(),
            (false, k) => format!("{k} excluded as gross errors; see the failed panels below"),
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
}

/// The overview, the relative errors against distance and the error plots.
fn figure_sections(o: &mut String, figs: &mut std::iter::Peekable<std::slice::Iter<'_, Figure>>) {
    if let Some(f) = figs.next() {
        o.push_str("<section id=\"overview\"><h2>Target positions</h2>");
        figure(
            o,
            f,
            "Survey frame. Each arrow runs from a surveyed position to the aligned map estimate, lengthened by the factor in the legend so that centimetre errors are visible on a plan of tens of metres.",
        );
        o.push_str("</section>\n");
    }
    if let Some(f) = figs.next() {
        o.push_str("<section id=\"relative\"><h2>Relative error against distance</h2>");
        figure(
            o,
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
        figure(o, f, cap);
        o.push_str("</section>\n");
    }
}

/// One panel per target: its facts, why it failed, its figure.
fn targets_section<'f>(o: &mut String, rep: &Report, figs: impl Iterator<Item = &'f Figure>) {
    let r = rep.result;
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
            if d.pass > 1 && ok {
                facts.push("found in the second pass".into());
            } else if d.pass > 1 {
                facts.push(format!(
                    "searched again within {:.2} m of where the other targets place it",
                    d.search_radius_m
                ));
            } else if d.waited {
                facts.push(format!(
                    "searched within {:.2} m of where the other targets place it (its crop is dense)",
                    d.search_radius_m
                ));
            }
            if let Some(r) = d.detail_radius_m {
                facts.push(format!(
                    "found in the map's coarse octree levels, located in every level within {r:.2} m"
                ));
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
        figure(o, f, cap);
        o.push_str("</div>\n");
    }
    o.push_str("</section>\n");
}

/// Parameters, inputs with their hashes, every setting, and the footer.
fn provenance_section(o: &mut String, rep: &Report, dim: &str) {
    let (r, p) = (rep.result, &rep.provenance);
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
}

#[cfg(test)]
pub(crate) mod tests;
