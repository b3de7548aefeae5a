//! How far the located corner may be from the truth: its 3×3 covariance.
//!
//! The spread of the accepted samples measures the randomness of the algorithm
//! (with the refit every sample converges to nearly the same planes), not the
//! error the plates' noise causes. This module propagates the plate fits
//! instead, then adds the samples' spread where it is larger.
//!
//! Model. Plate k's least-squares plane has normal n_k through the centroid μ_k
//! of its N_k inliers. With residual variance σ_k² and the inliers' in-plane
//! scatter S_k (2×2, about μ_k), the fitted plane's position along n_k at a
//! point x has variance σ_k² (1/N_k + wᵀ S_k⁻¹ w), w the in-plane coordinates
//! of x − μ_k (the offset error and the two tilt errors of a plane fit are
//! independent in these coordinates). The corner solves n₁·c = d₁, n₂·c = d₂,
//! up·c = h; linearised, δc = M⁻¹ (e₁, e₂, δh) with M = [n₁; n₂; up], e_k the
//! plates' position errors at the corner and δh the error of the mean height,
//! whose variance is the heights' variance over their count. The plates' errors
//! come from different points and are taken independent.

use nalgebra::{Matrix2, Matrix3, SymmetricEigen, Vector2, Vector3};

/// One plate's inliers and its fitted plane, in the centred frame.
pub(crate) struct PlateFitPoints<'a> {
    /// Unit normal of the fitted plane.
    pub(crate) normal: Vector3<f64>,
    /// Offset of the plane along `normal`.
    pub(crate) offset: f64,
    /// The inliers.
    pub(crate) points: Vec<&'a Vector3<f64>>,
}

/// Residual variance of a plane fit: Σr² / (N − 3), corrected for the inlier
/// band's truncation of the noise when `band` is given (a band ±2.5 σ wide
/// keeps 91 % of the variance; narrower ones, like the paper's 3 cm at 3 cm
/// noise, much less).
fn residual_variance(p: &PlateFitPoints, band: Option<f64>) -> Option<f64> {
    let n = p.points.len();
    if n < 4 {
        return None;
    }
    let sse: f64 = p
        .points
        .iter()
        .map(|q| (p.normal.dot(q) - p.offset).powi(2))
        .sum();
    let var = sse / (n - 3) as f64;
    Some(match band {
        Some(b) if b > 0.0 => untruncate(var, b),
        _ => var,
    })
}

/// The variance σ² of a zero-mean normal whose part within ±`band` has
/// variance `v` (fixed point of v = σ² g(band/σ), g the truncated normal's
/// variance ratio). When `v` is too large for any σ (the residuals are not a
/// truncated normal), `v` itself.
pub(crate) fn untruncate(v: f64, band: f64) -> f64 {
    // g(a) = 1 − 2aφ(a) / (2Φ(a) − 1), decreasing in σ (a = band/σ); g → 1/3 as σ → ∞.
    let g = |a: f64| {
        let phi = (-0.5 * a * a).exp() / (2.0 * std::f64::consts::PI).sqrt();
        let mass = libm_erf(a / std::f64::consts::SQRT_2);
        if mass <= 0.0 {
            1.0 / 3.0
        } else {
            1.0 - 2.0 * a * phi / mass
        }
    };
    if !(v > 0.0) || v >= band * band / 3.0 * 0.999 {
        return v.max(0.0);
    }
    let mut s2 = v;
    for _ in 0..60 {
        let next = v / g(band / s2.sqrt());
        if (next - s2).abs() <= 1e-12 * s2 {
            return next;
        }
        s2 = next;
    }
    s2
}

/// erf(x) (Abramowitz–Stegun 7.1.26, |error| < 1.5e-7: ample for a variance correction).
fn libm_erf(x: f64) -> f64 {
    let s = x.signum();
    let x = x.abs();
    let t = 1.0 / (1.0 + 0.327_591_1 * x);
    let y = 1.0
        - (((((1.061_405_429 * t - 1.453_152_027) * t) + 1.421_413_741) * t - 0.284_496_736) * t
            + 0.254_829_592)
            * t
            * (-x * x).exp();
    s * y
}

/// Variance of plate `p`'s fitted position along its normal at `x`.
fn position_variance(
    p: &PlateFitPoints,
    x: &Vector3<f64>,
    up: &Vector3<f64>,
    band: Option<f64>,
) -> Option<f64> {
    let var = residual_variance(p, band)?;
    let n = p.points.len() as f64;
    let mean = p.points.iter().copied().sum::<Vector3<f64>>() / n;
    // In-plane axes: the plate's vertical and its horizontal.
    let e1 = (up - p.normal * up.dot(&p.normal)).try_normalize(1e-9)?;
    let e2 = p.normal.cross(&e1);
    let mut s = Matrix2::zeros();
    for q in &p.points {
        let d = *q - mean;
        let w = Vector2::new(d.dot(&e1), d.dot(&e2));
        s += w * w.transpose();
    }
    let inv = s.try_inverse()?;
    let d = x - mean;
    let w = Vector2::new(d.dot(&e1), d.dot(&e2));
    let v = var * (1.0 / n + (w.transpose() * inv * w)[(0, 0)]);
    v.is_finite().then_some(v)
}

/// How much plate `p`'s position variance grows when the corner moves from
/// `from` to `to` along the plates' line (m²; 0 where it shrinks): the
/// plane's tilt errors reach farther from its centroid. The residual
/// variance is taken as it is (no band correction: the caller does not know
/// the band), about 0.9 of the corrected one for the locator's ±2.5 σ.
pub(crate) fn moved_variance(
    p: &PlateFitPoints,
    from: &Vector3<f64>,
    to: &Vector3<f64>,
    up: &Vector3<f64>,
) -> f64 {
    match (
        position_variance(p, to, up, None),
        position_variance(p, from, up, None),
    ) {
        (Some(a), Some(b)) => (a - b).max(0.0),
        _ => 0.0,
    }
}

/// The corner's covariance from the two plate fits and the heights of their
/// inliers, `None` when it cannot be computed (too few points, degenerate
/// layout). `band` is the inlier band half-width of the fits, when known.
pub(crate) fn corner_covariance(
    plates: &[PlateFitPoints; 2],
    corner: &Vector3<f64>,
    up: &Vector3<f64>,
    band: [Option<f64>; 2],
) -> Option<Matrix3<f64>> {
    let v1 = position_variance(&plates[0], corner, up, band[0])?;
    let v2 = position_variance(&plates[1], corner, up, band[1])?;
    let heights: Vec<f64> = plates
        .iter()
        .flat_map(|p| p.points.iter().map(|q| up.dot(q)))
        .collect();
    let nh = heights.len() as f64;
    let mh = heights.iter().sum::<f64>() / nh;
    let vh = heights.iter().map(|h| (h - mh).powi(2)).sum::<f64>() / (nh - 1.0) / nh;
    let m = Matrix3::from_rows(&[
        plates[0].normal.transpose(),
        plates[1].normal.transpose(),
        up.transpose(),
    ]);
    let inv = m.try_inverse()?;
    let c = inv * Matrix3::from_diagonal(&Vector3::new(v1, v2, vh)) * inv.transpose();
    let c = (c + c.transpose()) / 2.0;
    c.iter().all(|v| v.is_finite()).then_some(c)
}

/// `a` raised to also cover `b`: a + (b − a)₊, the positive part taken in
/// `b − a`'s eigenbasis. The result is ≥ both in every direction, and equals
/// `a` when `a` already covers `b`.
pub(crate) fn cover(a: &Matrix3<f64>, b: &Matrix3<f64>) -> Matrix3<f64> {
    let diff = (b - a + (b - a).transpose()) / 2.0;
    let eig = SymmetricEigen::new(diff);
    let mut pos = Matrix3::zeros();
    for i in 0..3 {
        let l = eig.eigenvalues[i];
        if l > 0.0 {
            let v = eig.eigenvectors.column(i);
            pos += v * v.transpose() * l;
        }
    }
    a + pos
}

/// Population covariance of sample points.
pub(crate) fn sample_covariance(samples: &[Vector3<f64>]) -> Matrix3<f64> {
    let k = samples.len().max(1) as f64;
    let mean = samples.iter().sum::<Vector3<f64>>() / k;
    samples
        .iter()
        .map(|s| (s - mean) * (s - mean).transpose())
        .sum::<Matrix3<f64>>()
        / k
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};

    #[test]
    fn untruncate_inverts_the_truncated_variance() {
        // A ±2.5 σ band keeps 0.9111 of the variance.
        let v = untruncate(0.9111 * 0.02f64.powi(2), 2.5 * 0.02);
        assert!((v.sqrt() - 0.02).abs() < 1e-4, "{}", v.sqrt());
        // No band → unchanged; impossible ratios → unchanged.
        assert_eq!(untruncate(1.0, 1.0), 1.0);
        assert!((libm_erf(1.0) - 0.842_700_79).abs() < 2e-7);
    }

    #[test]
    fn cover_is_at_least_both() {
        let a = Matrix3::from_diagonal(&Vector3::new(4.0, 1.0, 1.0));
        let b = Matrix3::from_diagonal(&Vector3::new(1.0, 3.0, 0.5));
        let c = cover(&a, &b);
        assert!((c - Matrix3::from_diagonal(&Vector3::new(4.0, 3.0, 1.0))).norm() < 1e-12);
        assert_eq!(cover(&a, &Matrix3::zeros()), a);
    }

    /// Monte Carlo: the predicted covariance of two noisy plates' corner matches
    /// the scatter of the corners fitted to many noise draws.
    #[test]
    fn matches_monte_carlo_on_two_plates() {
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(7);
        let noise = Normal::new(0.0, 0.02).unwrap();
        let up = Vector3::z();
        // Plate A: y = 0, x ∈ [0.1, 0.6]; plate B: x = 0, y ∈ [0.1, 0.4]; z ∈ [0, 0.6].
        let grid = |a: usize, b: usize| {
            (0..a)
                .flat_map(move |i| (0..b).map(move |j| (i as f64 / a as f64, j as f64 / b as f64)))
        };
        let mut corners = Vec::new();
        let mut predicted = Matrix3::zeros();
        let trials = 2000;
        for _ in 0..trials {
            let pa: Vec<Vector3<f64>> = grid(20, 12)
                .map(|(u, v)| Vector3::new(0.1 + 0.5 * u, noise.sample(&mut rng), 0.6 * v))
                .collect();
            let pb: Vec<Vector3<f64>> = grid(8, 12)
                .map(|(u, v)| Vector3::new(noise.sample(&mut rng), 0.1 + 0.3 * u, 0.6 * v))
                .collect();
            let fit = |pts: &[Vector3<f64>]| {
                let idx: Vec<u32> = (0..pts.len() as u32).collect();
                crate::geom::plane::fit(pts, &idx).unwrap()
            };
            let (a, b) = (fit(&pa), fit(&pb));
            let plates = [
                PlateFitPoints {
                    normal: a.normal,
                    offset: a.offset,
                    points: pa.iter().collect(),
                },
                PlateFitPoints {
                    normal: b.normal,
                    offset: b.offset,
                    points: pb.iter().collect(),
                },
            ];
            let h = pa.iter().chain(&pb).map(|p| p.z).sum::<f64>() / (pa.len() + pb.len()) as f64;
            let m =
                Matrix3::from_rows(&[a.normal.transpose(), b.normal.transpose(), up.transpose()]);
            let c = m.lu().solve(&Vector3::new(a.offset, b.offset, h)).unwrap();
            predicted += corner_covariance(&plates, &c, &up, [None, None]).unwrap();
            corners.push(c);
        }
        let predicted = predicted / trials as f64;
        let observed = sample_covariance(&corners);
        for i in 0..2 {
            let r = predicted[(i, i)] / observed[(i, i)];
            assert!(
                (0.85..1.15).contains(&r),
                "axis {i}: predicted/observed = {r}"
            );
        }
    }
}
