//! Planes and their least-squares (SVD) fit.
//!
//! The fit is the paper's "SVD" step: the normal is the right singular vector of
//! the centred inlier matrix with the smallest singular value, which equals the
//! eigenvector of the 3×3 scatter matrix with the smallest eigenvalue. Working on
//! the 3×3 scatter matrix keeps the cost linear in the number of points.

use nalgebra::{Matrix3, SymmetricEigen, Vector3};

/// A plane `normal · p = offset`, with a unit normal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Plane {
    /// Unit normal.
    pub(crate) normal: Vector3<f64>,
    /// Signed distance of the plane from the origin along `normal`.
    pub(crate) offset: f64,
}

impl Plane {
    /// The plane through three points, or `None` when they are (nearly) collinear.
    pub(crate) fn through(a: &Vector3<f64>, b: &Vector3<f64>, c: &Vector3<f64>) -> Option<Plane> {
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

    /// The same plane with the opposite normal.
    pub(crate) fn flipped(self) -> Plane {
        Plane {
            normal: -self.normal,
            offset: -self.offset,
        }
    }

    /// Signed distance of `p` from the plane.
    #[inline]
    pub(crate) fn distance(&self, p: &Vector3<f64>) -> f64 {
        self.normal.dot(p) - self.offset
    }
}

/// Centroid and scatter matrix (sum of the outer products of the offsets from
/// the centroid) of a point set: everything a least-squares plane needs.
pub(crate) struct Scatter {
    mean: Vector3<f64>,
    matrix: Matrix3<f64>,
}

impl Scatter {
    /// The scatter of `points` (iterated twice: centroid, then offsets), or
    /// `None` for no points.
    pub(crate) fn of<'a, I>(points: I) -> Option<Scatter>
    where
        I: IntoIterator<Item = &'a Vector3<f64>>,
        I::IntoIter: Clone,
    {
        let points = points.into_iter();
        let mut mean = Vector3::zeros();
        let mut n = 0usize;
        for p in points.clone() {
            mean += p;
            n += 1;
        }
        if n == 0 {
            return None;
        }
        mean /= n as f64;
        let mut matrix = Matrix3::zeros();
        for p in points {
            let d = p - mean;
            matrix += d * d.transpose();
        }
        Some(Scatter { mean, matrix })
    }

    /// The least-squares plane, or `None` when its normal is undetermined: the
    /// points are collinear (the two smallest eigenvalues are equal up to
    /// rounding) or the numbers are not finite.
    pub(crate) fn plane(&self) -> Option<Plane> {
        let eig = SymmetricEigen::new(self.matrix);
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
            offset: normal.dot(&self.mean),
        })
    }

    /// The direction of least spread (the least-squares plane's normal, not
    /// normalised, either sign) without [`Scatter::plane`]'s checks: the first
    /// eigenvector whose eigenvalue is smallest (NaN never counts as smallest).
    /// For callers that have a fallback of their own and want an answer even
    /// for a degenerate set.
    pub(crate) fn least_axis(&self) -> Vector3<f64> {
        let eig = SymmetricEigen::new(self.matrix);
        let (imin, _) =
            eig.eigenvalues
                .iter()
                .enumerate()
                .fold(
                    (0, f64::INFINITY),
                    |m, (i, &e)| if e < m.1 { (i, e) } else { m },
                );
        eig.eigenvectors.column(imin).into()
    }
}

/// Least-squares plane through the points `pts[i]` for `i` in `idx`.
///
/// Returns `None` for fewer than 3 points or when the normal is undetermined
/// (see [`Scatter::plane`]).
pub(crate) fn fit(pts: &[Vector3<f64>], idx: &[u32]) -> Option<Plane> {
    if idx.len() < 3 {
        return None;
    }
    Scatter::of(idx.iter().map(|&i| &pts[i as usize]))?.plane()
}

/// Running sums of points about a fixed origin near them: a scatter in one
/// pass, and a part's sums taken from the whole's (the locator's refit fits a
/// plate with and without its free end from one pass, `locate::attempt`).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Moments {
    origin: Vector3<f64>,
    n: usize,
    sum: Vector3<f64>,
    sq: Matrix3<f64>,
}

impl Moments {
    /// No points yet, about `origin`.
    pub(crate) fn new(origin: Vector3<f64>) -> Self {
        Moments {
            origin,
            n: 0,
            sum: Vector3::zeros(),
            sq: Matrix3::zeros(),
        }
    }

    /// One more point.
    #[inline]
    pub(crate) fn add(&mut self, p: &Vector3<f64>) {
        let d = p - self.origin;
        self.n += 1;
        self.sum += d;
        self.sq += d * d.transpose();
    }

    /// The points counted.
    pub(crate) fn count(&self) -> usize {
        self.n
    }

    /// The sums of this set's points that are not in `part` (a subset
    /// summed about the same origin).
    pub(crate) fn without(&self, part: &Moments) -> Moments {
        Moments {
            origin: self.origin,
            n: self.n - part.n,
            sum: self.sum - part.sum,
            sq: self.sq - part.sq,
        }
    }

    /// How much a plane fitted to the points knows of its turn about `up`:
    /// the variance of that turn per unit residual variance, [S⁻¹]_uu of
    /// the points' 2×2 scatter S in the plane of `normal` (u its horizontal
    /// axis, v its vertical). Not 1/S_uu: where the points seen of a plate
    /// slant across it, its along and up spreads are correlated and the turn
    /// is known less well. Infinite for a degenerate set.
    pub(crate) fn turn_leverage(&self, normal: &Vector3<f64>, up: &Vector3<f64>) -> f64 {
        let Some(u) = up.cross(normal).try_normalize(1e-9) else {
            return f64::INFINITY;
        };
        let v = normal.cross(&u);
        if self.n < 3 {
            return f64::INFINITY;
        }
        let m = self.sq - self.sum * (self.sum / self.n as f64).transpose();
        let (uu, vv, uv) = (u.dot(&(m * u)), v.dot(&(m * v)), u.dot(&(m * v)));
        let det = uu * vv - uv * uv;
        if !(det > 0.0) {
            return f64::INFINITY;
        }
        vv / det
    }

    /// The least-squares plane of the points ([`Scatter::plane`]), `None`
    /// for fewer than three.
    pub(crate) fn plane(&self) -> Option<Plane> {
        if self.n < 3 {
            return None;
        }
        let n = self.n as f64;
        let mean = self.sum / n;
        Scatter {
            mean: self.origin + mean,
            matrix: self.sq - self.sum * mean.transpose(),
        }
        .plane()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn moments_fit_the_plane_a_scatter_does() {
        let pts: Vec<Vector3<f64>> = (0..40)
            .map(|i| {
                let (u, v) = (f64::from(i % 7) * 0.1, f64::from(i / 7) * 0.1);
                Vector3::new(u, 0.02 * u + 0.001 * f64::from(i % 3), v)
            })
            .collect();
        let idx: Vec<u32> = (0..40).collect();
        let mut all = Moments::new(pts[5]);
        let mut tail = Moments::new(pts[5]);
        for (i, p) in pts.iter().enumerate() {
            all.add(p);
            if i >= 30 {
                tail.add(p);
            }
        }
        let (a, b) = (all.plane().unwrap(), fit(&pts, &idx).unwrap());
        assert!((a.normal - b.normal).norm() < 1e-9 || (a.normal + b.normal).norm() < 1e-9);
        let (c, d) = (
            all.without(&tail).plane().unwrap(),
            fit(&pts, &idx[..30]).unwrap(),
        );
        assert!(c.normal.dot(&d.normal).abs() > 1.0 - 1e-12);
        assert!((c.offset.abs() - d.offset.abs()).abs() < 1e-12);
        assert_eq!(all.without(&tail).count(), 30);
        // Points in the plane x = 0 (u = y, v = z): uncorrelated, 1/S_uu;
        // slanted across it, more.
        let grid = |slant: f64| {
            let mut m = Moments::new(Vector3::zeros());
            for i in 0..10 {
                for j in 0..10 {
                    let (y, z) = (f64::from(i) * 0.1, f64::from(j) * 0.1);
                    m.add(&Vector3::new(0.0, y, z + slant * y));
                }
            }
            m.turn_leverage(&Vector3::x(), &Vector3::z())
        };
        let s_uu: f64 = 10.0
            * (0..10)
                .map(|i| (f64::from(i) * 0.1 - 0.45).powi(2))
                .sum::<f64>();
        assert!((grid(0.0) - 1.0 / s_uu).abs() < 1e-9 / s_uu);
        assert!(grid(1.0) > 1.5 / s_uu);
    }

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
        // The unchecked axis is the same direction.
        let axis = Scatter::of(&pts).unwrap().least_axis().normalize();
        assert!(axis.dot(&n).abs() > 1.0 - 1e-9);
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
        assert!(Scatter::of(&[]).is_none());
    }

    #[test]
    fn flipped_turns_normal_and_offset_together() {
        let p = Plane::through(
            &Vector3::z(),
            &(Vector3::z() + Vector3::y()),
            &(Vector3::z() + Vector3::x()),
        )
        .unwrap();
        assert!(p.normal.z < 0.0);
        let q = p.flipped();
        assert_eq!(q.normal, -p.normal);
        let probe = Vector3::new(0.3, -0.2, 1.7);
        assert_eq!(q.distance(&probe), -p.distance(&probe));
        assert!((q.distance(&probe) - 0.7).abs() < 1e-12);
        assert_eq!(q.flipped(), p);
    }
}
