//! RANSAC plane detection: the best-supported plane through 3 random points.
//!
//! Hypotheses are planes through 3 random points of the candidate set; the one
//! with the most points within the inlier threshold wins (first one on ties, so
//! the result depends only on the random stream). The locator runs it on each
//! plate's cluster, the tight crop on the ground candidates.

use super::plane::Plane;
use nalgebra::Vector3;
use rand::Rng;

/// Hypotheses kept from the subset scoring of preemptive RANSAC and re-scored
/// on all points. A few guard against a lucky subset; more cost full passes.
const KEEP: usize = 4;

/// How a hypothesis' three points are drawn from the candidates.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Draw {
    /// Three distinct points (the locator: no draw is wasted).
    Distinct,
    /// Three independent draws; a repeated point gives no plane and the
    /// hypothesis is skipped (the ground fit).
    Independent,
}

/// One RANSAC plane search's settings.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Ransac {
    /// Hypotheses to draw (at most, with `confidence`).
    pub(crate) iterations: usize,
    /// Inlier distance from the plane, metres (strictly less counts).
    pub(crate) threshold: f64,
    /// With > 0 and more candidates than this, *preemptive* RANSAC: every
    /// hypothesis is scored on the same random subset of `score_points`
    /// candidates (drawn with replacement), and only the best [`KEEP`] on all of
    /// them. 0 = score every hypothesis on every candidate.
    pub(crate) score_points: usize,
    /// In (0, 1): stop once the standard bound N = ln(1 − confidence) /
    /// ln(1 − w³) on the hypotheses needed is reached, w being the best inlier
    /// fraction so far. 0 = draw all `iterations`.
    pub(crate) confidence: f64,
    /// How each hypothesis' points are drawn.
    pub(crate) draw: Draw,
}

impl Ransac {
    /// Best plane among the hypotheses drawn from `idx` (indices into `pts`),
    /// and its inliers (appended to `inliers` after clearing it). `scratch`
    /// holds the preemptive subset and is reused between calls.
    ///
    /// Returns `None` when there are fewer than 3 candidates or every
    /// hypothesis was degenerate (collinear draws).
    pub(crate) fn best_plane<R: Rng>(
        &self,
        pts: &[Vector3<f64>],
        idx: &[u32],
        rng: &mut R,
        scratch: &mut Vec<Vector3<f64>>,
        inliers: &mut Vec<u32>,
    ) -> Option<Plane> {
        self.best_plane_where(pts, idx, rng, scratch, inliers, Some)
    }

    /// [`Ransac::best_plane`] with every hypothesis first passed through
    /// `admit`, which may reorient it or turn it down (`None`: not scored).
    pub(crate) fn best_plane_where<R: Rng, F: Fn(Plane) -> Option<Plane>>(
        &self,
        pts: &[Vector3<f64>],
        idx: &[u32],
        rng: &mut R,
        scratch: &mut Vec<Vector3<f64>>,
        inliers: &mut Vec<u32>,
        admit: F,
    ) -> Option<Plane> {
        inliers.clear();
        let n = idx.len();
        if n < 3 {
            return None;
        }
        let preemptive = self.score_points > 0 && self.score_points < n;
        if preemptive {
            scratch.clear();
            scratch
                .extend((0..self.score_points).map(|_| pts[idx[rng.random_range(0..n)] as usize]));
        }
        let subset = preemptive.then_some(&scratch[..]);
        let (_, plane) = self.search(pts, idx, rng, subset, &admit)?;
        let threshold = self.threshold;
        inliers.extend(
            idx.iter()
                .copied()
                .filter(|&i| plane.distance(&pts[i as usize]).abs() < threshold),
        );
        Some(plane)
    }

    /// The hypotheses drawn and scored (on `subset` when preemptive, then the
    /// best [`KEEP`] on all of `idx`): the best one and its inlier count.
    /// Drawing, scoring and the stopping bound stay one loop: it is the hot
    /// one of every plane search.
    fn search<R: Rng, F: Fn(Plane) -> Option<Plane>>(
        &self,
        pts: &[Vector3<f64>],
        idx: &[u32],
        rng: &mut R,
        subset: Option<&[Vector3<f64>]>,
        admit: &F,
    ) -> Option<(usize, Plane)> {
        let Ransac {
            iterations,
            threshold,
            draw,
            ..
        } = *self;
        let n = idx.len();
        let preemptive = subset.is_some();
        let scratch = subset.unwrap_or(&[]);
        let count_in = |plane: &Plane, set: &[Vector3<f64>]| {
            set.iter()
                .filter(|q| plane.distance(q).abs() < threshold)
                .count()
        };
        let count_all = |plane: &Plane| {
            idx.iter()
                .filter(|&&i| plane.distance(&pts[i as usize]).abs() < threshold)
                .count()
        };
        let mut best: Option<(usize, Plane)> = None;
        // Preemptive: the KEEP best by subset score, best first; ties keep the earlier one.
        let mut top: [(usize, Option<Plane>); KEEP] = [(0, None); KEEP];
        let log_miss = self.log_miss();
        let scored = if preemptive { scratch.len() } else { n } as f64;
        for it in 1..=iterations {
            let [a, b, c] = match draw {
                Draw::Distinct => distinct3(rng, n),
                Draw::Independent => [
                    rng.random_range(0..n),
                    rng.random_range(0..n),
                    rng.random_range(0..n),
                ],
            };
            let (pa, pb, pc) = (
                &pts[idx[a] as usize],
                &pts[idx[b] as usize],
                &pts[idx[c] as usize],
            );
            if let Some(plane) = Plane::through(pa, pb, pc).and_then(admit) {
                if preemptive {
                    let count = count_in(&plane, scratch);
                    if let Some(pos) = top.iter().position(|(k, p)| p.is_none() || count > *k) {
                        top.copy_within(pos..KEEP - 1, pos + 1);
                        top[pos] = (count, Some(plane));
                    }
                } else {
                    let count = count_all(&plane);
                    if best.is_none_or(|(k, _)| count > k) {
                        best = Some((count, plane));
                    }
                }
            }
            if log_miss < 0.0 {
                let found = if preemptive {
                    top[0].0
                } else {
                    best.map_or(0, |b| b.0)
                };
                let w3 = (found as f64 / scored).powi(3);
                // w3 ≥ 1 (every point an inlier): one hypothesis is enough.
                if w3 >= 1.0 || (w3 > 0.0 && it as f64 >= log_miss / (1.0 - w3).ln()) {
                    break;
                }
            }
        }
        if preemptive {
            for plane in top.iter().filter_map(|t| t.1) {
                let count = count_all(&plane);
                if best.is_none_or(|(k, _)| count > k) {
                    best = Some((count, plane));
                }
            }
        }
        best
    }

    /// ln(1 − confidence), the numerator of the stopping bound; 0 when no
    /// confidence is set (every hypothesis is drawn).
    fn log_miss(&self) -> f64 {
        if self.confidence > 0.0 && self.confidence < 1.0 {
            (1.0 - self.confidence).ln()
        } else {
            0.0
        }
    }
}

/// Three distinct indices in `0..n` (n ≥ 3), uniformly, from three draws.
fn distinct3<R: Rng>(rng: &mut R, n: usize) -> [usize; 3] {
    let a = rng.random_range(0..n);
    let mut b = rng.random_range(0..n - 1);
    if b >= a {
        b += 1;
    }
    let mut c = rng.random_range(0..n - 2);
    for lo in if a < b { [a, b] } else { [b, a] } {
        if c >= lo {
            c += 1;
        }
    }
    [a, b, c]
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    fn ransac(iterations: usize, score_points: usize, confidence: f64) -> Ransac {
        Ransac {
            iterations,
            threshold: 0.01,
            score_points,
            confidence,
            draw: Draw::Distinct,
        }
    }

    #[test]
    fn finds_the_dominant_plane_and_ignores_clutter() {
        let mut pts = Vec::new();
        for i in 0..30 {
            for j in 0..10 {
                pts.push(Vector3::new(i as f64 * 0.02, 1.0, j as f64 * 0.05));
            }
        }
        for i in 0..40 {
            let t = i as f64;
            pts.push(Vector3::new(
                (t * 0.37).sin(),
                1.2 + (t * 0.91).cos(),
                (t * 0.53).sin(),
            ));
        }
        let idx: Vec<u32> = (0..pts.len() as u32).collect();
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(3);
        let mut inl = Vec::new();
        let p = ransac(100, 0, 0.0)
            .best_plane(&pts, &idx, &mut rng, &mut Vec::new(), &mut inl)
            .unwrap();
        assert!(p.normal.y.abs() > 0.999);
        assert!(inl.len() >= 300 && inl.len() < 310);
        // Preemptive scoring on 64 of the 340 points finds the same plate.
        let mut sub = Vec::new();
        let p = ransac(100, 64, 0.999)
            .best_plane(&pts, &idx, &mut rng, &mut sub, &mut inl)
            .unwrap();
        assert_eq!(sub.len(), 64);
        assert!(p.normal.y.abs() > 0.999);
        assert!(inl.len() >= 300 && inl.len() < 310);
        // Independent draws find it too.
        let p = Ransac {
            draw: Draw::Independent,
            ..ransac(100, 0, 0.0)
        }
        .best_plane(&pts, &idx, &mut rng, &mut Vec::new(), &mut inl)
        .unwrap();
        assert!(p.normal.y.abs() > 0.999);
        assert!(inl.len() >= 300 && inl.len() < 310);
        // the distinctness of the three draws: 3 points in a cluster always give a plane
        let tri = [Vector3::zeros(), Vector3::x(), Vector3::y()];
        let mut inl = Vec::new();
        assert!(
            ransac(5, 0, 0.0)
                .best_plane(&tri, &[0, 1, 2], &mut rng, &mut Vec::new(), &mut inl)
                .is_some()
        );
        assert_eq!(inl.len(), 3);
    }

    #[test]
    fn admit_reorients_and_turns_down_hypotheses() {
        // A floor (z = 0) and a larger wall (x = 0): admitting only near-level
        // planes, turned to face +z, finds the floor.
        let mut pts = Vec::new();
        for i in 0..10 {
            for j in 0..10 {
                pts.push(Vector3::new(0.1 + i as f64 * 0.1, j as f64 * 0.1, 0.0));
            }
        }
        for i in 0..20 {
            for j in 0..10 {
                pts.push(Vector3::new(0.0, j as f64 * 0.1, 0.1 + i as f64 * 0.1));
            }
        }
        let idx: Vec<u32> = (0..pts.len() as u32).collect();
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(9);
        let mut inl = Vec::new();
        let level = |p: Plane| {
            let p = if p.normal.z < 0.0 { p.flipped() } else { p };
            (p.normal.z >= 0.94).then_some(p)
        };
        let p = ransac(200, 0, 0.0)
            .best_plane_where(&pts, &idx, &mut rng, &mut Vec::new(), &mut inl, level)
            .unwrap();
        assert!(p.normal.z > 0.999, "{p:?}");
        assert_eq!(inl.len(), 100);
        // Admitting nothing finds nothing.
        let none = ransac(50, 0, 0.0).best_plane_where(
            &pts,
            &idx,
            &mut rng,
            &mut Vec::new(),
            &mut inl,
            |_| None,
        );
        assert!(none.is_none() && inl.is_empty());
    }
}
