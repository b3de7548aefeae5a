//! One attempt: the paper's steps on one random draw.
//!
//! k-means (K = 2) splits the crop into the clusters P1, P2 → RANSAC finds each
//! plate's inliers → SVD fits each plate's plane → (beyond the paper) a refit in
//! a noise-wide band → the plates must be perpendicular to each other and to the
//! ground → the corner is the planes' intersection at the inliers' mean height.
//! [`Ctx::attempt`] is that list, one named call per step.

use super::kmeans::{self, Space};
use super::params::LocateParams;
use super::types::{Label, Rejects};
use crate::geom::{Draw, Plane, Ransac, plane};
use nalgebra::{Matrix3, Vector2, Vector3};
use rand::SeedableRng;
use rand_pcg::Pcg64Mcg;
use std::f64::consts::FRAC_1_SQRT_2;

/// Fewest inliers a plate must have for its plane to be trusted.
const MIN_PLATE_INLIERS: usize = 8;

/// An accepted attempt.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Sample {
    /// Corner, centred frame.
    pub(crate) corner: Vector3<f64>,
    /// The two plates' planes (P1, P2).
    pub(crate) planes: [Plane; 2],
    /// Inliers of each plane.
    pub(crate) inliers: [usize; 2],
}

/// Why an attempt was rejected; tallied in [`Rejects`].
#[derive(Debug, Clone, Copy)]
pub(crate) enum Reason {
    Degenerate,
    SamePlane,
    NotPerpendicular,
    Tilted,
}

impl Rejects {
    /// Counts one rejected attempt.
    pub(crate) fn tally(&mut self, reason: Reason) {
        match reason {
            Reason::Degenerate => self.degenerate += 1,
            Reason::SamePlane => self.same_plane += 1,
            Reason::NotPerpendicular => self.not_perpendicular += 1,
            Reason::Tilted => self.tilted += 1,
        }
    }
}

/// The points as k-means compares them.
enum KPoints<'a> {
    Full(&'a [Vector3<f64>]),
    Horizontal(Vec<Vector2<f64>>),
}

/// Buffers of one attempt, reused across the attempts of a rayon work item.
#[derive(Default)]
pub(crate) struct Scratch {
    /// k-means label of each point.
    cl: Vec<u8>,
    /// Each cluster's point indices.
    idx: [Vec<u32>; 2],
    /// Each plate's inliers.
    inl: [Vec<u32>; 2],
    /// A refit's next inliers.
    next: Vec<u32>,
    /// Preemptive RANSAC's subset.
    sub: Vec<Vector3<f64>>,
    /// Residuals for the refit band's noise estimate.
    resid: Vec<f64>,
}

/// Inputs shared by all attempts.
pub(crate) struct Ctx<'a> {
    /// The crop, centred.
    pts: &'a [Vector3<f64>],
    /// The points in k-means' space.
    kpts: KPoints<'a>,
    /// Unit vertical of the gates and of the corner height.
    up: Vector3<f64>,
    params: &'a LocateParams,
    /// Each plate's RANSAC.
    ransac: Ransac,
    /// Sine of the angle tolerance: the gates compare |cos| of normals with it.
    sin_tol: f64,
}

/// The random stream of attempt `attempt`: its own generator, so attempts can
/// run in any order on any number of threads.
pub(crate) fn attempt_rng(seed: u64, attempt: usize) -> Pcg64Mcg {
    // splitmix64 of a seed/index mix: neighbouring indices get unrelated streams.
    let mut z = seed
        ^ (attempt as u64)
            .wrapping_add(1)
            .wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    Pcg64Mcg::seed_from_u64(z ^ (z >> 31))
}

impl<'a> Ctx<'a> {
    /// The context of attempts on `pts` (centred) with unit vertical `up`.
    pub(crate) fn new(pts: &'a [Vector3<f64>], up: Vector3<f64>, params: &'a LocateParams) -> Self {
        Ctx {
            pts,
            kpts: match params.kmeans_space {
                Space::Full => KPoints::Full(pts),
                Space::Horizontal => KPoints::Horizontal(kmeans::horizontal(pts, &up)),
            },
            up,
            params,
            ransac: Ransac {
                iterations: params.ransac_iterations,
                threshold: params.inlier_threshold,
                score_points: params.ransac_score_points,
                confidence: params.ransac_confidence,
                draw: Draw::Distinct,
            },
            sin_tol: params.angle_tolerance_deg.to_radians().sin(),
        }
    }

    /// Unit vertical of the gates.
    pub(crate) fn up(&self) -> Vector3<f64> {
        self.up
    }

    /// The crop, centred.
    pub(crate) fn points(&self) -> &'a [Vector3<f64>] {
        self.pts
    }

    /// Half-width of the band each plate's final inliers were taken from: the
    /// refit's noise-wide band, or RANSAC's threshold without a refit.
    pub(crate) fn final_band(&self, planes: &[Plane; 2]) -> [f64; 2] {
        if self.params.refit_iterations == 0 {
            return [self.params.inlier_threshold; 2];
        }
        let mut resid = Vec::new();
        [
            self.refit_band(&planes[0], &planes[1], &mut resid),
            self.refit_band(&planes[1], &planes[0], &mut resid),
        ]
    }

    /// Runs attempt `index`; with `labels`, also records each point's role.
    pub(crate) fn attempt(
        &self,
        index: usize,
        s: &mut Scratch,
        labels: Option<&mut Vec<Label>>,
    ) -> Result<Sample, Reason> {
        let Scratch {
            cl,
            idx,
            inl,
            next,
            sub,
            resid,
        } = s;
        let mut rng = attempt_rng(self.params.seed, index);
        // 1. k-means (K = 2): the crop → clusters P1, P2.
        self.kmeans_split(&mut rng, cl)?;
        clusters(cl, idx);
        // 2.–3. Per plate: RANSAC's inliers P_k^R, then their SVD plane P_k^op.
        self.ransac(&idx[0], &mut rng, sub, &mut inl[0])?;
        let p1 = svd_plane(self.pts, &inl[0])?;
        self.ransac(&idx[1], &mut rng, sub, &mut inl[1])?;
        let p2 = svd_plane(self.pts, &inl[1])?;
        let mut planes = [p1, p2];
        two_planes(&planes)?;
        // Beyond the paper: refit each plate in a noise-wide band.
        self.refit(&mut planes, inl, next, resid)?;
        // 4. Gates: perpendicular to each other, each perpendicular to the ground.
        self.perpendicular(&planes)?;
        self.vertical(&planes)?;
        // 5. Corner: the planes' intersection line at the inliers' mean height.
        let height = self.mean_height(inl);
        let corner = self.corner(&planes, height)?;
        if let Some(labels) = labels {
            label(labels, self.pts.len(), inl);
        }
        Ok(Sample {
            corner,
            planes,
            inliers: [inl[0].len(), inl[1].len()],
        })
    }

    /// Step 1: k-means with K = 2 labels every point 0 (P1) or 1 (P2).
    fn kmeans_split(&self, rng: &mut Pcg64Mcg, cl: &mut Vec<u8>) -> Result<(), Reason> {
        let p = self.params;
        let split = match &self.kpts {
            KPoints::Full(k) => kmeans::split2_points(
                k,
                p.kmeans_init,
                p.kmeans_iterations,
                p.kmeans_points,
                rng,
                cl,
            ),
            KPoints::Horizontal(k) => kmeans::split2_points(
                k,
                p.kmeans_init,
                p.kmeans_iterations,
                p.kmeans_points,
                rng,
                cl,
            ),
        };
        split.then_some(()).ok_or(Reason::Degenerate)
    }

    /// Step 2: RANSAC on one cluster leaves its plate's inliers (P_k^R).
    fn ransac(
        &self,
        cluster: &[u32],
        rng: &mut Pcg64Mcg,
        sub: &mut Vec<Vector3<f64>>,
        inliers: &mut Vec<u32>,
    ) -> Result<(), Reason> {
        self.ransac
            .best_plane(self.pts, cluster, rng, sub, inliers)
            .ok_or(Reason::Degenerate)?;
        if inliers.len() < MIN_PLATE_INLIERS {
            return Err(Reason::Degenerate);
        }
        Ok(())
    }

    /// Beyond the paper: refit both plates on the inliers of their previous fit,
    /// taken from the whole crop (so k-means mistakes heal) but excluding the
    /// corner region, where the pole, the antenna mast and the other plate's edge
    /// also lie near the plane; until nothing changes or `refit_iterations` runs out.
    fn refit(
        &self,
        planes: &mut [Plane; 2],
        inl: &mut [Vec<u32>; 2],
        next: &mut Vec<u32>,
        resid: &mut Vec<f64>,
    ) -> Result<(), Reason> {
        let p = self.params;
        for _ in 0..p.refit_iterations {
            let mut changed = false;
            for k in 0..2 {
                let (own, other) = (planes[k], planes[1 - k]);
                let band = self.refit_band(&own, &other, resid);
                next.clear();
                for (i, q) in self.pts.iter().enumerate() {
                    if own.distance(q).abs() < band && other.distance(q).abs() >= p.corner_margin {
                        next.push(i as u32);
                    }
                }
                if *next == inl[k] {
                    continue;
                }
                if next.len() < MIN_PLATE_INLIERS {
                    return Err(Reason::Degenerate);
                }
                planes[k] = svd_plane(self.pts, next)?;
                std::mem::swap(&mut inl[k], next);
                changed = true;
            }
            if !changed {
                break;
            }
        }
        Ok(())
    }

    /// Half-width of the refit's inlier band around `own`: `refit_sigmas` times the
    /// plate's noise, estimated as 1.4826 × the median absolute residual of the
    /// points within `corner_margin` of `own` and away from the corner (a window a
    /// few times wider than the noise, so the estimate is hardly truncated, and
    /// robust to the outliers inside it).
    fn refit_band(&self, own: &Plane, other: &Plane, resid: &mut Vec<f64>) -> f64 {
        let p = self.params;
        if p.refit_sigmas <= 0.0 {
            return p.inlier_threshold;
        }
        resid.clear();
        resid.extend(self.pts.iter().filter_map(|q| {
            let d = own.distance(q).abs();
            (d < p.corner_margin && other.distance(q).abs() >= p.corner_margin).then_some(d)
        }));
        if resid.len() < MIN_PLATE_INLIERS {
            return p.inlier_threshold;
        }
        let mid = resid.len() / 2;
        let (_, median, _) = resid.select_nth_unstable_by(mid, f64::total_cmp);
        let sigma = 1.4826 * *median;
        (p.refit_sigmas * sigma).clamp(p.inlier_threshold, p.corner_margin)
    }

    /// Step 4a: the plates perpendicular to each other within the tolerance.
    fn perpendicular(&self, planes: &[Plane; 2]) -> Result<(), Reason> {
        two_planes(planes)?;
        if planes[0].normal.dot(&planes[1].normal).abs() > self.sin_tol {
            return Err(Reason::NotPerpendicular);
        }
        Ok(())
    }

    /// Step 4b: each plate perpendicular to the ground (vertical w.r.t. `up`)
    /// within the tolerance.
    fn vertical(&self, planes: &[Plane; 2]) -> Result<(), Reason> {
        if planes
            .iter()
            .any(|q| q.normal.dot(&self.up).abs() > self.sin_tol)
        {
            return Err(Reason::Tilted);
        }
        Ok(())
    }

    /// Step 5a: the mean height (along `up`) of both plates' inliers.
    fn mean_height(&self, inl: &[Vec<u32>; 2]) -> f64 {
        let n_in = (inl[0].len() + inl[1].len()) as f64;
        inl.iter()
            .flatten()
            .map(|&i| self.up.dot(&self.pts[i as usize]))
            .sum::<f64>()
            / n_in
    }

    /// Step 5b: the corner, the point of the planes' intersection line at `height`.
    fn corner(&self, planes: &[Plane; 2], height: f64) -> Result<Vector3<f64>, Reason> {
        let m = Matrix3::from_rows(&[
            planes[0].normal.transpose(),
            planes[1].normal.transpose(),
            self.up.transpose(),
        ]);
        let rhs = Vector3::new(planes[0].offset, planes[1].offset, height);
        m.lu()
            .solve(&rhs)
            .filter(|c| c.iter().all(|v| v.is_finite()))
            .ok_or(Reason::Degenerate)
    }
}

/// Each cluster's point indices from the k-means labels.
fn clusters(cl: &[u8], idx: &mut [Vec<u32>; 2]) {
    for v in idx.iter_mut() {
        v.clear();
    }
    for (i, &c) in cl.iter().enumerate() {
        idx[usize::from(c & 1)].push(i as u32);
    }
}

/// Step 3: the least-squares (SVD) plane of a plate's inliers (P_k^op).
fn svd_plane(pts: &[Vector3<f64>], inliers: &[u32]) -> Result<Plane, Reason> {
    plane::fit(pts, inliers).ok_or(Reason::Degenerate)
}

/// Both clusters must have found different planes (≥ 45° apart); otherwise the
/// split saw one plate twice.
fn two_planes(planes: &[Plane; 2]) -> Result<(), Reason> {
    if planes[0].normal.dot(&planes[1].normal).abs() > FRAC_1_SQRT_2 {
        return Err(Reason::SamePlane);
    }
    Ok(())
}

/// Each point's role: inlier of plate 1, of plate 2, or neither.
fn label(labels: &mut Vec<Label>, n: usize, inl: &[Vec<u32>; 2]) {
    labels.clear();
    labels.resize(n, Label::Outlier);
    for &i in &inl[0] {
        labels[i as usize] = Label::Plate1;
    }
    for &i in &inl[1] {
        labels[i as usize] = Label::Plate2;
    }
}
