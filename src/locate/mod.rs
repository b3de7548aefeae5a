//! Step 5: locate an L-target's corner in a tight crop (the paper's Section II).
//!
//! One *attempt* is: k-means (K = 2) splits the crop into two plates; RANSAC
//! finds each plate's plane among its cluster (3-point hypotheses, inlier
//! threshold 3 cm); a least-squares (SVD) fit on the inliers gives the plane;
//! the attempt is *accepted* only if the planes are perpendicular to each other
//! and each is vertical (w.r.t. `up`), both within the angle tolerance. Its
//! *sample* is the point of the planes' intersection line at the mean height of
//! both plates' inliers. Attempts repeat until `samples` are accepted; the
//! corner is their mean and the spread their per-axis standard deviation.
//!
//! The steps map to functions as listed in `docs/algorithm.md`.
//!
//! Beyond the paper (all switchable, see [`LocateParams::paper`]): k-means on
//! horizontal coordinates with k-means++ starts (the pole and antenna no longer
//! drag the split into top/bottom halves), and a refit loop (inliers of the SVD
//! plane → SVD again) that removes the dependence of the normal on RANSAC's
//! 3-point hypothesis. The refit takes its inliers from a band 2.5 noise
//! standard deviations wide (noise estimated robustly per plate): with 2–3 cm
//! LiDAR noise a 3 cm band cuts the plate's point cloud and drags each fit
//! towards the previous one, so plates that are exactly vertical came out
//! ~1° off and most samples failed the 1° gates. Together these raise
//! acceptance from ~1 % (the paper's algorithm on synthetic crops with pole and
//! antenna) to ~25 % without touching the gates.
//!
//! Speed (also switchable, all off in [`LocateParams::paper`]): k-means finds its
//! centres on a random sample of the crop, RANSAC scores its hypotheses on a
//! random subset of each cluster (preemptive RANSAC, the best few re-scored on
//! all points) and stops once the standard confidence bound is met. The gates,
//! the inlier threshold and the final SVD fit on all inliers are unchanged.
//!
//! Determinism: attempt `i` draws from its own generator seeded from
//! `(seed, i)`, attempts run in fixed-size batches (in parallel with rayon) and
//! are consumed in index order, so results are bit-identical for any thread count.

mod attempt;
pub(crate) mod covariance;
mod ground_layers;
mod height;
pub(crate) mod kmeans;
mod layers;
mod params;
/// Random L-target crops with known corners, for the unit tests and the
/// locator's benchmark: behind the `testgen` feature, not part of the API.
#[cfg(any(test, feature = "testgen"))]
pub mod testgen;
#[cfg(test)]
mod tests;
mod types;

use crate::Point;
use attempt::{Ctx, Sample, Scratch};
use nalgebra::Vector3;
use rayon::prelude::*;

pub use ground_layers::{GroundLayers, ground_layers};
pub use height::{HeightSeen, place_height};
pub use kmeans::{Init, Space};
pub use layers::{Doubled, DoublingLimit, Layering, PlateLayers, layering};
pub use params::LocateParams;
pub use types::{Label, LocateError, Located, PlateFit, Rejects};

/// Fewest points a crop must have: two plates need a plane each, and a plane
/// needs several points beyond the 3 that define it to be checked at all.
pub(crate) const MIN_POINTS: usize = 20;
/// Attempts computed per parallel batch. Fixed (not the thread count) so the
/// set of attempts looked at never depends on the machine.
const BATCH: usize = 32;

/// [`locate`] with the configured draws, then the other kind (plain draws
/// and the refit fail on different crops: with the refit every attempt
/// converges to the same planes, so when that one answer misses a gate
/// every attempt does, while plain draws may pass a sparse, noisy crop).
/// `eval` does the same, so `locate` on a crop `eval` accepts agrees with
/// it. The second's error when both fail.
pub fn locate_either(
    points: &[Point],
    up: Option<Vector3<f64>>,
    params: &LocateParams,
) -> Result<Located, LocateError> {
    locate(points, up, params).or_else(|_| locate(points, up, &params.other_draws()))
}

/// Locates the corner of the L-target in a tight crop.
///
/// `up` is the local vertical (the ground normal where one was estimated);
/// `None` means +z. Points may sit at large (UTM-sized) coordinates: they are
/// centred before any fitting.
pub fn locate(
    points: &[Point],
    up: Option<Vector3<f64>>,
    params: &LocateParams,
) -> Result<Located, LocateError> {
    params.validate()?;
    let up = unit_up(up)?;
    check_points(points)?;
    let (origin, pts) = centred(points);
    let ctx = Ctx::new(&pts, up, params);
    let run = run_attempts(&ctx, params)?;
    Ok(summarise(&ctx, origin, run))
}

/// `up` as a unit vector (+z for `None`).
fn unit_up(up: Option<Vector3<f64>>) -> Result<Vector3<f64>, LocateError> {
    match up {
        None => Ok(Vector3::z()),
        Some(u) if u.iter().all(|v| v.is_finite()) && u.norm() > 0.0 => Ok(u.normalize()),
        Some(_) => Err(LocateError::BadUp),
    }
}

/// Finite coordinates, enough points for two planes, indices that fit in u32.
fn check_points(points: &[Point]) -> Result<(), LocateError> {
    if let Some(index) = points
        .iter()
        .position(|p| !p.coords.iter().all(|v| v.is_finite()))
    {
        return Err(LocateError::NonFinite { index });
    }
    if points.len() < MIN_POINTS {
        return Err(LocateError::TooFewPoints { n: points.len() });
    }
    if points.len() > u32::MAX as usize {
        return Err(LocateError::Param(
            "a tight crop must have fewer than 2^32 points".into(),
        ));
    }
    Ok(())
}

/// The points relative to their mean, and the mean. Centred on the first point,
/// then on the mean (the first point keeps the mean's sum small even at UTM
/// coordinates).
fn centred(points: &[Point]) -> (Vector3<f64>, Vec<Vector3<f64>>) {
    let p0 = points[0].coords;
    let mean_off = points.iter().map(|p| p.coords - p0).sum::<Vector3<f64>>() / points.len() as f64;
    let origin = p0 + mean_off;
    let pts: Vec<Vector3<f64>> = points.iter().map(|p| p.coords - origin).collect();
    (origin, pts)
}

/// The accepted samples of a run of attempts, and how the run went.
struct Run {
    samples: Vec<Sample>,
    /// Index of the last accepted attempt (replayed for the labels).
    last_accepted: usize,
    attempts: usize,
    rejects: Rejects,
}

/// Attempts until `samples` are accepted or `max_attempts` are made, in
/// batches of [`BATCH`] computed in parallel and consumed in index order.
fn run_attempts(ctx: &Ctx, params: &LocateParams) -> Result<Run, LocateError> {
    let mut samples: Vec<Sample> = Vec::with_capacity(params.samples);
    let mut last_accepted = 0;
    let mut rejects = Rejects::default();
    let mut attempts = 0;
    'outer: while attempts < params.max_attempts {
        let end = (attempts + BATCH).min(params.max_attempts);
        let outcomes: Vec<_> = (attempts..end)
            .into_par_iter()
            .map_init(Scratch::default, |s, i| ctx.attempt(i, s, None))
            .collect();
        for outcome in outcomes {
            attempts += 1;
            match outcome {
                Ok(s) => {
                    samples.push(s);
                    last_accepted = attempts - 1;
                    if samples.len() == params.samples {
                        break 'outer;
                    }
                }
                Err(reason) => rejects.tally(reason),
            }
        }
        // One plate only: nothing accepted and nearly every split found one plane twice.
        if samples.is_empty() && attempts >= 200 && rejects.same_plane * 10 >= attempts * 9 {
            return Err(LocateError::OnePlate {
                attempts,
                same_plane: rejects.same_plane,
            });
        }
    }
    if samples.len() < params.min_samples {
        if samples.is_empty() && rejects.same_plane * 2 > rejects.total() {
            return Err(LocateError::OnePlate {
                attempts,
                same_plane: rejects.same_plane,
            });
        }
        return Err(LocateError::TooFewAccepted {
            accepted: samples.len(),
            needed: params.min_samples,
            attempts,
            rejects,
        });
    }
    Ok(Run {
        samples,
        last_accepted,
        attempts,
        rejects,
    })
}

/// The corner (mean of the samples), their spread, and the reference sample's
/// plates and point labels, back in the input's frame.
fn summarise(ctx: &Ctx, origin: Vector3<f64>, run: Run) -> Located {
    let Run {
        samples,
        last_accepted,
        attempts,
        rejects,
    } = run;
    let up = ctx.up();
    let k = samples.len() as f64;
    let mean = samples.iter().map(|s| s.corner).sum::<Vector3<f64>>() / k;
    let var = samples
        .iter()
        .map(|s| (s.corner - mean).component_mul(&(s.corner - mean)))
        .sum::<Vector3<f64>>()
        / k;
    let mut labels = Vec::new();
    let reference = match ctx.attempt(last_accepted, &mut Scratch::default(), Some(&mut labels)) {
        Ok(s) => s,
        // The same attempt index replays the same random stream; kept total anyway.
        Err(_) => *samples.last().expect("min_samples >= 1"),
    };
    let plate = |j: usize| {
        let n = reference.planes[j].normal;
        PlateFit {
            normal: [n.x, n.y, n.z],
            inliers: reference.inliers[j],
            tilt_deg: n.dot(&up).abs().clamp(0.0, 1.0).asin().to_degrees(),
        }
    };
    let covariance = corner_covariance(ctx, &reference, &labels, &mean, &samples);
    let cos = reference.planes[0]
        .normal
        .dot(&reference.planes[1].normal)
        .abs()
        .clamp(0.0, 1.0);
    Located {
        corner: Point::from(origin + mean),
        std: [var.x.sqrt(), var.y.sqrt(), var.z.sqrt()],
        covariance,
        accepted: samples.len(),
        attempts,
        rejects,
        plates: [plate(0), plate(1)],
        plate_angle_deg: cos.acos().to_degrees(),
        labels,
        samples: samples
            .iter()
            .map(|s| Point::from(origin + s.corner))
            .collect(),
    }
}

/// The corner's covariance: the reference sample's plate fits propagated to the
/// corner (`covariance.rs`), raised to cover the samples' own spread where that
/// is larger. Without a usable propagation (degenerate plate layout) the
/// samples' spread alone.
fn corner_covariance(
    ctx: &Ctx,
    reference: &Sample,
    labels: &[Label],
    corner: &Vector3<f64>,
    samples: &[Sample],
) -> [[f64; 3]; 3] {
    let pts = ctx.points();
    let plate = |j: usize, want: Label| covariance::PlateFitPoints {
        normal: reference.planes[j].normal,
        offset: reference.planes[j].offset,
        points: pts
            .iter()
            .zip(labels)
            .filter(|(_, l)| **l == want)
            .map(|(p, _)| p)
            .collect(),
    };
    let plates = [plate(0, Label::Plate1), plate(1, Label::Plate2)];
    let band = ctx.final_band(&reference.planes);
    let spread =
        covariance::sample_covariance(&samples.iter().map(|s| s.corner).collect::<Vec<_>>());
    let c = match covariance::corner_covariance(
        &plates,
        corner,
        &ctx.up(),
        [Some(band[0]), Some(band[1])],
    ) {
        Some(fit) => covariance::cover(&fit, &spread),
        None => spread,
    };
    [
        [c[(0, 0)], c[(0, 1)], c[(0, 2)]],
        [c[(1, 0)], c[(1, 1)], c[(1, 2)]],
        [c[(2, 0)], c[(2, 1)], c[(2, 2)]],
    ]
}
