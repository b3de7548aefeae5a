//! The panels of a place where no target was taken: its loose crop from
//! above and from the side about where the target was looked for, what the
//! tight crop kept and refused there, and the reason.

use super::{LEGEND_Y, SIDE, THIRD, TOP, bounds, cloud, pad};
use crate::Point;
use crate::render::target_label;
use crate::report::figure::{Anchor, Color, Figure, MarkerKind, Panel, palette};
use crate::report::plots::{MAX_POINTS_PER_VIEW, legend_dot, legend_marker, wrap};

/// What a target's loose-crop panels show: a target not found in a scored
/// run, or any surveyed place of a run that could not score.
pub(crate) struct LooseView<'a> {
    /// Loose crop (map frame).
    pub(crate) loose: &'a [Point],
    /// Tight crop (map frame), empty when none was made.
    pub(crate) tight: &'a [Point],
    /// Where the target was looked for (map frame): the views' origin.
    pub(crate) expected: Point,
    /// The surveyed position in the map, when an alignment places it.
    pub(crate) survey: Option<Point>,
    /// The object the tight crop saw there and refused.
    pub(crate) seen: Option<&'a crate::crop::Seen>,
    /// A corner located there (a run that could not score still located some).
    pub(crate) corner: Option<Point>,
    /// `not_found`, `ambiguous`, `located`…
    pub(crate) status: &'a str,
    /// Why it was not taken (or what was found).
    pub(crate) reason: &'a str,
}

/// A figure of one place's loose crop alone (`stem` names it).
pub(crate) fn loose_figure(stem: &str, id: &str, v: &LooseView) -> Figure {
    let title = format!(
        "Target {}: {} — loose crop",
        target_label(id),
        v.status.replace('_', " ")
    );
    let mut f = Figure::new(stem, &title, 950.0, 366.0);
    loose_panels(&mut f, v);
    f
}

/// The crops' paint order: the loose crop behind the tight one.
const ORDER: [Color; 2] = [palette::OUTLIER, palette::TIGHT];

pub(super) fn loose_panels(f: &mut Figure, v: &LooseView) {
    loose_top(f, v);
    loose_side(f, v);
    reason(f, v);
    if v.loose.is_empty() {
        f.text(
            // Under the ring of where it was looked for, not over it.
            (TOP.0 + TOP.2 / 2.0, TOP.1 + TOP.3 / 2.0 + 22.0),
            "no points within the crop radius",
            11.0,
            palette::ERROR,
            Anchor::Middle,
        );
    }
    legend(f, v);
}

/// Both crops through `proj`, at most [`MAX_POINTS_PER_VIEW`] points between
/// them: two thirds loose, a third tight.
fn crops(f: &mut Figure, panel: &Panel, v: &LooseView, proj: impl Fn(&Point) -> (f64, f64)) {
    cloud(
        f,
        panel,
        v.loose,
        &proj,
        |_| palette::OUTLIER,
        &ORDER,
        MAX_POINTS_PER_VIEW * 2 / 3,
    );
    cloud(
        f,
        panel,
        v.tight,
        &proj,
        |_| palette::TIGHT,
        &ORDER,
        MAX_POINTS_PER_VIEW / 3,
    );
}

/// Top view, metres from where the target was looked for: the crops, the
/// object refused there, the survey and a corner located.
fn loose_top(f: &mut Figure, v: &LooseView) {
    let c = v.expected;
    let top_of = |p: &Point| (p.x - c.x, p.y - c.y);
    let (bx, by) = if v.loose.is_empty() {
        ((-5.0, 5.0), (-5.0, 5.0))
    } else {
        bounds(v.loose.iter().map(top_of))
    };
    let top = Panel::new(TOP, pad(bx, 0.2), pad(by, 0.2), true);
    top.axes(
        f,
        "loose crop, top view",
        "x − expected x (m)",
        "y − expected y (m)",
    );
    crops(f, &top, v, top_of);
    f.marker(top.map(0.0, 0.0), MarkerKind::Ring, 6.0, palette::ESTIMATE);
    if let Some(s) = v.seen {
        refused(f, &top, s, c);
    }
    // The survey's position (aligned into the map) and a corner located.
    let marks = [
        (v.survey, MarkerKind::Diamond, 6.0, palette::SURVEY),
        (v.corner, MarkerKind::Plus, 8.0, palette::ESTIMATE),
    ];
    for (p, kind, size, color) in marks {
        if let Some(p) = p.filter(|p| top.contains(p.x - c.x, p.y - c.y)) {
            f.marker(top.map(p.x - c.x, p.y - c.y), kind, size, color);
        }
    }
}

/// The object the crop saw and refused: its faces as thick lines, so the
/// user sees what stood there (a wall, a cabinet, a neighbour's target).
fn refused(f: &mut Figure, top: &Panel, s: &crate::crop::Seen, c: Point) {
    let at = (s.at[0] - c.x, s.at[1] - c.y);
    for e in s.faces.iter().flatten() {
        if let Some((a, b)) = top.clip(at, (e[0] - c.x, e[1] - c.y)) {
            f.line(a, b, palette::ERROR, 3.0, false);
        }
    }
    if top.contains(at.0, at.1) {
        f.marker(top.map(at.0, at.1), MarkerKind::Cross, 7.0, palette::ERROR);
    }
}

/// Side view looking north, metres from where the target was looked for.
fn loose_side(f: &mut Figure, v: &LooseView) {
    let c = v.expected;
    let side_of = |p: &Point| (p.x - c.x, p.z - c.z);
    let (sx, sz) = if v.loose.is_empty() {
        ((-5.0, 5.0), (-1.0, 1.0))
    } else {
        bounds(v.loose.iter().map(side_of))
    };
    let side = Panel::new(SIDE, pad(sx, 0.2), pad(sz, 0.2), true);
    side.axes(
        f,
        "loose crop, side view (looking north)",
        "x − expected x (m)",
        "z − expected z (m)",
    );
    crops(f, &side, v, side_of);
}

/// The status and the reason, wrapped, in the third column.
fn reason(f: &mut Figure, v: &LooseView) {
    f.bold(
        (THIRD.0, THIRD.1 - 10.0),
        &v.status.replace('_', " "),
        12.0,
        Anchor::Start,
    );
    let mut y = THIRD.1 + 12.0;
    for line in wrap(v.reason, 38).into_iter().take(14) {
        f.text((THIRD.0, y), &line, 11.0, palette::ERROR, Anchor::Start);
        y += 15.0;
    }
}

/// One legend line under the views.
fn legend(f: &mut Figure, v: &LooseView) {
    let y = LEGEND_Y;
    legend_dot(f, (60.0, y), palette::OUTLIER, "loose crop");
    legend_dot(f, (170.0, y), palette::TIGHT, "tight crop");
    legend_marker(
        f,
        (280.0, y),
        MarkerKind::Ring,
        palette::ESTIMATE,
        "where it was looked for",
    );
    // The third entry: the survey's position when an alignment places it,
    // else the corner located there (a run that could not score).
    if v.survey.is_some() {
        legend_marker(
            f,
            (470.0, y),
            MarkerKind::Diamond,
            palette::SURVEY,
            "survey (aligned into the map)",
        );
    } else if v.corner.is_some() {
        legend_marker(
            f,
            (470.0, y),
            MarkerKind::Plus,
            palette::ESTIMATE,
            "corner located",
        );
    }
    if v.seen.is_some() {
        legend_marker(
            f,
            (680.0, y),
            MarkerKind::Cross,
            palette::ERROR,
            "object seen and refused",
        );
    }
}
