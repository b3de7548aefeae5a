//! The run-wide overview: surveyed and aligned target positions with error
//! vectors magnified, over the map seen from above and the route driven
//! when they are given.

mod footprint;
mod labels;
mod legend;

use crate::align::Alignment;
use crate::frame::Footprint;
use crate::record::ResultFile;
use crate::render::target_label;
use crate::report::figure::{Figure, Item, MarkerKind, Panel, nice_floor, palette};
use crate::trajectory::Trajectory;
use footprint::footprint_tiles;
use labels::{Seg, place_labels};
pub(crate) use legend::fmt_len;
use legend::{Legend, legend};

/// Surveyed positions and the aligned estimates, error vectors magnified,
/// over the map seen from above when its footprint is given (with the
/// map → survey alignment that places it).
pub(crate) fn overview(
    r: &ResultFile,
    map: Option<(&Footprint, &Alignment)>,
    route: Option<&Trajectory>,
) -> Figure {
    let mut f = Figure::new(
        "overview",
        "Surveyed target positions and aligned map estimates (error vectors magnified)",
        780.0,
        540.0,
    );
    let v = SurveyView::of(r);
    let base = f.items.len();
    v.panel
        .axes(&mut f, "", &v.axis_label("x"), &v.axis_label("y"));
    let mut shaded = false;
    if let Some((fp, al)) = map {
        // Over the panel's white ground, under its grid and everything else.
        let tiles = footprint_tiles(fp, al, &v.panel, v.off);
        shaded = !tiles.is_empty();
        f.items.splice(base + 1..base + 1, tiles);
    }
    // The route over the map, under the targets: drawn through the same
    // alignment as the map, clipped to the panel.
    let drawn_route = match (route, map) {
        (Some(t), Some((_, al))) => draw_route(&mut f, t, al, &v),
        _ => false,
    };
    let e = Errors::of(r, v.span);
    error_vectors(&mut f, r, &v, &e);
    let key = Legend {
        k: e.k,
        max_err: e.max,
        scale: v.panel.scale(),
        drawn_route,
        shaded,
    };
    legend(&mut f, r, &key);
    f
}

/// The panel the survey's positions are drawn in: a survey in a projected
/// grid (coordinates beyond 10 km) is drawn less a round origin so its axis
/// labels stay short.
struct SurveyView {
    panel: Panel,
    /// The origin taken off every position (zero for a small survey).
    off: (f64, f64),
    /// Whether an origin is taken off (the axes then say so).
    big: bool,
    /// The larger side of the positions' extent (m, at least 1).
    span: f64,
    /// Each target's surveyed position less `off`, in survey order.
    rel: Vec<(f64, f64)>,
}

impl SurveyView {
    /// The view of `r`'s surveyed positions, padded by 12 % of their span.
    fn of(r: &ResultFile) -> SurveyView {
        let pts: Vec<(f64, f64)> = r.targets.iter().map(|t| (t.survey.x, t.survey.y)).collect();
        let big = pts.iter().any(|p| p.0.abs() > 1e4 || p.1.abs() > 1e4);
        let (ox, oy) = if big {
            let mx = pts.iter().map(|p| p.0).fold(f64::INFINITY, f64::min);
            let my = pts.iter().map(|p| p.1).fold(f64::INFINITY, f64::min);
            ((mx / 100.0).floor() * 100.0, (my / 100.0).floor() * 100.0)
        } else {
            (0.0, 0.0)
        };
        let rel: Vec<(f64, f64)> = pts.iter().map(|p| (p.0 - ox, p.1 - oy)).collect();
        let (mut x0, mut x1, mut y0, mut y1) = (
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
        );
        for p in &rel {
            x0 = x0.min(p.0);
            x1 = x1.max(p.0);
            y0 = y0.min(p.1);
            y1 = y1.max(p.1);
        }
        if !x0.is_finite() {
            (x0, x1, y0, y1) = (-1.0, 1.0, -1.0, 1.0);
        }
        let span = (x1 - x0).max(y1 - y0).max(1.0);
        let pad = 0.12 * span;
        let panel = Panel::new(
            (70.0, 40.0, 500.0, 440.0),
            (x0 - pad, x1 + pad),
            (y0 - pad, y1 + pad),
            true,
        );
        SurveyView {
            panel,
            off: (ox, oy),
            big,
            span,
            rel,
        }
    }

    /// Axis `a`'s title, naming the origin taken off when there is one.
    fn axis_label(&self, a: &str) -> String {
        let (ox, oy) = self.off;
        if self.big {
            format!(
                "{a} − {:.0} (m, survey frame)",
                if a == "x" { ox } else { oy }
            )
        } else {
            format!("{a} (m, survey frame)")
        }
    }
}

/// The trajectory as line segments of at least 2 px, through `al` into the
/// survey frame and clipped to the panel; whether any was drawn.
fn draw_route(f: &mut Figure, t: &Trajectory, al: &Alignment, v: &SurveyView) -> bool {
    let (ox, oy) = v.off;
    let panel = &v.panel;
    let mut drawn = false;
    let mut last: Option<(f64, f64)> = None;
    for p in &t.positions {
        let q = al.apply(p);
        let q = (q.x - ox, q.y - oy);
        if let Some(a) = last
            && (a.0 - q.0).hypot(a.1 - q.1) * panel.scale() >= 2.0
        {
            if let Some((pa, pb)) = panel.clip(a, q) {
                f.line(pa, pb, palette::SAMPLE, 1.5, false);
                drawn = true;
            }
            last = Some(q);
        } else if last.is_none() {
            last = Some(q);
        }
    }
    drawn
}

/// Each target's horizontal error (aligned − survey, m; `None` when not
/// found) and the magnification that makes them visible.
struct Errors {
    each: Vec<Option<(f64, f64)>>,
    /// The largest error (m; 0 when none).
    max: f64,
    /// Magnification: the longest vector gets about 15 % of the plot's span.
    k: f64,
}

impl Errors {
    fn of(r: &ResultFile, span: f64) -> Errors {
        let each: Vec<Option<(f64, f64)>> = r
            .targets
            .iter()
            .map(|t| {
                t.aligned
                    .filter(|_| t.status == "ok")
                    .map(|a| (a.x - t.survey.x, a.y - t.survey.y))
            })
            .collect();
        let max = each
            .iter()
            .flatten()
            .map(|e| e.0.hypot(e.1))
            .fold(0.0, f64::max);
        // The longest vector gets about 15 % of the plot's span.
        let k = if max > 0.0 {
            nice_floor(0.15 * span / max).max(1.0)
        } else {
            1.0
        };
        Errors { each, max, k }
    }
}

/// Each target's ring and magnified error arrow (a cross for one not found),
/// then the labels: arrows and rings first, then each label where it covers
/// none of them (nor another label), as a fixed offset put labels over
/// arrows pointing up and right.
fn error_vectors(f: &mut Figure, r: &ResultFile, v: &SurveyView, e: &Errors) {
    let (panel, k) = (&v.panel, e.k);
    let mut segs: Vec<Seg> = Vec::new();
    let mut rings: Vec<(f64, f64)> = Vec::new();
    let mut labels: Vec<((f64, f64), String, crate::report::figure::Color)> = Vec::new();
    for ((t, p), e) in r.targets.iter().zip(&v.rel).zip(&e.each) {
        let s = panel.map(p.0, p.1);
        rings.push(s);
        match e {
            Some(e) => {
                let tip = panel.map(p.0 + k * e.0, p.1 + k * e.1);
                if (tip.0 - s.0).hypot(tip.1 - s.1) > 1.0 {
                    f.items.push(Item::Arrow {
                        a: s,
                        b: tip,
                        color: palette::PLATE1,
                        width: 2.0,
                    });
                    segs.push((s, tip));
                }
                f.marker(s, MarkerKind::Ring, 5.0, palette::SURVEY);
                labels.push((s, target_label(&t.id), palette::INK));
            }
            None => {
                f.marker(s, MarkerKind::Cross, 6.0, palette::ERROR);
                labels.push((
                    s,
                    format!("{} ({})", target_label(&t.id), t.status.replace('_', " ")),
                    palette::ERROR,
                ));
            }
        }
    }
    place_labels(f, panel, labels, &segs, &rings);
}
