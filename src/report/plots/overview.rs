//! The run-wide figures: survey and aligned positions with magnified error
//! vectors, and relative error against pair distance.

use super::{legend_dot, legend_line, legend_marker};
use crate::Point;
use crate::align::Alignment;
use crate::frame::Footprint;
use crate::record::ResultFile;
use crate::render::target_label;
use crate::report::figure::{
    Anchor, Color, Figure, Item, MarkerKind, Panel, nice_floor, nice_step, palette,
};
use crate::trajectory::Trajectory;

/// Surveyed positions and the aligned estimates, error vectors magnified,
/// over the map seen from above when its footprint is given (with the
/// map → survey alignment that places it).
pub fn overview(
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
    let base = f.items.len();
    panel.axes(&mut f, "", &lab("x"), &lab("y"));
    let mut shaded = false;
    if let Some((fp, al)) = map {
        // Over the panel's white ground, under its grid and everything else.
        let tiles = footprint_tiles(fp, al, &panel, (ox, oy));
        shaded = !tiles.is_empty();
        f.items.splice(base + 1..base + 1, tiles);
    }
    // The route over the map, under the targets: drawn through the same
    // alignment as the map, clipped to the panel.
    let drawn_route = match (route, map) {
        (Some(t), Some((_, al))) => {
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
        _ => false,
    };

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
    // Arrows and rings first, then each label where it covers none of them
    // (nor another label): a fixed offset put labels over arrows pointing
    // up and right.
    let mut segs: Vec<Seg> = Vec::new();
    let mut rings: Vec<(f64, f64)> = Vec::new();
    let mut labels: Vec<((f64, f64), String, crate::report::figure::Color)> = Vec::new();
    for ((t, p), e) in r.targets.iter().zip(&rel).zip(&errs) {
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
    let frame = (
        panel.px.0,
        panel.px.1,
        panel.px.0 + panel.px.2,
        panel.px.1 + panel.px.3,
    );
    let mut placed: Vec<Rect> = Vec::new();
    for (s, text, color) in labels {
        let (at, anchor, b) = place_label(s, &text, &segs, &rings, &placed, frame);
        placed.push(b);
        f.text(at, &text, 12.0, color, anchor);
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
    if drawn_route {
        legend_line(
            &mut f,
            (lx, 330.0),
            palette::SAMPLE,
            1.5,
            false,
            "the trajectory",
        );
    }
    if shaded {
        f.items.push(Item::Rect {
            at: (lx, 288.0),
            size: (18.0, 12.0),
            fill: Some(FOOTPRINT_SHADES[2]),
            stroke: None,
        });
        f.text(
            (lx + 24.0, 294.0),
            "the map from above",
            11.0,
            palette::INK,
            Anchor::Start,
        );
        f.text(
            (lx + 24.0, 308.0),
            "(darker: more covered)",
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

/// Shades of the map's footprint, from a few points in a pixel's square to
/// every part of it holding some.
const FOOTPRINT_SHADES: [Color; 4] = [
    Color(0xee, 0xf0, 0xf3),
    Color(0xdd, 0xe1, 0xe7),
    Color(0xcb, 0xd1, 0xd9),
    Color(0xb6, 0xbe, 0xc9),
];

/// The footprint as shaded squares of at least 3 px in the panel (survey
/// frame less `off`), each row's runs of one shade merged into one
/// rectangle: a few thousand items however big the map.
fn footprint_tiles(fp: &Footprint, al: &Alignment, panel: &Panel, off: (f64, f64)) -> Vec<Item> {
    let scale = panel.scale();
    if fp.cells.is_empty() || !(scale > 0.0) || !(fp.cell > 0.0) {
        return Vec::new();
    }
    let (l, t, w, h) = panel.px;
    // A whole number of cells a square (an unturned map's cells then fall
    // in one square each), and each cell's area spread over it by 3 × 3
    // samples: a turned map's cells straddle squares, and a cell counted
    // whole in the square of its centre leaves a moiré of holes.
    let cell_px = fp.cell * scale;
    let pc = cell_px * (3.0 / cell_px).ceil().max(1.0);
    let (nx, ny) = ((w / pc).ceil() as usize, (h / pc).ceil() as usize);
    let mut area = vec![0.0f64; nx * ny];
    const SUB: usize = 3;
    for (c, share) in &fp.cells {
        let a = *share as f64 * fp.cell * fp.cell / (SUB * SUB) as f64;
        for si in 0..SUB {
            for sj in 0..SUB {
                let d = |s: usize| ((s as f64 + 0.5) / SUB as f64 - 0.5) * fp.cell;
                let q = al.apply(&Point::new(c[0] + d(si), c[1] + d(sj), c[2]));
                let (px, py) = panel.map(q.x - off.0, q.y - off.1);
                let (i, j) = (((px - l) / pc).floor(), ((py - t) / pc).floor());
                if i >= 0.0 && j >= 0.0 && (i as usize) < nx && (j as usize) < ny {
                    area[j as usize * nx + i as usize] += a;
                }
            }
        }
    }
    let bin = (pc / scale).powi(2);
    let shade = |a: f64| -> Option<usize> {
        (a > 0.0).then(|| (((a / bin).min(1.0) * 4.0).ceil() as usize).clamp(1, 4) - 1)
    };
    let mut items = Vec::new();
    for j in 0..ny {
        let mut i = 0;
        while i < nx {
            let Some(s) = shade(area[j * nx + i]) else {
                i += 1;
                continue;
            };
            let start = i;
            while i < nx && shade(area[j * nx + i]) == Some(s) {
                i += 1;
            }
            let (x0, y0) = (l + start as f64 * pc, t + j as f64 * pc);
            items.push(Item::Rect {
                at: (x0, y0),
                size: (
                    ((i - start) as f64 * pc).min(l + w - x0),
                    pc.min(t + h - y0),
                ),
                fill: Some(FOOTPRINT_SHADES[s]),
                stroke: None,
            });
        }
    }
    items
}

/// A label's box in pixels: left, top, right, bottom.
type Rect = (f64, f64, f64, f64);
/// An arrow from tail to head, in pixels.
type Seg = ((f64, f64), (f64, f64));

/// Where a 12 px label of a marker at `s` goes: the first of eight places
/// around it that overlaps the fewest arrows, markers, labels already placed
/// and the panel's edge (upper right when nothing is in the way).
fn place_label(
    s: (f64, f64),
    text: &str,
    segs: &[Seg],
    rings: &[(f64, f64)],
    placed: &[Rect],
    frame: Rect,
) -> ((f64, f64), Anchor, Rect) {
    // DejaVu Sans at 12 px: about 7.2 px a character, 12 px high.
    let w = 7.2 * text.chars().count() as f64;
    let h = 12.0;
    let candidates = [
        (8.0, -10.0, Anchor::Start),
        (8.0, 10.0, Anchor::Start),
        (-8.0, -10.0, Anchor::End),
        (-8.0, 10.0, Anchor::End),
        (9.0, 0.0, Anchor::Start),
        (-9.0, 0.0, Anchor::End),
        (0.0, -15.0, Anchor::Middle),
        (0.0, 15.0, Anchor::Middle),
    ];
    let boxed = |dx: f64, dy: f64, a: Anchor| -> Rect {
        let x = s.0 + dx;
        let y = s.1 + dy;
        let left = match a {
            Anchor::Start => x,
            Anchor::End => x - w,
            Anchor::Middle => x - w / 2.0,
        };
        (
            left - 1.0,
            y - h / 2.0 - 1.0,
            left + w + 1.0,
            y + h / 2.0 + 1.0,
        )
    };
    let inside = |b: &Rect, p: (f64, f64)| p.0 >= b.0 && p.0 <= b.2 && p.1 >= b.1 && p.1 <= b.3;
    let cost = |b: &Rect| -> usize {
        let mut c = 0;
        for (a, e) in segs {
            // An arrow crossing the box: sampled along its length and head.
            if (0..=12).any(|i| {
                let t = i as f64 / 12.0;
                inside(b, (a.0 + t * (e.0 - a.0), a.1 + t * (e.1 - a.1)))
            }) {
                c += 3;
            }
        }
        for r in rings {
            let grown = (b.0 - 5.0, b.1 - 5.0, b.2 + 5.0, b.3 + 5.0);
            if inside(&grown, *r) {
                c += 2;
            }
        }
        for p in placed {
            if b.0 < p.2 && p.0 < b.2 && b.1 < p.3 && p.1 < b.3 {
                c += 3;
            }
        }
        if b.0 < frame.0 || b.2 > frame.2 || b.1 < frame.1 || b.3 > frame.3 {
            c += 1;
        }
        c
    };
    let mut best: Option<(usize, (f64, f64), Anchor, Rect)> = None;
    for (dx, dy, a) in candidates {
        let b = boxed(dx, dy, a);
        let c = cost(&b);
        if best.as_ref().is_none_or(|x| c < x.0) {
            best = Some((c, (s.0 + dx, s.1 + dy), a, b));
        }
        if c == 0 {
            break;
        }
    }
    let (_, at, a, b) = best.unwrap_or((
        0,
        (s.0 + 8.0, s.1 - 10.0),
        Anchor::Start,
        boxed(8.0, -10.0, Anchor::Start),
    ));
    (at, a, b)
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
    legend_line(
        &mut f,
        (lx, 96.0),
        palette::SAMPLE,
        2.0,
        false,
        "least-squares line",
    );
    legend_line(
        &mut f,
        (lx, 118.0),
        palette::OUTLIER,
        1.0,
        true,
        "E_rel (mean)",
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

#[cfg(test)]
mod tests;
