//! One figure per target: top and side views of its tight crop with the
//! fitted plates, the corner and the sample spread; or, for a target not
//! found, its loose crop and the reason.

use super::{MAX_POINTS_PER_VIEW, legend_dot, legend_marker, survey_in_map, wrap};
use crate::Point;
use crate::locate::Label;
use crate::record::TargetOut;
use crate::render::target_label;
use crate::report::figure::{Anchor, Color, Figure, Item, MarkerKind, Panel, palette, thin};
use crate::report::{Report, TargetView};
use nalgebra::{Vector2, Vector3};

fn label_color(l: Label) -> Color {
    match l {
        Label::Plate1 => palette::PLATE1,
        Label::Plate2 => palette::PLATE2,
        Label::Outlier => palette::OUTLIER,
    }
}

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

fn located_panels(f: &mut Figure, rep: &Report, t: &TargetOut, view: &TargetView) {
    let Some(d) = view.diag else { return };
    let Some(c) = d.corner else { return };
    let tight = view.tight;
    let labels_ok = d.labels.len() == tight.len();
    let label = |i: usize| {
        if labels_ok {
            d.labels[i]
        } else {
            Label::Outlier
        }
    };
    let colour = |i: usize| label_color(label(i));
    let order = [palette::OUTLIER, palette::PLATE1, palette::PLATE2];
    let s = survey_in_map(&rep.alignment, t);
    let ds = (s.x - c.x, s.y - c.y);

    // Top view, metres from the corner.
    let (mut bx, mut by) = bounds(tight.iter().map(|p| (p.x - c.x, p.y - c.y)));
    if ds.0.hypot(ds.1) < 1.0 {
        bx = (bx.0.min(ds.0), bx.1.max(ds.0));
        by = (by.0.min(ds.1), by.1.max(ds.1));
    }
    let top = Panel::new(TOP, pad(bx, 0.08), pad(by, 0.08), true);
    top.axes(f, "top view", "x − corner x (m)", "y − corner y (m)");
    cloud(
        f,
        &top,
        tight,
        |p| (p.x - c.x, p.y - c.y),
        colour,
        &order,
        MAX_POINTS_PER_VIEW,
    );
    // Plate traces: each plane's horizontal line, over its inliers' extent.
    let mut dirs: Vec<Vector2<f64>> = Vec::new();
    if let Some(normals) = d.plate_normals {
        for (j, n) in normals.iter().enumerate() {
            let want = if j == 0 { Label::Plate1 } else { Label::Plate2 };
            let dir = Vector2::new(-n[1], n[0]);
            if dir.norm() < 1e-9 {
                continue;
            }
            let dir = dir.normalize();
            let ts: Vec<f64> = (0..tight.len())
                .filter(|&i| label(i) == want)
                .map(|i| dir.dot(&Vector2::new(tight[i].x - c.x, tight[i].y - c.y)))
                .collect();
            let (lo, hi) = ts
                .iter()
                .fold((0.0f64, 0.0f64), |(a, b), &v| (a.min(v), b.max(v)));
            let mean = if ts.is_empty() {
                1.0
            } else {
                ts.iter().sum::<f64>() / ts.len() as f64
            };
            dirs.push(if mean < 0.0 { -dir } else { dir });
            let col = if j == 0 {
                Color(0x0b, 0x3d, 0x66)
            } else {
                Color(0x9a, 0x4a, 0x05)
            };
            f.line(
                top.map(dir.x * lo, dir.y * lo),
                top.map(dir.x * hi, dir.y * hi),
                col,
                2.5,
                false,
            );
        }
    }
    f.marker(top.map(0.0, 0.0), MarkerKind::Plus, 8.0, palette::ESTIMATE);
    if top.contains(ds.0, ds.1) {
        f.marker(
            top.map(ds.0, ds.1),
            MarkerKind::Diamond,
            6.0,
            palette::SURVEY,
        );
    }

    // Side view: looking into the L, so both plates show side by side.
    let u = if dirs.len() == 2 && (dirs[0] + dirs[1]).norm() > 1e-6 {
        let b = (dirs[0] + dirs[1]).normalize();
        Vector2::new(-b.y, b.x)
    } else {
        Vector2::new(1.0, 0.0)
    };
    let side_of = |p: &Point| (u.dot(&Vector2::new(p.x - c.x, p.y - c.y)), p.z - c.z);
    let (sx, sz) = bounds(tight.iter().map(side_of));
    let side = Panel::new(SIDE, pad(sx, 0.08), pad(sz, 0.08), true);
    side.axes(
        f,
        "side view (into the corner)",
        "across the L (m)",
        "z − corner z (m)",
    );
    cloud(
        f,
        &side,
        tight,
        side_of,
        colour,
        &order,
        MAX_POINTS_PER_VIEW,
    );
    if let Some(n) = d.plate_normals {
        // The plates' intersection line (the target's edge).
        let axis = Vector3::from(n[0]).cross(&Vector3::from(n[1]));
        if axis.norm() > 1e-9 {
            let a = axis.normalize();
            let a = if a.z < 0.0 { -a } else { a };
            let h = 2.0 * (side.y.1 - side.y.0) / a.z.abs().max(0.2);
            let s0 = u.dot(&Vector2::new(a.x, a.y));
            if let Some((p, q)) = side.clip((-s0 * h, -a.z * h), (s0 * h, a.z * h)) {
                f.line(p, q, palette::ESTIMATE, 1.0, true);
            }
        }
    }
    f.marker(side.map(0.0, 0.0), MarkerKind::Plus, 8.0, palette::ESTIMATE);
    let su = u.dot(&Vector2::new(ds.0, ds.1));
    // A 2D alignment fits no height: the survey's z in the map frame is off by
    // the map's own height offset, so only its position across the L is drawn.
    let z_fitted = rep.alignment.method.uses_z();
    if t.survey.z.is_some() && !z_fitted {
        f.text(
            (SIDE.0, SIDE.1 + SIDE.3 + 44.0),
            &format!(
                "survey: across-L position only ({} fits no height)",
                rep.alignment.method
            ),
            10.0,
            palette::SURVEY,
            Anchor::Start,
        );
    }
    match t.survey.z {
        Some(_) if z_fitted && side.contains(su, s.z - c.z) => f.marker(
            side.map(su, s.z - c.z),
            MarkerKind::Diamond,
            6.0,
            palette::SURVEY,
        ),
        _ if su >= side.x.0 && su <= side.x.1 => f.line(
            side.map(su, side.y.0),
            side.map(su, side.y.1),
            palette::SURVEY,
            1.0,
            true,
        ),
        _ => {}
    }

    // Sample spread, millimetres from the mean corner.
    let dev: Vec<(f64, f64)> = d
        .samples
        .iter()
        .map(|p| ((p.x - c.x) * 1000.0, (p.y - c.y) * 1000.0))
        .collect();
    // The 95 % ellipse of the corner's covariance (χ²₂ = 5.991), millimetres.
    let ellipse = t.map_covariance.and_then(|c| ellipse95_mm(&c));
    let m = dev
        .iter()
        .map(|p| p.0.abs().max(p.1.abs()))
        .chain(ellipse.iter().flatten().map(|p| p.0.abs().max(p.1.abs())))
        .fold(0.0, f64::max)
        .max(1.0)
        * 1.25;
    let sp = Panel::new(THIRD, (-m, m), (-m, m), true);
    sp.axes(
        f,
        &format!("{} samples (mm)", dev.len()),
        "x − corner (mm)",
        "y − corner (mm)",
    );
    f.items.push(Item::Dots {
        xy: dev.iter().map(|p| sp.map(p.0, p.1)).collect(),
        r: 2.0,
        color: palette::SAMPLE,
    });
    if let Some(ring) = &ellipse {
        f.items.push(Item::Polyline {
            pts: ring.iter().map(|p| sp.map(p.0, p.1)).collect(),
            color: Color(0x1e, 0x84, 0x49),
            width: 1.2,
        });
    }
    f.marker(sp.map(0.0, 0.0), MarkerKind::Plus, 8.0, palette::ESTIMATE);
    let smm = (ds.0 * 1000.0, ds.1 * 1000.0);
    if sp.contains(smm.0, smm.1) {
        f.marker(
            sp.map(smm.0, smm.1),
            MarkerKind::Diamond,
            6.0,
            palette::SURVEY,
        );
    } else {
        let l = smm.0.hypot(smm.1).max(1e-9);
        // Off scale: an arrow at the edge pointing at it, with its distance.
        let e = (smm.0 / l * m * 0.95, smm.1 / l * m * 0.95);
        let (tail, head) = (sp.map(e.0 * 0.6, e.1 * 0.6), sp.map(e.0, e.1));
        f.items.push(Item::Arrow {
            a: tail,
            b: head,
            color: palette::SURVEY,
            width: 1.5,
        });
        // Its distance under the panel, where it covers no sample.
        f.text(
            (THIRD.0, THIRD.1 + THIRD.3 + 58.0),
            &format!("survey off scale, {l:.0} mm away (red arrow)"),
            10.0,
            palette::SURVEY,
            Anchor::Start,
        );
    }
    f.text(
        (THIRD.0, THIRD.1 + THIRD.3 + 44.0),
        if ellipse.is_some() {
            "ellipse: 95 % of the corner's uncertainty"
        } else {
            "no uncertainty recorded"
        },
        10.0,
        palette::INK,
        Anchor::Start,
    );

    // One legend line under the views.
    let y = LEGEND_Y;
    legend_dot(f, (60.0, y), palette::PLATE1, "plate 1");
    legend_dot(f, (140.0, y), palette::PLATE2, "plate 2");
    legend_dot(f, (220.0, y), palette::OUTLIER, "outlier");
    legend_marker(
        f,
        (300.0, y),
        MarkerKind::Plus,
        palette::ESTIMATE,
        "estimated corner",
    );
    legend_marker(
        f,
        (440.0, y),
        MarkerKind::Diamond,
        palette::SURVEY,
        "survey (aligned into the map)",
    );
    legend_dot(f, (660.0, y), palette::SAMPLE, "accepted sample");
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

/// What a target's loose-crop panels show: a target not found in a scored
/// run, or any surveyed place of a run that could not score.
pub struct LooseView<'a> {
    /// Loose crop (map frame).
    pub loose: &'a [Point],
    /// Tight crop (map frame), empty when none was made.
    pub tight: &'a [Point],
    /// Where the target was looked for (map frame): the views' origin.
    pub expected: Point,
    /// The surveyed position in the map, when an alignment places it.
    pub survey: Option<Point>,
    /// The object the tight crop saw there and refused.
    pub seen: Option<&'a crate::crop::Seen>,
    /// A corner located there (a run that could not score still located some).
    pub corner: Option<Point>,
    /// `not_found`, `ambiguous`, `located`…
    pub status: &'a str,
    /// Why it was not taken (or what was found).
    pub reason: &'a str,
}

/// A figure of one place's loose crop alone (`stem` names it).
pub fn loose_figure(stem: &str, id: &str, v: &LooseView) -> Figure {
    let title = format!(
        "Target {}: {} — loose crop",
        target_label(id),
        v.status.replace('_', " ")
    );
    let mut f = Figure::new(stem, &title, 950.0, 366.0);
    loose_panels(&mut f, v);
    f
}

fn loose_panels(f: &mut Figure, v: &LooseView) {
    let c = v.expected;
    let loose = v.loose;
    let order = [palette::OUTLIER, palette::TIGHT];
    let top_of = |p: &Point| (p.x - c.x, p.y - c.y);
    let (bx, by) = if loose.is_empty() {
        ((-5.0, 5.0), (-5.0, 5.0))
    } else {
        bounds(loose.iter().map(top_of))
    };
    let top = Panel::new(TOP, pad(bx, 0.2), pad(by, 0.2), true);
    top.axes(
        f,
        "loose crop, top view",
        "x − expected x (m)",
        "y − expected y (m)",
    );
    cloud(
        f,
        &top,
        loose,
        top_of,
        |_| palette::OUTLIER,
        &order,
        MAX_POINTS_PER_VIEW * 2 / 3,
    );
    cloud(
        f,
        &top,
        v.tight,
        top_of,
        |_| palette::TIGHT,
        &order,
        MAX_POINTS_PER_VIEW / 3,
    );
    f.marker(top.map(0.0, 0.0), MarkerKind::Ring, 6.0, palette::ESTIMATE);
    // The object the crop saw and refused: its faces as thick lines, so the
    // user sees what stood there (a wall, a cabinet, a neighbour's target).
    let seen = v.seen;
    if let Some(s) = seen {
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
    let side_of = |p: &Point| (p.x - c.x, p.z - c.z);
    let (sx, sz) = if loose.is_empty() {
        ((-5.0, 5.0), (-1.0, 1.0))
    } else {
        bounds(loose.iter().map(side_of))
    };
    let side = Panel::new(SIDE, pad(sx, 0.2), pad(sz, 0.2), true);
    side.axes(
        f,
        "loose crop, side view (looking north)",
        "x − expected x (m)",
        "z − expected z (m)",
    );
    cloud(
        f,
        &side,
        loose,
        side_of,
        |_| palette::OUTLIER,
        &order,
        MAX_POINTS_PER_VIEW * 2 / 3,
    );
    cloud(
        f,
        &side,
        v.tight,
        side_of,
        |_| palette::TIGHT,
        &order,
        MAX_POINTS_PER_VIEW / 3,
    );
    // The reason, wrapped, in the third column.
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
    if loose.is_empty() {
        f.text(
            // Under the ring of where it was looked for, not over it.
            (TOP.0 + TOP.2 / 2.0, TOP.1 + TOP.3 / 2.0 + 22.0),
            "no points within the crop radius",
            11.0,
            palette::ERROR,
            Anchor::Middle,
        );
    }
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
    if seen.is_some() {
        legend_marker(
            f,
            (680.0, y),
            MarkerKind::Cross,
            palette::ERROR,
            "object seen and refused",
        );
    }
}

/// The horizontal 95 % ellipse (χ²₂ = 5.991) of a covariance (m²), as a closed
/// ring of points in millimetres about the corner; `None` when degenerate.
fn ellipse95_mm(c: &[[f64; 3]; 3]) -> Option<Vec<(f64, f64)>> {
    let (a, b, d) = (c[0][0], c[0][1], c[1][1]);
    // Eigen-decomposition of the symmetric 2×2 [[a, b], [b, d]].
    let tr = (a + d) / 2.0;
    let disc = (((a - d) / 2.0).powi(2) + b * b).sqrt();
    let (l1, l2) = (tr + disc, (tr - disc).max(0.0));
    if !(l1 > 0.0) || !l1.is_finite() {
        return None;
    }
    let theta = 0.5 * (2.0 * b).atan2(a - d);
    let k = 5.991_464_547_107_979f64.sqrt() * 1000.0;
    let (r1, r2) = (k * l1.sqrt(), k * l2.sqrt());
    let (st, ct) = theta.sin_cos();
    Some(
        (0..=48)
            .map(|i| {
                let t = i as f64 / 48.0 * std::f64::consts::TAU;
                let (u, v) = (r1 * t.cos(), r2 * t.sin());
                (ct * u - st * v, st * u + ct * v)
            })
            .collect(),
    )
}
