//! RANSAC plane detection inside one cluster.
//!
//! Hypotheses are planes through 3 random points of the cluster; the one with
//! the most points within the inlier threshold wins (first one on ties, so the
//! result depends only on the random stream).

use super::plane::Plane;
use nalgebra::Vector3;
use rand::Rng;

/// Hypotheses kept from the subset scoring of preemptive RANSAC and re-scored
/// on all points. A few guard against a lucky subset; more cost full passes.
const KEEP: usize = 4;

/// Best plane among `iterations` 3-point hypotheses drawn from `idx`, and its
/// inliers (indices into `pts`, appended to `inliers` after clearing it).
///
/// With `score_points` > 0 and a cluster larger than that, RANSAC is
/// *preemptive*: every hypothesis is scored on the same random subset of
/// `score_points` cluster points (drawn with replacement), and only the best
/// [`KEEP`] are scored on the whole cluster. With 0, every hypothesis is scored
/// on every point (the reference algorithm). `scratch` is reused between calls.
///
/// With `confidence` in (0, 1), RANSAC stops early once the standard bound
/// N = ln(1 − confidence) / ln(1 − w³) on the hypotheses needed is reached, w
/// being the best inlier fraction so far; `iterations` stays the maximum. With
/// 0, all `iterations` hypotheses are drawn (the reference algorithm).
///
/// Returns `None` when the cluster has fewer than 3 points or every hypothesis
/// was degenerate (collinear draws).
#[allow(clippy::too_many_arguments)]
pub fn best_plane<R: Rng>(
    pts: &[Vector3<f64>],
    idx: &[u32],
    iterations: usize,
    threshold: f64,
    score_points: usize,
    confidence: f64,
    rng: &mut R,
    scratch: &mut Vec<Vector3<f64>>,
    inliers: &mut Vec<u32>,
) -> Option<Plane> {
    inliers.clear();
    let n = idx.len();
    if n < 3 {
        return None;
    }
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
    let preemptive = score_points > 0 && score_points < n;
    if preemptive {
        scratch.clear();
        scratch.extend((0..score_points).map(|_| pts[idx[rng.random_range(0..n)] as usize]));
    }
    let mut best: Option<(usize, Plane)> = None;
    // Preemptive: the KEEP best by subset score, best first; ties keep the earlier one.
    let mut top: [(usize, Option<Plane>); KEEP] = [(0, None); KEEP];
    let log_miss = if confidence > 0.0 && confidence < 1.0 {
        (1.0 - confidence).ln()
    } else {
        0.0
    };
    let scored = if preemptive { score_points } else { n } as f64;
    for it in 1..=iterations {
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
        let (pa, pb, pc) = (
            &pts[idx[a] as usize],
            &pts[idx[b] as usize],
            &pts[idx[c] as usize],
        );
        if let Some(plane) = Plane::through(pa, pb, pc) {
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
    let (_, plane) = best?;
    inliers.extend(
        idx.iter()
            .copied()
            .filter(|&i| plane.distance(&pts[i as usize]).abs() < threshold),
    );
    Some(plane)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

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
        let p = best_plane(
            &pts,
            &idx,
            100,
            0.01,
            0,
            0.0,
            &mut rng,
            &mut Vec::new(),
            &mut inl,
        )
        .unwrap();
        assert!(p.normal.y.abs() > 0.999);
        assert!(inl.len() >= 300 && inl.len() < 310);
        // Preemptive scoring on 64 of the 340 points finds the same plate.
        let mut sub = Vec::new();
        let p = best_plane(
            &pts, &idx, 100, 0.01, 64, 0.999, &mut rng, &mut sub, &mut inl,
        )
        .unwrap();
        assert_eq!(sub.len(), 64);
        assert!(p.normal.y.abs() > 0.999);
        assert!(inl.len() >= 300 && inl.len() < 310);
        // the distinctness of the three draws: 3 points in a cluster always give a plane
        let tri = [Vector3::zeros(), Vector3::x(), Vector3::y()];
        let mut inl = Vec::new();
        assert!(
            best_plane(
                &tri,
                &[0, 1, 2],
                5,
                0.01,
                0,
                0.0,
                &mut rng,
                &mut Vec::new(),
                &mut inl
            )
            .is_some()
        );
        assert_eq!(inl.len(), 3);
    }
}
