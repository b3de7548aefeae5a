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
use crate::geom::plane::Moments;
use crate::geom::{Draw, Plane, Ransac, plane};
use nalgebra::{Matrix3, Vector2, Vector3};
use rand::SeedableRng;
use rand_pcg::Pcg64Mcg;
use std::f64::consts::FRAC_1_SQRT_2;

/// Fewest inliers a plate must have for its plane to be trusted.
const MIN_PLATE_INLIERS: usize = 8;

/// The margin at a plate's free end, in the other plate's noise σ
/// ([`free_end`]): of the returns from within 2.5 σ of the end, 0.6 % are
/// pushed past the margin.
const FREE_END_SIGMAS: f64 = 2.5;

/// The plate is refitted short of its free end only when that turns it by
/// more than the points it drops explain, at 3 σ (a Hausman test: the turn's
/// variance under no pull is the shorter fit's less the whole one's). A
/// scanner driving past sees each plate from both sides and its pulls
/// cancel; dropping the end's points, the most telling of the turn, would
/// cost it precision for nothing: at 1.96 σ the clutter cases' median error
/// grew 8 % (docs/algorithm.md, "The plate's free end").
const FREE_END_CHI2: f64 = 9.0;

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
    /// Each plate's refit candidates.
    near: [Vec<Near>; 2],
    /// Residuals for the refit band's noise estimate.
    resid: Vec<f64>,
}

/// A point near one plate and away from the corner: its index and its
/// distances from that plate's plane and from the other's (how far along
/// the plate it lies from the corner line).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Near {
    i: u32,
    own: f64,
    other: f64,
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
        // The refit's own candidates and noise, about the final planes.
        let (mut near, mut resid) = ([Vec::new(), Vec::new()], Vec::new());
        self.near_plates(planes, &mut near);
        [0, 1].map(|k| self.band(noise(&near[k], &mut resid)))
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
            near,
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
        self.refit(&mut planes, inl, next, near, resid)?;
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
    /// also lie near the plane, and the plate's free end (`free_end`); until
    /// nothing changes or `refit_iterations` runs out. Both plates' candidates
    /// come from one pass over the crop, against the planes the iteration began
    /// with.
    fn refit(
        &self,
        planes: &mut [Plane; 2],
        inl: &mut [Vec<u32>; 2],
        next: &mut Vec<u32>,
        near: &mut [Vec<Near>; 2],
        resid: &mut Vec<f64>,
    ) -> Result<(), Reason> {
        let p = self.params;
        for _ in 0..p.refit_iterations {
            self.near_plates(planes, near);
            let sigma = [noise(&near[0], resid), noise(&near[1], resid)];
            let mut changed = false;
            for k in 0..2 {
                let band = self.band(sigma[k]);
                let keep_to = free_end(&near[k], band, sigma[1 - k], p.corner_margin, resid);
                let to = keep_to.unwrap_or(f64::INFINITY);
                // One pass: the in-band candidates, their sums, and those of
                // the ones past the free end's margin.
                next.clear();
                let origin = near[k]
                    .first()
                    .map_or_else(Vector3::zeros, |c| self.pts[c.i as usize]);
                let (mut all, mut past) = (Moments::new(origin), Moments::new(origin));
                for c in near[k].iter().filter(|c| c.own < band) {
                    let q = &self.pts[c.i as usize];
                    next.push(c.i);
                    all.add(q);
                    if c.other > to {
                        past.add(q);
                    }
                }
                if next.len() < MIN_PLATE_INLIERS {
                    return Err(Reason::Degenerate);
                }
                let Some(mut plane) = all.plane() else {
                    // The old inliers' own plane, fitted before: kept.
                    if *next == inl[k] {
                        continue;
                    }
                    return Err(Reason::Degenerate);
                };
                let short = all.without(&past);
                if let Some(s) = sigma[k].filter(|_| past.count() > 0)
                    && short.count() >= MIN_PLATE_INLIERS
                    && let Some(trimmed) = short.plane()
                {
                    let leverage = |m: &Moments| m.turn_leverage(&plane.normal, &self.up);
                    let excess = s * s * (leverage(&short) - leverage(&all));
                    let turn = plane.normal.cross(&trimmed.normal).dot(&self.up);
                    // No excess (noiseless or quantised points): nothing to test.
                    if excess > 0.0 && turn * turn > FREE_END_CHI2 * excess {
                        plane = trimmed;
                        next.clear();
                        next.extend(
                            near[k]
                                .iter()
                                .filter(|c| c.own < band && c.other <= to)
                                .map(|c| c.i),
                        );
                    }
                }
                if *next == inl[k] {
                    continue;
                }
                planes[k] = plane;
                std::mem::swap(&mut inl[k], next);
                changed = true;
            }
            if !changed {
                break;
            }
        }
        Ok(())
    }

    /// The refit's candidates of each plate: the points within `corner_margin`
    /// of its plane and at least that far from the other's, with both
    /// distances.
    fn near_plates(&self, planes: &[Plane; 2], near: &mut [Vec<Near>; 2]) {
        let m = self.params.corner_margin;
        for v in near.iter_mut() {
            v.clear();
        }
        for (i, q) in self.pts.iter().enumerate() {
            let d = [planes[0].distance(q).abs(), planes[1].distance(q).abs()];
            for k in 0..2 {
                if d[k] < m && d[1 - k] >= m {
                    near[k].push(Near {
                        i: i as u32,
                        own: d[k],
                        other: d[1 - k],
                    });
                }
            }
        }
    }

    /// Half-width of the refit's inlier band: `refit_sigmas` times the plate's
    /// noise ([`noise`]), never less than `inlier_threshold` nor more than
    /// `corner_margin`; `inlier_threshold` without a noise estimate.
    fn band(&self, sigma: Option<f64>) -> f64 {
        let p = self.params;
        match sigma {
            Some(s) if p.refit_sigmas > 0.0 => {
                (p.refit_sigmas * s).clamp(p.inlier_threshold, p.corner_margin)
            }
            _ => p.inlier_threshold,
        }
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

/// A plate's noise: 1.4826 × the median distance of its candidates from its
/// plane (they lie in a window a few times wider than the noise, so the
/// estimate is hardly truncated, and robust to the outliers inside it);
/// `None` with too few.
fn noise(near: &[Near], resid: &mut Vec<f64>) -> Option<f64> {
    resid.clear();
    resid.extend(near.iter().map(|c| c.own));
    median_sigma(resid)
}

/// 1.4826 × the median of `d`; `None` with too few.
fn median_sigma(d: &mut [f64]) -> Option<f64> {
    if d.len() < MIN_PLATE_INLIERS {
        return None;
    }
    let mid = d.len() / 2;
    let (_, median, _) = d.select_nth_unstable_by(mid, f64::total_cmp);
    Some(1.4826 * *median)
}

/// How far from the corner line a plate's inliers may lie when the refit
/// drops its free end: the end less `FREE_END_SIGMAS` of the other plate's
/// noise, at most `corner_margin`. Range noise moves a return along its ray,
/// so on a plate seen obliquely it moves along the plate as much as off it;
/// in the plate's middle the moves cancel, but past the free end only the
/// returns pushed outwards remain, all offset to one side, and a plane
/// fitted through them turns (by σ²·cos·sin of the incidence over the
/// plate's spread: ~5 mrad, ~1.5 mm at the corner, for 2 cm of noise seen at
/// 45° from one side, as a forward-looking scanner sees it; docs/algorithm.md).
/// Along-plate noise is the other plate's off-plate noise (the plates are
/// square to each other), so its σ sets the margin. The free end is the
/// 99th percentile of the in-band candidates' distance from the corner line
/// (the returns pushed past the end are about 1 % of a plate's). The corner
/// end is already `corner_margin` away.
fn free_end(
    near: &[Near],
    band: f64,
    other_sigma: Option<f64>,
    cap: f64,
    d: &mut Vec<f64>,
) -> Option<f64> {
    let s = other_sigma?;
    d.clear();
    d.extend(near.iter().filter(|c| c.own < band).map(|c| c.other));
    if d.len() < MIN_PLATE_INLIERS {
        return None;
    }
    let at = (d.len() - 1) * 99 / 100;
    let (_, end, _) = d.select_nth_unstable_by(at, f64::total_cmp);
    Some(*end - (FREE_END_SIGMAS * s).min(cap))
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
