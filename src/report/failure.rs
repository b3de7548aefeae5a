//! The page a run that could not score leaves in its output folder: why, and
//! what each surveyed place showed (its loose crop, the object refused there,
//! a corner located there), so that a failed run leaves something to debug
//! with rather than nothing.

use super::Provenance;
use super::figure::Figure;
use super::html::{escape, page};
use super::plots::{LooseView, loose_figure};
use super::svg;
use crate::Result;
use crate::pipeline::{Failed, Failure, TargetRun};
use crate::record::write_atomic;
use crate::render::target_label;
use crate::survey::file_stem;
use std::fmt::Write as _;
use std::path::Path;

/// A surveyed place's status in a run that could not score, and the
/// sentence saying why.
pub fn place_status(
    outcome: &std::result::Result<crate::pipeline::Found, Failure>,
) -> (&'static str, String) {
    match outcome {
        Ok(_) => ("located", String::new()),
        Err(e @ Failure::Doubled(_)) => ("ambiguous", e.to_string()),
        Err(e) => ("not_found", e.to_string()),
    }
}

/// The failure page of `failed` (a run of `map` that could not score).
pub fn failure_page(map: &str, failed: &Failed, prov: &Provenance) -> String {
    let mut o = String::new();
    let _ = writeln!(o, "<header><h1>Map accuracy report: no result</h1>");
    let _ = writeln!(
        o,
        "<p class=\"sub\">{} · mapgauge {} · {}</p></header>",
        escape(map),
        escape(&prov.version),
        escape(&prov.date_utc)
    );
    why_section(&mut o, failed);
    places_section(&mut o, failed);
    let mut stems: Vec<String> = Vec::new();
    for (i, t) in failed.targets.iter().enumerate() {
        let mut stem = format!("target-{}", file_stem(&t.id));
        if stems.contains(&stem) {
            stem = format!("{stem}-{i}");
        }
        stems.push(stem.clone());
        place_panel(&mut o, failed, i, t, &stem);
    }
    o.push_str("</section>\n");
    let _ = write!(
        o,
        "<footer>mapgauge {} · {}{}</footer>",
        escape(&prov.version),
        escape(&prov.date_utc),
        prov.seed
            .map(|s| format!(" · seed {s}"))
            .unwrap_or_default()
    );
    page(
        "mapgauge: no result",
        &o,
        &[("mapgauge-status", "failed".to_string())],
    )
}

/// Why the run could not score, and how many places showed a target anyway.
fn why_section(o: &mut String, failed: &Failed) {
    let located = failed.targets.iter().filter(|t| t.outcome.is_ok()).count();
    let _ = write!(
        o,
        "<section id=\"summary\"><h2>Why the run could not score</h2><p class=\"reason\">{}</p><p class=\"facts\">{located} of {} surveyed places showed a target that could be located. Below, what each place showed: its loose crop (grey, every point within the crop radius of where the target was looked for), the tight crop (orange) when one was made, the object refused there and the reason.</p></section>\n",
        escape(&failed.error.to_string()),
        failed.targets.len()
    );
}

/// The table of places, a row each (its status, the stage that failed, its
/// crops' sizes), then the opening of the per-place section that follows it.
fn places_section(o: &mut String, failed: &Failed) {
    o.push_str("<section id=\"places\"><h2>Surveyed places</h2><div class=\"scroll\"><table class=\"grid\"><thead><tr><th>id</th><th>status</th><th>stage</th><th>loose points</th><th>tight points</th><th class=\"t\">reason</th></tr></thead><tbody>");
    for t in &failed.targets {
        let (status, reason) = place_status(&t.outcome);
        let stage = t.outcome.as_ref().err().map_or("", |e| e.stage());
        let _ = write!(
            o,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td class=\"t\">{}</td></tr>",
            escape(&target_label(&t.id)),
            escape(status),
            escape(stage),
            t.loose.len(),
            t.tight.len(),
            escape(&reason)
        );
    }
    o.push_str(
        "</tbody></table></div></section>\n<section id=\"targets\"><h2>What each place showed</h2>",
    );
}

/// What place `i` showed: its loose-crop figure (named `stem`) with the
/// object refused there or the corner located, and the reason.
fn place_panel(o: &mut String, failed: &Failed, i: usize, t: &TargetRun, stem: &str) {
    let (status, reason) = place_status(&t.outcome);
    let seen = match &t.outcome {
        Err(Failure::Tight(crate::crop::TightError::NoTargetShape { seen, .. })) => seen.as_ref(),
        _ => None,
    };
    let corner = t.corner();
    let reason = if reason.is_empty() {
        // In the map's own frame, as failed.csv gives it.
        let l = &failed.levelling;
        corner.map_or(String::new(), |c| {
            let c = if l.is_identity() { c } else { l.invert(&c) };
            format!(
                "a corner located at ({:.3}, {:.3}, {:.3}) m in the map",
                c.x, c.y, c.z
            )
        })
    } else {
        reason
    };
    let f: Figure = loose_figure(
        stem,
        &t.id,
        &LooseView {
            loose: &t.loose,
            tight: &t.tight,
            expected: t.expected,
            survey: None,
            seen,
            corner,
            status,
            reason: &reason,
        },
    );
    let _ = write!(
        o,
        "<div class=\"target{}\" id=\"target-{i}\"><h3>{} <span class=\"badge\">{}</span></h3><p class=\"facts\">{} loose / {} tight points</p>",
        if t.outcome.is_ok() { "" } else { " failed" },
        escape(&target_label(&t.id)),
        escape(&status.replace('_', " ")),
        t.loose.len(),
        t.tight.len()
    );
    if !reason.is_empty() {
        let _ = write!(o, "<p class=\"reason\">{}</p>", escape(&reason));
    }
    let _ = write!(
        o,
        "<figure id=\"fig-{}\">{}<figcaption>Loose crop about where the target was looked for (the ring); the cross and thick lines mark an object the tight crop refused, the plus a corner located there.</figcaption></figure></div>\n",
        escape(&f.name),
        svg::render(&f)
    );
}

/// Writes [`failure_page`] to `path` atomically.
pub fn write_failure(path: &Path, map: &str, failed: &Failed, prov: &Provenance) -> Result<()> {
    write_atomic(path, failure_page(map, failed, prov).as_bytes())
}
