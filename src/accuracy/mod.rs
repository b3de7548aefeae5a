//! Absolute and relative errors, honest (held-out) errors and survey-standard
//! statistics: steps 6–7 of the pipeline in one call, [`score`].
//!
//! The result, [`Accuracy`], is plain typed numbers: no file schema, no
//! sentences. `record` turns it into `result.json`, `render` into tables.

mod asprs;
pub mod intervals;
mod scale;
mod stats;

pub use asprs::{Asprs, AsprsCaveat};
pub use intervals::{Ci95, Interval, Intervals};
pub use scale::{ScaleEstimate, layout_scale};
pub(crate) use stats::t975;
pub use stats::{AxisStats, PairError, Summary, dist, leave_one_out, relative_errors, summarize};

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
            Warning::GrossError { .. } | Warning::HeightDatumNotCorrected(_) => 0,
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

/// Aligns the estimates to the survey and computes every error statistic.
///
/// Targets are matched by id; estimates that are not found or excluded are
/// listed in the result with their reason but never scored.
pub fn score(survey: &Survey, estimates: &[Estimate], opts: &ScoreOptions) -> Result<Accuracy> {
    score_with_covariances(survey, estimates, &HashMap::new(), opts)
}

/// [`score`] with each located target's covariance (m², map frame), by id:
/// they are reported per target and give the measurement intervals (which
/// need one for every scored target).
pub fn score_with_covariances(
    survey: &Survey,
    estimates: &[Estimate],
    covariances: &HashMap<String, [[f64; 3]; 3]>,
    opts: &ScoreOptions,
) -> Result<Accuracy> {
    let dim = opts.dim;
    let mut warnings = Vec::new();
    let by_id: HashMap<&str, &Estimate> = estimates.iter().map(|e| (e.id.as_str(), e)).collect();
    let mut targets = Vec::new();
    let mut used = Vec::new(); // index into survey.targets of scored targets
    let mut map_pts = Vec::new();
    let mut sur_pts = Vec::new();
    let mut survey_only = Vec::new();
    for (k, st) in survey.targets.iter().enumerate() {
        let sp = st.reference();
        let base = TargetScore {
            id: st.id.clone(),
            status: Status::Ok,
            survey: sp,
            survey_has_z: st.has_z,
            map: None,
            map_has_z: false,
            aligned: None,
            aligned_has_z: false,
            abs_error: None,
            loo_error: None,
            role: st.role,
            map_covariance: None,
        };
        match by_id.get(st.id.as_str()) {
            None => {
                survey_only.push(st.id.clone());
                targets.push(TargetScore {
                    status: Status::NoEstimate,
                    ..base
                });
            }
            Some(e) => match &e.status {
                EstimateStatus::Found(p) => {
                    if dim == Dim::D3 && !(st.has_z && e.has_z) {
                        return Err(Error::Input(format!(
                            "target `{}`: 3D errors need z in both the survey and the estimates (use --dim 2d)",
                            st.id
                        )));
                    }
                    used.push(k);
                    map_pts.push(*p);
                    sur_pts.push(sp);
                    targets.push(TargetScore {
                        map: Some(*p),
                        map_has_z: e.has_z,
                        map_covariance: covariances
                            .get(&st.id)
                            .map(|c| opts.vertical.map_or(*c, |v| v.add_to(c, p))),
                        ..base
                    });
                }
                EstimateStatus::NotFound { reason } => targets.push(TargetScore {
                    status: Status::NotFound(reason.clone()),
                    ..base
                }),
                EstimateStatus::Excluded { reason } => targets.push(TargetScore {
                    status: Status::Excluded(reason.clone()),
                    ..base
                }),
                EstimateStatus::Ambiguous { reason } => targets.push(TargetScore {
                    status: Status::Ambiguous(reason.clone()),
                    ..base
                }),
            },
        }
    }
    let estimates_only: Vec<String> = estimates
        .iter()
        .filter(|e| survey.get(&e.id).is_none())
        .map(|e| e.id.clone())
        .collect();
    if !survey_only.is_empty() {
        warnings.push(Warning::SurveyOnly(survey_only.clone()));
    }
    if !estimates_only.is_empty() {
        warnings.push(Warning::EstimatesOnly(estimates_only.clone()));
    }
    let n = used.len();
    let need = opts.method.min_points().max(2);
    if n < need {
        let mut msg = format!(
            "only {n} target(s) are both surveyed and located; at least {need} are needed for {} alignment",
            opts.method
        );
        let shared = estimates.iter().any(|e| survey.get(&e.id).is_some());
        if !shared && !estimates.is_empty() {
            let list = |ids: Vec<&str>| {
                let more = if ids.len() > 5 { ", ..." } else { "" };
                ids[..ids.len().min(5)].join(", ") + more
            };
            msg += &format!(
                ": the ids differ (survey: {}; estimates: {})",
                list(survey.targets.iter().map(|t| t.id.as_str()).collect()),
                list(estimates.iter().map(|e| e.id.as_str()).collect())
            );
        }
        return Err(Error::Input(msg));
    }
    let all_z = used.iter().all(|&k| survey.targets[k].has_z)
        && used.iter().all(|&k| {
            by_id
                .get(survey.targets[k].id.as_str())
                .is_some_and(|e| e.has_z)
        });
    if opts.method.uses_z() && !all_z {
        return Err(Error::Input(format!(
            "alignment {} needs z in both the survey and the estimates",
            opts.method
        )));
    }
    if dim == Dim::D3 && !opts.method.uses_z() && opts.method != AlignMethod::None {
        warnings.push(Warning::HeightDatumNotCorrected(opts.method));
    }

    let al = align::fit(opts.method, &map_pts, &sur_pts)?;
    let aligned: Vec<Point> = map_pts.iter().map(|p| al.apply(p)).collect();
    let abs: Vec<f64> = aligned
        .iter()
        .zip(&sur_pts)
        .map(|(a, s)| dist(a, s, dim))
        .collect();
    let ids: Vec<String> = used.iter().map(|&k| survey.targets[k].id.clone()).collect();
    let pairs = relative_errors(&ids, &map_pts, &sur_pts, dim);
    let rel: Vec<f64> = pairs.iter().map(|p| p.error).collect();

    // Honest errors.
    let loo = leave_one_out(opts.method, &map_pts, &sur_pts, dim);
    if loo.is_none() {
        warnings.push(Warning::LeaveOneOutTooFew {
            method: opts.method,
            n,
        });
    }
    let sigma_hat = {
        let (d, sse) = if opts.method.uses_z() {
            (
                3,
                aligned
                    .iter()
                    .zip(&sur_pts)
                    .map(|(a, s)| (a - s).norm_squared())
                    .sum::<f64>(),
            )
        } else {
            (
                2,
                aligned
                    .iter()
                    .zip(&sur_pts)
                    .map(|(a, s)| (a - s).xy().norm_squared())
                    .sum::<f64>(),
            )
        };
        let dof = (d * n) as i64 - opts.method.params() as i64;
        (dof > 0).then(|| SigmaHat {
            value: (sse / dof as f64).sqrt(),
            sse,
            dof: dof as usize,
        })
    };

    for (j, &k) in used.iter().enumerate() {
        let t = &mut targets[k];
        t.aligned = Some(aligned[j]);
        t.aligned_has_z = all_z || opts.method.uses_z();
        t.abs_error = Some(abs[j]);
        t.loo_error = loo.as_ref().map(|l| l[j]);
    }

    // Control/check split.
    let has_roles = used.iter().any(|&k| survey.targets[k].role.is_some());
    let mut control_check = None;
    let mut check_residuals = None;
    if has_roles {
        let is_check = |k: usize| survey.targets[k].role == Some(Role::Check);
        let ctrl: Vec<usize> = (0..n).filter(|&j| !is_check(used[j])).collect();
        let chk: Vec<usize> = (0..n).filter(|&j| is_check(used[j])).collect();
        if chk.is_empty() {
            warnings.push(Warning::NoCheckTargets);
        } else if ctrl.len() < need {
            warnings.push(Warning::TooFewControls {
                n: ctrl.len(),
                method: opts.method,
            });
        } else {
            let src: Vec<Point> = ctrl.iter().map(|&j| map_pts[j]).collect();
            let dst: Vec<Point> = ctrl.iter().map(|&j| sur_pts[j]).collect();
            let a = align::fit(opts.method, &src, &dst)?;
            let per: Vec<(String, f64)> = chk
                .iter()
                .map(|&j| {
                    (
                        ids[j].clone(),
                        dist(&a.apply(&map_pts[j]), &sur_pts[j], dim),
                    )
                })
                .collect();
            let errs: Vec<f64> = per.iter().map(|t| t.1).collect();
            check_residuals = Some(
                chk.iter()
                    .map(|&j| a.apply(&map_pts[j]) - sur_pts[j])
                    .collect::<Vec<_>>(),
            );
            control_check = Some(ControlCheck {
                control: ctrl.iter().map(|&j| ids[j].clone()).collect(),
                fit: Fit {
                    alignment: a,
                    n_used: ctrl.len(),
                },
                check: HeldOut {
                    summary: summarize(&errs),
                    targets: per,
                },
            });
        }
    }
    // Heights are comparable when the fit corrected them or the map is already in the survey frame.
    let vertical = all_z && (opts.method.uses_z() || opts.method == AlignMethod::None);
    let asprs = match check_residuals {
        Some(r) => asprs::asprs(&r, vertical, opts.survey_sigma, true),
        None => {
            let r: Vec<_> = aligned.iter().zip(&sur_pts).map(|(a, s)| a - s).collect();
            asprs::asprs(&r, vertical, opts.survey_sigma, false)
        }
    };
    if all_z && !vertical {
        warnings.push(Warning::VerticalNotReported);
    }
    let covs: Option<Vec<nalgebra::Matrix3<f64>>> = used
        .iter()
        .map(|&k| {
            covariances
                .get(&survey.targets[k].id)
                .map(|c| nalgebra::Matrix3::from_fn(|i, j| c[i][j]))
        })
        .collect();
    let intervals = intervals::intervals(&intervals::Inputs {
        method: opts.method,
        dim,
        ids: &ids,
        map: &map_pts,
        survey: &sur_pts,
        covariances: covs,
        vertical: opts.vertical,
        survey_sigma_h: opts.survey_sigma.map_or(0.0, |s| s.0),
        rmse_h: !asprs.independent,
    });
    if n < intervals::MIN_TARGETS {
        warnings.push(Warning::TooFewForIntervals { n });
    }
    let residuals: Vec<nalgebra::Vector3<f64>> =
        aligned.iter().zip(&sur_pts).map(|(a, s)| a - s).collect();
    // Each target's own, as reported (the vertical's share included: the
    // alignment does not absorb what it does to one target alone).
    let reported: HashMap<&str, [[f64; 3]; 3]> = targets
        .iter()
        .filter_map(|t| t.map_covariance.map(|c| (t.id.as_str(), c)))
        .collect();
    let covs_survey: Vec<Option<nalgebra::Matrix3<f64>>> = used
        .iter()
        .map(|&k| {
            reported.get(survey.targets[k].id.as_str()).map(|c| {
                let c = nalgebra::Matrix3::from_fn(|i, j| c[i][j]);
                let r = al.rotation * al.scale;
                r * c * r.transpose()
            })
        })
        .collect();
    warnings.extend(gross_errors(&ids, &abs, &residuals, &covs_survey));
    let scale = layout_scale(
        &sur_pts
            .iter()
            .zip(&map_pts)
            .map(|(s, m)| ([s.x, s.y], [m.x, m.y]))
            .collect::<Vec<_>>(),
    );

    Ok(Accuracy {
        scale,
        dim,
        fit: Fit {
            alignment: al,
            n_used: n,
        },
        targets,
        absolute: summarize(&abs),
        relative: Relative {
            summary: summarize(&rel),
            pairs,
        },
        leave_one_out: loo.map(|l| HeldOut {
            summary: summarize(&l),
            targets: ids.iter().cloned().zip(l).collect(),
        }),
        control_check,
        sigma_hat,
        asprs,
        survey_only,
        estimates_only,
        intervals,
        warnings,
    })
}

/// χ²₂ 99.9 % quantile: −2 ln(0.001).
const CHI2_2_999: f64 = 13.815_510_557_964_274;
/// Robust z-score above which an error is far from the others.
const ROBUST_Z: f64 = 3.5;

/// Targets whose horizontal residual lies outside their own 99.9 % ellipse and
/// whose error is a robust outlier among the targets' errors (needs ≥ 5
/// targets: a median and MAD of fewer say little).
fn gross_errors(
    ids: &[String],
    errors: &[f64],
    residuals: &[nalgebra::Vector3<f64>],
    covs: &[Option<nalgebra::Matrix3<f64>>],
) -> Vec<Warning> {
    let n = errors.len();
    if n < 5 {
        return Vec::new();
    }
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        let m = v.len() / 2;
        if v.len() % 2 == 1 {
            v[m]
        } else {
            (v[m - 1] + v[m]) / 2.0
        }
    };
    let med = median(&mut errors.to_vec());
    let mad = 1.4826 * median(&mut errors.iter().map(|e| (e - med).abs()).collect());
    // A floor of 1 mm: identical errors would make any difference "infinitely" far.
    let scale = mad.max(1e-3);
    let mut out = Vec::new();
    for j in 0..n {
        let z = (errors[j] - med) / scale;
        let Some(c) = covs[j] else { continue };
        let c2 = nalgebra::Matrix2::new(c[(0, 0)], c[(0, 1)], c[(1, 0)], c[(1, 1)]);
        let r = residuals[j].xy();
        let Some(inv) = c2.try_inverse() else {
            continue;
        };
        let m2 = (r.transpose() * inv * r)[(0, 0)];
        if z > ROBUST_Z && m2 > CHI2_2_999 {
            out.push(Warning::GrossError {
                id: ids[j].clone(),
                error: errors[j],
                sigma: ((c2[(0, 0)] + c2[(1, 1)]) / 2.0).max(0.0).sqrt(),
                robust_z: z,
            });
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    fn survey(pts: &[(f64, f64, f64)]) -> Survey {
        Survey::local(pts, true)
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
        };
        let r3 = score(&s, &est, &none).unwrap();
        assert!(r3.asprs.rmse_v.unwrap() > 99.0);
        let mut no_z = est.clone();
        no_z[0].has_z = false;
        assert!(score(&s, &no_z, &opts).is_err());
    }
}
