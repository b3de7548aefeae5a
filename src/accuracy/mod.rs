//! Absolute and relative errors, honest (held-out) errors and survey-standard
//! statistics: steps 6–7 of the pipeline in one call, [`score`].
//!
//! The result, [`Accuracy`], is plain typed numbers: no file schema, no
//! sentences. `record` turns it into `result.json`, `render` into tables.

mod asprs;
pub(crate) mod blunder;
mod distances;
pub mod intervals;
pub(crate) use distances::misfit_by_distances;
mod iso19157;
mod scale;
mod score;
mod stats;
mod unfitted;

pub use asprs::{Asprs, AsprsCaveat};
pub use intervals::{Ci95, Intervals};
pub use iso19157::{Bias, Iso19157};
pub use scale::ScaleEstimate;
pub(crate) use scale::layout_scale;
pub use score::{score, score_with_covariances};
pub(crate) use stats::t975;
pub use stats::{AxisStats, PairError, Summary, leave_one_out};
pub(crate) use stats::{dist, relative_errors, summarize};
pub use unfitted::{Unfitted, unfitted};

use crate::align::{self, AlignMethod, Alignment};
use crate::survey::{Estimate, EstimateStatus, Role, Survey};
use crate::{Error, Point, Result};
use serde::{Deserialize, Serialize};
use std::collections::HashMap;

/// Whether errors are measured in the horizontal plane or in space. (Serde
/// only for the configuration file, where it is a setting.)
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum Dim {
    /// x, y only (the paper's tables).
    #[default]
    #[serde(rename = "2d")]
    D2,
    /// x, y, z (needs heights in the survey and the estimates).
    #[serde(rename = "3d")]
    D3,
}

impl Dim {
    /// "2D" or "3D", as tables, cards and the terminal say it.
    pub fn label(self) -> &'static str {
        match self {
            Dim::D2 => "2D",
            Dim::D3 => "3D",
        }
    }
}

impl std::str::FromStr for Dim {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s.to_ascii_lowercase().as_str() {
            "2d" | "2" => Ok(Dim::D2),
            "3d" | "3" => Ok(Dim::D3),
            _ => Err(Error::Param(format!("unknown dimension `{s}` (2d or 3d)"))),
        }
    }
}

/// Knobs of [`score`].
#[derive(Debug, Clone, Default)]
pub struct ScoreOptions {
    /// Alignment of the map onto the survey.
    pub method: AlignMethod,
    /// Error dimension.
    pub dim: Dim,
    /// The survey's own 1-σ error (horizontal RMSE, optional vertical), folded into
    /// the ASPRS figures as √(measured² + survey²).
    pub survey_sigma: Option<(f64, Option<f64>)>,
    /// The levelled frame's vertical and its standard error (radians), when
    /// the map was turned upright: one shared tilt per Monte Carlo draw of
    /// the measurement intervals (it moves every target together, by its
    /// height above the origin horizontally).
    pub vertical: Option<Vertical>,
    /// ISO 19157's threshold (m): how many checkpoints err beyond it.
    pub threshold: Option<f64>,
}

/// The vertical a levelled map was turned to, as far as it is known.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Vertical {
    /// Point the map was turned about (levelled frame).
    pub origin: Point,
    /// Standard error of the vertical in each horizontal direction (radians).
    pub se_rad: f64,
}

impl Vertical {
    /// `c` plus what this vertical's error does at `p` on its own: a tilt
    /// ω = (ωx, ωy, 0) about the origin moves p by ω × d (d = p − origin),
    /// so x and y by the height dz times ω and z by the horizontal distance
    /// (small angles, each ω component of variance σ²).
    pub fn add_to(&self, c: &[[f64; 3]; 3], p: &Point) -> [[f64; 3]; 3] {
        let d = p - self.origin;
        let s2 = self.se_rad * self.se_rad;
        let mut c = *c;
        c[0][0] += s2 * d.z * d.z;
        c[1][1] += s2 * d.z * d.z;
        c[2][2] += s2 * (d.x * d.x + d.y * d.y);
        for (i, di) in [(0, d.x), (1, d.y)] {
            c[i][2] -= s2 * di * d.z;
            c[2][i] -= s2 * di * d.z;
        }
        c
    }
}

/// How one surveyed target fared.
#[derive(Debug, Clone, PartialEq)]
pub enum Status {
    /// Located and scored.
    Ok,
    /// No estimate carries this id.
    NoEstimate,
    /// The estimate says it was not found, and why.
    NotFound(String),
    /// The estimate says it was left out, and why.
    Excluded(String),
    /// The estimate says it was seen twice (mapped twice), and where.
    Ambiguous(String),
}

/// One surveyed target's numbers.
#[derive(Debug, Clone, PartialEq)]
pub struct TargetScore {
    /// Target id.
    pub id: String,
    /// Located and scored, or why not.
    pub status: Status,
    /// Surveyed reference point (survey frame, antenna height removed).
    pub survey: Point,
    /// Whether the survey gave a height.
    pub survey_has_z: bool,
    /// Estimated position (map frame), when located.
    pub map: Option<Point>,
    /// Whether the estimate has a meaningful height.
    pub map_has_z: bool,
    /// The estimate mapped into the survey frame, when scored.
    pub aligned: Option<Point>,
    /// Whether `aligned` has a meaningful height.
    pub aligned_has_z: bool,
    /// Absolute error (m) in the chosen dimension.
    pub abs_error: Option<f64>,
    /// Error under an alignment fitted without this target.
    pub loo_error: Option<f64>,
    /// Control or check, when the survey says.
    pub role: Option<Role>,
    /// Covariance of `map` (m², map frame, row-major), when the locator gave one.
    pub map_covariance: Option<[[f64; 3]; 3]>,
}

/// The fitted map → survey transform and how many targets it used.
#[derive(Debug, Clone, PartialEq)]
pub struct Fit {
    /// The transform.
    pub alignment: Alignment,
    /// Targets the fit used.
    pub n_used: usize,
}

/// Relative errors: their statistics and every pair.
#[derive(Debug, Clone, PartialEq)]
pub struct Relative {
    /// Statistics of the pair errors (E_rel = mean, σ_rel = std).
    pub summary: Summary,
    /// Every pair, i < j in survey order.
    pub pairs: Vec<PairError>,
}

/// Errors of targets that the fit scoring them did not use (honest errors).
#[derive(Debug, Clone, PartialEq)]
pub struct HeldOut {
    /// Statistics of the held-out errors.
    pub summary: Summary,
    /// (id, error) per target.
    pub targets: Vec<(String, f64)>,
}

/// Fit on control targets, score on check targets.
#[derive(Debug, Clone, PartialEq)]
pub struct ControlCheck {
    /// Control target ids (used in the fit).
    pub control: Vec<String>,
    /// The control-only fit.
    pub fit: Fit,
    /// Errors of the check targets.
    pub check: HeldOut,
}

/// σ̂ = √(SSE / dof): the residual scale corrected for fitted parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SigmaHat {
    /// σ̂ (m).
    pub value: f64,
    /// Sum of squared residuals (m²).
    pub sse: f64,
    /// Degrees of freedom (e.g. 2n − 3 for rigid2d).
    pub dof: usize,
}

/// Something the reader of the numbers should know.
#[derive(Debug, Clone, PartialEq)]
pub enum Warning {
    /// Survey targets without an estimate.
    SurveyOnly(Vec<String>),
    /// Estimates whose id is not in the survey (ignored).
    EstimatesOnly(Vec<String>),
    /// 3D errors with an alignment that does not fit heights.
    HeightDatumNotCorrected(AlignMethod),
    /// Heights compared as they are (no alignment) share one offset of a
    /// metre or more: another height datum, not the map's error.
    HeightOffset {
        /// The targets' median height error (m, map less survey).
        dz: f64,
        /// Its robust spread over the targets (1.4826 · MAD, m).
        spread: f64,
    },
    /// Too few targets for leave-one-out errors.
    LeaveOneOutTooFew {
        /// The alignment.
        method: AlignMethod,
        /// Targets scored.
        n: usize,
    },
    /// The survey has roles but no check target was located.
    NoCheckTargets,
    /// Too few control targets to fit on them alone.
    TooFewControls {
        /// Located control targets.
        n: usize,
        /// The alignment.
        method: AlignMethod,
    },
    /// Heights were given but the alignment does not fit them.
    VerticalNotReported,
    /// A target whose aligned residual is inconsistent both with its own
    /// covariance (outside the 99.9 % ellipse) and with the other targets
    /// (robust z-score of its error > 3.5): probably a gross error (wrong
    /// corner, survey blunder). Reported, never dropped silently.
    GrossError {
        /// Target id.
        id: String,
        /// Its absolute error (m).
        error: f64,
        /// Its horizontal 1-σ from the covariance (m): √(trace of the 2×2 / 2).
        sigma: f64,
        /// (error − median) / (1.4826 · MAD) over the scored targets.
        robust_z: f64,
        /// Where the error is scored in 3D: its height part (m, map less
        /// survey, less the scored targets' median: a datum no fit
        /// corrected is theirs too), that height's 1-σ and its horizontal
        /// error (m); `None` in 2D.
        height: Option<(f64, f64, f64)>,
        /// Found after the first round's gross errors were set aside and
        /// the rest refitted (`metrics.exclude_outliers`): it stays in the
        /// numbers.
        after_exclusion: bool,
    },
    /// A target a rigid fit on the other targets places over
    /// [`score::BLUNDER_M`] and over 5 × their own rms residual from its
    /// survey position (four targets or more), not flagged as a
    /// [`Warning::GrossError`]: a blunder of a few decimetres pulls a fit of
    /// five targets so far that its own error no longer stands out; left
    /// out, it shows whole. A warning only: it cannot tell a survey typo
    /// from the map distorted there, so `--exclude-outliers` keeps it.
    LayoutMisfit {
        /// Target id.
        id: String,
        /// Distance from where the others' fit places it (m; 3D in a run
        /// that scores heights).
        off: f64,
        /// The others' rms residual in that fit (m).
        others_rms: f64,
        /// Its height part (m, map less survey) where the test is 3D.
        dz: Option<f64>,
    },
    /// Too few scored targets for confidence intervals.
    TooFewForIntervals {
        /// Targets scored.
        n: usize,
    },
}

impl Warning {
    /// What it does to the numbers (as [`crate::pipeline::Warning::weight`]):
    /// 0 a number may be wrong, 2 what could not be computed or matched, 3 the
    /// stock caveat every 2D run carries (the terminal folds it into one line).
    pub fn weight(&self) -> u8 {
        match self {
            // A gross error, or every 3D number biased by the height datum.
            Warning::GrossError { .. }
            | Warning::LayoutMisfit { .. }
            | Warning::HeightDatumNotCorrected(_)
            | Warning::HeightOffset { .. } => 0,
            Warning::VerticalNotReported => 3,
            _ => 2,
        }
    }
}

/// Everything [`score`] computes.
#[derive(Debug, Clone, PartialEq)]
pub struct Accuracy {
    /// Error dimension.
    pub dim: Dim,
    /// The map → survey fit on every scored target.
    pub fit: Fit,
    /// Every survey target, in survey order.
    pub targets: Vec<TargetScore>,
    /// Absolute error statistics (E_abs = mean, σ_abs = std).
    pub absolute: Summary,
    /// Relative errors.
    pub relative: Relative,
    /// Leave-one-out absolute errors (≥ 3 targets).
    pub leave_one_out: Option<HeldOut>,
    /// Control/check split, when the survey has roles.
    pub control_check: Option<ControlCheck>,
    /// σ̂ of the fit.
    pub sigma_hat: Option<SigmaHat>,
    /// Survey-standard statistics.
    pub asprs: Asprs,
    /// ISO 19157 measures of the same checkpoints.
    pub iso19157: Iso19157,
    /// In the survey, not in the estimates.
    pub survey_only: Vec<String>,
    /// In the estimates, not in the survey.
    pub estimates_only: Vec<String>,
    /// 95 % intervals of E_abs, E_rel and RMSE_H (`intervals.rs`).
    pub intervals: Intervals,
    /// The map's horizontal scale against the survey's, from the scored
    /// targets' layout (3 or more), whatever the alignment.
    pub scale: Option<ScaleEstimate>,
    /// Caveats for the reader.
    pub warnings: Vec<Warning>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    fn survey(pts: &[(f64, f64, f64)]) -> Survey {
        Survey::local(pts, true)
    }

    /// What a vertical known to σ adds at a point is what turning it by
    /// tilts of that σ does: 20 000 tilts about the origin, their moves'
    /// covariance against `Vertical::add_to`.
    #[test]
    fn the_vertical_adds_what_its_tilts_do() {
        use rand::{Rng, SeedableRng};
        let v = Vertical {
            origin: Point::new(10.0, -5.0, 2.0),
            se_rad: 1e-3,
        };
        let p = Point::new(310.0, -205.0, 4.5);
        let d = p - v.origin;
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(5);
        let mut sum = nalgebra::Matrix3::zeros();
        let draws = 20_000;
        for _ in 0..draws {
            let mut g = || v.se_rad * rng.sample::<f64, _>(rand_distr::StandardNormal);
            let tilt = nalgebra::Rotation3::from_scaled_axis(Vector3::new(g(), g(), 0.0));
            let m = tilt * d - d;
            sum += m * m.transpose();
        }
        let got = sum / draws as f64;
        let want = v.add_to(&[[0.0; 3]; 3], &p);
        for i in 0..3 {
            for j in 0..3 {
                // Against the two coordinates' own spreads.
                let scale = (want[i][i] * want[j][j]).sqrt();
                assert!(
                    (got[(i, j)] - want[i][j]).abs() < 0.04 * scale,
                    "({i}, {j}): {} drawn, {} added",
                    got[(i, j)],
                    want[i][j]
                );
            }
        }
        // The horizontal part is the height's: 2.5 m × 1 mrad, squared.
        assert!((want[0][0] - (2.5e-3_f64).powi(2)).abs() < 1e-12);
    }

    /// A 20 cm survey blunder among five targets pulls the fit so far that
    /// its error is no robust outlier (a user's trial: errors 19-159 mm, no
    /// warning); a fit on the other four places it its whole size off. A
    /// 3 cm one, within what an RTK survey's noise gives, is not called one.
    #[test]
    fn a_blunder_among_five_is_flagged_by_the_others_fit() {
        let s = survey(&[
            (0.0, 0.0, 0.0),
            (24.0, 8.0, 0.0),
            (47.5, -13.2, 0.0),
            (75.0, 10.0, 0.0),
            (100.0, -12.0, 0.0),
        ]);
        let jitter = [0.003, -0.004, 0.002, -0.003, 0.004];
        let run = |blunder: f64| {
            let est: Vec<Estimate> = s
                .targets
                .iter()
                .zip(jitter)
                .enumerate()
                .map(|(i, (t, j))| {
                    let b = if i == 2 { blunder } else { 0.0 };
                    Estimate::found(t.id.clone(), t.position + Vector3::new(j + b, -j, 0.0))
                })
                .collect();
            let r = score(&s, &est, &ScoreOptions::default()).unwrap();
            r.warnings
                .iter()
                .filter_map(|w| match w {
                    Warning::LayoutMisfit { id, off, .. } => Some((id.clone(), *off)),
                    Warning::GrossError { id, .. } => Some((format!("gross {id}"), 0.0)),
                    _ => None,
                })
                .collect::<Vec<_>>()
        };
        let flagged = run(0.2);
        assert_eq!(flagged.len(), 1, "{flagged:?}");
        assert_eq!(flagged[0].0, "t3");
        // Its whole size, within the others' few millimetres.
        assert!((flagged[0].1 - 0.2).abs() < 0.01, "{flagged:?}");
        assert!(run(0.03).is_empty());
        assert!(run(0.0).is_empty());
    }

    #[test]
    fn a_gross_error_is_flagged_with_its_covariance_only() {
        let s = survey(&[
            (0.0, 0.0, 0.0),
            (30.0, 0.0, 0.0),
            (0.0, 30.0, 0.0),
            (30.0, 30.0, 0.0),
            (15.0, 5.0, 0.0),
            (5.0, 20.0, 0.0),
            (22.0, 12.0, 0.0),
        ]);
        let jitter = [0.004, -0.006, 0.005, -0.003, 0.002, -0.005, 0.0];
        let est: Vec<Estimate> = s
            .targets
            .iter()
            .zip(jitter)
            .enumerate()
            .map(|(i, (t, j))| {
                let blunder = if i == 6 { 0.3 } else { 0.0 };
                Estimate::found(
                    t.id.clone(),
                    t.position + Vector3::new(j + blunder, -j, 0.0),
                )
            })
            .collect();
        let cov = [[1e-5, 0.0, 0.0], [0.0, 1e-5, 0.0], [0.0, 0.0, 1e-4]];
        let covs: HashMap<String, [[f64; 3]; 3]> =
            s.targets.iter().map(|t| (t.id.clone(), cov)).collect();
        let r = score_with_covariances(&s, &est, &covs, &ScoreOptions::default()).unwrap();
        let flagged: Vec<&str> = r
            .warnings
            .iter()
            .filter_map(|w| match w {
                Warning::GrossError { id, .. } => Some(id.as_str()),
                _ => None,
            })
            .collect();
        assert_eq!(flagged, ["t7"]);
        // Without covariances nothing is claimed.
        let r2 = score(&s, &est, &ScoreOptions::default()).unwrap();
        assert!(
            !r2.warnings
                .iter()
                .any(|w| matches!(w, Warning::GrossError { .. }))
        );
        assert!(r2.intervals.e_abs.measurement.is_none() && r2.intervals.e_abs.targets.is_some());
    }

    #[test]
    fn summary_is_population() {
        let s = summarize(&[1.0, 2.0, 3.0, 4.0]);
        assert_eq!(s.mean, 2.5);
        assert!((s.std - 1.25f64.sqrt()).abs() < 1e-15);
        assert_eq!(s.median, 2.5);
        assert_eq!(s.max, 4.0);
        assert!((s.rmse - 7.5f64.sqrt()).abs() < 1e-15);
    }

    #[test]
    fn relative_errors_invariant_under_rigid_motion() {
        let s = survey(&[
            (0.0, 0.0, 0.0),
            (10.0, 1.0, 0.5),
            (20.0, -5.0, 1.0),
            (3.0, 30.0, -1.0),
        ]);
        let est: Vec<Point> = s
            .targets
            .iter()
            .map(|t| t.position + Vector3::new(0.01, -0.02, 0.03) * t.position.x)
            .collect();
        let ids: Vec<String> = s.targets.iter().map(|t| t.id.clone()).collect();
        let sp: Vec<Point> = s.targets.iter().map(|t| t.position).collect();
        for dim in [Dim::D2, Dim::D3] {
            let before = relative_errors(&ids, &est, &sp, dim);
            let r = nalgebra::Rotation3::from_euler_angles(
                if dim == Dim::D3 { 0.3 } else { 0.0 },
                0.1 * (dim == Dim::D3) as u8 as f64,
                2.0,
            );
            let moved: Vec<Point> = est
                .iter()
                .map(|p| r * p + Vector3::new(350_000.0, 4_150_000.0, 50.0))
                .collect();
            let after = relative_errors(&ids, &moved, &sp, dim);
            for (a, b) in before.iter().zip(&after) {
                assert!((a.error - b.error).abs() < 1e-8, "{dim:?}");
            }
        }
    }

    #[test]
    fn not_found_and_unmatched_are_reported_not_scored() {
        let s = survey(&[
            (0.0, 0.0, 0.0),
            (10.0, 0.0, 0.0),
            (0.0, 10.0, 0.0),
            (5.0, 5.0, 0.0),
        ]);
        let est = vec![
            Estimate::found("t1", Point::new(0.1, 0.0, 0.0)),
            Estimate::found("t2", Point::new(10.0, 0.0, 0.0)),
            Estimate::found("t3", Point::new(0.0, 10.0, 0.0)),
            Estimate {
                id: "t4".into(),
                status: EstimateStatus::NotFound {
                    reason: "no points".into(),
                },
                has_z: false,
            },
            Estimate::found("zz", Point::origin()),
        ];
        let r = score(&s, &est, &ScoreOptions::default()).unwrap();
        assert_eq!(r.absolute.n, 3);
        assert_eq!(r.relative.summary.n, 3);
        assert_eq!(r.targets[3].status, Status::NotFound("no points".into()));
        assert!(r.targets[3].abs_error.is_none());
        assert_eq!(r.estimates_only, vec!["zz".to_string()]);
        assert!(r.leave_one_out.is_some());
        let two = &est[..2];
        let r2 = score(&s, two, &ScoreOptions::default()).unwrap();
        assert!(r2.leave_one_out.is_none());
        assert!(r2.survey_only.len() == 2);
        let e = score(&s, &est[..1], &ScoreOptions::default())
            .unwrap_err()
            .to_string();
        assert!(e.contains("at least 2"), "{e}");
    }

    #[test]
    fn control_check_and_sigma_hat() {
        let mut s = survey(&[
            (0.0, 0.0, 0.0),
            (30.0, 0.0, 0.0),
            (0.0, 30.0, 0.0),
            (30.0, 30.0, 0.0),
            (15.0, 15.0, 0.0),
        ]);
        s.targets[4].role = Some(Role::Check);
        for t in &mut s.targets[..4] {
            t.role = Some(Role::Control);
        }
        // Map = survey rotated by 10°, plus a 0.1 m error on the check target only.
        let r = nalgebra::Rotation3::from_euler_angles(0.0, 0.0, 10f64.to_radians());
        let est: Vec<Estimate> = s
            .targets
            .iter()
            .map(|t| {
                let mut p = r * t.position;
                if t.role == Some(Role::Check) {
                    p.x += 0.1;
                }
                Estimate::found(t.id.clone(), p)
            })
            .collect();
        let res = score(
            &s,
            &est,
            &ScoreOptions {
                survey_sigma: Some((0.02, None)),
                vertical: None,
                ..Default::default()
            },
        )
        .unwrap();
        let cc = res.control_check.as_ref().unwrap();
        assert_eq!(cc.check.targets.len(), 1);
        assert!((cc.check.targets[0].1 - 0.1).abs() < 1e-9);
        assert!(res.asprs.independent);
        assert!((res.asprs.rmse_h_measured - 0.1).abs() < 1e-9);
        assert!((res.asprs.rmse_h - 0.1f64.hypot(0.02)).abs() < 1e-12);
        assert!((res.asprs.nssda_horizontal_95 - 1.7308 * res.asprs.rmse_h).abs() < 1e-12);
        assert!(res.asprs.caveats.contains(&AsprsCaveat::FewerThanNssda(1)));
        // σ̂ = sqrt(SSE / (2n − 3)).
        let sh = res.sigma_hat.unwrap();
        assert_eq!(sh.dof, 7);
        let sse: f64 = res
            .targets
            .iter()
            .map(|t| t.abs_error.unwrap().powi(2))
            .sum();
        assert!((sh.value - (sse / 7.0).sqrt()).abs() < 1e-12);
        // LOO is never smaller on the perturbed target than the in-sample error.
        let t5 = &res.targets[4];
        assert!(t5.loo_error.unwrap() >= t5.abs_error.unwrap());
    }

    #[test]
    fn three_d_with_z_alignment() {
        let s = survey(&[
            (0.0, 0.0, 1.0),
            (30.0, 0.0, 2.0),
            (0.0, 30.0, 0.0),
            (30.0, 30.0, 1.5),
        ]);
        let est: Vec<Estimate> = s
            .targets
            .iter()
            .enumerate()
            .map(|(i, t)| {
                Estimate::found(
                    t.id.clone(),
                    t.position + Vector3::new(5.0, -3.0, 100.0 + 0.01 * i as f64),
                )
            })
            .collect();
        let opts = ScoreOptions {
            method: AlignMethod::Rigid2dZ,
            dim: Dim::D3,
            survey_sigma: None,
            vertical: None,
            threshold: None,
        };
        let r = score(&s, &est, &opts).unwrap();
        assert!((r.absolute.mean - 0.01).abs() < 1e-9, "{:?}", r.absolute);
        assert!(r.asprs.rmse_v.is_some() && r.asprs.rmse_3d.is_some());
        // The antenna height is taken off the survey z before comparing.
        let mut raised = s.clone();
        raised.targets[1].position.z += 1.8;
        raised.targets[1].antenna_height = 1.8;
        let r2 = score(&raised, &est, &opts).unwrap();
        assert!((r2.absolute.mean - r.absolute.mean).abs() < 1e-12);
        // With no alignment heights are compared as they are.
        let none = ScoreOptions {
            method: AlignMethod::None,
            dim: Dim::D3,
            survey_sigma: None,
            vertical: None,
            threshold: None,
        };
        let r3 = score(&s, &est, &none).unwrap();
        assert!(r3.asprs.rmse_v.unwrap() > 99.0);
        let mut no_z = est.clone();
        no_z[0].has_z = false;
        assert!(score(&s, &no_z, &opts).is_err());
    }

    /// Heights compared as they are, all 30.2 m off (ellipsoidal against
    /// orthometric): named as a datum's offset; a few centimetres, or
    /// scattered metres, are not.
    #[test]
    fn a_shared_height_offset_is_named_as_a_datum() {
        let s = survey(&[
            (0.0, 0.0, 1.0),
            (30.0, 0.0, 2.0),
            (0.0, 30.0, 0.0),
            (30.0, 30.0, 1.5),
            (60.0, 10.0, 1.2),
        ]);
        let run = |dz: &dyn Fn(usize) -> f64| {
            let est: Vec<Estimate> = s
                .targets
                .iter()
                .enumerate()
                .map(|(i, t)| {
                    Estimate::found(
                        t.id.clone(),
                        t.position + Vector3::new(0.01 * i as f64, -0.01, dz(i)),
                    )
                })
                .collect();
            let opts = ScoreOptions {
                method: AlignMethod::None,
                dim: Dim::D3,
                ..ScoreOptions::default()
            };
            score(&s, &est, &opts)
                .unwrap()
                .warnings
                .into_iter()
                .find_map(|w| match w {
                    Warning::HeightOffset { dz, .. } => Some(dz),
                    _ => None,
                })
        };
        let dz = run(&|i| 30.2 + 0.01 * i as f64).expect("named");
        assert!((dz - 30.22).abs() < 0.01, "{dz}");
        assert!(run(&|i| 0.03 * i as f64).is_none());
        assert!(run(&|i| [0.0, 3.0, -2.0, 5.0, 1.0][i]).is_none());
    }
}
