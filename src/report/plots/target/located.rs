//! The panels of a located target: its tight crop from above and from the
//! side, coloured by each point's plate, and the spread of the corner's
//! samples; each drawn from the corner located.

use super::{LEGEND_Y, SIDE, THIRD, TOP, bounds, cloud, pad};
use crate::Point;
use crate::locate::Label;
use crate::model::ModelKind;
use crate::record::TargetOut;
use crate::report::figure::{Anchor, Color, Figure, Item, MarkerKind, Panel, palette};
use crate::report::plots::{MAX_POINTS_PER_VIEW, legend_dot, legend_marker, survey_in_map};
use crate::report::{Diagnostics, Report, TargetView};
use nalgebra::{Vector2, Vector3};

fn label_color(l: Label) -> Color {
    match l {
        Label::Plate1 => palette::PLATE1,
        Label::Plate2 => palette::PLATE2,
        Label::Outlier => palette::OUTLIER,
    }
}

/// The crops' paint order: outliers behind the plates.
const ORDER: [Color; 3] = [palette::OUTLIER, palette::PLATE1, palette::PLATE2];

/// What the views of a located target share: the tight crop and what
/// localisation kept of it, the corner every view is drawn from, and the
/// survey's position in the map.
struct Located<'a> {
    tight: &'a [Point],
    d: Diagnostics<'a>,
    /// The corner located (map frame).
    c: Point,
    /// The survey's position (map frame).
    s: Point,
    /// The survey's horizontal offset from the corner (m).
    ds: (f64, f64),
    /// Whether every tight-crop point has its role (else all are outliers).
    labels_ok: bool,
}

impl Located<'_> {
    /// What the estimate is: an L's corner, a sphere's centre or a
    /// board's crossing.
    fn point(&self) -> &'static str {
        if self.d.circle.is_some() {
            "centre"
        } else if self.d.board.is_some() {
            "crossing"
        } else {
            "corner"
        }
    }

    /// Point `i`'s role in the fit.
    fn label(&self, i: usize) -> Label {
        if self.labels_ok {
            self.d.labels[i]
        } else {
            Label::Outlier
        }
    }

    /// Point `i`'s colour: its plate's, or an outlier's.
    fn colour(&self, i: usize) -> Color {
        label_color(self.label(i))
    }
}

pub(super) fn located_panels(f: &mut Figure, rep: &Report, t: &TargetOut, view: &TargetView) {
    let Some(d) = view.diag else { return };
    let Some(c) = d.corner else { return };
    let tight = view.tight;
    let s = survey_in_map(&rep.alignment, t);
    let l = Located {
        tight,
        d,
        c,
        s,
        ds: (s.x - c.x, s.y - c.y),
        labels_ok: d.labels.len() == tight.len(),
    };
    let dirs = top_view(f, &l);
    match l.d.board {
        Some(b) => face_view(f, &l, &b),
        None => side_view(f, rep, t, &l, &dirs),
    }
    spread_view(f, t, &l);
    legend(
        f,
        match (l.d.circle, l.d.board) {
            (Some(_), _) => ModelKind::Sphere,
            (_, Some(_)) => ModelKind::Board,
            _ => ModelKind::L,
        },
    );
}

/// A bright square's points and a dark one's, in the face view.
const BRIGHT: Color = Color(0xd9, 0xa4, 0x0b);
const DARK: Color = Color(0x33, 0x33, 0x33);

/// A board's face, face on, metres from the crossing: its points coloured by
/// the square their intensity reads as, and the two fitted lines.
fn face_view(f: &mut Figure, l: &Located, b: &crate::report::BoardView) {
    let c = l.c;
    let n = Vector3::from(b.normal);
    let h = Vector3::z().cross(&n);
    let e0 = if h.norm() > 0.3 {
        h.normalize()
    } else {
        (Vector3::x() - n * n.x).normalize()
    };
    let e1 = n.cross(&e0);
    let e1 = if e1.z < 0.0 { -e1 } else { e1 };
    let face_of = |p: &Point| (e0.dot(&(p - c)), e1.dot(&(p - c)));
    let (sx, sz) = bounds(l.tight.iter().map(face_of));
    let side = Panel::new(SIDE, pad(sx, 0.08), pad(sz, 0.08), true);
    side.axes(
        f,
        "face view (the print)",
        "along the face (m)",
        "up the face (m)",
    );
    let ok = b.bright.len() == l.tight.len();
    cloud(
        f,
        &side,
        l.tight,
        face_of,
        |i| if ok && b.bright[i] { BRIGHT } else { DARK },
        &[DARK, BRIGHT],
        MAX_POINTS_PER_VIEW,
    );
    let reach = 2.0 * ((side.x.1 - side.x.0).abs() + (side.y.1 - side.y.0).abs());
    for d in b.lines {
        let d = Vector3::from(d);
        let (du, dv) = (e0.dot(&d) * reach, e1.dot(&d) * reach);
        if let Some((p, q)) = side.clip((-du, -dv), (du, dv)) {
            f.line(p, q, palette::ESTIMATE, 1.0, true);
        }
    }
    f.marker(side.map(0.0, 0.0), MarkerKind::Plus, 8.0, palette::ESTIMATE);
}

/// Top view, metres from the corner: the crop, each plate's trace, the
/// corner and the survey (when near enough to share the view); the plates'
/// directions away from the corner, for the side view.
fn top_view(f: &mut Figure, l: &Located) -> Vec<Vector2<f64>> {
    let (c, ds) = (l.c, l.ds);
    let (mut bx, mut by) = bounds(l.tight.iter().map(|p| (p.x - c.x, p.y - c.y)));
    if ds.0.hypot(ds.1) < 1.0 {
        bx = (bx.0.min(ds.0), bx.1.max(ds.0));
        by = (by.0.min(ds.1), by.1.max(ds.1));
    }
    let top = Panel::new(TOP, pad(bx, 0.08), pad(by, 0.08), true);
    let w = l.point();
    top.axes(
        f,
        "top view",
        &format!("x − {w} x (m)"),
        &format!("y − {w} y (m)"),
    );
    cloud(
        f,
        &top,
        l.tight,
        |p| (p.x - c.x, p.y - c.y),
        |i| l.colour(i),
        &ORDER,
        MAX_POINTS_PER_VIEW,
    );
    let dirs = plate_traces(f, &top, l);
    outline(f, &top, l.d.circle);
    f.marker(top.map(0.0, 0.0), MarkerKind::Plus, 8.0, palette::ESTIMATE);
    if top.contains(ds.0, ds.1) {
        f.marker(
            top.map(ds.0, ds.1),
            MarkerKind::Diamond,
            6.0,
            palette::SURVEY,
        );
    }
    dirs
}

/// A sphere's fitted outline about its centre (the view's origin): a
/// sphere cut through its centre is a circle in any view.
fn outline(f: &mut Figure, view: &Panel, radius: Option<f64>) {
    let Some(r) = radius else { return };
    let at = |k: usize| {
        let a = k as f64 * std::f64::consts::TAU / 72.0;
        (r * a.cos(), r * a.sin())
    };
    for k in 0..72 {
        let (p, q) = (at(k), at(k + 1));
        if let Some((p, q)) = view.clip(p, q) {
            f.line(p, q, palette::ESTIMATE, 1.0, false);
        }
    }
}

/// Plate traces: each plane's horizontal line, over its inliers' extent;
/// returns each plate's direction pointing along its inliers.
fn plate_traces(f: &mut Figure, top: &Panel, l: &Located) -> Vec<Vector2<f64>> {
    let (tight, c) = (l.tight, l.c);
    let mut dirs: Vec<Vector2<f64>> = Vec::new();
    if let Some(normals) = l.d.plate_normals {
        for (j, n) in normals.iter().enumerate() {
            let want = if j == 0 { Label::Plate1 } else { Label::Plate2 };
            let dir = Vector2::new(-n[1], n[0]);
            if dir.norm() < 1e-9 {
                continue;
            }
            let dir = dir.normalize();
            let ts: Vec<f64> = (0..tight.len())
                .filter(|&i| l.label(i) == want)
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
    dirs
}

/// Side view: looking into the L (across the bisector of the plates'
/// directions `dirs`), so both plates show side by side, with the plates'
/// intersection line, the corner and the survey.
fn side_view(f: &mut Figure, rep: &Report, t: &TargetOut, l: &Located, dirs: &[Vector2<f64>]) {
    let c = l.c;
    let u = if dirs.len() == 2 && (dirs[0] + dirs[1]).norm() > 1e-6 {
        let b = (dirs[0] + dirs[1]).normalize();
        Vector2::new(-b.y, b.x)
    } else {
        Vector2::new(1.0, 0.0)
    };
    let side_of = |p: &Point| (u.dot(&Vector2::new(p.x - c.x, p.y - c.y)), p.z - c.z);
    let (sx, sz) = bounds(l.tight.iter().map(side_of));
    let side = Panel::new(SIDE, pad(sx, 0.08), pad(sz, 0.08), true);
    if l.d.circle.is_some() {
        side.axes(f, "side view", "across (m)", "z − centre z (m)");
    } else {
        side.axes(
            f,
            "side view (into the corner)",
            "across the L (m)",
            "z − corner z (m)",
        );
    }
    cloud(
        f,
        &side,
        l.tight,
        side_of,
        |i| l.colour(i),
        &ORDER,
        MAX_POINTS_PER_VIEW,
    );
    if let Some(n) = l.d.plate_normals {
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
    outline(f, &side, l.d.circle);
    f.marker(side.map(0.0, 0.0), MarkerKind::Plus, 8.0, palette::ESTIMATE);
    side_survey(f, rep, t, l, &side, u);
}

/// The survey in the side view: a point where its height is comparable,
/// else a dashed vertical at its position across the L.
fn side_survey(
    f: &mut Figure,
    rep: &Report,
    t: &TargetOut,
    l: &Located,
    side: &Panel,
    u: Vector2<f64>,
) {
    let (s, c, ds) = (l.s, l.c, l.ds);
    let su = u.dot(&Vector2::new(ds.0, ds.1));
    // A 2D alignment fits no height: the survey's z in the map frame is off by
    // the map's own height offset, so only its position across the L is drawn.
    let z_fitted = rep.alignment.method.uses_z();
    if t.survey.z.is_some() && !z_fitted {
        f.text(
            (SIDE.0, SIDE.1 + SIDE.3 + 44.0),
            &format!(
                "survey: {} position only ({} fits no height)",
                if l.d.circle.is_some() {
                    "across"
                } else {
                    "across-L"
                },
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
}

/// Sample spread, millimetres from the mean corner: the accepted samples,
/// the corner's 95 % ellipse and the survey (or an arrow towards it).
fn spread_view(f: &mut Figure, t: &TargetOut, l: &Located) {
    let (c, ds) = (l.c, l.ds);
    let dev: Vec<(f64, f64)> =
        l.d.samples
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
        &format!("x − {} (mm)", l.point()),
        &format!("y − {} (mm)", l.point()),
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
    spread_survey(f, &sp, (ds.0 * 1000.0, ds.1 * 1000.0), m);
    f.text(
        (THIRD.0, THIRD.1 + THIRD.3 + 44.0),
        if ellipse.is_some() {
            if l.d.circle.is_some() {
                "ellipse: 95 % of the centre's uncertainty"
            } else {
                "ellipse: 95 % of the corner's uncertainty"
            }
        } else {
            "no uncertainty recorded"
        },
        10.0,
        palette::INK,
        Anchor::Start,
    );
}

/// The survey in the spread panel (`smm`, mm from the corner; the panel
/// spans ±`m`): its mark when on scale, else an arrow at the edge pointing
/// at it with its distance under the panel.
fn spread_survey(f: &mut Figure, sp: &Panel, smm: (f64, f64), m: f64) {
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
}

/// One legend line under the views of a target of model `kind`.
fn legend(f: &mut Figure, kind: ModelKind) {
    let y = LEGEND_Y;
    let (x, what) = match kind {
        ModelKind::Sphere => {
            legend_dot(f, (60.0, y), palette::OUTLIER, "point near the sphere");
            (300.0, "estimated centre")
        }
        ModelKind::Board => {
            legend_dot(f, (60.0, y), BRIGHT, "bright square");
            legend_dot(f, (170.0, y), DARK, "dark square");
            (280.0, "estimated crossing")
        }
        ModelKind::L => {
            legend_dot(f, (60.0, y), palette::PLATE1, "plate 1");
            legend_dot(f, (140.0, y), palette::PLATE2, "plate 2");
            legend_dot(f, (220.0, y), palette::OUTLIER, "outlier");
            (300.0, "estimated corner")
        }
    };
    legend_marker(f, (x, y), MarkerKind::Plus, palette::ESTIMATE, what);
    legend_marker(
        f,
        (440.0, y),
        MarkerKind::Diamond,
        palette::SURVEY,
        "survey (aligned into the map)",
    );
    legend_dot(f, (660.0, y), palette::SAMPLE, "accepted sample");
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
