//! The locator's parameters: the paper's values, the acceptance improvements
//! and the speed-ups, each switchable (see [`LocateParams::paper`]).

use super::kmeans::{Init, Space};
use super::types::LocateError;
use serde::{Deserialize, Serialize};

/// Parameters of [`locate`](crate::locate::locate). Defaults are the paper's values plus the
/// acceptance improvements; [`LocateParams::paper`] turns the improvements off.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LocateParams {
    /// Lloyd iterations of k-means (it usually converges in fewer).
    pub kmeans_iterations: usize,
    /// k-means finds its centres on this many randomly drawn points, then
    /// assigns every point to the nearer centre (paper: 0 = iterate on all points).
    pub kmeans_points: usize,
    /// Coordinates k-means clusters on.
    pub kmeans_space: Space,
    /// How k-means picks its starting centres.
    pub kmeans_init: Init,
    /// RANSAC hypotheses per plate (paper: 100).
    pub ransac_iterations: usize,
    /// Preemptive RANSAC: hypotheses are scored on a random subset of this many
    /// cluster points and only the best few on all of them (paper: 0 = score
    /// every hypothesis on every point). The plate's plane is in any case the SVD
    /// fit on all inliers of the winner, so this trades little accuracy for speed.
    pub ransac_score_points: usize,
    /// Adaptive RANSAC stop: draw hypotheses only until the best plane so far was
    /// found with this probability by the standard N = ln(1 − p) / ln(1 − w³)
    /// bound (w: its inlier fraction), at most `ransac_iterations` (paper: 0 =
    /// always draw all of them).
    pub ransac_confidence: f64,
    /// RANSAC / refit inlier distance, metres (paper: 0.03).
    pub inlier_threshold: f64,
    /// Extra SVD refits on the inliers of the previous fit (paper: 0).
    pub refit_iterations: usize,
    /// In refits, points closer than this to the other plate's plane are left out
    /// (pole, antenna mast, corner edge), metres. Must exceed `inlier_threshold`.
    pub corner_margin: f64,
    /// Refits take points within this many noise standard deviations of the plane
    /// (the noise estimated robustly from the plate's residuals), but never fewer
    /// than `inlier_threshold` nor more than `corner_margin`. A band as narrow as the
    /// noise (3 cm at 2–3 cm noise) cuts the plate's point distribution and pulls
    /// each fit towards the previous one, so fitted plates wander ~1° from the
    /// truth; 2.5 σ keeps the fit unbiased and about twice as precise. 0 = use
    /// `inlier_threshold` (the band of the first fit).
    pub refit_sigmas: f64,
    /// Gate: plates perpendicular to each other and to the ground within this, degrees (paper: 1).
    pub angle_tolerance_deg: f64,
    /// Accepted samples to average (paper: 100).
    pub samples: usize,
    /// Fewest accepted samples for a result when `max_attempts` runs out.
    pub min_samples: usize,
    /// Attempt limit. 2,000 bounds a hopeless crop to well under a second, yet
    /// still fills 100 samples at 5 % acceptance (the paper's method reached ~2 %).
    pub max_attempts: usize,
    /// Seed of all random draws.
    pub seed: u64,
}

impl Default for LocateParams {
    fn default() -> Self {
        LocateParams {
            kmeans_iterations: 20,
            kmeans_points: 256,
            kmeans_space: Space::Horizontal,
            kmeans_init: Init::PlusPlus,
            ransac_iterations: 100,
            ransac_score_points: 128,
            ransac_confidence: 0.999,
            inlier_threshold: 0.03,
            refit_iterations: 1,
            corner_margin: 0.1,
            refit_sigmas: 2.5,
            angle_tolerance_deg: 1.0,
            samples: 100,
            min_samples: 10,
            max_attempts: 2000,
            seed: 0,
        }
    }
}

impl LocateParams {
    /// The same with the other kind of draws: the refit when plain draws
    /// are configured, plain draws when the refit is.
    pub fn other_draws(&self) -> LocateParams {
        LocateParams {
            refit_iterations: if self.refit_iterations > 0 { 0 } else { 1 },
            ..self.clone()
        }
    }
    /// The reference implementation's algorithm: 3D k-means from random
    /// points, RANSAC + one SVD fit, no refit. For comparison and reproduction.
    pub fn paper() -> Self {
        LocateParams {
            kmeans_space: Space::Full,
            kmeans_init: Init::Random,
            refit_iterations: 0,
            kmeans_points: 0,
            ransac_score_points: 0,
            ransac_confidence: 0.0,
            max_attempts: 10_000,
            ..LocateParams::default()
        }
    }

    /// Checks the parameters' ranges and consistency.
    pub fn check(&self) -> crate::Result<()> {
        self.validate().map_err(Into::into)
    }

    pub(crate) fn validate(&self) -> Result<(), LocateError> {
        let bad = |m: &str| Err(LocateError::Param(m.to_string()));
        if !(self.inlier_threshold > 0.0 && self.inlier_threshold.is_finite()) {
            return bad("inlier_threshold must be a positive number of metres");
        }
        if !(self.corner_margin > self.inlier_threshold && self.corner_margin < 0.3) {
            return bad("corner_margin must be more than inlier_threshold and less than 0.3 m");
        }
        if !(self.angle_tolerance_deg > 0.0 && self.angle_tolerance_deg < 45.0) {
            return bad("angle_tolerance_deg must be in (0, 45)");
        }
        if !(self.refit_sigmas >= 0.0 && self.refit_sigmas <= 10.0) {
            return bad("refit_sigmas must be in [0, 10]");
        }
        if !(0.0..1.0).contains(&self.ransac_confidence) {
            return bad("ransac_confidence must be in [0, 1)");
        }
        if self.samples == 0 || self.ransac_iterations == 0 || self.max_attempts == 0 {
            return bad("samples, ransac_iterations and max_attempts must be at least 1");
        }
        if self.min_samples == 0 || self.min_samples > self.samples {
            return bad("min_samples must be in 1..=samples");
        }
        Ok(())
    }
}
