//! Benchmark scores: the points SLAM challenges give each checkpoint for
//! its error, summed over a run and normalised to 0–100, so a leaderboard
//! built on mapgauge reads like the challenge's (issue 35).
//!
//! | name | points per checkpoint (error e) | source |
//! |---|---|---|
//! | `hilti2022` | e < 1 / 3 / 6 / 10 cm → 10 / 6 / 3 / 1, else 0 | Hilti SLAM Challenge 2022 |
//! | `hilti2023` | e < 0.5 / 1 / 3 / 6 / 10 / 40 cm → 20 / 10 / 6 / 5 / 3 / 1, else 0 | Hilti SLAM Challenge 2023 |
//! | `hilti2026` | 100 · e^(−0.4605 · e/cm) (10 points at 5 cm) | Hilti SLAM Challenge 2026 |
//!
//! The total is 100 × (points earned) / (most points every surveyed target
//! could earn): a target not located (or mapped twice) earns nothing, as a
//! challenge's missing pose does, so an incomplete map scores lower. Each
//! target's error is its absolute error after the run's alignment, in the
//! run's dimension (the challenges score 3D positions: `--dim 3d`).
//!
//! A score is a step function of errors that are measured, not known: each
//! target's points are also given over its error ± 1.96 σ (σ of the error
//! along its own direction, from the target's covariance), and the total
//! over those, so a score that a millimetre could move by a band says so.
//!
//! Scores are computed from a result's targets alone, so `table --score`
//! scores results written before scores existed, by the same rule.
//!
//! ```
//! use mapgauge::scores::ScoreKind;
//! assert_eq!(ScoreKind::Hilti2022.points(0.02), 6.0);
//! assert_eq!(ScoreKind::Hilti2023.points(0.004), 20.0);
//! assert!((ScoreKind::Hilti2026.points(0.05) - 10.0).abs() < 0.01);
//! ```

use crate::record::{ResultFile, TargetOut};
use crate::{Error, Result};
use nalgebra::{Matrix2, Matrix3, Vector3};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// A challenge's scoring rule.
#[derive(
    Debug,
    Clone,
    Copy,
    PartialEq,
    Eq,
    PartialOrd,
    Ord,
    Hash,
    Serialize,
    Deserialize,
    clap::ValueEnum,
)]
#[serde(rename_all = "lowercase")]
pub enum ScoreKind {
    /// Hilti SLAM Challenge 2022: 10/6/3/1 points below 1/3/6/10 cm.
    Hilti2022,
    /// Hilti SLAM Challenge 2023: 20/10/6/5/3/1 points below
    /// 0.5/1/3/6/10/40 cm.
    Hilti2023,
    /// Hilti SLAM Challenge 2026: 100·e^(−0.4605·error in cm) points.
    Hilti2026,
}

/// The bands of the stepped rules: (error below, m; points).
const HILTI2022: [(f64, f64); 4] = [(0.01, 10.0), (0.03, 6.0), (0.06, 3.0), (0.10, 1.0)];
const HILTI2023: [(f64, f64); 6] = [
    (0.005, 20.0),
    (0.01, 10.0),
    (0.03, 6.0),
    (0.06, 5.0),
    (0.10, 3.0),
    (0.40, 1.0),
];
/// Hilti 2026's decay per centimetre: ln 10 / 5, a tenth of the points at 5 cm.
const HILTI2026_PER_CM: f64 = 0.4605;

impl ScoreKind {
    /// Every rule, in the order tables list them.
    pub const ALL: [ScoreKind; 3] = [
        ScoreKind::Hilti2022,
        ScoreKind::Hilti2023,
        ScoreKind::Hilti2026,
    ];

    /// The key in `result.json`'s `scores` and the flag's value.
    pub fn name(self) -> &'static str {
        match self {
            ScoreKind::Hilti2022 => "hilti2022",
            ScoreKind::Hilti2023 => "hilti2023",
            ScoreKind::Hilti2026 => "hilti2026",
        }
    }

    /// As tables and the summary title it.
    pub fn title(self) -> &'static str {
        match self {
            ScoreKind::Hilti2022 => "Hilti 2022",
            ScoreKind::Hilti2023 => "Hilti 2023",
            ScoreKind::Hilti2026 => "Hilti 2026",
        }
    }

    /// Points for one checkpoint whose error is `error` (m).
    pub fn points(self, error: f64) -> f64 {
        // An error that is not a number earns nothing (NaN.max(0) is 0).
        if !error.is_finite() {
            return 0.0;
        }
        let banded = |bands: &[(f64, f64)]| {
            bands
                .iter()
                .find(|(below, _)| error < *below)
                .map_or(0.0, |b| b.1)
        };
        match self {
            ScoreKind::Hilti2022 => banded(&HILTI2022),
            ScoreKind::Hilti2023 => banded(&HILTI2023),
            ScoreKind::Hilti2026 => 100.0 * (-HILTI2026_PER_CM * error.max(0.0) * 100.0).exp(),
        }
    }

    /// The most points one checkpoint can earn.
    pub fn max_points(self) -> f64 {
        match self {
            ScoreKind::Hilti2022 => 10.0,
            ScoreKind::Hilti2023 => 20.0,
            ScoreKind::Hilti2026 => 100.0,
        }
    }

    /// The fewest and most points for an error anywhere in `[lo, hi]` (m):
    /// every rule gives fewer points for a larger error.
    fn points_over(self, lo: f64, hi: f64) -> [f64; 2] {
        [self.points(hi), self.points(lo)]
    }
}

impl std::str::FromStr for ScoreKind {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        ScoreKind::ALL
            .into_iter()
            .find(|k| k.name().eq_ignore_ascii_case(s.trim()))
            .ok_or_else(|| {
                Error::Param(format!(
                    "unknown score `{s}` (hilti2022, hilti2023 or hilti2026)"
                ))
            })
    }
}

/// One target's points.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TargetPoints {
    /// Target id.
    pub id: String,
    /// Its absolute error (m); `null` when it was not located.
    pub error_m: Option<f64>,
    /// Points earned.
    pub points: f64,
    /// Points anywhere within its error ± 1.96 σ (σ along the error;
    /// [fewest, most]); the
    /// points themselves when it has no covariance or was not located.
    pub range95: [f64; 2],
}

/// A run's score under one rule.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BenchScore {
    /// 100 × points earned / the most the surveyed targets could earn.
    pub total: f64,
    /// The total with every target at the low and at the high end of its
    /// points' `range95`: the span the measurement noise leaves.
    pub range95: [f64; 2],
    /// Targets scored (every surveyed target; those not located earn 0).
    pub targets: usize,
    /// Targets located and scored by their error.
    pub located: usize,
    /// The most points one target can earn.
    pub max_points: f64,
    /// Each target's points, in the survey's order.
    pub per_target: Vec<TargetPoints>,
}

/// The score of `r`'s targets under `kind`.
pub fn score(kind: ScoreKind, r: &ResultFile) -> BenchScore {
    let three = r.dim == crate::accuracy::Dim::D3;
    let per_target: Vec<TargetPoints> = r
        .targets
        .iter()
        .map(|t| {
            // Only a target located and kept earns points: one not located,
            // mapped twice, or excluded as a gross error (its error is not
            // scored: `abs_error` is null) earns nothing.
            let error = t.abs_error.filter(|_| t.status == "ok");
            let Some(e) = error else {
                return TargetPoints {
                    id: t.id.clone(),
                    error_m: None,
                    points: 0.0,
                    range95: [0.0, 0.0],
                };
            };
            let points = kind.points(e);
            let range95 = match sigma_of_error(t, r, three) {
                Some(s) => kind.points_over((e - 1.96 * s).max(0.0), e + 1.96 * s),
                None => [points, points],
            };
            TargetPoints {
                id: t.id.clone(),
                error_m: Some(e),
                points,
                range95,
            }
        })
        .collect();
    let full = kind.max_points() * per_target.len() as f64;
    let share = |p: f64| if full > 0.0 { 100.0 * p / full } else { 0.0 };
    BenchScore {
        total: share(per_target.iter().map(|t| t.points).sum()),
        range95: [
            share(per_target.iter().map(|t| t.range95[0]).sum()),
            share(per_target.iter().map(|t| t.range95[1]).sum()),
        ],
        targets: per_target.len(),
        located: per_target.iter().filter(|t| t.error_m.is_some()).count(),
        max_points: kind.max_points(),
        per_target,
    }
}

/// Sets `r.scores` to the score of its targets under each of `kinds`
/// (replacing any there).
pub fn apply(kinds: &[ScoreKind], r: &mut ResultFile) {
    let scores: BTreeMap<ScoreKind, BenchScore> = kinds.iter().map(|&k| (k, score(k, r))).collect();
    r.scores = scores;
}

/// The 1-σ of a target's error (m): its covariance turned into the survey's
/// axes by the alignment (s² R Σ Rᵀ), along the error's own direction
/// (horizontal for 2D errors); the largest axis where the error is too small
/// to have one. `None` without a covariance or an aligned position.
fn sigma_of_error(t: &TargetOut, r: &ResultFile, three: bool) -> Option<f64> {
    let cov = t.map_covariance?;
    let c = Matrix3::from_fn(|i, j| cov[i][j]);
    let rot = Matrix3::from_fn(|i, j| r.alignment.rotation_matrix[i][j]);
    let s = r.alignment.scale * r.alignment.scale * rot * c * rot.transpose();
    let a = t.aligned?;
    let mut d = Vector3::new(
        a.x - t.survey.x,
        a.y - t.survey.y,
        a.z.zip(t.survey.z).map_or(0.0, |(m, v)| m - v),
    );
    if !three {
        d.z = 0.0;
    }
    let var = if d.norm() > 1e-9 {
        let u = d.normalize();
        (u.transpose() * s * u)[0]
    } else if three {
        s.symmetric_eigenvalues().max()
    } else {
        Matrix2::new(s[(0, 0)], s[(0, 1)], s[(1, 0)], s[(1, 1)])
            .symmetric_eigenvalues()
            .max()
    };
    // A rounding error's tiny negative variance is none, not unknown.
    var.is_finite().then(|| var.max(0.0).sqrt())
}

#[cfg(test)]
mod tests;
