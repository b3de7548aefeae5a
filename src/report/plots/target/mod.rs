//! One figure per target: top and side views of its tight crop with the
//! fitted plates, the corner and the sample spread; or, for a target not
//! found, its loose crop and the reason.

mod located;
mod loose;

use super::survey_in_map;
use crate::Point;
use crate::record::TargetOut;
use crate::render::target_label;
use crate::report::figure::{Color, Figure, Item, Panel, thin};
use crate::report::{Report, TargetView};
use located::located_panels;
use loose::loose_panels;
pub(crate) use loose::{LooseView, loose_figure};

/// Dots of `pts` (thinned), projected by `proj`, coloured by `color`; painted in
/// colour order so outliers stay behind the plates.
fn cloud(
    f: &mut Figure,
    panel: &Panel,
    pts: &[Point],
    proj: impl Fn(&Point) -> (f64, f64),
    color: impl Fn(usize) -> Color,
    order: &[Color],
    max: usize,
) {
    let mut groups: Vec<(Color, Vec<(f64, f64)>)> =
        order.iter().map(|c| (*c, Vec::new())).collect();
    for i in thin(pts.len(), max) {
        let c = color(i);
        let (x, y) = proj(&pts[i]);
        if !panel.contains(x, y) {
            continue;
        }
        let xy = panel.map(x, y);
        match groups.iter_mut().find(|g| g.0 == c) {
            Some(g) => g.1.push(xy),
            None => groups.push((c, vec![xy])),
        }
    }
    for (c, xy) in groups {
        f.items.push(Item::Dots {
            xy,
            r: 1.6,
            color: c,
        });
    }
}

fn bounds(v: impl Iterator<Item = (f64, f64)>) -> ((f64, f64), (f64, f64)) {
    let (mut x0, mut x1, mut y0, mut y1) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for (x, y) in v {
        if x.is_finite() && y.is_finite() {
            x0 = x0.min(x);
            x1 = x1.max(x);
            y0 = y0.min(y);
            y1 = y1.max(y);
        }
    }
    if !x0.is_finite() {
        return ((-1.0, 1.0), (-1.0, 1.0));
    }
    ((x0, x1), (y0, y1))
}

fn pad(r: (f64, f64), p: f64) -> (f64, f64) {
    (r.0 - p, r.1 + p)
}

const TOP: (f64, f64, f64, f64) = (60.0, 40.0, 250.0, 250.0);
const SIDE: (f64, f64, f64, f64) = (380.0, 40.0, 250.0, 250.0);
const THIRD: (f64, f64, f64, f64) = (700.0, 40.0, 220.0, 220.0);
/// The legend row under the views (below the notes under the panels).
const LEGEND_Y: f64 = 354.0;

pub(super) fn target_figure(rep: &Report, i: usize, t: &TargetOut, stem: &str) -> Figure {
    let empty = TargetView::default();
    let view = rep.targets.get(i).unwrap_or(&empty);
    let located =
        t.status == "ok" && view.diag.and_then(|d| d.corner).is_some() && !view.tight.is_empty();
    let title = format!(
        "Target {}: {}",
        target_label(&t.id),
        if located {
            "top view, side view and sample spread".to_string()
        } else {
            format!("{} — loose crop", t.status.replace('_', " "))
        }
    );
    let mut f = Figure::new(stem, &title, 950.0, 366.0);
    if located {
        located_panels(&mut f, rep, t, view);
    } else {
        failed_panels(&mut f, rep, i, t, view);
    }
    f
}

fn failed_panels(f: &mut Figure, rep: &Report, i: usize, t: &TargetOut, view: &TargetView) {
    let detail = rep
        .result
        .eval
        .as_ref()
        .and_then(|e| e.targets.iter().find(|d| d.id == t.id).or(e.targets.get(i)));
    let expected = detail.map(|d| Point::new(d.expected[0], d.expected[1], d.expected[2]));
    let survey = survey_in_map(&rep.alignment, t);
    loose_panels(
        f,
        &LooseView {
            loose: view.loose,
            tight: view.tight,
            expected: expected.unwrap_or(survey),
            survey: Some(survey),
            seen: detail.and_then(|d| d.seen.as_ref()),
            corner: None,
            status: &t.status,
            reason: t.reason.as_deref().unwrap_or("no reason recorded"),
        },
    );
}
