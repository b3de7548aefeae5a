//! How the absolute errors are distributed: their cumulative distribution
//! (what share of targets is within a given error, against the NSSDA 95 %
//! figure), and against the distance driven, where SLAM drift grows.

use super::{fit_line, legend_dot, legend_line};
use crate::record::{ResultFile, TargetOut};
use crate::render::target_label;
use crate::report::figure::{Anchor, Figure, Item, Panel, palette};
use crate::trajectory::{Station, Trajectory};

/// A target farther than this from every point of the route (m) was not seen
/// from it: the trajectory is likely in another frame.
pub const ROUTE_FAR_M: f64 = 100.0;

/// Each located target with where it stands against `route` (in the frame
/// of the targets' map positions).
pub fn located_stations<'a>(
    r: &'a ResultFile,
    route: &Trajectory,
) -> Vec<(&'a TargetOut, Station)> {
    r.targets
        .iter()
        .filter(|t| t.status == "ok")
        .filter_map(|t| {
            let m = t.map?;
            Some((
                t,
                route.station(&crate::Point::new(m.x, m.y, m.z.unwrap_or(0.0)))?,
            ))
        })
        .collect()
}

/// Legend column's left edge.
const LX: f64 = 592.0;

/// The checkpoints' absolute errors (mm) with their labels, smallest first:
/// the targets NSSDA's figure is computed from (role=check ones when the
/// survey holds some out of the fit, else every scored target).
fn scored(r: &ResultFile) -> Vec<(f64, String)> {
    let mut e: Vec<(f64, String)> = r
        .targets
        .iter()
        .filter(|t| t.status == "ok")
        .filter(|t| !r.asprs.independent || t.role == Some(crate::survey::Role::Check))
        .filter_map(|t| t.abs_error.map(|e| (e * 1000.0, target_label(&t.id))))
        .collect();
    e.sort_by(|a, b| a.0.total_cmp(&b.0));
    e
}

/// The empirical CDF of the absolute errors, with E_abs and the NSSDA 95 %
/// horizontal value: a step well left of the 95 % line at 0.95 means the
/// normal model behind NSSDA overstates the tail, one right of it a tail
/// heavier than the model (a gross error).
pub(crate) fn cdf(r: &ResultFile) -> Figure {
    let mut f = Figure::new(
        "error-cdf",
        "Share of targets within each absolute error (empirical CDF)",
        780.0,
        380.0,
    );
    let e = scored(r);
    // NSSDA's figure is horizontal: beside 3D errors it would mislead.
    let horizontal = r.dim == crate::accuracy::Dim::D2;
    let nssda = if horizontal {
        r.asprs.nssda_horizontal_95 * 1000.0
    } else {
        f64::NAN
    };
    let xmax = e
        .iter()
        .map(|x| x.0)
        .chain(nssda.is_finite().then_some(nssda))
        .fold(0.0, f64::max)
        .max(1.0)
        * 1.1;
    let panel = Panel::new((70.0, 40.0, 500.0, 280.0), (0.0, xmax), (0.0, 1.05), false);
    panel.axes(
        &mut f,
        "",
        if horizontal {
            "absolute error (mm, horizontal)"
        } else {
            "absolute error (mm, 3D)"
        },
        "share of checkpoints within it",
    );
    cdf_steps(&mut f, &panel, &e, xmax);
    cdf_references(&mut f, &panel, r.absolute.mean * 1000.0, nssda, xmax);
    cdf_legend(&mut f, r, &e, nssda);
    f
}

/// The CDF itself: a staircase rising by one target's share at each error,
/// a dot on each step (labelled when few enough to read).
fn cdf_steps(f: &mut Figure, panel: &Panel, e: &[(f64, String)], xmax: f64) {
    let n = e.len() as f64;
    let mut pts = vec![panel.map(0.0, 0.0)];
    for (k, (v, _)) in e.iter().enumerate() {
        pts.push(panel.map(*v, k as f64 / n));
        pts.push(panel.map(*v, (k + 1) as f64 / n));
    }
    if let Some(last) = e.last() {
        pts.push(panel.map(xmax.max(last.0), 1.0));
    }
    f.items.push(Item::Polyline {
        pts,
        color: palette::PLATE1,
        width: 2.0,
    });
    f.items.push(Item::Dots {
        xy: e
            .iter()
            .enumerate()
            .map(|(k, (v, _))| panel.map(*v, (k + 1) as f64 / n))
            .collect(),
        r: 3.5,
        color: palette::PLATE1,
    });
    if e.len() <= 15 {
        for (k, (v, id)) in e.iter().enumerate() {
            let s = panel.map(*v, (k + 1) as f64 / n);
            f.text((s.0 + 6.0, s.1 + 9.0), id, 9.0, palette::INK, Anchor::Start);
        }
    }
}

/// What the staircase is read against: E_abs and NSSDA's value (mm) as
/// dashed verticals, and the 95 % share as a dashed horizontal.
fn cdf_references(f: &mut Figure, panel: &Panel, mean: f64, nssda: f64, xmax: f64) {
    let dashed = |f: &mut Figure, x: f64, c| {
        if x.is_finite() && x > 0.0 {
            f.line(panel.map(x, 0.0), panel.map(x, 1.05), c, 1.0, true);
        }
    };
    dashed(f, mean, palette::OUTLIER);
    dashed(f, nssda, palette::SURVEY);
    f.line(
        panel.map(0.0, 0.95),
        panel.map(xmax, 0.95),
        palette::GRID,
        1.0,
        true,
    );
}

/// The legend column: the marks, why NSSDA is missing from a 3D run, and
/// which targets were counted and over what range.
fn cdf_legend(f: &mut Figure, r: &ResultFile, e: &[(f64, String)], nssda: f64) {
    f.bold((LX, 50.0), "Legend", 12.0, Anchor::Start);
    legend_dot(f, (LX + 6.0, 74.0), palette::PLATE1, "one target");
    legend_line(f, (LX, 96.0), palette::OUTLIER, 1.0, true, "E_abs (mean)");
    if nssda.is_finite() {
        legend_line(
            f,
            (LX, 118.0),
            palette::SURVEY,
            1.0,
            true,
            "NSSDA 95 % horizontal",
        );
    } else {
        f.text(
            (LX, 118.0),
            "3D errors: NSSDA's horizontal",
            11.0,
            palette::INK,
            Anchor::Start,
        );
        f.text(
            (LX, 132.0),
            "figure is not drawn",
            11.0,
            palette::INK,
            Anchor::Start,
        );
    }
    f.text(
        (LX, 150.0),
        &format!(
            "{} {}",
            e.len(),
            if r.asprs.independent {
                "check targets (held out of the fit)"
            } else {
                "targets scored"
            }
        ),
        11.0,
        palette::INK,
        Anchor::Start,
    );
    if let (Some(a), Some(b)) = (e.first(), e.last()) {
        f.text(
            (LX, 168.0),
            &format!("from {:.1} to {:.1} mm", a.0, b.0),
            11.0,
            palette::INK,
            Anchor::Start,
        );
    }
}

/// Each scored target's absolute error against the distance along the
/// route to the point of it closest to the target, with a least-squares
/// line: drift that grows with distance driven shows as a slope. `route` is
/// in the frame of the targets' map positions.
pub(crate) fn along_route(r: &ResultFile, route: &Trajectory) -> Figure {
    let mut f = Figure::new(
        "error-route",
        "Absolute error against the distance driven to each target",
        780.0,
        380.0,
    );
    let mut xy: Vec<(f64, f64, String, f64)> = located_stations(r, route)
        .into_iter()
        .filter_map(|(t, s)| Some((s.along, t.abs_error? * 1000.0, target_label(&t.id), s.off)))
        .collect();
    xy.sort_by(|a, b| a.0.total_cmp(&b.0));
    let length = route.length();
    let xmax = xy.iter().map(|p| p.0).fold(length, f64::max).max(1.0);
    let ymax = xy.iter().map(|p| p.1).fold(0.0, f64::max).max(1.0) * 1.15;
    let panel = Panel::new((70.0, 40.0, 500.0, 280.0), (0.0, xmax), (0.0, ymax), false);
    panel.axes(
        &mut f,
        "",
        "distance along the route to the target (m)",
        "absolute error (mm)",
    );
    let pts: Vec<(f64, f64)> = xy.iter().map(|p| (p.0, p.1)).collect();
    let fit = fit_line(&pts);
    if let Some((a, b)) = fit
        && let Some((p, q)) = panel.clip((0.0, a), (xmax, a + b * xmax))
    {
        f.line(p, q, palette::SAMPLE, 2.0, false);
    }
    f.items.push(Item::Dots {
        xy: pts.iter().map(|p| panel.map(p.0, p.1)).collect(),
        r: 4.5,
        color: palette::PLATE1,
    });
    if xy.len() <= 15 {
        for (x, y, id, _) in &xy {
            let s = panel.map(*x, *y);
            f.text((s.0 + 7.0, s.1 - 8.0), id, 9.0, palette::INK, Anchor::Start);
        }
    }
    f.bold((LX, 50.0), "Legend", 12.0, Anchor::Start);
    legend_dot(&mut f, (LX + 6.0, 74.0), palette::PLATE1, "one target");
    legend_line(
        &mut f,
        (LX, 96.0),
        palette::SAMPLE,
        2.0,
        false,
        "least-squares line",
    );
    let mut y = 128.0;
    let mut line = |f: &mut Figure, s: String| {
        f.text((LX, y), &s, 11.0, palette::INK, Anchor::Start);
        y += 18.0;
    };
    line(
        &mut f,
        format!("route {:.0} m, {} poses", length, route.positions.len()),
    );
    match fit {
        Some((_, b)) => line(&mut f, format!("slope {:.2} mm per 100 m", b * 100.0)),
        None if xy.len() >= 2 => line(&mut f, "no spread along the route for a line".into()),
        None => line(&mut f, "too few targets for a line".into()),
    }
    let far = xy.iter().map(|p| p.3).fold(0.0, f64::max);
    line(&mut f, format!("farthest target {far:.1} m off the route"));
    if far > ROUTE_FAR_M {
        // A sensor sees its targets from tens of metres: a route farther
        // from them is another frame's (or another run's).
        line(&mut f, "far from the route: is the trajectory".into());
        line(&mut f, "in the map's frame, of this run?".into());
    }
    f
}
