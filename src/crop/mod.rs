//! Cropping: the loose crop (every map point near a target's expected position,
//! one streaming pass for all targets) and the automatic tight crop (ground
//! removed, the target's plates isolated).

mod intensity;
mod loose;
mod tight;

pub use intensity::{IntensityCrop, crops_with_intensity};

pub use loose::{LooseCrop, LooseParams, Shape, loose_crop, loose_crop_by_level, loose_crop_each};
/// The coordinate hash crops thin by (deterministic, order-free).
pub(crate) fn point_hash(p: &crate::Point) -> u64 {
    loose::Thinned::hash(p)
}
pub use tight::{Seen, TightCrop, TightError, TightParams, tight_crop, tight_crop_among};

/// Horizontal span (x, y) of a crop that is too wide to be a tight crop of a
/// target with plates `plate_width` wide: a loose crop, ground and all, handed
/// where a tight one was expected. `None` when it could be a tight crop.
///
/// A tight crop holds the two plates and little else, so it spans about one
/// plate width in x and y whatever the target's heading; three plate widths
/// (and at least 2 m) leaves room for hand-made crops with a margin.
pub fn looks_loose(points: &[crate::Point], plate_width: f64) -> Option<(f64, f64)> {
    if points.is_empty() {
        return None;
    }
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in points {
        lo = [lo[0].min(p.x), lo[1].min(p.y)];
        hi = [hi[0].max(p.x), hi[1].max(p.y)];
    }
    let span = (hi[0] - lo[0], hi[1] - lo[1]);
    let limit = (3.0 * plate_width).max(2.0);
    (span.0 > limit || span.1 > limit).then_some(span)
}

/// The message for a crop that [`looks_loose`].
pub fn loose_crop_message(span: (f64, f64)) -> String {
    format!(
        "this looks like a loose crop ({:.1} × {:.1} m, ground included), not a tight crop of one target: write tight crops with `mapgauge crop --tight`, or remove the ground by hand",
        span.0, span.1
    )
}

#[cfg(test)]
mod looks_loose_tests {
    use super::*;
    use crate::Point;

    #[test]
    fn a_target_is_tight_and_a_patch_of_ground_is_not() {
        let plates: Vec<Point> = (0..30)
            .flat_map(|i| {
                let s = i as f64 * 0.02;
                [Point::new(s, 0.0, 1.0), Point::new(0.0, s, 1.0)]
            })
            .collect();
        assert_eq!(looks_loose(&plates, 0.6), None);
        let mut ground = plates.clone();
        ground.push(Point::new(4.0, -3.0, 0.0));
        assert!(looks_loose(&ground, 0.6).is_some());
        assert!(loose_crop_message((9.8, 9.9)).contains("crop --tight"));
    }
}
