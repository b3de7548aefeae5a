//! Planes and their least-squares (SVD) fit.
//!
//! The fit is the paper's "SVD" step: the normal is the right singular vector of
//! the centred inlier matrix with the smallest singular value, which equals the
//! eigenvector of the 3×3 scatter matrix with the smallest eigenvalue. Working on
//! the 3×3 scatter matrix keeps the cost linear in the number of points.

use nalgebra::{Matrix3, SymmetricEigen, Vector3};

/// A plane `normal · p = offset`, with a unit normal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plane {
    /// Unit normal.
    pub normal: Vector3<f64>,
    /// Signed distance of the plane from the origin along `normal`.
    pub offset: f64,
}

impl Plane {
    /// The plane through three points, or `None` when they are (nearly) collinear.
    pub fn through(a: &Vector3<f64>, b: &Vector3<f64>, c: &Vector3<f64>) -> Option<Plane> {
        let n = (b - a).cross(&(c - a));
        let len = n.norm();
        // 1e-9 m² of triangle area: below this the normal is numerically meaningless.
        if !(len > 1e-9) {
            return None;
        }
        let normal = n / len;
        Some(Plane {
            normal,
            offset: normal.dot(a),
        })
    }

    /// Signed distance of `p` from the plane.
    #[inline]
    pub fn distance(&self, p: &Vector3<f64>) -> f64 {
        self.normal.dot(p) - self.offset
    }
}

/// Least-squares plane through the points `pts[i]` for `i` in `idx`.
///
/// Returns `None` for fewer than 3 points or when the points are collinear
/// (the two smallest scatter eigenvalues are equal up to rounding), because the
/// normal is then undetermined.
pub fn fit(pts: &[Vector3<f64>], idx: &[u32]) -> Option<Plane> {
    if idx.len() < 3 {
        return None;
    }
    let mut mean = Vector3::zeros();
    for &i in idx {
        mean += pts[i as usize];
    }
    mean /= idx.len() as f64;
    let mut scatter = Matrix3::zeros();
    for &i in idx {
        let d = pts[i as usize] - mean;
        scatter += d * d.transpose();
    }
    let eig = SymmetricEigen::new(scatter);
    let mut order = [0usize, 1, 2];
    order.sort_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]));
    let (l0, l1) = (eig.eigenvalues[order[0]], eig.eigenvalues[order[1]]);
    if !(l1 > 0.0) || l1 - l0 <= 1e-12 * l1.abs() {
        return None;
    }
    let normal = eig.eigenvectors.column(order[0]).into_owned().normalize();
    if !normal.iter().all(|v| v.is_finite()) {
        return None;
    }
    Some(Plane {
        normal,
        offset: normal.dot(&mean),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fit_recovers_a_tilted_plane() {
        let n = Vector3::new(0.3, -0.2, 0.9).normalize();
        let u = n.cross(&Vector3::x()).normalize();
        let v = n.cross(&u);
        let mut pts = Vec::new();
        for i in 0..20 {
            for j in 0..20 {
                let s = if (i + j) % 2 == 0 { 1e-3 } else { -1e-3 };
                pts.push(u * (i as f64 * 0.05) + v * (j as f64 * 0.03) + n * (2.0 + s));
            }
        }
        let idx: Vec<u32> = (0..pts.len() as u32).collect();
        let p = fit(&pts, &idx).unwrap();
        assert!(p.normal.dot(&n).abs() > 1.0 - 1e-9);
        assert!((p.offset * p.normal.dot(&n).signum() - 2.0).abs() < 1e-6);
    }

    #[test]
    fn degenerate_inputs_give_none() {
        let pts = vec![
            Vector3::zeros(),
            Vector3::x(),
            Vector3::x() * 2.0,
            Vector3::x() * 3.0,
        ];
        assert!(fit(&pts, &[0, 1, 2, 3]).is_none());
        assert!(fit(&pts, &[0, 1]).is_none());
        assert!(Plane::through(&pts[0], &pts[1], &pts[2]).is_none());
    }
}
