//! What the locator returns: the located corner with its spread and
//! diagnostics, or a typed reason why the crop could not be located.

use super::MIN_POINTS;
use crate::Point;
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// Why attempts were rejected: tells a bad crop from a strict gate.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Rejects {
    /// k-means left a cluster empty, or a plate had too few inliers to fit.
    pub degenerate: usize,
    /// Both clusters gave (nearly) the same plane (< 45° apart): one plate seen twice.
    pub same_plane: usize,
    /// Planes 45°–(90° − tolerance) apart.
    pub not_perpendicular: usize,
    /// Planes perpendicular, but a plate tilted from vertical by more than the tolerance.
    pub tilted: usize,
}

impl Rejects {
    pub(crate) fn total(&self) -> usize {
        self.degenerate + self.same_plane + self.not_perpendicular + self.tilted
    }
}

/// One point's role in the reference sample, for plots.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Label {
    /// Inlier of plate 1's plane.
    Plate1,
    /// Inlier of plate 2's plane.
    Plate2,
    /// Neither (pole, antenna, noise).
    Outlier,
}

/// One plate of the reference sample.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PlateFit {
    /// Unit normal of the fitted plane.
    pub normal: [f64; 3],
    /// Points within the inlier threshold used in the final fit.
    pub inliers: usize,
    /// Angle between the plate and the vertical (`up`), degrees.
    pub tilt_deg: f64,
}

/// A located target.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Located {
    /// The corner: mean of the accepted samples, in the crop's frame.
    #[serde(serialize_with = "ser_point")]
    pub corner: Point,
    /// Population standard deviation of the accepted samples per axis, metres.
    pub std: [f64; 3],
    /// Covariance of the corner (m², row-major): how far it may be from the
    /// truth, from the plates' noise and point layout (`locate/covariance.rs`),
    /// at least the samples' spread.
    pub covariance: [[f64; 3]; 3],
    /// Accepted samples averaged into `corner`.
    pub accepted: usize,
    /// Attempts needed to collect them (accepted + rejected).
    pub attempts: usize,
    /// Why the rejected attempts failed.
    pub rejects: Rejects,
    /// The plates of the reference sample (the last accepted one).
    pub plates: [PlateFit; 2],
    /// Angle between the plates in the reference sample, degrees.
    pub plate_angle_deg: f64,
    /// Per-point role in the reference sample (same order as the input).
    #[serde(skip)]
    pub labels: Vec<Label>,
    /// Every accepted sample corner, in the crop's frame (their scatter is the
    /// spread a report plots).
    #[serde(skip)]
    pub samples: Vec<Point>,
}

impl Located {
    /// One number for the spread: the norm of `std`, metres.
    pub fn spread(&self) -> f64 {
        Vector3::from(self.std).norm()
    }
    /// The corner's standard deviation per axis (√ of the covariance's diagonal), metres.
    pub fn sigma(&self) -> [f64; 3] {
        [0, 1, 2].map(|i| self.covariance[i][i].max(0.0).sqrt())
    }
    /// The two fitted plates as quadrilaterals through the corner: each in
    /// its reference plane, spanning the middle 96 % of its labelled points
    /// (`pts`, the crop this was located in) along the plate and along the
    /// plates' common axis. For drawing beside the map; `None` when a plate
    /// has fewer than 3 points or the planes are near parallel.
    pub fn plate_outlines(&self, pts: &[Point]) -> Option<[[Point; 4]; 2]> {
        let n = self.plates.map(|p| Vector3::from(p.normal));
        let mut d = n[0].cross(&n[1]);
        if d.norm() < 0.1 {
            return None;
        }
        d = d.normalize();
        if d.z < 0.0 {
            d = -d;
        }
        let c = self.corner;
        let mut out = [[c; 4]; 2];
        for (k, label) in [Label::Plate1, Label::Plate2].into_iter().enumerate() {
            let u = d.cross(&n[k]).normalize();
            let (mut a, mut b): (Vec<f64>, Vec<f64>) = pts
                .iter()
                .zip(&self.labels)
                .filter(|(_, l)| **l == label)
                .map(|(p, _)| ((p - c).dot(&u), (p - c).dot(&d)))
                .unzip();
            if a.len() < 3 {
                return None;
            }
            let span = |v: &mut Vec<f64>| {
                let m = v.len() - 1;
                let lo = *v.select_nth_unstable_by(m / 50, f64::total_cmp).1;
                let hi = *v.select_nth_unstable_by(m - m / 50, f64::total_cmp).1;
                (lo, hi)
            };
            let ((a0, a1), (b0, b1)) = (span(&mut a), span(&mut b));
            out[k] = [(a0, b0), (a1, b0), (a1, b1), (a0, b1)].map(|(s, t)| c + u * s + d * t);
        }
        Some(out)
    }
    /// Fraction of attempts accepted.
    pub fn acceptance(&self) -> f64 {
        self.accepted as f64 / self.attempts.max(1) as f64
    }
}

impl PlateFit {
    /// No plate: what a target model without plates (a sphere) has.
    pub const NONE: PlateFit = PlateFit {
        normal: [0.0; 3],
        inliers: 0,
        tilt_deg: f64::NAN,
    };
}

impl Located {
    /// The estimate of a target model without plates (a sphere's centre):
    /// its point, covariance and refitted samples (whose spread is `std`).
    /// The plates are [`PlateFit::NONE`], the plate angle NaN, and no point
    /// is labelled.
    pub fn without_plates(
        corner: Point,
        covariance: [[f64; 3]; 3],
        samples: Vec<Point>,
    ) -> Located {
        let n = samples.len().max(1) as f64;
        let mean = samples.iter().map(|p| p.coords).sum::<Vector3<f64>>() / n;
        let std = [0, 1, 2].map(|k| {
            (samples
                .iter()
                .map(|p| (p[k] - mean[k]).powi(2))
                .sum::<f64>()
                / n)
                .sqrt()
        });
        Located {
            corner,
            std,
            covariance,
            accepted: samples.len(),
            attempts: samples.len(),
            rejects: Rejects::default(),
            plates: [PlateFit::NONE; 2],
            plate_angle_deg: f64::NAN,
            labels: Vec::new(),
            samples,
        }
    }
}

fn ser_point<S: serde::Serializer>(p: &Point, s: S) -> Result<S::Ok, S::Error> {
    [p.x, p.y, p.z].serialize(s)
}

/// Why a crop could not be located.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LocateError {
    /// Not enough points to fit two planes.
    #[error("too few points: {n} (need at least {MIN_POINTS})")]
    TooFewPoints {
        /// Points in the crop.
        n: usize,
    },
    /// A coordinate is NaN or infinite.
    #[error("point {index} has a non-finite coordinate")]
    NonFinite {
        /// Index of the offending point.
        index: usize,
    },
    /// Every split found the same plane twice: the crop shows one plate.
    #[error(
        "only one plate visible: in {same_plane} of {attempts} attempts both clusters fit the same plane"
    )]
    OnePlate {
        /// Attempts made.
        attempts: usize,
        /// Attempts whose two planes were < 45° apart.
        same_plane: usize,
    },
    /// The gates rejected (almost) everything within the attempt limit.
    #[error(
        "only {accepted} of {attempts} attempts passed the perpendicularity gates (need {needed}); rejected: {} degenerate, {} same plane, {} not perpendicular, {} tilted",
        rejects.degenerate, rejects.same_plane, rejects.not_perpendicular, rejects.tilted
    )]
    TooFewAccepted {
        /// Accepted samples.
        accepted: usize,
        /// `min_samples`.
        needed: usize,
        /// Attempts made (`max_attempts`).
        attempts: usize,
        /// Why the others failed.
        rejects: Rejects,
    },
    /// The `up` vector is zero or not finite.
    #[error("up vector must be finite and non-zero")]
    BadUp,
    /// A parameter is out of range.
    #[error("invalid locate parameter: {0}")]
    Param(String),
}

impl From<LocateError> for crate::Error {
    fn from(e: LocateError) -> Self {
        match e {
            LocateError::Param(m) => crate::Error::Param(m),
            other => crate::Error::Input(other.to_string()),
        }
    }
}
