//! [`Figure`] → SVG text: inline in report.html and standalone for `--plots`.
//! Plain SVG 1.1 with presentation attributes only (no CSS, no script, no
//! external reference), so it renders the same in a browser, an editor or a
//! LaTeX toolchain.

use super::figure::{Anchor, Color, Figure, Item, MarkerKind};
use super::html::escape;
use std::fmt::Write as _;

/// Font stack for figure text: the DejaVu Sans the PNGs embed, else any sans.
const FONT: &str = "DejaVu Sans, Verdana, Arial, sans-serif";

fn n(v: f64) -> String {
    // One decimal is a tenth of a pixel: enough, and keeps clouds small.
    let r = (v * 10.0).round() / 10.0;
    if r == r.trunc() {
        format!("{}", r as i64)
    } else {
        format!("{r:.1}")
    }
}

/// The figure as an `<svg>` element (no XML declaration, fine inline in HTML
/// and as a file).
pub(crate) fn render(f: &Figure) -> String {
    let mut o = String::with_capacity(4096 + f.dot_count() * 14);
    let _ = write!(
        o,
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" viewBox=\"0 0 {w} {h}\" role=\"img\" font-family=\"{FONT}\">",
        w = n(f.width),
        h = n(f.height)
    );
    let _ = write!(o, "<title>{}</title>", escape(&f.title));
    let _ = write!(
        o,
        "<rect x=\"0\" y=\"0\" width=\"{}\" height=\"{}\" fill=\"#ffffff\"/>",
        n(f.width),
        n(f.height)
    );
    for item in &f.items {
        item_svg(&mut o, item);
    }
    o.push_str("</svg>");
    o
}

/// One item as SVG elements: the figure's kinds of mark map one to one
/// onto SVG's, so the page and a `--plots` file draw the same.
fn item_svg(o: &mut String, item: &Item) {
    match item {
        Item::Dots { xy, r, color } => {
            if xy.is_empty() {
                return;
            }
            // Zero-length subpaths with round caps are dots: ~12 bytes a point.
            let _ = write!(
                o,
                "<path fill=\"none\" stroke=\"{}\" stroke-width=\"{}\" stroke-linecap=\"round\" d=\"",
                color.hex(),
                n(2.0 * r)
            );
            for (x, y) in xy {
                let _ = write!(o, "M{} {}h0", n(*x), n(*y));
            }
            o.push_str("\"/>");
        }
        Item::Line {
            a,
            b,
            color,
            width,
            dashed,
        } => {
            let _ = write!(
                o,
                "<line x1=\"{}\" y1=\"{}\" x2=\"{}\" y2=\"{}\" stroke=\"{}\" stroke-width=\"{}\"{}/>",
                n(a.0),
                n(a.1),
                n(b.0),
                n(b.1),
                color.hex(),
                n(*width),
                if *dashed {
                    " stroke-dasharray=\"5 4\""
                } else {
                    ""
                }
            );
        }
        Item::Polyline { pts, color, width } => {
            let p: Vec<String> = pts
                .iter()
                .map(|(x, y)| format!("{},{}", n(*x), n(*y)))
                .collect();
            let _ = write!(
                o,
                "<polyline fill=\"none\" stroke=\"{}\" stroke-width=\"{}\" points=\"{}\"/>",
                color.hex(),
                n(*width),
                p.join(" ")
            );
        }
        Item::Rect {
            at,
            size,
            fill,
            stroke,
        } => {
            let _ = write!(
                o,
                "<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"{}\" stroke=\"{}\"/>",
                n(at.0),
                n(at.1),
                n(size.0),
                n(size.1),
                fill.map(|c| c.hex()).unwrap_or_else(|| "none".into()),
                stroke.map(|c| c.hex()).unwrap_or_else(|| "none".into()),
            );
        }
        Item::Arrow { a, b, color, width } => arrow(o, *a, *b, *color, *width),
        Item::Marker {
            at,
            kind,
            size,
            color,
            width,
        } => marker(o, *at, *kind, *size, &color.hex(), &n(*width)),
        Item::Text { .. } => text(o, item),
    }
}

/// A text item: SVG anchors it by its baseline, a figure by its centre.
fn text(o: &mut String, item: &Item) {
    let Item::Text {
        at,
        text,
        size,
        color,
        anchor,
        bold,
        vertical,
    } = item
    else {
        return;
    };
    let anchor = match anchor {
        Anchor::Start => "start",
        Anchor::Middle => "middle",
        Anchor::End => "end",
    };
    // `at` is the vertical centre; SVG places the baseline.
    let (x, y) = if *vertical {
        (at.0 + 0.35 * size, at.1)
    } else {
        (at.0, at.1 + 0.35 * size)
    };
    let rot = if *vertical {
        format!(" transform=\"rotate(-90 {} {})\"", n(x), n(y))
    } else {
        String::new()
    };
    let _ = write!(
        o,
        "<text x=\"{}\" y=\"{}\" font-size=\"{}\" fill=\"{}\" text-anchor=\"{anchor}\"{}{rot}>{}</text>",
        n(x),
        n(y),
        n(*size),
        color.hex(),
        if *bold { " font-weight=\"bold\"" } else { "" },
        escape(text)
    );
}

/// An arrow: its shaft as a line, its head as a filled triangle at `b`.
fn arrow(o: &mut String, a: (f64, f64), b: (f64, f64), color: Color, width: f64) {
    let (h1, h2) = arrow_head(a, b, 4.0 + 2.0 * width);
    let _ = write!(
        o,
        "<line x1=\"{}\" y1=\"{}\" x2=\"{}\" y2=\"{}\" stroke=\"{c}\" stroke-width=\"{}\"/><polygon fill=\"{c}\" points=\"{},{} {},{} {},{}\"/>",
        n(a.0),
        n(a.1),
        n(b.0),
        n(b.1),
        n(width),
        n(b.0),
        n(b.1),
        n(h1.0),
        n(h1.1),
        n(h2.0),
        n(h2.1),
        c = color.hex(),
    );
}

/// A marker's outline of half-size `s` about `at`, in colour `c` and stroke
/// width `sw` (both already as SVG text).
fn marker(o: &mut String, at: (f64, f64), kind: MarkerKind, s: f64, c: &str, sw: &str) {
    let (x, y) = at;
    let _ = match kind {
        MarkerKind::Plus => write!(
            o,
            "<path fill=\"none\" stroke=\"{c}\" stroke-width=\"{sw}\" d=\"M{} {}H{}M{} {}V{}\"/>",
            n(x - s),
            n(y),
            n(x + s),
            n(x),
            n(y - s),
            n(y + s)
        ),
        MarkerKind::Cross => write!(
            o,
            "<path fill=\"none\" stroke=\"{c}\" stroke-width=\"{sw}\" d=\"M{} {}L{} {}M{} {}L{} {}\"/>",
            n(x - s),
            n(y - s),
            n(x + s),
            n(y + s),
            n(x - s),
            n(y + s),
            n(x + s),
            n(y - s)
        ),
        MarkerKind::Diamond => write!(
            o,
            "<polygon fill=\"none\" stroke=\"{c}\" stroke-width=\"{sw}\" points=\"{},{} {},{} {},{} {},{}\"/>",
            n(x),
            n(y - s),
            n(x + s),
            n(y),
            n(x),
            n(y + s),
            n(x - s),
            n(y)
        ),
        MarkerKind::Ring => write!(
            o,
            "<circle cx=\"{}\" cy=\"{}\" r=\"{}\" fill=\"none\" stroke=\"{c}\" stroke-width=\"{sw}\"/>",
            n(x),
            n(y),
            n(s)
        ),
    };
}

/// The two base corners of an arrow head at `b`.
pub(crate) fn arrow_head(a: (f64, f64), b: (f64, f64), len: f64) -> ((f64, f64), (f64, f64)) {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let l = (dx * dx + dy * dy).sqrt().max(1e-9);
    let (ux, uy) = (dx / l, dy / l);
    let (bx, by) = (b.0 - ux * len, b.1 - uy * len);
    let w = len * 0.45;
    ((bx - uy * w, by + ux * w), (bx + uy * w, by - ux * w))
}

#[cfg(test)]
mod tests {
    use super::super::figure::{Color, Panel};
    use super::*;

    #[test]
    fn svg_is_balanced_and_escaped() {
        let mut f = Figure::new("t", "target <t&1>", 300.0, 200.0);
        let p = Panel::new((50.0, 20.0, 200.0, 140.0), (0.0, 1.0), (0.0, 1.0), true);
        p.axes(&mut f, "top view <t&1>", "x (m)", "y (m)");
        f.items.push(Item::Dots {
            xy: vec![(1.0, 2.0), (3.25, 4.0)],
            r: 1.0,
            color: Color(1, 2, 3),
        });
        f.items.push(Item::Arrow {
            a: (0.0, 0.0),
            b: (10.0, 0.0),
            color: Color(0, 0, 0),
            width: 1.0,
        });
        for k in [
            MarkerKind::Plus,
            MarkerKind::Cross,
            MarkerKind::Diamond,
            MarkerKind::Ring,
        ] {
            f.marker((5.0, 5.0), k, 3.0, Color(9, 9, 9));
        }
        let s = render(&f);
        assert!(s.starts_with("<svg xmlns=\"http://www.w3.org/2000/svg\""));
        assert!(s.ends_with("</svg>"));
        assert!(s.contains("top view &lt;t&amp;1&gt;"), "{s}");
        assert!(!s.contains("<t&1>"));
        assert!(s.contains("M1 2h0M3.3 4h0") || s.contains("M1 2h0M3.2 4h0"));
        super::super::tests::check_xmlish(&s);
    }
}
