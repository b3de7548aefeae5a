//! The result file, `result.json` (schema `mapgauge.result/1`): its types,
//! built from the typed [`crate::accuracy::Accuracy`] and
//! [`crate::pipeline::Evaluation`], read back, and written atomically.
//!
//! The JSON keys are a contract read by scripts and by `mapgauge table`; keys may be
//! added, never renamed.

mod atomic;
mod build;
pub(crate) use build::warning_text;
mod eval_info;

pub use atomic::{refuse_overwrite, write_atomic};
pub use eval_info::{DetectionInfo, EvalInfo, FrameInfo, Levelling, TargetDetail};

use crate::accuracy::Dim;
use crate::survey::{Geodetic, Role, SurveyFrame};
use crate::{Error, Result};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Schema identifier written into every result file.
pub const SCHEMA: &str = "mapgauge.result/1";

/// A position in a result file (z absent when unknown).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Xyz {
    /// x (m).
    pub x: f64,
    /// y (m).
    pub y: f64,
    /// z (m), `null` when the source had no height.
    pub z: Option<f64>,
}

/// The fitted map → survey transform as written to the result.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AlignmentOut {
    /// Method name (`rigid2d`, ...).
    pub method: String,
    /// Yaw of the map → survey rotation, degrees.
    pub rotation_deg: f64,
    /// Translation (m).
    pub translation: [f64; 3],
    /// Scale factor.
    pub scale: f64,
    /// Scale deviation, parts per million.
    #[serde(default)]
    pub scale_ppm: f64,
    /// Full rotation matrix, row-major.
    #[serde(default)]
    pub rotation_matrix: [[f64; 3]; 3],
    /// Number of targets the fit used.
    #[serde(default)]
    pub n_used: usize,
    /// Iterations (robust2d), 0 for closed forms.
    #[serde(default)]
    pub iterations: usize,
}

/// One target's line in the result.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TargetOut {
    /// Target id.
    pub id: String,
    /// `ok`, `not_found`, `excluded` or `ambiguous` (mapped twice).
    pub status: String,
    /// Why, when not ok.
    pub reason: Option<String>,
    /// Surveyed reference point (survey frame, antenna height removed).
    pub survey: Xyz,
    /// Estimated position, map frame.
    pub map: Option<Xyz>,
    /// Estimate mapped into the survey frame.
    pub aligned: Option<Xyz>,
    /// Absolute error (m) in the chosen dimension.
    pub abs_error: Option<f64>,
    /// Error when this target is left out of the alignment fit.
    #[serde(default)]
    pub loo_error: Option<f64>,
    /// Control or check, when the survey says.
    #[serde(default)]
    pub role: Option<Role>,
    /// Covariance of `map` (m², map frame, row-major), `null` when not located
    /// or when the estimates came from a file without one.
    #[serde(default)]
    pub map_covariance: Option<[[f64; 3]; 3]>,
}

/// Summary statistics of a list of errors (the paper's Table II numbers and more).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Stats {
    /// Count.
    pub n: usize,
    /// Mean.
    pub mean: f64,
    /// Population standard deviation (divide by n), as the paper.
    pub std: f64,
    /// Root mean square.
    pub rmse: f64,
    /// Median.
    pub median: f64,
    /// Maximum.
    pub max: f64,
    /// 95 % interval [lo, hi] of the mean from the per-target covariances
    /// (Monte Carlo); `null` when not computable, absent where not defined
    /// (held-out errors).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ci95_measurement: Option<Option<[f64; 2]>>,
    /// 95 % interval [lo, hi] of the mean from the choice of targets
    /// (bootstrap); `null`/absent as `ci95_measurement`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ci95_targets: Option<Option<[f64; 2]>>,
}

/// One pair's relative error (the paper's Table I).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Pair {
    /// First target id.
    pub a: String,
    /// Second target id.
    pub b: String,
    /// Distance between the surveyed points (m).
    pub survey_distance: f64,
    /// Distance between the map estimates (m).
    pub map_distance: f64,
    /// | map_distance − survey_distance | (m).
    pub error: f64,
    /// The error per 100 m of survey distance (m), for comparing short and long
    /// pairs; `null` for coincident survey points.
    #[serde(default)]
    pub error_per_100m: Option<f64>,
}

/// Relative error statistics and every pair.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RelativeStats {
    /// Number of pairs.
    pub n: usize,
    /// Mean (E_rel).
    pub mean: f64,
    /// Population standard deviation (σ_rel).
    pub std: f64,
    /// RMS of pair errors.
    #[serde(default)]
    pub rmse: f64,
    /// Median pair error.
    #[serde(default)]
    pub median: f64,
    /// Largest pair error.
    #[serde(default)]
    pub max: f64,
    /// 95 % interval [lo, hi] of E_rel from the per-target covariances (Monte Carlo).
    #[serde(default)]
    pub ci95_measurement: Option<[f64; 2]>,
    /// 95 % interval [lo, hi] of E_rel from the choice of targets (bootstrap).
    #[serde(default)]
    pub ci95_targets: Option<[f64; 2]>,
    /// Every pair, i < j in survey order.
    pub pairs: Vec<Pair>,
}

/// One held-out target's error.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HeldOutTarget {
    /// Target id.
    pub id: String,
    /// Error (m) under an alignment that did not see this target.
    pub error: f64,
}

/// Errors of targets not used in the fit that scores them (honest errors).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HeldOut {
    /// Statistics of the held-out errors.
    #[serde(flatten)]
    pub summary: Stats,
    /// Per target.
    pub targets: Vec<HeldOutTarget>,
}

/// Fit on control targets, score on check targets.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ControlCheck {
    /// Control target ids (used in the fit).
    pub control: Vec<String>,
    /// The control-only alignment.
    pub alignment: AlignmentOut,
    /// Errors of the check targets.
    pub check: HeldOut,
}

/// σ̂ = √(SSE / dof): the residual scale corrected for fitted parameters.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SigmaHat {
    /// σ̂ (m).
    pub value: f64,
    /// Sum of squared residuals (m²).
    pub sse: f64,
    /// Degrees of freedom (e.g. 2n − 3 for rigid2d).
    pub dof: usize,
}

/// Bias, sample std and RMSE of one axis.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct AxisStats {
    /// Mean residual (aligned − survey).
    pub bias: f64,
    /// Sample standard deviation (n − 1).
    pub std: f64,
    /// Root mean square residual.
    pub rmse: f64,
}

/// ASPRS Positional Accuracy Standards (Ed. 2, 2023) figures and NSSDA lines.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Asprs {
    /// Checkpoints used.
    pub n_checkpoints: usize,
    /// True when the checkpoints were not used to fit the alignment.
    pub independent: bool,
    /// x axis.
    pub x: AxisStats,
    /// y axis.
    pub y: AxisStats,
    /// z axis, when heights were fitted.
    pub z: Option<AxisStats>,
    /// RMSE_x (m).
    pub rmse_x: f64,
    /// RMSE_y (m).
    pub rmse_y: f64,
    /// RMSE_H = √(RMSE_x² + RMSE_y²), survey error folded in when given (m).
    pub rmse_h: f64,
    /// RMSE_V, survey error folded in when given (m).
    pub rmse_v: Option<f64>,
    /// RMSE_3D = √(RMSE_H² + RMSE_V²) (m).
    pub rmse_3d: Option<f64>,
    /// RMSE_H of the data alone (m).
    pub rmse_h_measured: f64,
    /// RMSE_V of the data alone (m).
    pub rmse_v_measured: Option<f64>,
    /// Survey horizontal σ folded in (m).
    pub survey_sigma_h: Option<f64>,
    /// Survey vertical σ folded in (m).
    pub survey_sigma_v: Option<f64>,
    /// 1.7308 · RMSE_H (m).
    pub nssda_horizontal_95: f64,
    /// 1.96 · RMSE_V (m).
    pub nssda_vertical_95: Option<f64>,
    /// The NSSDA statements, ready to paste into a report.
    pub nssda_lines: Vec<String>,
    /// Caveats (too few checkpoints, not independent).
    pub warnings: Vec<String>,
    /// 95 % interval [lo, hi] of RMSE_H from the per-target covariances (Monte
    /// Carlo); `null` with check targets or too few targets.
    #[serde(default)]
    pub ci95_measurement: Option<[f64; 2]>,
    /// 95 % interval [lo, hi] of RMSE_H from the choice of targets (bootstrap).
    #[serde(default)]
    pub ci95_targets: Option<[f64; 2]>,
}

/// Ids present on one side only.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Unmatched {
    /// In the survey, not in the estimates.
    pub survey_only: Vec<String>,
    /// In the estimates, not in the survey.
    pub estimates_only: Vec<String>,
}

/// Everything one evaluation produced: the content of `result.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ResultFile {
    /// Always [`SCHEMA`].
    pub schema: String,
    /// Version of mapgauge that wrote the file.
    pub mapgauge_version: String,
    /// Error dimension.
    #[serde(default)]
    pub dim: Dim,
    /// Frame of the survey coordinates.
    #[serde(default = "local")]
    pub survey_frame: SurveyFrame,
    /// ENU origin for lat/lon surveys.
    #[serde(default)]
    pub origin: Option<Geodetic>,
    /// The map → survey alignment.
    pub alignment: AlignmentOut,
    /// Every survey target, located or not.
    pub targets: Vec<TargetOut>,
    /// Absolute error statistics.
    pub absolute: Stats,
    /// The absolute error without any fit, when the map is in the survey's
    /// frame (`eval` found the targets where the survey places them, on a
    /// map it did not level): the error the map carries as it is.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub unfitted: Option<Stats>,
    /// The share of the unfitted mean error the alignment removed,
    /// (unfitted − absolute) / unfitted; absent with `unfitted`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fit_absorbed: Option<f64>,
    /// Relative error statistics.
    pub relative: RelativeStats,
    /// Leave-one-out absolute errors (≥ 3 targets).
    #[serde(default)]
    pub leave_one_out: Option<HeldOut>,
    /// Control/check split, when the survey has roles.
    #[serde(default)]
    pub control_check: Option<ControlCheck>,
    /// σ̂ of the fit.
    #[serde(default)]
    pub sigma_hat: Option<SigmaHat>,
    /// Survey-standard statistics.
    pub asprs: Asprs,
    /// ISO 19157 measures of the checkpoints (bias per axis with its 95 %
    /// interval, CE90/CE95 and LE90/LE95 with the bias accounted for, the
    /// count beyond a threshold); absent in results written before them.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub iso19157: Option<crate::accuracy::Iso19157>,
    /// Ids on one side only.
    #[serde(default)]
    pub unmatched: Unmatched,
    /// The map's horizontal scale against the survey's (ppm, with its 95 %
    /// interval), from a similarity fit of the scored targets' layout
    /// whatever the alignment used; absent with fewer than 3.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scale: Option<crate::accuracy::ScaleEstimate>,
    /// Caveats for the reader, what may make a number wrong first (a gross
    /// error, targets set aside), the stock caveats last.
    #[serde(default)]
    pub warnings: Vec<String>,
    /// Provenance and per-target details of a map evaluation (`eval` only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub eval: Option<EvalInfo>,
    /// The quality gates the run was held to, each with its verdict, in the
    /// order given; absent when none were set.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub gates: Vec<crate::gate::GateVerdict>,
    /// What the gates decided under their policy; absent without gates.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gate_outcome: Option<crate::gate::GateOutcome>,
    /// Benchmark scores asked for (`--score`), by rule; absent when none.
    #[serde(default, skip_serializing_if = "std::collections::BTreeMap::is_empty")]
    pub scores: std::collections::BTreeMap<crate::scores::ScoreKind, crate::scores::BenchScore>,
}

fn local() -> SurveyFrame {
    SurveyFrame::Local
}

impl ResultFile {
    /// Targets the map showed (scored, or excluded as a gross error: it
    /// was found, and its error judged), and of them the excluded.
    pub fn found(&self) -> (usize, usize) {
        let excluded = self
            .targets
            .iter()
            .filter(|t| t.status == "excluded")
            .count();
        let ok = self.targets.iter().filter(|t| t.status == "ok").count();
        (ok + excluded, excluded)
    }

    /// Every caveat of the result, signal first: the ranked warnings (what
    /// may make a number wrong leads), then the accuracy standard's stock
    /// ones (NSSDA/ASPRS), as the report lists them (eval's terminal summary
    /// folds the stock ones, with "vertical not reported", into one note).
    pub fn caveats(&self) -> impl Iterator<Item = &String> {
        self.warnings.iter().chain(&self.asprs.warnings)
    }

    /// Reads a result file, checking its schema.
    pub fn from_json_file(path: &Path) -> Result<ResultFile> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        let r: ResultFile = serde_json::from_str(&text).map_err(|e| {
            Error::table(path, e.line() as u64, format!("not a mapgauge result: {e}"))
        })?;
        if r.schema != SCHEMA {
            return Err(Error::format(
                path,
                format!("schema `{}`, expected `{SCHEMA}`", r.schema),
            ));
        }
        Ok(r)
    }
    /// Pretty JSON, ending in a newline.
    pub fn to_json(&self) -> String {
        // Serialising plain data cannot fail; NaN becomes null.
        let mut s = serde_json::to_string_pretty(self).unwrap_or_default();
        s.push('\n');
        s
    }
}
