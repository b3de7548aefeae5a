//! A figure as a list of drawing primitives in pixel coordinates (y down), so
//! one description renders both to SVG (the HTML report, `--plots`) and to PNG
//! (`--plots`), and the two always show the same thing.

/// An sRGB colour.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Color(pub u8, pub u8, pub u8);

impl Color {
    /// `#rrggbb`, for SVG and CSS.
    pub(crate) fn hex(&self) -> String {
        format!("#{:02x}{:02x}{:02x}", self.0, self.1, self.2)
    }
}

/// The report's palette: plate 1, plate 2, outliers, and the markers.
pub(crate) mod palette {
    use super::Color;
    /// Plate 1 inliers.
    pub(crate) const PLATE1: Color = Color(0x1f, 0x77, 0xb4);
    /// Plate 2 inliers.
    pub(crate) const PLATE2: Color = Color(0xe6, 0x7e, 0x22);
    /// Outliers (pole, antenna, noise) and untyped crop points.
    pub(crate) const OUTLIER: Color = Color(0xa0, 0xa0, 0xa0);
    /// Estimated positions.
    pub(crate) const ESTIMATE: Color = Color(0x11, 0x11, 0x11);
    /// Surveyed positions.
    pub(crate) const SURVEY: Color = Color(0xc0, 0x39, 0x2b);
    /// Errors, failures.
    pub(crate) const ERROR: Color = Color(0x8e, 0x44, 0xad);
    /// Axis frames and text.
    pub(crate) const INK: Color = Color(0x33, 0x33, 0x33);
    /// Grid lines.
    pub(crate) const GRID: Color = Color(0xe4, 0xe4, 0xe4);
    /// Samples and fitted lines.
    pub(crate) const SAMPLE: Color = Color(0x27, 0xae, 0x60);
    /// The tight crop drawn over a loose crop.
    pub(crate) const TIGHT: Color = Color(0xe6, 0x7e, 0x22);
}

/// Horizontal text anchor.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Anchor {
    /// Text starts at the position.
    Start,
    /// Text is centred on the position.
    Middle,
    /// Text ends at the position.
    End,
}

/// Marker shapes for single positions.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum MarkerKind {
    /// `+`.
    Plus,
    /// `×`.
    Cross,
    /// A diamond outline.
    Diamond,
    /// A circle outline.
    Ring,
}

/// One drawing primitive (pixels, y down).
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Item {
    /// Many small filled dots of one colour (point clouds).
    Dots {
        /// Centres.
        xy: Vec<(f64, f64)>,
        /// Radius.
        r: f64,
        /// Fill.
        color: Color,
    },
    /// A straight line.
    Line {
        /// Start.
        a: (f64, f64),
        /// End.
        b: (f64, f64),
        /// Colour.
        color: Color,
        /// Stroke width.
        width: f64,
        /// Dashed.
        dashed: bool,
    },
    /// An open polyline.
    Polyline {
        /// Vertices.
        pts: Vec<(f64, f64)>,
        /// Colour.
        color: Color,
        /// Stroke width.
        width: f64,
    },
    /// An axis-aligned rectangle.
    Rect {
        /// Top-left corner.
        at: (f64, f64),
        /// Width and height.
        size: (f64, f64),
        /// Fill, if any.
        fill: Option<Color>,
        /// Outline, if any.
        stroke: Option<Color>,
    },
    /// A line with an arrow head at `b`.
    Arrow {
        /// Tail.
        a: (f64, f64),
        /// Head.
        b: (f64, f64),
        /// Colour.
        color: Color,
        /// Stroke width.
        width: f64,
    },
    /// A marker of a single position.
    Marker {
        /// Centre.
        at: (f64, f64),
        /// Shape.
        kind: MarkerKind,
        /// Half size.
        size: f64,
        /// Colour.
        color: Color,
        /// Stroke width.
        width: f64,
    },
    /// A text line; `at.1` is the vertical centre of the text.
    Text {
        /// Position.
        at: (f64, f64),
        /// The text (plain, unescaped).
        text: String,
        /// Font size (px).
        size: f64,
        /// Colour.
        color: Color,
        /// Horizontal anchor.
        anchor: Anchor,
        /// Bold.
        bold: bool,
        /// Rotated 90° anticlockwise (vertical axis labels).
        vertical: bool,
    },
}

/// A figure: a canvas and what is drawn on it, in order.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Figure {
    /// File stem for `--plots` (ASCII, safe in file names).
    pub(crate) name: String,
    /// What the figure shows (SVG `<title>`, alt text).
    pub(crate) title: String,
    /// Canvas width (px).
    pub(crate) width: f64,
    /// Canvas height (px).
    pub(crate) height: f64,
    /// Primitives, painted in order.
    pub(crate) items: Vec<Item>,
}

impl Figure {
    /// An empty canvas.
    pub(crate) fn new(name: &str, title: &str, width: f64, height: f64) -> Figure {
        Figure {
            name: name.into(),
            title: title.into(),
            width,
            height,
            items: Vec::new(),
        }
    }
    /// Adds a text item.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn text(
        &mut self,
        at: (f64, f64),
        text: &str,
        size: f64,
        color: Color,
        anchor: Anchor,
    ) {
        self.items.push(Item::Text {
            at,
            text: text.into(),
            size,
            color,
            anchor,
            bold: false,
            vertical: false,
        });
    }
    /// Adds a bold text item.
    pub(crate) fn bold(&mut self, at: (f64, f64), text: &str, size: f64, anchor: Anchor) {
        self.items.push(Item::Text {
            at,
            text: text.into(),
            size,
            color: palette::INK,
            anchor,
            bold: true,
            vertical: false,
        });
    }
    /// Adds a line.
    pub(crate) fn line(
        &mut self,
        a: (f64, f64),
        b: (f64, f64),
        color: Color,
        width: f64,
        dashed: bool,
    ) {
        self.items.push(Item::Line {
            a,
            b,
            color,
            width,
            dashed,
        });
    }
    /// Adds a marker.
    pub(crate) fn marker(&mut self, at: (f64, f64), kind: MarkerKind, size: f64, color: Color) {
        self.items.push(Item::Marker {
            at,
            kind,
            size,
            color,
            width: 2.0,
        });
    }
    /// Number of dots over all point clouds (bounded per view for small files).
    pub(crate) fn dot_count(&self) -> usize {
        self.items
            .iter()
            .map(|i| match i {
                Item::Dots { xy, .. } => xy.len(),
                _ => 0,
            })
            .sum()
    }
}

/// Maps a data rectangle onto a pixel rectangle of a figure and draws axes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Panel {
    /// Pixel rectangle: left, top, width, height.
    pub(crate) px: (f64, f64, f64, f64),
    /// Data x range.
    pub(crate) x: (f64, f64),
    /// Data y range (y up in data).
    pub(crate) y: (f64, f64),
}

impl Panel {
    /// A panel showing `x` × `y`; with `equal`, the ranges are widened so one
    /// metre is as long across as up (plans and elevations must not be squashed).
    pub(crate) fn new(
        px: (f64, f64, f64, f64),
        x: (f64, f64),
        y: (f64, f64),
        equal: bool,
    ) -> Panel {
        let fix = |r: (f64, f64)| {
            if !(r.1 - r.0 > 1e-12) || !r.0.is_finite() || !r.1.is_finite() {
                let c = if r.0.is_finite() { r.0 } else { 0.0 };
                (c - 0.5, c + 0.5)
            } else {
                r
            }
        };
        let (mut x, mut y) = (fix(x), fix(y));
        if equal {
            let sx = (x.1 - x.0) / px.2;
            let sy = (y.1 - y.0) / px.3;
            let s = sx.max(sy);
            let (cx, cy) = ((x.0 + x.1) / 2.0, (y.0 + y.1) / 2.0);
            x = (cx - s * px.2 / 2.0, cx + s * px.2 / 2.0);
            y = (cy - s * px.3 / 2.0, cy + s * px.3 / 2.0);
        }
        Panel { px, x, y }
    }
    /// Data → pixel.
    pub(crate) fn map(&self, x: f64, y: f64) -> (f64, f64) {
        let (l, t, w, h) = self.px;
        (
            l + (x - self.x.0) / (self.x.1 - self.x.0) * w,
            t + (self.y.1 - y) / (self.y.1 - self.y.0) * h,
        )
    }
    /// True when the data point falls inside the panel.
    pub(crate) fn contains(&self, x: f64, y: f64) -> bool {
        x >= self.x.0 && x <= self.x.1 && y >= self.y.0 && y <= self.y.1
    }
    /// The part of the data segment `a`–`b` inside the panel (Liang–Barsky), in pixels.
    pub(crate) fn clip(&self, a: (f64, f64), b: (f64, f64)) -> Option<((f64, f64), (f64, f64))> {
        let (dx, dy) = (b.0 - a.0, b.1 - a.1);
        let (mut t0, mut t1) = (0.0f64, 1.0f64);
        for (p, q) in [
            (-dx, a.0 - self.x.0),
            (dx, self.x.1 - a.0),
            (-dy, a.1 - self.y.0),
            (dy, self.y.1 - a.1),
        ] {
            if p == 0.0 {
                if q < 0.0 {
                    return None;
                }
            } else {
                let r = q / p;
                if p < 0.0 {
                    t0 = t0.max(r);
                } else {
                    t1 = t1.min(r);
                }
            }
        }
        if t0 > t1 {
            return None;
        }
        Some((
            self.map(a.0 + t0 * dx, a.1 + t0 * dy),
            self.map(a.0 + t1 * dx, a.1 + t1 * dy),
        ))
    }
    /// Pixels per data unit along x.
    pub(crate) fn scale(&self) -> f64 {
        self.px.2 / (self.x.1 - self.x.0)
    }
    /// Frame, grid, ticks, tick labels, axis labels and a title.
    pub(crate) fn axes(&self, f: &mut Figure, title: &str, xlabel: &str, ylabel: &str) {
        let (l, t, w, h) = self.px;
        f.items.push(Item::Rect {
            at: (l, t),
            size: (w, h),
            fill: Some(Color(0xff, 0xff, 0xff)),
            stroke: None,
        });
        let xt = nice_ticks(self.x.0, self.x.1, (w / 50.0).clamp(3.0, 8.0) as usize);
        for &v in &xt {
            let (px, _) = self.map(v, self.y.0);
            f.line((px, t), (px, t + h), palette::GRID, 1.0, false);
            f.line((px, t + h), (px, t + h + 4.0), palette::INK, 1.0, false);
            f.text(
                (px, t + h + 13.0),
                &tick_label(v, &xt),
                10.0,
                palette::INK,
                Anchor::Middle,
            );
        }
        let yt = nice_ticks(self.y.0, self.y.1, (h / 50.0).clamp(3.0, 8.0) as usize);
        for &v in &yt {
            let (_, py) = self.map(self.x.0, v);
            f.line((l, py), (l + w, py), palette::GRID, 1.0, false);
            f.line((l - 4.0, py), (l, py), palette::INK, 1.0, false);
            f.text(
                (l - 6.0, py),
                &tick_label(v, &yt),
                10.0,
                palette::INK,
                Anchor::End,
            );
        }
        f.items.push(Item::Rect {
            at: (l, t),
            size: (w, h),
            fill: None,
            stroke: Some(palette::INK),
        });
        f.text(
            (l + w / 2.0, t + h + 28.0),
            xlabel,
            11.0,
            palette::INK,
            Anchor::Middle,
        );
        f.items.push(Item::Text {
            at: (l - 44.0, t + h / 2.0),
            text: ylabel.into(),
            size: 11.0,
            color: palette::INK,
            anchor: Anchor::Middle,
            bold: false,
            vertical: true,
        });
        if !title.is_empty() {
            f.bold((l, t - 10.0), title, 12.0, Anchor::Start);
        }
    }
}

/// Round tick positions (1, 2, 5 × 10^k steps) covering `[a, b]` with about `n` ticks.
pub(crate) fn nice_ticks(a: f64, b: f64, n: usize) -> Vec<f64> {
    if !(b > a) || !a.is_finite() || !b.is_finite() {
        return Vec::new();
    }
    let mut step = nice_step((b - a) / n.max(1) as f64);
    // A step rounded up can leave one tick, or none, in the range: no scale.
    // Finer steps (5 → 2 → 1 → 0.5 …) until at least 3 ticks fall inside.
    for _ in 0..6 {
        if ((b / step).floor() - (a / step).ceil()) >= 2.0 {
            break;
        }
        step = finer_step(step);
    }
    let first = (a / step).ceil() as i64;
    let last = (b / step).floor() as i64;
    (first..=last)
        .take(50)
        .map(|k| {
            let v = k as f64 * step;
            if v.abs() < step * 1e-9 { 0.0 } else { v }
        })
        .collect()
}

/// The next 1, 2, 5 × 10^k step below `step` (itself such a step).
fn finer_step(step: f64) -> f64 {
    let e = 10f64.powf(step.log10().floor());
    let m = (step / e).round();
    if m >= 5.0 {
        2.0 * e
    } else if m >= 2.0 {
        e
    } else {
        0.5 * e
    }
}

/// The nearest of 1, 2, 5 × 10^k at or above `raw`.
pub(crate) fn nice_step(raw: f64) -> f64 {
    if !(raw > 0.0) || !raw.is_finite() {
        return 1.0;
    }
    let e = 10f64.powf(raw.log10().floor());
    let m = raw / e;
    let m = if m <= 1.0 {
        1.0
    } else if m <= 2.0 {
        2.0
    } else if m <= 5.0 {
        5.0
    } else {
        10.0
    };
    m * e
}

/// The nearest of 1, 2, 5 × 10^k at or below `raw` (for magnifications).
pub(crate) fn nice_floor(raw: f64) -> f64 {
    if !(raw > 0.0) || !raw.is_finite() {
        return 1.0;
    }
    let e = 10f64.powf(raw.log10().floor());
    let m = raw / e;
    let m = if m >= 5.0 {
        5.0
    } else if m >= 2.0 {
        2.0
    } else {
        1.0
    };
    m * e
}

/// A tick's label with as many decimals as the ticks' own step needs (0.5
/// steps get one decimal, 0.25 would get two), never "-0".
fn tick_label(v: f64, ticks: &[f64]) -> String {
    let step = match ticks {
        [a, b, ..] => b - a,
        _ => v.abs().max(1.0),
    };
    let mut decimals = 0usize;
    while decimals < 6 {
        let x = step * 10f64.powi(decimals as i32);
        if (x - x.round()).abs() < 1e-6 * x.abs().max(1.0) {
            break;
        }
        decimals += 1;
    }
    let s = format!("{v:.decimals$}");
    if s.starts_with('-') && s[1..].chars().all(|c| c == '0' || c == '.') {
        s[1..].to_string()
    } else {
        s
    }
}

/// Every `k`-th index so that at most `max` of `n` remain: a deterministic
/// thinning that keeps the spatial mix of a crop (crops are in file order).
pub(crate) fn thin(n: usize, max: usize) -> impl Iterator<Item = usize> {
    let step = n.div_ceil(max.max(1)).max(1);
    (0..n).step_by(step)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_and_steps() {
        assert_eq!(
            nice_ticks(0.0, 10.0, 5),
            vec![0.0, 2.0, 4.0, 6.0, 8.0, 10.0]
        );
        assert_eq!(nice_step(0.23), 0.5);
        assert_eq!(nice_floor(230.0), 200.0);
        assert_eq!(nice_floor(0.7), 0.5);
        assert!(nice_ticks(1.0, 1.0, 5).is_empty());
        // A step rounded up to 5 left only "0" in ±4.4 (the 100-samples
        // panels' single tick): finer steps until 3 ticks show a scale.
        for (a, b, n) in [
            (-4.4, 4.4, 4),
            (-44.0, 44.0, 4),
            (0.1, 0.9, 3),
            (-0.6, 0.6, 5),
        ] {
            let t = nice_ticks(a, b, n);
            assert!(t.len() >= 3, "{a}..{b}: {t:?}");
            let labels: Vec<String> = t.iter().map(|&v| tick_label(v, &t)).collect();
            let mut unique = labels.clone();
            unique.dedup();
            assert_eq!(unique, labels, "labels must differ: {labels:?}");
        }
        assert_eq!(
            nice_ticks(-4.4, 4.4, 4)
                .iter()
                .map(|&v| tick_label(v, &nice_ticks(-4.4, 4.4, 4)))
                .collect::<Vec<_>>(),
            vec!["-4", "-2", "0", "2", "4"]
        );
        let t = nice_ticks(0.1, 0.9, 3);
        assert_eq!(tick_label(t[1], &t), "0.4", "{t:?}");
        assert_eq!(tick_label(-0.00001, &[0.0, 1.0]), "0");
        assert_eq!(thin(10, 3).collect::<Vec<_>>(), vec![0, 4, 8]);
        assert_eq!(thin(3, 3000).count(), 3);
        assert!(thin(10_001, 3000).count() <= 3000);
    }

    #[test]
    fn equal_aspect_panel() {
        let p = Panel::new((0.0, 0.0, 200.0, 100.0), (0.0, 1.0), (0.0, 1.0), true);
        assert!((p.scale() - 100.0).abs() < 1e-9);
        let (x, y) = p.map(0.5, 0.5);
        assert!((x - 100.0).abs() < 1e-9 && (y - 50.0).abs() < 1e-9);
        // Degenerate ranges widen instead of dividing by zero.
        let q = Panel::new((0.0, 0.0, 100.0, 100.0), (3.0, 3.0), (f64::NAN, 1.0), false);
        assert!(q.map(3.0, 0.0).0.is_finite());
        // Clipping keeps the inside part of a segment, direction unchanged.
        let (a, b) = p.clip((-1.0, 0.5), (3.0, 0.5)).unwrap();
        assert!(
            (a.0 - p.map(p.x.0, 0.5).0).abs() < 1e-9 && (b.0 - p.map(p.x.1, 0.5).0).abs() < 1e-9
        );
        assert!(p.clip((5.0, 5.0), (6.0, 6.0)).is_none());
    }
}
