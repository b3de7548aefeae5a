//! How well a located corner's height is known, from how much of the plates
//! the map shows (issue 30).
//!
//! The reference point is the corner at mid plate height, and the locator
//! puts it at the mean height of the plates' inliers. That is the middle of
//! the plate only when the plate is seen evenly from bottom to top. A barrier,
//! grass or a parked car hides the lower plates from a sensor on the road;
//! the mean then sits in the middle of what is left, tens of centimetres
//! high, while the covariance (the heights' scatter over their count) says a
//! few millimetres.
//!
//! The plates are `plate_height` tall. The inliers' heights span `seen` of it
//! (their 1–99 % range, scaled to the whole for an even spread), from `lo` to
//! `hi`. A plate that holds every seen point has its middle between
//! `hi − H/2` (the top edge is the plate's) and `lo + H/2` (the bottom edge
//! is), an interval `|H − seen|` wide centred on `(lo + hi)/2`; nothing in the
//! points says which edge is the plate's. With the middle anywhere in it, the
//! mean height's squared error is expected to be (its offset from the
//! interval's centre)² + width²/12, added to the corner's covariance along
//! the direction a height error moves the corner. (When one edge is the
//! plate's, as with a barrier in front, the error is the whole half-width:
//! √3 = 1.73 σ of that term, inside the 95 % interval but not well inside.)
//! A span taller than the plates (plates taller than configured, noise at
//! the edges) leaves no interval: only the offset counts.

use super::{Label, Located};
use crate::Point;
use nalgebra::{Matrix3, Vector3};

/// What the plates' inliers show of the plates' height.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HeightSeen {
    /// Height of plate the inliers span (m).
    pub seen_m: f64,
    /// The configured plate height (m).
    pub plate_height_m: f64,
    /// The located corner's height less the middle of the span seen (m):
    /// how unevenly the plates were seen.
    pub off_centre_m: f64,
}

/// Fewest inliers for a span to mean anything.
const MIN_POINTS: usize = 20;

/// Share of the heights between the quantiles the span is read from.
const KEPT: f64 = 0.98;

impl HeightSeen {
    /// The span of the located plates' inliers (`pts` the crop the target
    /// was located in, `up` its vertical). `None` with too few inliers.
    pub fn of(
        pts: &[Point],
        located: &Located,
        up: &Vector3<f64>,
        plate_height: f64,
    ) -> Option<HeightSeen> {
        let o = located.corner;
        let mut h: Vec<f64> = pts
            .iter()
            .zip(&located.labels)
            .filter(|(_, l)| matches!(l, Label::Plate1 | Label::Plate2))
            .map(|(p, _)| up.dot(&(p - o)))
            .filter(|v| v.is_finite())
            .collect();
        HeightSeen::from_heights(&mut h, plate_height)
    }

    /// From the inliers' heights relative to the corner (reordered).
    pub(crate) fn from_heights(h: &mut [f64], plate_height: f64) -> Option<HeightSeen> {
        let n = h.len();
        if n < MIN_POINTS || !(plate_height > 0.0) {
            return None;
        }
        let q = ((1.0 - KEPT) / 2.0 * (n - 1) as f64).round() as usize;
        let lo = *h.select_nth_unstable_by(q, f64::total_cmp).1;
        let hi = *h.select_nth_unstable_by(n - 1 - q, f64::total_cmp).1;
        Some(HeightSeen {
            seen_m: (hi - lo) / KEPT,
            plate_height_m: plate_height,
            off_centre_m: -(lo + hi) / 2.0,
        })
    }

    /// Height of plate not seen (m; 0 when the span is a whole plate or more).
    pub(crate) fn hidden_m(&self) -> f64 {
        (self.plate_height_m - self.seen_m).max(0.0)
    }

    /// How far the corner's height can be from the plates' middle if the
    /// plates are as seen (m): its offset from the span's middle, and half
    /// the height not seen.
    pub(crate) fn worst_m(&self) -> f64 {
        self.off_centre_m.abs() + self.hidden_m() / 2.0
    }

    /// Expected squared error of the corner's height (m²): its offset from
    /// the middle of the possible plate middles, and their spread.
    pub fn variance(&self) -> f64 {
        let width = self.hidden_m();
        self.off_centre_m.powi(2) + width * width / 12.0
    }

    /// `cov` with [`HeightSeen::variance`] added along the direction a height
    /// error moves the corner (the plates' line, through `normals`): an error
    /// independent of the points' scatter already in `cov`.
    pub(crate) fn widen(
        &self,
        cov: &[[f64; 3]; 3],
        normals: [Vector3<f64>; 2],
        up: &Vector3<f64>,
    ) -> [[f64; 3]; 3] {
        let m = Matrix3::from_rows(&[
            normals[0].transpose(),
            normals[1].transpose(),
            up.transpose(),
        ]);
        let Some(g) = m.try_inverse().map(|inv| inv * Vector3::z()) else {
            return *cov;
        };
        let w = Matrix3::from_fn(|i, j| cov[i][j]) + g * g.transpose() * self.variance();
        if !w.iter().all(|v| v.is_finite()) {
            return *cov;
        }
        [0, 1, 2].map(|i| [0, 1, 2].map(|j| w[(i, j)]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Heights spread evenly over `lo..hi`, `n` of them, relative to `at`.
    fn even(lo: f64, hi: f64, n: usize, at: f64) -> Vec<f64> {
        (0..n)
            .map(|i| lo + (hi - lo) * (i as f64 + 0.5) / n as f64 - at)
            .collect()
    }

    #[test]
    fn a_whole_plate_seen_evenly_adds_nothing() {
        let mut h = even(-0.3, 0.3, 2000, 0.0);
        let s = HeightSeen::from_heights(&mut h, 0.6).unwrap();
        assert!((s.seen_m - 0.6).abs() < 0.002, "{s:?}");
        assert!(s.hidden_m() < 0.002);
        assert!(s.variance().sqrt() < 0.001, "{}", s.variance().sqrt());
    }

    /// The lower 40 % hidden: the mean sits 12 cm above the plate's middle,
    /// which lies anywhere in a 24 cm interval as far as the points say. The
    /// error is within 2 σ whichever edge was the plate's.
    #[test]
    fn a_plate_hidden_from_below_is_as_uncertain_as_what_is_missing() {
        let mean = (-0.06 + 0.3) / 2.0;
        let mut h = even(-0.06, 0.3, 1500, mean);
        let s = HeightSeen::from_heights(&mut h, 0.6).unwrap();
        assert!((s.seen_m - 0.36).abs() < 0.003, "{s:?}");
        assert!((s.hidden_m() - 0.24).abs() < 0.003);
        let sigma = s.variance().sqrt();
        for err in [mean - 0.0, mean - 0.24] {
            assert!(err.abs() < 2.0 * sigma, "error {err}, sigma {sigma}");
        }
        assert!(sigma < 0.1, "{sigma}");
    }

    /// Grass thins the lower quarter to a fifth of its returns: the mean is
    /// pulled up, the span is whole, and the offset is what is added.
    #[test]
    fn a_plate_seen_unevenly_adds_its_mean_offset() {
        let mut h = even(-0.3, -0.15, 100, 0.0);
        h.extend(even(-0.15, 0.3, 1500, 0.0));
        let mean = h.iter().sum::<f64>() / h.len() as f64;
        let mut rel: Vec<f64> = h.iter().map(|v| v - mean).collect();
        let s = HeightSeen::from_heights(&mut rel, 0.6).unwrap();
        assert!(s.hidden_m() < 0.03, "{s:?}");
        assert!(
            mean > 0.03 && (s.off_centre_m - mean).abs() < 0.015,
            "{s:?} {mean}"
        );
        assert!(s.variance().sqrt() >= mean * 0.75);
    }

    #[test]
    fn the_height_error_is_covered_along_the_plates_line() {
        let s = HeightSeen {
            seen_m: 0.36,
            plate_height_m: 0.6,
            off_centre_m: 0.0,
        };
        let cov = [[1e-6, 0.0, 0.0], [0.0, 1e-6, 0.0], [0.0, 0.0, 1e-5]];
        // Upright plates: only z widens.
        let n = [Vector3::x(), Vector3::y()];
        let w = s.widen(&cov, n, &Vector3::z());
        assert!((w[2][2] - 1e-5 - s.variance()).abs() < 1e-12, "{w:?}");
        assert_eq!((w[0][0], w[1][1], w[0][2], w[1][2]), (1e-6, 1e-6, 0.0, 0.0));
        // A plates' line leaning 1° in x: a height error moves it in x too.
        let a = 1f64.to_radians();
        let n = [Vector3::new(a.cos(), 0.0, -a.sin()), Vector3::y()];
        let w = s.widen(&cov, n, &Vector3::z());
        assert!(
            w[0][0] > 1e-6 + 0.9 * s.variance() * a.tan().powi(2),
            "{w:?}"
        );
        // A span taller than the plates adds only its offset.
        let tall = HeightSeen {
            seen_m: 0.9,
            plate_height_m: 0.6,
            off_centre_m: 0.01,
        };
        assert!((tall.variance() - 1e-4).abs() < 1e-12);
    }

    #[test]
    fn too_few_points_say_nothing() {
        let mut h = even(-0.3, 0.3, 10, 0.0);
        assert!(HeightSeen::from_heights(&mut h, 0.6).is_none());
    }
}
