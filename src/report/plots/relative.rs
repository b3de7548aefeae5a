//! Relative error against pair distance: whether the map's error grows with
//! the distance between targets, as a least-squares line shows.

use super::{legend_dot, legend_line};
use crate::record::ResultFile;
use crate::render::target_label;
use crate::report::figure::{Anchor, Figure, Item, Panel, palette};

/// Legend column's left edge.
const LX: f64 = 592.0;

/// Relative error of every pair against the pairs' surveyed distance, with a
/// least-squares line (the paper observes that the error grows with distance).
pub(crate) fn relative(r: &ResultFile) -> Figure {
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
    trend_lines(&mut f, &panel, r, fit);
    pairs(&mut f, &panel, r, &xy);
    legend(&mut f, &xy, fit);
    f
}

/// What the pairs are read against: the least-squares line (clipped to the
/// panel) and E_rel, their mean, dashed.
fn trend_lines(f: &mut Figure, panel: &Panel, r: &ResultFile, fit: Option<(f64, f64)>) {
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
}

/// A dot a pair, named by its two targets when few enough to read.
fn pairs(f: &mut Figure, panel: &Panel, r: &ResultFile, xy: &[(f64, f64)]) {
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
}

/// The legend, then the line's slope, intercept and R² (how much of the
/// errors' spread the distance explains).
fn legend(f: &mut Figure, xy: &[(f64, f64)], fit: Option<(f64, f64)>) {
    f.bold((LX, 50.0), "Legend", 12.0, Anchor::Start);
    legend_dot(f, (LX + 6.0, 74.0), palette::PLATE1, "one target pair");
    legend_line(
        f,
        (LX, 96.0),
        palette::SAMPLE,
        2.0,
        false,
        "least-squares line",
    );
    legend_line(f, (LX, 118.0), palette::OUTLIER, 1.0, true, "E_rel (mean)");
    let mut y = 150.0;
    let mut line = |f: &mut Figure, s: String| {
        f.text((LX, y), &s, 11.0, palette::INK, Anchor::Start);
        y += 18.0;
    };
    line(f, format!("{} pairs", xy.len()));
    match fit {
        Some((a, b)) => {
            line(f, format!("slope {:.2} mm per 100 m", b * 100.0));
            line(f, format!("intercept {a:.2} mm"));
            let n = xy.len() as f64;
            let my = xy.iter().map(|p| p.1).sum::<f64>() / n;
            let ss: f64 = xy.iter().map(|p| (p.1 - my).powi(2)).sum();
            let res: f64 = xy.iter().map(|p| (p.1 - a - b * p.0).powi(2)).sum();
            if ss > 0.0 {
                line(f, format!("R² {:.2}", 1.0 - res / ss));
            }
        }
        None => line(f, "too few pairs for a line".into()),
    }
}

/// Least-squares line `y = a + b x`; `None` with fewer than 2 points or no spread in x.
pub(crate) fn fit_line(xy: &[(f64, f64)]) -> Option<(f64, f64)> {
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
