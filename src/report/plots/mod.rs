//! The report's figures, built from what `eval` produced: the overview of
//! target positions, relative error against pair distance, and one panel per
//! target (top view, side view, spread of samples; the loose crop for failures).

use crate::Point;
use crate::align::Alignment;
use crate::record::TargetOut;
use crate::report::Report;
use crate::report::figure::{Anchor, Color, Figure, Item, MarkerKind, palette};

mod errors;
mod overview;
mod relative;
mod target;

pub(crate) use errors::along_route;
pub(crate) use errors::cdf;
pub use errors::{ROUTE_FAR_M, located_stations};
pub(crate) use overview::fmt_len;
pub(crate) use overview::overview;
pub(crate) use relative::fit_line;
pub(crate) use relative::relative;
use target::target_figure;
pub(crate) use target::{LooseView, loose_figure};

/// Most crop points drawn per view: keeps report.html small (a few hundred kB).
pub(crate) const MAX_POINTS_PER_VIEW: usize = 3000;

/// Every figure of a report, in page order.
pub(crate) fn figures(rep: &Report) -> Vec<Figure> {
    let mut v = vec![
        overview(
            rep.result,
            rep.footprint.map(|f| (f, &rep.alignment)),
            rep.trajectory.as_ref(),
        ),
        relative(rep.result),
        cdf(rep.result),
    ];
    if let Some(t) = &rep.trajectory {
        v.push(along_route(rep.result, t));
    }
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
pub(crate) fn survey_in_map(alignment: &Alignment, t: &TargetOut) -> Point {
    let s = Point::new(t.survey.x, t.survey.y, t.survey.z.unwrap_or(0.0));
    alignment.inverse().apply(&s)
}

pub(super) fn legend_dot(f: &mut Figure, at: (f64, f64), color: Color, text: &str) {
    f.items.push(Item::Dots {
        xy: vec![at],
        r: 4.0,
        color,
    });
    f.text((at.0 + 10.0, at.1), text, 11.0, palette::INK, Anchor::Start);
}

/// A legend entry: a short line of `color` (dashed or not) and its text.
pub(super) fn legend_line(
    f: &mut Figure,
    at: (f64, f64),
    color: Color,
    width: f64,
    dashed: bool,
    text: &str,
) {
    f.line(at, (at.0 + 22.0, at.1), color, width, dashed);
    f.text((at.0 + 30.0, at.1), text, 11.0, palette::INK, Anchor::Start);
}

pub(super) fn legend_marker(
    f: &mut Figure,
    at: (f64, f64),
    kind: MarkerKind,
    color: Color,
    text: &str,
) {
    f.marker(at, kind, 5.0, color);
    f.text((at.0 + 10.0, at.1), text, 11.0, palette::INK, Anchor::Start);
}

/// Greedy word wrap at `width` characters.
pub(crate) fn wrap(s: &str, width: usize) -> Vec<String> {
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
    use crate::locate::Label;
    use crate::report::TargetView;

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
            circle: None,
            board: None,
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
            footprint: None,
            trajectory: None,
        };
        let figs = figures(&rep);
        assert_eq!(figs.len(), 7);
        // Two crop views each, at most MAX_POINTS_PER_VIEW apiece, plus samples and legend.
        for f in &figs[3..] {
            assert!(
                f.dot_count() <= 2 * MAX_POINTS_PER_VIEW + 100 + 10,
                "{}: {}",
                f.name,
                f.dot_count()
            );
        }
        assert!(figs[3].dot_count() > 2000, "the located target is drawn");
        assert!(
            figs[6].dot_count() > 2000,
            "the failed target's crops are drawn"
        );
    }

    /// A target not found because of what stood there: the panel draws that
    /// object's faces where the crop saw them, and names it in the legend.
    #[test]
    fn a_refused_object_is_drawn_on_the_loose_crop() {
        use crate::record::{EvalInfo, TargetDetail};
        let mut r = crate::report::html::tests::result(&["1", "2", "3", "4"]);
        let e = r.targets[3].survey;
        let seen = crate::crop::Seen {
            what: "a plane continuing 2.1 m past the corner".into(),
            at: [e.x + 0.8, e.y - 0.3],
            faces: Some([[e.x + 1.4, e.y - 0.3], [e.x + 0.8, e.y + 0.3]]),
            from_expected: 0.85,
            plate_size: None,
        };
        r.eval = Some(EvalInfo {
            targets: vec![TargetDetail {
                id: "4".into(),
                expected: [e.x, e.y, 0.0],
                seen: Some(seen),
                ..Default::default()
            }],
            ..Default::default()
        });
        let pts: Vec<Point> = (0..400)
            .map(|i| Point::new(e.x - 2.0 + 0.01 * i as f64, e.y + 1.0, 0.1))
            .collect();
        let mut views = vec![crate::report::TargetView::default(); 4];
        views[3].loose = &pts;
        let rep = Report {
            result: &r,
            alignment: crate::report::alignment_of(&r),
            targets: views,
            provenance: Default::default(),
            footprint: None,
            trajectory: None,
        };
        let fig = &figures(&rep)[6];
        let faces = fig
            .items
            .iter()
            .filter(|it| matches!(it, Item::Line { color, width, .. } if *color == palette::ERROR && *width == 3.0))
            .count();
        assert_eq!(faces, 2);
        let legend = fig
            .items
            .iter()
            .any(|it| matches!(it, Item::Text { text, .. } if text == "object seen and refused"));
        assert!(legend);
        // Without it, nothing of the kind is drawn.
        r.eval.as_mut().unwrap().targets[0].seen = None;
        let rep = Report {
            result: &r,
            alignment: crate::report::alignment_of(&r),
            targets: {
                let mut v = vec![crate::report::TargetView::default(); 4];
                v[3].loose = &pts;
                v
            },
            provenance: Default::default(),
            footprint: None,
            trajectory: None,
        };
        let fig = &figures(&rep)[6];
        assert!(!fig.items.iter().any(|it| matches!(it, Item::Line { color, width, .. } if *color == palette::ERROR && *width == 3.0)));
    }
}
