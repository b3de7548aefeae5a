//! How well a located corner's height is known, from how much of the plates
//! the map shows, and where in what is seen the corner belongs (issue 30).
//!
//! The reference point is the corner at mid plate height. The locator (the
//! paper's estimator) puts it at the mean height of the plates' inliers.
//! That is the middle of the plate only when the plate is seen evenly from
//! bottom to top. A barrier, grass or a parked car hides the lower plates
//! from a sensor on the road, and the mean sits in the middle of what is
//! left, tens of centimetres high. Far from the road a spinning LiDAR's scan
//! lines cross a plate at a few fixed heights, one of them often holding
//! most of the returns, and the mean leans toward it. The post and the GNSS
//! antenna above the corner lie in both plates' planes and pull it up.
//!
//! So the plates' height is read from their body: inliers more than a fifth
//! of the plate width (and 10 cm) from the corner line (the post and the
//! antenna are narrower), or all inliers when too few are that far. Their heights span
//! `seen` of the plate (their 1–99 % range, scaled to the whole for an even
//! spread), from `lo` to `hi`. A plate that holds every seen point has its
//! middle between `hi − H/2` (the top edge is the plate's) and `lo + H/2`
//! (the bottom edge is), an interval `|H − seen|` wide centred on
//! `(lo + hi)/2`; nothing in the points says which edge is the plate's.
//!
//! Where the span fits in a plate, the corner is moved along the plates'
//! line to the span's middle ([`HeightSeen::centre`]): the best guess of the
//! plate's middle whatever the scan lines' densities, and its squared error
//! is expected to be width²/12. (When one edge is the plate's, as with a
//! barrier in front, the error is the whole half-width: √3 = 1.73 σ of that
//! term, inside the 95 % interval but not well inside.) A span taller than
//! the plates (plates taller than configured, the target mapped twice at
//! heights centimetres apart, something else in their planes) leaves no
//! middle to trust: the mean is kept, and the error added is its offset
//! from the span's middle and, as for a short span, the spread of the
//! places an H-tall plate could have in it, `(seen − H)²/12`. Left out,
//! plates 0.68 m tall measured as 0.6 m ones and targets mapped twice 4 cm
//! apart in height were up to 3.3 and 6.9 σ off (`bench/heights_table.py`).
//! [`HeightSeen::variance`] is added to the corner's covariance along the
//! direction a height error moves the corner.

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

/// Inliers nearer the corner line than this share of the plate width, and
/// than [`ANTENNA_M`], are left out of the span: the post and the antenna
/// stand there (the plates the paper uses are 0.6 m wide).
const CORNER_STRIP: f64 = 0.2;

/// A survey antenna's radius, about (8–12 cm): on small plates the strip is
/// at least this wide (at most half the plate).
const ANTENNA_M: f64 = 0.1;

/// A span up to this much taller than the plates still fits one (noise and
/// mixed pixels at the edges).
const FITS: f64 = 1.05;

impl HeightSeen {
    /// The span of the located plates' inliers (`pts` the crop the target
    /// was located in, `up` its vertical), read away from the corner line.
    /// `None` with too few inliers.
    pub fn of(
        pts: &[Point],
        located: &Located,
        up: &Vector3<f64>,
        plate: (f64, f64),
    ) -> Option<HeightSeen> {
        let o = located.corner;
        let n = located.plates.map(|p| Vector3::from(p.normal));
        // A plate's inlier lies along that plate at its offset along the
        // other plate's normal.
        let inliers = || {
            pts.iter()
                .zip(&located.labels)
                .filter_map(|(p, l)| match l {
                    Label::Plate1 => Some((p - o, n[1])),
                    Label::Plate2 => Some((p - o, n[0])),
                    Label::Outlier => None,
                })
                .filter(|(d, _)| d.iter().all(|v| v.is_finite()))
        };
        let strip = (CORNER_STRIP * plate.0).max(ANTENNA_M).min(0.5 * plate.0);
        let mut h: Vec<f64> = inliers()
            .filter(|(d, along)| along.dot(d).abs() > strip)
            .map(|(d, _)| up.dot(&d))
            .collect();
        if h.len() < MIN_POINTS {
            h = inliers().map(|(d, _)| up.dot(&d)).collect();
        }
        HeightSeen::from_heights(&mut h, plate.1)
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

    /// How far the plate's middle may lie from the span's, end to end (m):
    /// the height not seen of a span that fits, the excess of one that does
    /// not (within [`FITS`] the excess is the edges' noise, and the span's
    /// middle is used).
    fn open_m(&self) -> f64 {
        if self.fits() {
            self.hidden_m()
        } else {
            self.seen_m - self.plate_height_m
        }
    }

    /// Whether the run should name this target: its height's σ from what
    /// was seen is a twentieth of the plate height or more (3 cm for the
    /// paper's plates, ten times what a corner's points give its height),
    /// or its plates span more than a plate's height, which no plate of the
    /// configured size shows.
    pub(crate) fn worth_naming(&self) -> bool {
        !self.fits() || self.variance().sqrt() >= 0.05 * self.plate_height_m
    }

    /// Whether the span fits in one plate, so its middle is where the
    /// plate's is expected.
    pub(crate) fn fits(&self) -> bool {
        self.seen_m <= FITS * self.plate_height_m
    }

    /// Expected squared error of the corner's height (m²): its offset from
    /// the middle of the possible plate middles, and their spread.
    pub fn variance(&self) -> f64 {
        let width = self.open_m();
        self.off_centre_m.powi(2) + width * width / 12.0
    }

    /// Moves `located`'s corner (and its samples, which the report plots
    /// around it) along the plates' line to the span's middle, where the span
    /// fits in a plate; the offset left is then none. `up` is the vertical
    /// the heights were read along.
    pub(crate) fn centre(&mut self, located: &mut Located, up: &Vector3<f64>) {
        let normals = located.plates.map(|p| Vector3::from(p.normal));
        let Some(g) = along_line(normals, up) else {
            return;
        };
        if !self.fits() {
            return;
        }
        let shift = g * -self.off_centre_m;
        if !shift.iter().all(|v| v.is_finite()) {
            return;
        }
        located.corner += shift;
        for s in &mut located.samples {
            *s += shift;
        }
        self.off_centre_m = 0.0;
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
        let Some(g) = along_line(normals, up) else {
            return *cov;
        };
        let w = Matrix3::from_fn(|i, j| cov[i][j]) + g * g.transpose() * self.variance();
        if !w.iter().all(|v| v.is_finite()) {
            return *cov;
        }
        [0, 1, 2].map(|i| [0, 1, 2].map(|j| w[(i, j)]))
    }
}

/// What `eval` does with a located L's height (and `locate` but with
/// `--paper`): the corner moved to the middle of the plates' seen span where
/// it fits a plate, and the covariance widened by what the span leaves open
/// (`pts` the crop it was located in, `up` its vertical, `plate` the plates'
/// width and height). `None`, with nothing changed, when too few inliers
/// show a span.
pub fn place_height(
    pts: &[Point],
    located: &mut Located,
    up: &Vector3<f64>,
    plate: (f64, f64),
) -> Option<HeightSeen> {
    let mut seen = HeightSeen::of(pts, located, up, plate)?;
    let from = located.corner;
    seen.centre(located, up);
    let normals = located.plates.map(|p| Vector3::from(p.normal));
    let moved = tilt_reach(pts, located, &from, up);
    let cov = [0, 1, 2].map(|i| [0, 1, 2].map(|j| located.covariance[i][j] + moved[(i, j)]));
    located.covariance = seen.widen(&cov, normals, up);
    Some(seen)
}

/// The covariance the corner gains by being moved from `from` along the
/// plates' line: each plate's position error at the new place, less at the
/// old (its fitted tilt's error times the distance from its centroid;
/// `covariance::moved_variance`), carried to the corner as the locator's
/// propagation carries it. Zero when nothing moved.
fn tilt_reach(pts: &[Point], located: &Located, from: &Point, up: &Vector3<f64>) -> Matrix3<f64> {
    use super::covariance::{PlateFitPoints, moved_variance};
    let to = located.corner - from;
    if to.norm() == 0.0 {
        return Matrix3::zeros();
    }
    let normals = located.plates.map(|p| Vector3::from(p.normal));
    // About the old corner: maps may sit at UTM-sized coordinates.
    let mut v = [0.0; 2];
    for (k, want) in [Label::Plate1, Label::Plate2].into_iter().enumerate() {
        let own: Vec<Vector3<f64>> = pts
            .iter()
            .zip(&located.labels)
            .filter(|(_, l)| **l == want)
            .map(|(p, _)| p - from)
            .filter(|d| d.iter().all(|c| c.is_finite()))
            .collect();
        if own.is_empty() {
            continue;
        }
        let offset = own.iter().map(|d| normals[k].dot(d)).sum::<f64>() / own.len() as f64;
        let plate = PlateFitPoints {
            normal: normals[k],
            offset,
            points: own.iter().collect(),
        };
        v[k] = moved_variance(&plate, &Vector3::zeros(), &to, up);
    }
    let Some(inv) = corner_map(normals, up) else {
        return Matrix3::zeros();
    };
    let c = inv * Matrix3::from_diagonal(&Vector3::new(v[0], v[1], 0.0)) * inv.transpose();
    if c.iter().all(|x| x.is_finite()) {
        (c + c.transpose()) / 2.0
    } else {
        Matrix3::zeros()
    }
}

/// M⁻¹, M = [n₁; n₂; up]: how the corner moves when either plate's plane
/// or the height does (the locator's propagation, `covariance.rs`).
fn corner_map(normals: [Vector3<f64>; 2], up: &Vector3<f64>) -> Option<Matrix3<f64>> {
    Matrix3::from_rows(&[
        normals[0].transpose(),
        normals[1].transpose(),
        up.transpose(),
    ])
    .try_inverse()
}

/// How the corner moves when its height (along `up`) rises by one: along
/// the plates' line (`normals`), which leans where the plates do.
fn along_line(normals: [Vector3<f64>; 2], up: &Vector3<f64>) -> Option<Vector3<f64>> {
    corner_map(normals, up).map(|inv| inv * Vector3::z())
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
        // A span taller than the plates adds its offset and the spread of
        // the places a plate could have in it.
        let tall = HeightSeen {
            seen_m: 0.9,
            plate_height_m: 0.6,
            off_centre_m: 0.01,
        };
        assert!((tall.variance() - 1e-4 - 0.09 / 12.0).abs() < 1e-12);
        assert!(tall.worth_naming());
        // Within the edges' noise the span fits: nothing for the excess.
        let noisy = HeightSeen {
            seen_m: 0.62,
            ..tall
        };
        assert!(noisy.fits() && (noisy.variance() - 1e-4).abs() < 1e-12);
    }

    /// An L of plates along x (normal y) and along y (normal x), their
    /// corner at `corner`: plate points every 2 cm along and at `heights`,
    /// and a post with an antenna on the corner line up to 0.42 m.
    fn l_with_antenna(corner: Point, heights: &[f64]) -> (Vec<Point>, Located) {
        let mut pts = Vec::new();
        let mut labels = Vec::new();
        for &z in heights {
            for k in 1..=30 {
                let a = 0.02 * k as f64;
                pts.push(Point::new(a, 0.0, z));
                labels.push(Label::Plate1);
                pts.push(Point::new(0.0, a, z));
                labels.push(Label::Plate2);
            }
        }
        for k in 0..40 {
            let z = 0.3 + 0.003 * k as f64;
            pts.push(Point::new(0.01, 0.005, z));
            labels.push(if k % 2 == 0 {
                Label::Plate1
            } else {
                Label::Plate2
            });
        }
        let plate = |n: [f64; 3]| super::super::PlateFit {
            normal: n,
            inliers: 0,
            tilt_deg: 0.0,
        };
        let mut l = Located::without_plates(
            corner,
            [[1e-6, 0.0, 0.0], [0.0, 1e-6, 0.0], [0.0, 0.0, 1e-6]],
            vec![corner],
        );
        l.plates = [plate([0.0, 1.0, 0.0]), plate([1.0, 0.0, 0.0])];
        l.labels = labels;
        (pts, l)
    }

    /// Far scan lines: a dense one near the top pulls the mean 9 cm up, and
    /// the antenna's returns lie in both plates' planes. The span read away
    /// from the corner line puts the corner at the plates' middle, and what
    /// the lines leave open between them is all that is added.
    #[test]
    fn a_dense_scan_line_and_the_antenna_do_not_lift_the_corner() {
        let mut heights = vec![0.25; 12];
        heights.extend([-0.28, -0.18, -0.08, 0.02, 0.12, 0.22, 0.28]);
        let n = heights.len() as f64 * 60.0 + 40.0;
        let mean = (heights.iter().sum::<f64>() * 60.0
            + (0..40).map(|k| 0.3 + 0.003 * k as f64).sum::<f64>())
            / n;
        assert!(mean > 0.09, "{mean}");
        let (pts, mut l) = l_with_antenna(Point::new(0.0, 0.0, mean), &heights);
        let mut s = HeightSeen::of(&pts, &l, &Vector3::z(), (0.6, 0.6)).unwrap();
        assert!(s.fits() && (s.seen_m - 0.57).abs() < 0.01, "{s:?}");
        s.centre(&mut l, &Vector3::z());
        assert!(
            l.corner.z.abs() < 0.003 && l.samples[0] == l.corner,
            "{:?}",
            l.corner
        );
        assert!(l.corner.x == 0.0 && l.corner.y == 0.0);
        assert!(s.off_centre_m == 0.0 && s.variance().sqrt() < 0.01, "{s:?}");
        assert!(!s.worth_naming());
    }

    /// Moved 9 cm from where the plates' points are centred, the corner's
    /// horizontal σ grows by what the fitted planes' tilt errors reach
    /// there; not moved, it does not.
    #[test]
    fn a_moved_corner_carries_the_plates_tilt_error() {
        let mut heights = vec![0.25; 12];
        heights.extend([-0.28, -0.18, -0.08, 0.02, 0.12, 0.22, 0.28]);
        let (mut pts, l) = l_with_antenna(Point::new(0.0, 0.0, 0.0), &heights);
        // ±1 cm of noise across each plate.
        for (i, (p, lab)) in pts.iter_mut().zip(&l.labels).enumerate() {
            let e = (((i * 7919) % 101) as f64 - 50.0) / 5000.0;
            match lab {
                Label::Plate1 => p.y += e,
                Label::Plate2 => p.x += e,
                Label::Outlier => {}
            }
        }
        let place = |z: f64| {
            let mut at = l.clone();
            at.corner.z = z;
            at.samples = vec![at.corner];
            let seen = place_height(&pts, &mut at, &Vector3::z(), (0.6, 0.6)).unwrap();
            (at, seen)
        };
        let (still, seen) = place(0.0);
        assert!(seen.off_centre_m.abs() < 1e-12 && still.corner.z.abs() < 0.003);
        let (moved, _) = place(0.09);
        // (The plates' centroid sits 9 cm up; the span's middle at 0.)
        let grown = moved.covariance[0][0] - still.covariance[0][0];
        assert!(grown > 0.0 && moved.covariance[1][1] > still.covariance[1][1]);
        // var (≈ 0.33 cm²) × (0.09² / Σ heights about their mean): well
        // under a millimetre here.
        assert!(grown.sqrt() < 1e-3, "{}", grown.sqrt());
        assert_eq!(still.covariance[2][2], moved.covariance[2][2]);
    }

    /// A span taller than the plates has no middle to trust: the corner
    /// stays, and its error is its offset from the span's middle and the
    /// spread of the places a plate could have in the span.
    #[test]
    fn a_span_taller_than_the_plates_keeps_the_mean() {
        let heights: Vec<f64> = (0..10).map(|k| -0.4 + 0.09 * k as f64).collect();
        let (pts, mut l) = l_with_antenna(Point::new(0.0, 0.0, 0.05), &heights);
        let mut s = HeightSeen::of(&pts, &l, &Vector3::z(), (0.6, 0.6)).unwrap();
        assert!(!s.fits(), "{s:?}");
        s.centre(&mut l, &Vector3::z());
        assert_eq!(l.corner.z, 0.05);
        let excess = s.seen_m - 0.6;
        assert!(excess > 0.1, "{s:?}");
        assert!((s.variance() - s.off_centre_m.powi(2) - excess * excess / 12.0).abs() < 1e-12);
        assert!(s.worth_naming());
    }

    #[test]
    fn too_few_points_say_nothing() {
        let mut h = even(-0.3, 0.3, 10, 0.0);
        assert!(HeightSeen::from_heights(&mut h, 0.6).is_none());
    }
}
