//! The report's figures, built from what `eval` produced: the overview of
//! target positions, relative error against pair distance, and one panel per
//! target (top view, side view, spread of samples; the loose crop for failures).

use super::figure::{
    Anchor, Color, Figure, Item, MarkerKind, Panel, nice_floor, nice_step, palette, thin,
};
use super::{Report, TargetView};
use crate::Point;
use crate::align::Alignment;
use crate::locate::Label;
use crate::record::{ResultFile, TargetOut};
use crate::render::target_label;
use nalgebra::{Vector2, Vector3};

/// Most crop points drawn per view: keeps report.html small (a few hundred kB).
pub const MAX_POINTS_PER_VIEW: usize = 3000;

/// Every figure of a report, in page order.
pub fn figures(rep: &Report) -> Vec<Figure> {
    let mut v = vec![overview(rep.result), relative(rep.result)];
    let mut stems: Vec<String> = Vec::new();
    for (i, t) in rep.result.targets.iter().enumerate() {
        let mut stem = format!("target-{}", crate::survey::file_stem(&t.id));
        // Ids that differ only in unsafe characters must not share a file.
        if stems.contains(&stem) {
            stem = format!("{stem}-{i}");
        }
        stems.push(stem.clone());
        v.push(target_figure(rep, i, t, &stem));
    }
    v
}

/// The survey point of `t` in the map frame (through the inverse alignment).
pub fn survey_in_map(alignment: &Alignment, t: &TargetOut) -> Point {
    let s = Point::new(t.survey.x, t.survey.y, t.survey.z.unwrap_or(0.0));
    alignment.inverse().apply(&s)
}

fn legend_dot(f: &mut Figure, at: (f64, f64), color: Color, text: &str) {
    f.items.push(Item::Dots {
        xy: vec![at],
        r: 4.0,
        color,
    });
    f.text((at.0 + 10.0, at.1), text, 11.0, palette::INK, Anchor::Start);
}

fn legend_marker(f: &mut Figure, at: (f64, f64), kind: MarkerKind, color: Color, text: &str) {
    f.marker(at, kind, 5.0, color);
    f.text((at.0 + 10.0, at.1), text, 11.0, palette::INK, Anchor::Start);
}

/// Surveyed positions and the aligned estimates, error vectors magnified.
pub fn overview(r: &ResultFile) -> Figure {
    let mut f = Figure::new(
        "overview",
        "Surveyed target positions and aligned map estimates (error vectors magnified)",
        780.0,
        540.0,
    );
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
    let lab = |a: &str| {
        if big {
            format!(
                "{a} − {:.0} (m, survey frame)",
                if a == "x" { ox } else { oy }
            )
        } else {
            format!("{a} (m, survey frame)")
        }
    };
    panel.axes(&mut f, "", &lab("x"), &lab("y"));

    let errs: Vec<Option<(f64, f64)>> = r
        .targets
        .iter()
        .map(|t| {
            t.aligned
                .filter(|_| t.status == "ok")
                .map(|a| (a.x - t.survey.x, a.y - t.survey.y))
        })
        .collect();
    let max_err = errs
        .iter()
        .flatten()
        .map(|e| e.0.hypot(e.1))
        .fold(0.0, f64::max);
    // The longest vector gets about 15 % of the plot's span.
    let k = if max_err > 0.0 {
        nice_floor(0.15 * span / max_err).max(1.0)
    } else {
        1.0
    };
    for ((t, p), e) in r.targets.iter().zip(&rel).zip(&errs) {
        let s = panel.map(p.0, p.1);
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
                }
                f.marker(s, MarkerKind::Ring, 5.0, palette::SURVEY);
                f.text(
                    (s.0 + 8.0, s.1 - 10.0),
                    &target_label(&t.id),
                    12.0,
                    palette::INK,
                    Anchor::Start,
                );
            }
            None => {
                f.marker(s, MarkerKind::Cross, 6.0, palette::ERROR);
                f.text(
                    (s.0 + 8.0, s.1 - 10.0),
                    &format!("{} ({})", target_label(&t.id), t.status.replace('_', " ")),
                    12.0,
                    palette::ERROR,
                    Anchor::Start,
                );
            }
        }
    }
    // Legend with an error scale bar.
    let lx = 592.0;
    f.bold((lx, 50.0), "Legend", 12.0, Anchor::Start);
    legend_marker(
        &mut f,
        (lx + 6.0, 74.0),
        MarkerKind::Ring,
        palette::SURVEY,
        "surveyed position",
    );
    f.items.push(Item::Arrow {
        a: (lx, 98.0),
        b: (lx + 24.0, 98.0),
        color: palette::PLATE1,
        width: 2.0,
    });
    f.text(
        (lx + 30.0, 98.0),
        "aligned estimate",
        11.0,
        palette::INK,
        Anchor::Start,
    );
    f.text(
        (lx + 30.0, 112.0),
        "− survey (error)",
        11.0,
        palette::INK,
        Anchor::Start,
    );
    legend_marker(
        &mut f,
        (lx + 6.0, 136.0),
        MarkerKind::Cross,
        palette::ERROR,
        "not found",
    );
    f.bold(
        (lx, 170.0),
        &format!("errors magnified ×{}", fmt_k(k)),
        12.0,
        Anchor::Start,
    );
    if max_err > 0.0 {
        let unit = nice_step(max_err / 2.0);
        let len = unit * k * panel.scale();
        f.items.push(Item::Arrow {
            a: (lx, 192.0),
            b: (lx + len.min(170.0), 192.0),
            color: palette::PLATE1,
            width: 2.0,
        });
        f.text(
            (lx, 208.0),
            &format!(
                "= {} error{}",
                fmt_len(unit),
                if len > 170.0 { " (clipped)" } else { "" }
            ),
            11.0,
            palette::INK,
            Anchor::Start,
        );
        f.text(
            (lx, 230.0),
            &format!("largest: {}", fmt_len(max_err)),
            11.0,
            palette::INK,
            Anchor::Start,
        );
    }
    let n_ok = r.targets.iter().filter(|t| t.status == "ok").count();
    f.text(
        (lx, 252.0),
        &format!("{n_ok} of {} targets found", r.targets.len()),
        11.0,
        palette::INK,
        Anchor::Start,
    );
    f.text(
        (lx, 274.0),
        &format!("alignment: {}", r.alignment.method),
        11.0,
        palette::INK,
        Anchor::Start,
    );
    f
}

fn fmt_k(k: f64) -> String {
    if k >= 1.0 {
        format!("{k:.0}")
    } else {
        format!("{k}")
    }
}

/// A length in mm below 1 m, in m above.
pub fn fmt_len(m: f64) -> String {
    if m.abs() < 1.0 {
        format!("{:.1} mm", m * 1000.0)
    } else {
        format!("{m:.3} m")
    }
}

/// Least-squares line `y = a + b x`; `None` with fewer than 2 points or no spread in x.
pub fn fit_line(xy: &[(f64, f64)]) -> Option<(f64, f64)> {
    if xy.len() < 2 {
        return None;
    }
    let n = xy.len() as f64;
    let mx = xy.iter().map(|p| p.0).sum::<f64>() / n;
    let my = xy.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = xy.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = xy.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    if !(sxx > 1e-12 * n) {
        return None;
    }
    let b = sxy / sxx;
    Some((my - b * mx, b))
}

/// Relative error of every pair against the pairs' surveyed distance, with a
/// least-squares line (the paper observes that the error grows with distance).
pub fn relative(r: &ResultFile) -> Figure {
    let mut f = Figure::new(
        "relative",
        "Relative error against pair distance, with a least-squares line",
        780.0,
        420.0,
    );
    let xy: Vec<(f64, f64)> = r
        .relative
        .pairs
        .iter()
        .map(|p| (p.survey_distance, p.error * 1000.0))
        .collect();
    let xmax = xy.iter().map(|p| p.0).fold(0.0, f64::max).max(1.0);
    let ymax = xy.iter().map(|p| p.1).fold(0.0, f64::max).max(1.0);
    let panel = Panel::new(
        (70.0, 40.0, 500.0, 320.0),
        (0.0, xmax * 1.08),
        (0.0, ymax * 1.15),
        false,
    );
    panel.axes(
        &mut f,
        "",
        "surveyed distance between the two targets (m)",
        "relative error (mm)",
    );
    let fit = fit_line(&xy);
    if let Some((a, b)) = fit {
        let (xa, xb) = (panel.x.0, panel.x.1);
        if let Some((p, q)) = panel.clip((xa, a + b * xa), (xb, a + b * xb)) {
            f.line(p, q, palette::SAMPLE, 2.0, false);
        }
    }
    if r.relative.n > 0 && r.relative.mean.is_finite() {
        let m = r.relative.mean * 1000.0;
        f.line(
            panel.map(panel.x.0, m),
            panel.map(panel.x.1, m),
            palette::OUTLIER,
            1.0,
            true,
        );
    }
    f.items.push(Item::Dots {
        xy: xy.iter().map(|p| panel.map(p.0, p.1)).collect(),
        r: 4.5,
        color: palette::PLATE1,
    });
    if xy.len() <= 15 {
        for (p, pair) in xy.iter().zip(&r.relative.pairs) {
            let s = panel.map(p.0, p.1);
            f.text(
                (s.0 + 7.0, s.1 - 8.0),
                &format!("{}&{}", target_label(&pair.a), target_label(&pair.b)),
                9.0,
                palette::INK,
                Anchor::Start,
            );
        }
    }
    let lx = 592.0;
    f.bold((lx, 50.0), "Legend", 12.0, Anchor::Start);
    legend_dot(&mut f, (lx + 6.0, 74.0), palette::PLATE1, "one target pair");
    f.line((lx, 96.0), (lx + 22.0, 96.0), palette::SAMPLE, 2.0, false);
    f.text(
        (lx + 30.0, 96.0),
        "least-squares line",
        11.0,
        palette::INK,
        Anchor::Start,
    );
    f.line((lx, 118.0), (lx + 22.0, 118.0), palette::OUTLIER, 1.0, true);
    f.text(
        (lx + 30.0, 118.0),
        "E_rel (mean)",
        11.0,
        palette::INK,
        Anchor::Start,
    );
    let mut y = 150.0;
    let mut line = |f: &mut Figure, s: String| {
        f.text((lx, y), &s, 11.0, palette::INK, Anchor::Start);
        y += 18.0;
    };
    line(&mut f, format!("{} pairs", xy.len()));
    match fit {
        Some((a, b)) => {
            line(&mut f, format!("slope {:.2} mm per 100 m", b * 100.0));
            line(&mut f, format!("intercept {a:.2} mm"));
            let n = xy.len() as f64;
            let my = xy.iter().map(|p| p.1).sum::<f64>() / n;
            let ss: f64 = xy.iter().map(|p| (p.1 - my).powi(2)).sum();
            let res: f64 = xy.iter().map(|p| (p.1 - a - b * p.0).powi(2)).sum();
            if ss > 0.0 {
                line(&mut f, format!("R² {:.2}", 1.0 - res / ss));
            }
        }
        None => line(&mut f, "too few pairs for a line".into()),
    }
    f
}

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

fn target_figure(rep: &Report, i: usize, t: &TargetOut, stem: &str) -> Figure {
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
    let mut f = Figure::new(stem, &title, 950.0, 350.0);
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
    match t.survey.z {
        Some(_) if side.contains(su, s.z - c.z) => f.marker(
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
    let m = dev
        .iter()
        .map(|p| p.0.abs().max(p.1.abs()))
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
    let n = dev.len().max(1) as f64;
    let sdx = (dev.iter().map(|p| p.0 * p.0).sum::<f64>() / n).sqrt();
    let sdy = (dev.iter().map(|p| p.1 * p.1).sum::<f64>() / n).sqrt();
    if sdx > 0.0 || sdy > 0.0 {
        let ring: Vec<(f64, f64)> = (0..=48)
            .map(|k| {
                let a = k as f64 / 48.0 * std::f64::consts::TAU;
                sp.map(2.0 * sdx * a.cos(), 2.0 * sdy * a.sin())
            })
            .collect();
        f.items.push(Item::Polyline {
            pts: ring,
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
        let below = if head.1 < THIRD.1 + 20.0 { 14.0 } else { -12.0 };
        let anchor = if e.0 > 0.0 {
            Anchor::End
        } else {
            Anchor::Start
        };
        f.text(
            (head.0, head.1 + below),
            &format!("survey at {l:.0} mm"),
            10.0,
            palette::SURVEY,
            anchor,
        );
    }
    f.text(
        (THIRD.0, THIRD.1 + THIRD.3 + 44.0),
        "ellipse: 2σ of the samples",
        10.0,
        palette::INK,
        Anchor::Start,
    );

    // One legend line under the views.
    let y = 338.0;
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
    let expected = rep
        .result
        .eval
        .as_ref()
        .and_then(|e| e.targets.iter().find(|d| d.id == t.id).or(e.targets.get(i)))
        .map(|d| Point::new(d.expected[0], d.expected[1], d.expected[2]));
    let c = expected.unwrap_or_else(|| survey_in_map(&rep.alignment, t));
    let loose = view.loose;
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
        view.tight,
        top_of,
        |_| palette::TIGHT,
        &order,
        MAX_POINTS_PER_VIEW / 3,
    );
    f.marker(top.map(0.0, 0.0), MarkerKind::Ring, 6.0, palette::ESTIMATE);
    let s = survey_in_map(&rep.alignment, t);
    if top.contains(s.x - c.x, s.y - c.y) {
        f.marker(
            top.map(s.x - c.x, s.y - c.y),
            MarkerKind::Diamond,
            6.0,
            palette::SURVEY,
        );
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
        view.tight,
        side_of,
        |_| palette::TIGHT,
        &order,
        MAX_POINTS_PER_VIEW / 3,
    );
    // The reason, wrapped, in the third column.
    f.bold(
        (THIRD.0, THIRD.1 - 10.0),
        &format!("{}", t.status.replace('_', " ")),
        12.0,
        Anchor::Start,
    );
    let reason = t.reason.as_deref().unwrap_or("no reason recorded");
    let mut y = THIRD.1 + 12.0;
    for line in wrap(reason, 38).into_iter().take(14) {
        f.text((THIRD.0, y), &line, 11.0, palette::ERROR, Anchor::Start);
        y += 15.0;
    }
    if loose.is_empty() {
        f.text(
            (TOP.0 + TOP.2 / 2.0, TOP.1 + TOP.3 / 2.0),
            "no points within the crop radius",
            11.0,
            palette::ERROR,
            Anchor::Middle,
        );
    }
    let y = 338.0;
    legend_dot(f, (60.0, y), palette::OUTLIER, "loose crop");
    legend_dot(f, (170.0, y), palette::TIGHT, "tight crop");
    legend_marker(
        f,
        (280.0, y),
        MarkerKind::Ring,
        palette::ESTIMATE,
        "where it was looked for",
    );
    legend_marker(
        f,
        (470.0, y),
        MarkerKind::Diamond,
        palette::SURVEY,
        "survey (aligned into the map)",
    );
}

/// Greedy word wrap at `width` characters.
pub fn wrap(s: &str, width: usize) -> Vec<String> {
    let mut out = Vec::new();
    let mut cur = String::new();
    for w in s.split_whitespace() {
        if !cur.is_empty() && cur.chars().count() + 1 + w.chars().count() > width {
            out.push(std::mem::take(&mut cur));
        }
        if !cur.is_empty() {
            cur.push(' ');
        }
        cur.push_str(w);
    }
    if !cur.is_empty() {
        out.push(cur);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_fit_and_wrap() {
        let (a, b) = fit_line(&[(0.0, 1.0), (1.0, 3.0), (2.0, 5.0)]).unwrap();
        assert!((a - 1.0).abs() < 1e-12 && (b - 2.0).abs() < 1e-12);
        assert!(fit_line(&[(1.0, 1.0), (1.0, 2.0)]).is_none());
        assert!(fit_line(&[(1.0, 1.0)]).is_none());
        assert_eq!(wrap("aa bb cc dd", 5), vec!["aa bb", "cc dd"]);
    }

    #[test]
    fn crop_views_are_thinned() {
        use crate::report::Diagnostics;
        let r = crate::report::html::tests::result(&["1", "2", "3", "4"]);
        // 20 000 points on two plates around target 1's corner, and a big loose crop.
        let c = r.targets[0].map.map(|m| Point::new(m.x, m.y, 0.0)).unwrap();
        let pts: Vec<Point> = (0..20_000)
            .map(|i| {
                let s = (i % 100) as f64 * 0.006;
                let z = (i / 200) as f64 * 0.006;
                if i % 2 == 0 {
                    Point::new(c.x + s, c.y, z)
                } else {
                    Point::new(c.x, c.y + s, z)
                }
            })
            .collect();
        let labels: Vec<Label> = (0..pts.len())
            .map(|i| {
                if i % 2 == 0 {
                    Label::Plate1
                } else {
                    Label::Plate2
                }
            })
            .collect();
        let samples = vec![c; 100];
        let diag = Diagnostics {
            labels: &labels,
            plate_normals: Some([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0]]),
            corner: Some(c),
            samples: &samples,
        };
        let mut views = vec![TargetView::default(); 4];
        views[0] = TargetView {
            loose: &pts,
            tight: &pts,
            diag: Some(diag),
        };
        views[3] = TargetView {
            loose: &pts,
            tight: &pts,
            diag: None,
        };
        let rep = Report {
            result: &r,
            alignment: crate::report::alignment_of(&r),
            targets: views,
            provenance: Default::default(),
        };
        let figs = figures(&rep);
        assert_eq!(figs.len(), 6);
        // Two crop views each, at most MAX_POINTS_PER_VIEW apiece, plus samples and legend.
        for f in &figs[2..] {
            assert!(
                f.dot_count() <= 2 * MAX_POINTS_PER_VIEW + 100 + 10,
                "{}: {}",
                f.name,
                f.dot_count()
            );
        }
        assert!(figs[2].dot_count() > 2000, "the located target is drawn");
        assert!(
            figs[5].dot_count() > 2000,
            "the failed target's crops are drawn"
        );
    }
}
