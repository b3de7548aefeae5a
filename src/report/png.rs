//! [`Figure`] → PNG through plotters' bitmap backend, with text drawn by
//! ab_glyph from an embedded DejaVu Sans (assets/fonts, Bitstream Vera licence):
//! no fontconfig or freetype on the machine is needed.

use super::figure::{Anchor, Figure, Item, MarkerKind};
use crate::{Error, Result};
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::{FontStyle, FontTransform};
use std::path::Path;
use std::sync::Once;

static FONT: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");

/// Pixels per figure unit: PNGs are drawn at twice the SVG size to stay sharp.
pub(crate) const SCALE: f64 = 2.0;

fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The bytes are a known-good TTF compiled in; failure would be a build defect.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    });
}

/// Renders `f` to a PNG file at `path` (written to a temporary sibling, then renamed).
pub(crate) fn write(f: &Figure, path: &Path) -> Result<()> {
    register_font();
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "figure.png".into());
    // The backend picks the encoder from the extension, so the temporary keeps `.png`.
    let tmp = path.with_file_name(format!(".{name}.tmp{}.png", std::process::id()));
    let fail = |e: String| Error::io(path, std::io::Error::other(e));
    let w = (f.width * SCALE).round().max(1.0) as u32;
    let h = (f.height * SCALE).round().max(1.0) as u32;
    {
        let root = BitMapBackend::new(&tmp, (w, h)).into_drawing_area();
        draw(f, &root).map_err(|e| fail(e.to_string()))?;
        root.present().map_err(|e| fail(e.to_string()))?;
    }
    std::fs::rename(&tmp, path).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        Error::io(path, e)
    })
}

type Area<'a> = DrawingArea<BitMapBackend<'a>, plotters::coord::Shift>;
type DrawResult = std::result::Result<
    (),
    plotters::drawing::DrawingAreaErrorKind<<BitMapBackend<'static> as DrawingBackend>::ErrorType>,
>;

fn p(v: (f64, f64)) -> (i32, i32) {
    ((v.0 * SCALE).round() as i32, (v.1 * SCALE).round() as i32)
}

fn rgb(c: super::figure::Color) -> RGBColor {
    RGBColor(c.0, c.1, c.2)
}

fn sw(w: f64) -> u32 {
    (w * SCALE).round().max(1.0) as u32
}

fn draw(f: &Figure, root: &Area<'_>) -> DrawResult {
    root.fill(&WHITE)?;
    for item in &f.items {
        draw_item(root, item)?;
    }
    Ok(())
}

/// One item in pixels: the same marks as the SVG, at [`SCALE`] times its size.
fn draw_item(root: &Area<'_>, item: &Item) -> DrawResult {
    match item {
        Item::Dots { xy, r, color } => {
            let style = rgb(*color).filled();
            let r = (r * SCALE).round().max(1.0) as i32;
            for &c in xy {
                root.draw(&Circle::new(p(c), r, style))?;
            }
        }
        Item::Line {
            a,
            b,
            color,
            width,
            dashed,
        } => {
            let style = rgb(*color).stroke_width(sw(*width));
            if *dashed {
                dashed_line(root, *a, *b, style)?;
            } else {
                root.draw(&PathElement::new(vec![p(*a), p(*b)], style))?;
            }
        }
        Item::Polyline { pts, color, width } => {
            let v: Vec<(i32, i32)> = pts.iter().map(|&c| p(c)).collect();
            root.draw(&PathElement::new(v, rgb(*color).stroke_width(sw(*width))))?;
        }
        Item::Rect {
            at,
            size,
            fill,
            stroke,
        } => {
            let c = [p(*at), p((at.0 + size.0, at.1 + size.1))];
            if let Some(fc) = fill {
                root.draw(&Rectangle::new(c, rgb(*fc).filled()))?;
            }
            if let Some(sc) = stroke {
                root.draw(&Rectangle::new(c, rgb(*sc).stroke_width(sw(1.0))))?;
            }
        }
        Item::Arrow { a, b, color, width } => {
            let (h1, h2) = super::svg::arrow_head(*a, *b, 4.0 + 2.0 * width);
            root.draw(&PathElement::new(
                vec![p(*a), p(*b)],
                rgb(*color).stroke_width(sw(*width)),
            ))?;
            root.draw(&Polygon::new(
                vec![p(*b), p(h1), p(h2)],
                rgb(*color).filled(),
            ))?;
        }
        Item::Marker {
            at,
            kind,
            size,
            color,
            width,
        } => {
            let style = rgb(*color).stroke_width(sw(*width));
            marker(root, *at, *kind, *size, style)?;
        }
        Item::Text {
            at,
            text,
            size,
            color,
            anchor,
            vertical,
            ..
        } => {
            let h = match anchor {
                Anchor::Start => HPos::Left,
                Anchor::Middle => HPos::Center,
                Anchor::End => HPos::Right,
            };
            let mut style = ("sans-serif", size * SCALE)
                .into_font()
                .color(&rgb(*color))
                .pos(Pos::new(h, VPos::Center));
            if *vertical {
                style = style.transform(FontTransform::Rotate270);
            }
            root.draw(&Text::new(text.clone(), p(*at), style))?;
        }
    }
    Ok(())
}

/// A dashed line as the SVG's `5 4` dash pattern: plotters' bitmap backend
/// draws no dashes of its own.
fn dashed_line(root: &Area<'_>, a: (f64, f64), b: (f64, f64), style: ShapeStyle) -> DrawResult {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let len = (dx * dx + dy * dy).sqrt();
    let n = (len / 9.0).floor() as usize;
    for k in 0..=n {
        let t0 = k as f64 * 9.0 / len.max(1e-9);
        let t1 = ((k as f64 * 9.0 + 5.0) / len.max(1e-9)).min(1.0);
        if t0 >= 1.0 {
            break;
        }
        root.draw(&PathElement::new(
            vec![
                p((a.0 + dx * t0, a.1 + dy * t0)),
                p((a.0 + dx * t1, a.1 + dy * t1)),
            ],
            style,
        ))?;
    }
    Ok(())
}

/// A marker's outline of half-size `s` about `at`, as the SVG draws it.
fn marker(
    root: &Area<'_>,
    at: (f64, f64),
    kind: MarkerKind,
    s: f64,
    style: ShapeStyle,
) -> DrawResult {
    let (x, y) = at;
    match kind {
        MarkerKind::Plus => {
            root.draw(&PathElement::new(vec![p((x - s, y)), p((x + s, y))], style))?;
            root.draw(&PathElement::new(vec![p((x, y - s)), p((x, y + s))], style))?;
        }
        MarkerKind::Cross => {
            root.draw(&PathElement::new(
                vec![p((x - s, y - s)), p((x + s, y + s))],
                style,
            ))?;
            root.draw(&PathElement::new(
                vec![p((x - s, y + s)), p((x + s, y - s))],
                style,
            ))?;
        }
        MarkerKind::Diamond => {
            root.draw(&PathElement::new(
                vec![
                    p((x, y - s)),
                    p((x + s, y)),
                    p((x, y + s)),
                    p((x - s, y)),
                    p((x, y - s)),
                ],
                style,
            ))?;
        }
        MarkerKind::Ring => {
            root.draw(&Circle::new(p(at), (s * SCALE).round() as i32, style))?;
        }
    }
    Ok(())
}
