//! Two-cluster k-means: splits a tight crop into the two plates.
//!
//! The paper runs k-means (K = 2) on the raw 3D points with a random start. The
//! pole under the target and the antenna on top stretch the crop vertically, so
//! a 3D split often cuts it into top and bottom halves that each hold both
//! plates. Seen from above an L is two segments, so clustering the horizontal
//! components (the points projected along `up`) separates the plates far more
//! reliably; [`Space`] chooses which.

use nalgebra::{SVector, Vector2, Vector3};
use rand::Rng;
use serde::{Deserialize, Serialize};

/// Which coordinates k-means compares.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Space {
    /// Full 3D coordinates (the paper).
    Full,
    /// The component perpendicular to `up`: the target as seen from above.
    Horizontal,
}

/// How the two initial centres are drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Init {
    /// Two distinct random points (Forgy).
    Random,
    /// k-means++: the second centre drawn with probability ∝ squared distance to the first.
    PlusPlus,
}

/// Splits `pts` into two clusters; `labels[i]` becomes 0 or 1.
///
/// Returns `false` when a cluster ends up empty (the split is unusable).
#[cfg(test)]
pub(crate) fn split2<R: Rng>(
    pts: &[Vector3<f64>],
    up: &Vector3<f64>,
    space: Space,
    init: Init,
    iterations: usize,
    rng: &mut R,
    labels: &mut Vec<u8>,
) -> bool {
    match space {
        Space::Full => split2_points(pts, init, iterations, 0, rng, labels),
        Space::Horizontal => {
            let flat = horizontal(pts, up);
            split2_points(&flat, init, iterations, 0, rng, labels)
        }
    }
}

/// The points' horizontal coordinates in a basis perpendicular to `up` (a unit
/// vector): distances between them are those of the projections along `up`,
/// at two thirds of the cost.
pub(crate) fn horizontal(pts: &[Vector3<f64>], up: &Vector3<f64>) -> Vec<Vector2<f64>> {
    let helper = if up.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let e1 = up.cross(&helper).normalize();
    let e2 = up.cross(&e1);
    pts.iter()
        .map(|p| Vector2::new(e1.dot(p), e2.dot(p)))
        .collect()
}

/// [`split2`] on points already in the space to cluster in (any dimension).
///
/// With `sample` > 0 and more points than that, the centres are found on
/// `sample` points drawn at random (with replacement) and every point then
/// goes to the nearer one: the split of a two-plate crop hardly changes, the
/// cost drops to one pass over all points.
pub(crate) fn split2_points<const D: usize, R: Rng>(
    pts: &[SVector<f64, D>],
    init: Init,
    iterations: usize,
    sample: usize,
    rng: &mut R,
    labels: &mut Vec<u8>,
) -> bool {
    let n = pts.len();
    labels.clear();
    labels.resize(n, 0);
    if n < 2 {
        return false;
    }
    if sample == 0 || sample >= n {
        return lloyd(pts, init, iterations, rng, labels).is_some();
    }
    let sub: Vec<SVector<f64, D>> = (0..sample).map(|_| pts[rng.random_range(0..n)]).collect();
    let mut sub_labels = vec![0; sample];
    let Some(centres) = lloyd(&sub, init, iterations, rng, &mut sub_labels) else {
        return false;
    };
    assign(pts, &centres, labels).is_some()
}

/// One assignment step: labels each point with its nearer centre; returns the
/// new centres and whether any label changed, or `None` if a cluster is empty.
fn assign<const D: usize>(
    pts: &[SVector<f64, D>],
    centres: &[SVector<f64, D>; 2],
    labels: &mut [u8],
) -> Option<([SVector<f64, D>; 2], bool)> {
    // Nearer to c1 than to c0  ⇔  q · (c1 − c0) > (|c1|² − |c0|²) / 2: one dot per point.
    let dir = centres[1] - centres[0];
    let cut = (centres[1].norm_squared() - centres[0].norm_squared()) / 2.0;
    let mut changed = false;
    let mut sums = [SVector::<f64, D>::zeros(); 2];
    let mut counts = [0usize; 2];
    for (q, l) in pts.iter().zip(labels.iter_mut()) {
        let lab = u8::from(q.dot(&dir) > cut);
        changed |= *l != lab;
        *l = lab;
        sums[lab as usize] += q;
        counts[lab as usize] += 1;
    }
    if counts[0] == 0 || counts[1] == 0 {
        return None;
    }
    Some((
        [sums[0] / counts[0] as f64, sums[1] / counts[1] as f64],
        changed,
    ))
}

/// Seeding and Lloyd iterations on all of `pts`; the final centres, or `None`
/// when the split is unusable. `labels` must hold `pts.len()` zeros.
fn lloyd<const D: usize, R: Rng>(
    pts: &[SVector<f64, D>],
    init: Init,
    iterations: usize,
    rng: &mut R,
    labels: &mut [u8],
) -> Option<[SVector<f64, D>; 2]> {
    let n = pts.len();
    let first = rng.random_range(0..n);
    let c0 = pts[first];
    let c1 = match init {
        Init::Random => {
            let mut second = rng.random_range(0..n - 1);
            if second >= first {
                second += 1;
            }
            pts[second]
        }
        Init::PlusPlus => {
            let total: f64 = pts.iter().map(|p| (p - c0).norm_squared()).sum();
            if !(total > 0.0) {
                return None;
            }
            let mut target = rng.random::<f64>() * total;
            let mut pick = n - 1;
            for (i, p) in pts.iter().enumerate() {
                target -= (p - c0).norm_squared();
                if target < 0.0 {
                    pick = i;
                    break;
                }
            }
            pts[pick]
        }
    };
    let mut centres = [c0, c1];
    for it in 0..iterations.max(1) {
        let (next, changed) = assign(pts, &centres, labels)?;
        centres = next;
        if !changed && it > 0 {
            break;
        }
    }
    Some(centres)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn separates_two_blobs_in_both_spaces() {
        let mut pts = Vec::new();
        for i in 0..50 {
            let t = i as f64 * 0.01;
            pts.push(Vector3::new(t, 0.0, t * 3.0));
            pts.push(Vector3::new(5.0 + t, 1.0, -t * 3.0));
        }
        for space in [Space::Full, Space::Horizontal] {
            for init in [Init::Random, Init::PlusPlus] {
                let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(7);
                let mut labels = Vec::new();
                assert!(split2(
                    &pts,
                    &Vector3::z(),
                    space,
                    init,
                    20,
                    &mut rng,
                    &mut labels
                ));
                for pair in labels.chunks(2) {
                    assert_ne!(pair[0], pair[1]);
                }
                assert!(labels.iter().step_by(2).all(|&l| l == labels[0]));
            }
        }
    }

    #[test]
    fn identical_points_cannot_be_split() {
        let pts = vec![Vector3::new(1.0, 2.0, 3.0); 10];
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(1);
        let mut labels = Vec::new();
        assert!(!split2(
            &pts,
            &Vector3::z(),
            Space::Full,
            Init::PlusPlus,
            10,
            &mut rng,
            &mut labels
        ));
        assert!(!split2(
            &pts,
            &Vector3::z(),
            Space::Full,
            Init::Random,
            10,
            &mut rng,
            &mut labels
        ));
    }
}
