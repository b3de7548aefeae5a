//! Alignment of map-frame estimates onto the survey frame (map → survey), so that
//! errors come out in survey metres.
//!
//! All fits subtract centroids before forming any product, so UTM-sized inputs
//! (~10^6 m) lose no precision. Reflections are never returned.

use crate::{Error, Point, Result};
use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};
use std::fmt;
use std::str::FromStr;

/// Which transform to fit; the choice decides how many degrees of freedom the
/// map is forgiven.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
pub enum AlignMethod {
    /// Identity: the map is already in the survey frame.
    #[serde(rename = "none")]
    None,
    /// Yaw + (x, y) translation, least squares on x, y (the paper's tables).
    #[default]
    #[serde(rename = "rigid2d")]
    Rigid2d,
    /// Yaw + (x, y, z) translation: a gravity-aligned 4-DoF fit.
    #[serde(rename = "rigid2d+z")]
    Rigid2dZ,
    /// Full 3D rotation + translation.
    #[serde(rename = "rigid3d")]
    Rigid3d,
    /// Yaw + translation + scale on x, y.
    #[serde(rename = "similarity2d")]
    Similarity2d,
    /// 3D rotation + translation + scale.
    #[serde(rename = "similarity3d")]
    Similarity3d,
    /// The paper's Eq. 1: yaw + (x, y) minimising the sum of distances.
    #[serde(rename = "robust2d")]
    Robust2d,
}

impl AlignMethod {
    /// Every method, for help texts and tests.
    pub(crate) const ALL: [AlignMethod; 7] = [
        AlignMethod::None,
        AlignMethod::Rigid2d,
        AlignMethod::Rigid2dZ,
        AlignMethod::Rigid3d,
        AlignMethod::Similarity2d,
        AlignMethod::Similarity3d,
        AlignMethod::Robust2d,
    ];

    /// The name used on the command line and in result files.
    pub fn name(self) -> &'static str {
        match self {
            AlignMethod::None => "none",
            AlignMethod::Rigid2d => "rigid2d",
            AlignMethod::Rigid2dZ => "rigid2d+z",
            AlignMethod::Rigid3d => "rigid3d",
            AlignMethod::Similarity2d => "similarity2d",
            AlignMethod::Similarity3d => "similarity3d",
            AlignMethod::Robust2d => "robust2d",
        }
    }

    /// Fewest point pairs that determine the transform.
    pub(crate) fn min_points(self) -> usize {
        match self {
            AlignMethod::None => 1,
            AlignMethod::Rigid3d | AlignMethod::Similarity3d => 3,
            _ => 2,
        }
    }

    /// Number of fitted parameters (for degrees of freedom in σ̂).
    pub fn params(self) -> usize {
        match self {
            AlignMethod::None => 0,
            AlignMethod::Rigid2d | AlignMethod::Robust2d => 3,
            AlignMethod::Rigid2dZ | AlignMethod::Similarity2d => 4,
            AlignMethod::Rigid3d => 6,
            AlignMethod::Similarity3d => 7,
        }
    }

    /// Whether the fit uses (and corrects) heights.
    pub(crate) fn uses_z(self) -> bool {
        matches!(
            self,
            AlignMethod::Rigid2dZ | AlignMethod::Rigid3d | AlignMethod::Similarity3d
        )
    }
}

impl fmt::Display for AlignMethod {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for AlignMethod {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        AlignMethod::ALL
            .into_iter()
            .find(|m| m.name().eq_ignore_ascii_case(s))
            .ok_or_else(|| {
                let names: Vec<_> = AlignMethod::ALL.iter().map(|m| m.name()).collect();
                Error::Param(format!(
                    "unknown alignment `{s}` (one of: {})",
                    names.join(", ")
                ))
            })
    }
}

/// A fitted map → survey transform: `p_survey = scale · R · p_map + t`.
#[derive(Debug, Clone, PartialEq)]
pub struct Alignment {
    /// The method that produced it.
    pub method: AlignMethod,
    /// Rotation (a proper rotation, det = +1).
    pub rotation: Matrix3<f64>,
    /// Translation (m).
    pub translation: Vector3<f64>,
    /// Scale factor (1 for rigid methods).
    pub scale: f64,
    /// Iterations used (robust2d), 0 for closed forms.
    pub iterations: usize,
}

impl Alignment {
    /// The identity transform.
    pub fn identity(method: AlignMethod) -> Self {
        Alignment {
            method,
            rotation: Matrix3::identity(),
            translation: Vector3::zeros(),
            scale: 1.0,
            iterations: 0,
        }
    }
    /// Maps a map-frame point into the survey frame.
    pub fn apply(&self, p: &Point) -> Point {
        Point::from(self.scale * (self.rotation * p.coords) + self.translation)
    }
    /// Heading change (yaw about +z), degrees.
    pub fn rotation_deg(&self) -> f64 {
        self.rotation[(1, 0)]
            .atan2(self.rotation[(0, 0)])
            .to_degrees()
    }
    /// Scale deviation in parts per million.
    pub(crate) fn scale_ppm(&self) -> f64 {
        (self.scale - 1.0) * 1e6
    }
    /// The inverse transform (survey → map), e.g. to place survey targets in a map.
    pub fn inverse(&self) -> Alignment {
        let rt = self.rotation.transpose();
        Alignment {
            method: self.method,
            rotation: rt,
            translation: -(rt * self.translation) / self.scale,
            scale: 1.0 / self.scale,
            iterations: self.iterations,
        }
    }
}

/// Fits `method` so that `apply(src[i]) ≈ dst[i]`.
pub fn fit(method: AlignMethod, src: &[Point], dst: &[Point]) -> Result<Alignment> {
    if src.len() != dst.len() {
        return Err(Error::Input(format!(
            "alignment needs paired points ({} vs {})",
            src.len(),
            dst.len()
        )));
    }
    let n = src.len();
    if n < method.min_points() {
        return Err(Error::Input(format!(
            "alignment {method} needs at least {} common targets, got {n}",
            method.min_points()
        )));
    }
    let w = vec![1.0; n];
    let a = match method {
        AlignMethod::None => Alignment::identity(method),
        AlignMethod::Rigid2d => planar(method, src, dst, &w, false, false),
        AlignMethod::Rigid2dZ => planar(method, src, dst, &w, false, true),
        AlignMethod::Similarity2d => planar(method, src, dst, &w, true, false),
        AlignMethod::Rigid3d => spatial(method, src, dst, false)?,
        AlignMethod::Similarity3d => spatial(method, src, dst, true)?,
        AlignMethod::Robust2d => robust2d(src, dst),
    };
    let ok =
        a.rotation.iter().all(|v| v.is_finite()) && a.translation.iter().all(|v| v.is_finite());
    if !ok || !a.scale.is_finite() || a.scale <= 0.0 {
        return Err(Error::Input(format!(
            "alignment {method} is degenerate (targets coincide?)"
        )));
    }
    Ok(a)
}

fn centroid(p: &[Point], w: &[f64]) -> Vector3<f64> {
    let sw: f64 = w.iter().sum();
    // Two-pass: shift by the first point so large coordinates do not swamp the sum.
    let o = p[0].coords;
    let mut s = Vector3::zeros();
    for (q, wi) in p.iter().zip(w) {
        s += (q.coords - o) * *wi;
    }
    o + s / sw
}

/// Weighted closed-form 2D fit (yaw, x, y[, z offset][, scale]).
fn planar(
    method: AlignMethod,
    src: &[Point],
    dst: &[Point],
    w: &[f64],
    scale: bool,
    z: bool,
) -> Alignment {
    let cs = centroid(src, w);
    let cd = centroid(dst, w);
    let (mut sc, mut ss, mut sp) = (0.0, 0.0, 0.0);
    for ((p, q), wi) in src.iter().zip(dst).zip(w) {
        let (px, py) = (p.x - cs.x, p.y - cs.y);
        let (qx, qy) = (q.x - cd.x, q.y - cd.y);
        sc += wi * (px * qx + py * qy);
        ss += wi * (px * qy - py * qx);
        sp += wi * (px * px + py * py);
    }
    let th = ss.atan2(sc);
    let (s, c) = th.sin_cos();
    let k = if scale && sp > 0.0 {
        sc.hypot(ss) / sp
    } else {
        1.0
    };
    let rot = Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0);
    let rc = rot * cs * k;
    let tz = if z { cd.z - cs.z } else { 0.0 };
    Alignment {
        method,
        rotation: rot,
        translation: Vector3::new(cd.x - rc.x, cd.y - rc.y, tz),
        scale: k,
        iterations: 0,
    }
}

/// Umeyama (1991): least-squares rotation (+ scale) in 3D, reflection excluded.
fn spatial(method: AlignMethod, src: &[Point], dst: &[Point], scale: bool) -> Result<Alignment> {
    let w = vec![1.0; src.len()];
    let cs = centroid(src, &w);
    let cd = centroid(dst, &w);
    let mut h = Matrix3::zeros();
    let mut var = 0.0;
    for (p, q) in src.iter().zip(dst) {
        let a = p.coords - cs;
        let b = q.coords - cd;
        h += b * a.transpose();
        var += a.norm_squared();
    }
    let svd = h.svd(true, true);
    let (u, vt) = match (svd.u, svd.v_t) {
        (Some(u), Some(vt)) => (u, vt),
        _ => return Err(Error::Input(format!("alignment {method}: SVD failed"))),
    };
    let d = if (u * vt).determinant() < 0.0 {
        -1.0
    } else {
        1.0
    };
    let dm = Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, d));
    let rot = u * dm * vt;
    let sv = svd.singular_values;
    let k = if scale && var > 0.0 {
        (sv[0] + sv[1] + d * sv[2]) / var
    } else {
        1.0
    };
    Ok(Alignment {
        method,
        rotation: rot,
        translation: cd - rot * cs * k,
        scale: k,
        iterations: 0,
    })
}

/// Sum of 2D distances after alignment: the objective of the paper's Eq. 1.
pub(crate) fn sum_of_distances_2d(a: &Alignment, src: &[Point], dst: &[Point]) -> f64 {
    src.iter()
        .zip(dst)
        .map(|(p, q)| (a.apply(p) - q).xy().norm())
        .sum()
}

/// The paper's Eq. 1 by iteratively reweighted least squares (Weiszfeld-style
/// majorise–minimise: weights 1/rᵢ, each step never increases the sum of distances).
fn robust2d(src: &[Point], dst: &[Point]) -> Alignment {
    let mut w = vec![1.0; src.len()];
    let mut a = planar(AlignMethod::Robust2d, src, dst, &w, false, false);
    let mut cost = sum_of_distances_2d(&a, src, dst);
    let scale = src
        .iter()
        .zip(dst)
        .map(|(p, q)| (p - q).xy().norm())
        .fold(0.0, f64::max)
        .max(1.0);
    let eps = 1e-12 * scale;
    let mut it = 0;
    while it < 10_000 {
        it += 1;
        for ((p, q), wi) in src.iter().zip(dst).zip(w.iter_mut()) {
            *wi = 1.0 / (a.apply(p) - q).xy().norm().max(eps);
        }
        let next = planar(AlignMethod::Robust2d, src, dst, &w, false, false);
        let c = sum_of_distances_2d(&next, src, dst);
        if c > cost {
            break;
        }
        let moved =
            (next.translation - a.translation).norm() + (next.rotation - a.rotation).norm() * scale;
        a = next;
        let gain = cost - c;
        cost = c;
        if gain <= 1e-15 * cost.max(eps) && moved < 1e-12 * scale {
            break;
        }
    }
    a.iterations = it;
    a
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    fn pts(rng: &mut rand_pcg::Pcg64, n: usize, big: bool) -> Vec<Point> {
        let o = if big {
            Vector3::new(350_000.0, 4_150_000.0, 100.0)
        } else {
            Vector3::zeros()
        };
        (0..n)
            .map(|_| {
                Point::from(
                    o + Vector3::new(
                        rng.random_range(-50.0..50.0),
                        rng.random_range(-50.0..50.0),
                        rng.random_range(-2.0..2.0),
                    ),
                )
            })
            .collect()
    }

    fn transform(yaw: f64, roll: f64, k: f64, t: Vector3<f64>) -> Alignment {
        let r = nalgebra::Rotation3::from_euler_angles(roll, 0.0, yaw.to_radians());
        Alignment {
            method: AlignMethod::None,
            rotation: *r.matrix(),
            translation: t,
            scale: k,
            iterations: 0,
        }
    }

    #[test]
    fn each_method_recovers_a_known_transform() {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(7);
        for big in [false, true] {
            let src = pts(&mut rng, 6, big);
            let t = Vector3::new(-12.3, 45.6, 0.0);
            let cases = [
                (AlignMethod::Rigid2d, transform(-1.27, 0.0, 1.0, t)),
                (AlignMethod::Robust2d, transform(33.0, 0.0, 1.0, t)),
                (
                    AlignMethod::Rigid2dZ,
                    transform(-170.0, 0.0, 1.0, t + Vector3::new(0.0, 0.0, 3.2)),
                ),
                (
                    AlignMethod::Similarity2d,
                    transform(5.0, 0.0, 1.0 + 250e-6, t),
                ),
                (
                    AlignMethod::Rigid3d,
                    transform(95.0, 0.02, 1.0, t + Vector3::new(0.0, 0.0, -7.0)),
                ),
                (
                    AlignMethod::Similarity3d,
                    transform(-60.0, -0.01, 0.999, t + Vector3::new(0.0, 0.0, 1.0)),
                ),
                (
                    AlignMethod::None,
                    transform(0.0, 0.0, 1.0, Vector3::zeros()),
                ),
            ];
            for (m, truth) in cases {
                let dst: Vec<Point> = src.iter().map(|p| truth.apply(p)).collect();
                let a = fit(m, &src, &dst).unwrap();
                assert!(
                    (a.rotation - truth.rotation).norm() < 1e-9,
                    "{m} {big}: {}",
                    a.rotation
                );
                assert!((a.scale - truth.scale).abs() < 1e-9, "{m}");
                for (p, q) in src.iter().zip(&dst) {
                    assert!(
                        (a.apply(p) - q).norm() < 1e-6,
                        "{m} big={big}: {}",
                        (a.apply(p) - q).norm()
                    );
                }
                assert!(
                    (a.rotation_deg() - truth.rotation_deg()).abs() < 1e-7,
                    "{m}"
                );
                assert!((a.rotation.determinant() - 1.0).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn reflection_is_excluded() {
        // dst is a mirror image of src: the best proper rotation must still be returned.
        let src = [
            Point::new(0.0, 0.0, 0.0),
            Point::new(10.0, 0.0, 0.0),
            Point::new(0.0, 5.0, 0.0),
            Point::new(3.0, 7.0, 1.0),
        ];
        let dst: Vec<Point> = src.iter().map(|p| Point::new(p.x, -p.y, p.z)).collect();
        for m in [
            AlignMethod::Rigid2d,
            AlignMethod::Rigid3d,
            AlignMethod::Similarity2d,
            AlignMethod::Similarity3d,
            AlignMethod::Robust2d,
        ] {
            let a = fit(m, &src, &dst).unwrap();
            assert!((a.rotation.determinant() - 1.0).abs() < 1e-9, "{m}");
            assert!(a.scale > 0.0);
            let err: f64 = src
                .iter()
                .zip(&dst)
                .map(|(p, q)| (a.apply(p) - q).norm())
                .sum();
            assert!(err > 1.0, "{m}: a mirror cannot be fitted by a rotation");
        }
        // A 3D planar configuration (all z equal) with a mirror must not flip z either.
        let src3 = [
            Point::new(0.0, 0.0, 0.0),
            Point::new(10.0, 0.0, 0.0),
            Point::new(0.0, 5.0, 0.0),
        ];
        let a = fit(AlignMethod::Rigid3d, &src3, &src3).unwrap();
        assert!((a.rotation - Matrix3::identity()).norm() < 1e-9);
    }

    #[test]
    fn inverse_undoes() {
        let a = transform(12.0, 0.03, 1.001, Vector3::new(1.0, 2.0, 3.0));
        let p = Point::new(5.0, -7.0, 2.0);
        assert!((a.inverse().apply(&a.apply(&p)) - p).norm() < 1e-12);
    }

    #[test]
    fn too_few_targets_is_an_error() {
        let p = [Point::origin()];
        let e = fit(AlignMethod::Rigid2d, &p, &p).unwrap_err().to_string();
        assert!(e.contains("at least 2"), "{e}");
        let p2 = [Point::origin(), Point::origin()];
        assert!(fit(AlignMethod::Rigid3d, &p2, &p2).is_err());
        assert!("rigid4d".parse::<AlignMethod>().is_err());
        assert_eq!(
            "rigid2d+z".parse::<AlignMethod>().unwrap(),
            AlignMethod::Rigid2dZ
        );
    }

    /// Brute-force minimum of the sum of distances over (yaw, tx, ty), refined twice.
    fn grid_min(src: &[Point], dst: &[Point], mut c: (f64, f64, f64), mut span: (f64, f64)) -> f64 {
        let mut best = f64::INFINITY;
        for _ in 0..6 {
            let mut bc = c;
            for i in -20..=20 {
                let th = c.0 + span.0 * i as f64 / 20.0;
                for j in -20..=20 {
                    for k in -20..=20 {
                        let t = Vector3::new(
                            c.1 + span.1 * j as f64 / 20.0,
                            c.2 + span.1 * k as f64 / 20.0,
                            0.0,
                        );
                        let a = transform(th, 0.0, 1.0, t);
                        let v = sum_of_distances_2d(&a, src, dst);
                        if v < best {
                            best = v;
                            bc = (th, t.x, t.y);
                        }
                    }
                }
            }
            c = bc;
            span = (span.0 / 5.0, span.1 / 5.0);
        }
        best
    }

    #[test]
    fn robust2d_matches_brute_force() {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(3);
        for case in 0..3 {
            let src = pts(&mut rng, 4 + case, false);
            let truth = transform(2.0, 0.0, 1.0, Vector3::new(0.5, -0.3, 0.0));
            let mut dst: Vec<Point> = src.iter().map(|p| truth.apply(p)).collect();
            for q in dst.iter_mut() {
                q.x += rng.random_range(-0.2..0.2);
                q.y += rng.random_range(-0.2..0.2);
            }
            dst[0].x += 3.0; // an outlier, where Eq. 1 and least squares differ
            let a = fit(AlignMethod::Robust2d, &src, &dst).unwrap();
            let ls = fit(AlignMethod::Rigid2d, &src, &dst).unwrap();
            let ours = sum_of_distances_2d(&a, &src, &dst);
            let brute = grid_min(&src, &dst, (0.0, 0.0, 0.0), (10.0, 5.0));
            assert!(
                ours <= brute + 1e-6,
                "case {case}: irls {ours} vs grid {brute}"
            );
            assert!(
                ours < sum_of_distances_2d(&ls, &src, &dst) - 1e-6,
                "case {case}: no better than LS"
            );
        }
    }
}
