//! Where the overview's target labels go: beside each marker, clear of the
//! error arrows, the other markers and the labels already placed.

use crate::report::figure::{Anchor, Color, Figure, Panel};

/// A label's box in pixels: left, top, right, bottom.
type Rect = (f64, f64, f64, f64);
/// An arrow from tail to head, in pixels.
pub(super) type Seg = ((f64, f64), (f64, f64));

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

/// Draws `labels` (a marker's position, its text and colour) in order, each
/// where [`place_label`] finds it covers least of what is already there.
pub(super) fn place_labels(
    f: &mut Figure,
    panel: &Panel,
    labels: Vec<((f64, f64), String, Color)>,
    segs: &[Seg],
    rings: &[(f64, f64)],
) {
    let frame = (
        panel.px.0,
        panel.px.1,
        panel.px.0 + panel.px.2,
        panel.px.1 + panel.px.3,
    );
    let mut placed: Vec<Rect> = Vec::new();
    for (s, text, color) in labels {
        let (at, anchor, b) = place_label(s, &text, segs, rings, &placed, frame);
        placed.push(b);
        f.text(at, &text, 12.0, color, anchor);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_keep_off_arrows_and_each_other() {
        let frame = (0.0, 0.0, 500.0, 500.0);
        let s = (200.0, 200.0);
        // Nothing in the way: upper right, as before.
        let (at, a, _) = place_label(s, "t1", &[], &[s], &[], frame);
        assert_eq!((at, a), ((208.0, 190.0), Anchor::Start));
        // An arrow up and to the right: the label goes elsewhere and covers none of it.
        let seg = (s, (240.0, 170.0));
        let (_, _, b) = place_label(s, "t1", &[seg], &[s], &[], frame);
        for i in 0..=20 {
            let t = i as f64 / 20.0;
            let p = (s.0 + t * 40.0, s.1 - t * 30.0);
            assert!(
                !(p.0 >= b.0 && p.0 <= b.2 && p.1 >= b.1 && p.1 <= b.3),
                "label box {b:?} covers the arrow at {p:?}"
            );
        }
        // A second label at the same place does not sit on the first.
        let (_, _, b1) = place_label(s, "t1", &[seg], &[s], &[], frame);
        let (_, _, b2) = place_label(s, "t2", &[seg], &[s], &[b1], frame);
        assert!(!(b1.0 < b2.2 && b2.0 < b1.2 && b1.1 < b2.3 && b2.1 < b1.3));
    }
}
