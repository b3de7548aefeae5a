//! The whole pipeline, map to accuracy: loose crop → tight crop → locate →
//! align → metrics. Each stage is a plain function of the previous stage's
//! output; this module only composes them and records what happened.

use crate::align::AlignMethod;
use crate::cloud;
use crate::crop::{self, LooseParams, Shape, TightParams};
use crate::locate::{self, LocateParams};
use crate::metrics::{self, Dim, EvalOptions};
use crate::result::RunResult;
use crate::survey::{Estimate, EstimateStatus, Survey};
use crate::{Error, Point, Result};
use nalgebra::Vector3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Every parameter of `mapgauge eval`; also the TOML configuration file.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct EvalConfig {
    /// Loose crop around each expected position.
    pub crop: LooseParams,
    /// Automatic tight crop (ground removal, target detection).
    pub tight: TightParams,
    /// Target localisation (the paper's algorithm).
    pub locate: LocateParams,
    /// Alignment and metrics.
    pub metrics: MetricsConfig,
    /// Frames: where to look for the targets in the map.
    pub frame: FrameConfig,
}

impl Default for EvalConfig {
    /// The locator's defaults (one refit in a noise-scaled band); the paper's
    /// plain draws are the fallback (see `locate_with`).
    fn default() -> Self {
        EvalConfig {
            crop: LooseParams::default(),
            tight: TightParams::default(),
            locate: LocateParams::default(),
            metrics: MetricsConfig::default(),
            frame: FrameConfig::default(),
        }
    }
}

/// Alignment and metric settings.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MetricsConfig {
    /// Map → survey alignment method.
    pub align: AlignMethod,
    /// Error dimension, "2d" (the paper) or "3d".
    pub dim: Dim,
    /// The survey's own horizontal 1-σ error (m), folded into the ASPRS figures.
    pub survey_sigma_h: Option<f64>,
    /// The survey's own vertical 1-σ error (m).
    pub survey_sigma_v: Option<f64>,
}

/// Where targets are expected in the map.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FrameConfig {
    /// Approximate map → survey transform `[x, y, yaw_deg]` (survey = R·map + t);
    /// `None` = the map is in the survey frame to within a few metres.
    pub init: Option<[f64; 3]>,
    /// Search again for targets not found, around the positions predicted by
    /// the alignment of the ones that were.
    pub second_pass: bool,
    /// Only search again when the prediction moved more than this (m).
    pub second_pass_min_shift: f64,
    /// The targets' common plumb line is trusted as the map's vertical up to this
    /// tilt from +z (degrees).
    pub max_tilt_deg: f64,
    /// Targets located with an "up" further than this from the common plumb line
    /// are located again with it (degrees).
    pub tilt_redo_deg: f64,
}

impl Default for FrameConfig {
    fn default() -> Self {
        FrameConfig {
            init: None,
            second_pass: true,
            second_pass_min_shift: 0.5,
            max_tilt_deg: 3.0,
            tilt_redo_deg: 0.25,
        }
    }
}

impl EvalConfig {
    /// Reads a TOML configuration; unknown keys are errors (a typo must not be ignored).
    pub fn from_toml_file(path: &Path) -> Result<EvalConfig> {
        let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
        let text = std::str::from_utf8(&bytes).map_err(|e| {
            let line = bytes[..e.valid_up_to()].split(|&b| b == b'\n').count() as u64;
            Error::table(path, line, "not UTF-8 text")
        })?;
        let cfg: EvalConfig = toml::from_str(text).map_err(|e| {
            let line = e.span().map_or(0, |s| {
                text.as_bytes()[..s.start.min(text.len())]
                    .iter()
                    .filter(|&&b| b == b'\n')
                    .count()
                    + 1
            });
            let msg = e.message().trim().replace('\n', " ");
            Error::table(path, line as u64, msg)
        })?;
        cfg.validate().map_err(|e| match e {
            Error::Param(m) => Error::format(path, m),
            other => other,
        })?;
        Ok(cfg)
    }
    /// Checks every value is in a physically sensible range, so a typo cannot
    /// make a run allocate or loop without bound (flags are checked too).
    pub fn validate(&self) -> Result<()> {
        fn range(key: &str, v: f64, lo: f64, hi: f64) -> Result<()> {
            if v >= lo && v <= hi {
                Ok(())
            } else {
                Err(Error::Param(format!(
                    "{key} = {v}: must be within {lo}..{hi}"
                )))
            }
        }
        fn count(key: &str, v: usize, lo: usize, hi: usize) -> Result<()> {
            if (lo..=hi).contains(&v) {
                Ok(())
            } else {
                Err(Error::Param(format!(
                    "{key} = {v}: must be within {lo}..{hi}"
                )))
            }
        }
        let (c, t, l, m, f) = (
            &self.crop,
            &self.tight,
            &self.locate,
            &self.metrics,
            &self.frame,
        );
        range("crop.radius", c.radius, 1e-3, 1e4)?;
        range("tight.plate_width", t.plate_width, 0.05, 10.0)?;
        range("tight.plate_height", t.plate_height, 0.05, 10.0)?;
        range("tight.ground_cell", t.ground_cell, 0.05, 100.0)?;
        range("tight.min_height", t.min_height, -100.0, 100.0)?;
        range("tight.max_height", t.max_height, t.min_height, 1000.0)?;
        range("tight.search_radius", t.search_radius, 1e-3, 1e4)?;
        range("tight.keep_distance", t.keep_distance, 1e-4, 10.0)?;
        count("tight.min_plate_points", t.min_plate_points, 1, 1 << 24)?;
        range("tight.max_up_tilt_deg", t.max_up_tilt_deg, 0.0, 90.0)?;
        count("locate.kmeans_iterations", l.kmeans_iterations, 1, 1 << 16)?;
        count("locate.kmeans_points", l.kmeans_points, 0, 1 << 24)?;
        count("locate.ransac_iterations", l.ransac_iterations, 1, 1 << 24)?;
        count(
            "locate.ransac_score_points",
            l.ransac_score_points,
            0,
            1 << 24,
        )?;
        count("locate.refit_iterations", l.refit_iterations, 0, 1 << 16)?;
        count("locate.samples", l.samples, 1, 1 << 20)?;
        count("locate.max_attempts", l.max_attempts, 1, 1 << 24)?;
        for (k, v) in [
            ("metrics.survey_sigma_h", m.survey_sigma_h),
            ("metrics.survey_sigma_v", m.survey_sigma_v),
        ] {
            if let Some(v) = v {
                range(k, v, 0.0, 1e3)?;
            }
        }
        if let Some(i) = f.init {
            for v in i {
                range("frame.init", v, -1e8, 1e8)?;
            }
        }
        range(
            "frame.second_pass_min_shift",
            f.second_pass_min_shift,
            0.0,
            1e4,
        )?;
        range("frame.max_tilt_deg", f.max_tilt_deg, 0.0, 90.0)?;
        range("frame.tilt_redo_deg", f.tilt_redo_deg, 0.0, 90.0)?;
        // The localisation's own consistency rules (thresholds, margins, angles).
        l.check()?;
        Ok(())
    }
    /// The configuration as TOML, every default written out.
    pub fn to_toml(&self) -> String {
        toml::to_string_pretty(self)
            .unwrap_or_else(|e| format!("# cannot print configuration: {e}\n"))
    }
}

/// What the pipeline learned about one target, for reports and debugging.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct TargetDetail {
    /// Target id.
    pub id: String,
    /// Where the target was looked for (map frame).
    pub expected: [f64; 3],
    /// Which pass found it (1, or 2 = around the alignment's prediction).
    pub pass: u8,
    /// Points in the loose crop.
    pub loose_points: usize,
    /// Points the map had inside the loose crop, when more than `crop.max_points`
    /// and the crop was thinned to `loose_points`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub loose_thinned_from: Option<u64>,
    /// Points in the tight crop.
    pub tight_points: usize,
    /// Local ground normal.
    pub ground_normal: Option<[f64; 3]>,
    /// Direction used as vertical by the gates.
    pub up: Option<[f64; 3]>,
    /// Accepted samples.
    pub accepted: usize,
    /// Attempts drawn.
    pub attempts: usize,
    /// Per-axis standard deviation of the accepted samples (m).
    pub spread: Option<[f64; 3]>,
    /// Angle between the plates (degrees).
    pub plate_angle_deg: Option<f64>,
    /// Direction of the plates' intersection line (the target's plumb line in the map).
    pub axis: Option<[f64; 3]>,
    /// Stage at which it failed (`loose`, `tight`, `locate`), when it did.
    pub failed_stage: Option<String>,
}

/// Provenance and per-target details of an `eval` run (the `eval` key of result.json).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct EvalInfo {
    /// Map file as given.
    pub map: String,
    /// Map size in bytes.
    pub map_bytes: u64,
    /// Points read from the map.
    pub map_points: u64,
    /// Points skipped as NaN / infinite.
    pub skipped_nonfinite: u64,
    /// Survey file as given.
    pub survey: String,
    /// Per target.
    pub targets: Vec<TargetDetail>,
}

/// What a report needs to draw one target, kept from localisation so the report
/// never has to run it again. Not part of result.json (per-point data).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TargetDiagnostics {
    /// Role of each tight-crop point in the reference sample (plate 1, plate 2,
    /// outlier), in the order of [`EvalRun::tight`]; empty when not located.
    pub labels: Vec<locate::Label>,
    /// Unit normals of the two fitted plate planes (map frame), when located.
    pub plate_normals: Option<[[f64; 3]; 2]>,
    /// The estimated corner (map frame), when located.
    pub corner: Option<Point>,
    /// Every accepted sample corner (map frame): the spread behind `corner`.
    pub samples: Vec<Point>,
}

/// Everything an `eval` run produces.
pub struct EvalRun {
    /// The result (result.json).
    pub result: RunResult,
    /// The loose crops, by survey order.
    pub loose: Vec<Vec<Point>>,
    /// The tight crops, by survey order (empty when none was made).
    pub tight: Vec<Vec<Point>>,
    /// Per-target plotting data, by survey order.
    pub diagnostics: Vec<TargetDiagnostics>,
}

/// Inputs of [`evaluate_map`].
pub struct EvalInputs<'a> {
    /// The map file.
    pub map: &'a Path,
    /// The survey, already read.
    pub survey: &'a Survey,
    /// Path the survey came from (for provenance).
    pub survey_path: &'a Path,
    /// Hand-made tight crops `DIR/<id>.ply|pcd|...` instead of the automatic ones.
    pub crops_dir: Option<PathBuf>,
}

struct Located {
    status: EstimateStatus,
    detail: TargetDetail,
    tight: Vec<Point>,
    diag: TargetDiagnostics,
}

/// Runs the whole pipeline. `progress` gets (bytes read, total bytes) while the
/// map streams.
pub fn evaluate_map(
    inp: &EvalInputs,
    cfg: &EvalConfig,
    mut progress: impl FnMut(u64, u64),
) -> Result<EvalRun> {
    cfg.validate()?;
    let survey = inp.survey;
    if survey.targets.is_empty() {
        return Err(Error::Input(format!(
            "{}: the survey has no targets",
            inp.survey_path.display()
        )));
    }
    let init = cfg.frame.init.unwrap_or([0.0, 0.0, 0.0]);
    let expected: Vec<Point> = survey
        .targets
        .iter()
        .map(|t| survey_to_map(&init, &t.reference()))
        .collect();
    let mut crop_params = cfg.crop;
    if crop_params.shape == Shape::Sphere && !survey.has_z() {
        eprintln!(
            "warning: the survey has no heights; cropping with a vertical cylinder instead of a sphere"
        );
        crop_params.shape = Shape::Cylinder;
    }
    let mut info = EvalInfo {
        map: inp.map.display().to_string(),
        survey: inp.survey_path.display().to_string(),
        ..Default::default()
    };

    let (loose, offered) = read_crops(inp.map, &expected, &crop_params, &mut info, &mut progress)?;
    let mut found: Vec<Located> = survey
        .targets
        .par_iter()
        .zip(&expected)
        .zip(&loose)
        .map(|((t, e), pts)| locate_one(&t.id, e, pts, inp.crops_dir.as_deref(), cfg, 1))
        .collect();
    for ((f, pts), n) in found.iter_mut().zip(&loose).zip(&offered) {
        f.detail.loose_thinned_from = (*n > pts.len() as u64).then_some(*n);
    }

    let opts = EvalOptions {
        method: cfg.metrics.align,
        dim: cfg.metrics.dim,
        survey_sigma: cfg
            .metrics
            .survey_sigma_h
            .map(|h| (h, cfg.metrics.survey_sigma_v)),
    };
    let mut loose = loose;
    let estimates = |found: &[Located]| -> Vec<Estimate> {
        survey
            .targets
            .iter()
            .zip(found)
            .map(|(t, l)| Estimate {
                id: t.id.clone(),
                status: l.status.clone(),
                has_z: true,
            })
            .collect()
    };

    // Second pass: look again where the alignment of the found targets says the
    // missing ones should be.
    let missing: Vec<usize> = (0..found.len())
        .filter(|&i| !matches!(found[i].status, EstimateStatus::Found(_)))
        .collect();
    if cfg.frame.second_pass && inp.crops_dir.is_none() && !missing.is_empty() {
        if let Ok(first) = metrics::evaluate(survey, &estimates(&found), &opts) {
            let inverse = first.alignment.to_alignment().inverse();
            let mut redo = Vec::new();
            for &i in &missing {
                let predicted = inverse.apply(&survey.targets[i].reference());
                if (predicted - expected[i]).xy().norm() > cfg.frame.second_pass_min_shift {
                    redo.push((i, predicted));
                }
            }
            if !redo.is_empty() {
                let centres: Vec<Point> = redo.iter().map(|r| r.1).collect();
                let mut again_info = EvalInfo::default();
                let (again, again_offered) = read_crops(
                    inp.map,
                    &centres,
                    &crop_params,
                    &mut again_info,
                    &mut progress,
                )?;
                for (((i, c), pts), n) in redo.into_iter().zip(again).zip(again_offered) {
                    let mut l = locate_one(&survey.targets[i].id, &c, &pts, None, cfg, 2);
                    l.detail.loose_thinned_from = (n > pts.len() as u64).then_some(n);
                    if matches!(l.status, EstimateStatus::Found(_)) {
                        found[i] = l;
                        loose[i] = pts;
                    }
                }
            }
        }
    }

    // Map tilt: when the targets agree on a vertical that differs from the one a
    // target was located with, locate it again with the common one.
    if let Some(axis) = consensus_up(&found) {
        if axis.angle(&Vector3::z()).to_degrees() <= cfg.frame.max_tilt_deg {
            let redo: Vec<usize> = (0..found.len())
                .filter(|&i| {
                    let used = found[i].detail.up.map(Vector3::from);
                    !found[i].tight.is_empty()
                        && used
                            .is_none_or(|u| u.angle(&axis).to_degrees() > cfg.frame.tilt_redo_deg)
                })
                .collect();
            let again: Vec<(usize, Located)> = redo
                .into_par_iter()
                .map(|i| {
                    let l = &found[i];
                    (
                        i,
                        locate_with(l.tight.clone(), &[axis], l.detail.clone(), cfg),
                    )
                })
                .collect();
            for (i, l) in again {
                if matches!(l.status, EstimateStatus::Found(_)) {
                    found[i] = l;
                }
            }
        }
    }

    let n_found = found
        .iter()
        .filter(|l| matches!(l.status, EstimateStatus::Found(_)))
        .count();
    if n_found < cfg.metrics.align.min_points() {
        let why: Vec<String> = survey
            .targets
            .iter()
            .zip(&found)
            .filter_map(|(t, l)| match &l.status {
                EstimateStatus::NotFound { reason } => Some(format!("{}: {reason}", t.id)),
                _ => None,
            })
            .take(5)
            .collect();
        return Err(Error::Input(format!(
            "{}: only {n_found} of {} targets found in the map (need {} for {}); {}{}. Is the map in the survey frame? If not, give --init x,y,yaw_deg",
            inp.map.display(),
            survey.targets.len(),
            cfg.metrics.align.min_points(),
            cfg.metrics.align.name(),
            why.join("; "),
            if survey.targets.len() - n_found > why.len() {
                "; ..."
            } else {
                ""
            },
        )));
    }
    let mut result = metrics::evaluate(survey, &estimates(&found), &opts)?;
    let mut tight = Vec::with_capacity(found.len());
    let mut diagnostics = Vec::with_capacity(found.len());
    for l in found {
        info.targets.push(l.detail);
        tight.push(l.tight);
        diagnostics.push(l.diag);
    }
    result.eval = Some(info);
    Ok(EvalRun {
        result,
        loose,
        tight,
        diagnostics,
    })
}

/// Applies the inverse of the approximate map → survey transform.
fn survey_to_map(init: &[f64; 3], p: &Point) -> Point {
    let (s, c) = init[2].to_radians().sin_cos();
    let (dx, dy) = (p.x - init[0], p.y - init[1]);
    Point::new(c * dx + s * dy, -s * dx + c * dy, p.z)
}

fn read_crops(
    map: &Path,
    centres: &[Point],
    params: &LooseParams,
    info: &mut EvalInfo,
    progress: &mut impl FnMut(u64, u64),
) -> Result<(Vec<Vec<Point>>, Vec<u64>)> {
    let mut reader = cloud::open(map)?;
    let total = reader.info().file_bytes;
    info.map_bytes = total;
    let crop = crop::loose_crop(reader.as_mut(), centres, params, |b| progress(b, total))?;
    info.map_points = crop.map_points;
    info.skipped_nonfinite = crop.skipped_nonfinite;
    Ok((crop.points, crop.offered))
}

fn locate_one(
    id: &str,
    expected: &Point,
    loose: &[Point],
    crops_dir: Option<&Path>,
    cfg: &EvalConfig,
    pass: u8,
) -> Located {
    let mut detail = TargetDetail {
        id: id.to_string(),
        expected: [expected.x, expected.y, expected.z],
        pass,
        loose_points: loose.len(),
        ..Default::default()
    };
    let fail = |mut detail: TargetDetail, stage: &str, reason: String| {
        detail.failed_stage = Some(stage.into());
        Located {
            status: EstimateStatus::NotFound { reason },
            detail,
            tight: Vec::new(),
            diag: TargetDiagnostics::default(),
        }
    };
    // Hand-made tight crops (the paper's workflow) or the automatic one.
    let (points, ups): (Vec<Point>, Vec<Vector3<f64>>) = match crops_dir {
        Some(dir) => match manual_crop(dir, id) {
            Ok(p) => (p, vec![Vector3::z()]),
            Err(e) => return fail(detail, "tight", e.to_string()),
        },
        None => {
            if loose.is_empty() {
                return fail(
                    detail,
                    "loose",
                    "no map points within the crop radius of the expected position".into(),
                );
            }
            match crop::tight_crop(loose, expected, &cfg.tight) {
                Ok(t) => {
                    detail.ground_normal = Some(t.ground_normal);
                    let up = Vector3::from(t.up);
                    // A fallback "up" in case the ground normal misleads the gates.
                    let mut ups = vec![up];
                    if up != Vector3::z() {
                        ups.push(Vector3::z());
                    }
                    (t.points, ups)
                }
                Err(e) => return fail(detail, "tight", e.to_string()),
            }
        }
    };
    detail.tight_points = points.len();
    locate_with(points, &ups, detail, cfg)
}

/// Step 5 on a tight crop, trying each "up" in turn.
fn locate_with(
    points: Vec<Point>,
    ups: &[Vector3<f64>],
    mut detail: TargetDetail,
    cfg: &EvalConfig,
) -> Located {
    // Paper-style draws and the refit fail on different crops: with the refit
    // every attempt converges to the same planes, so when that one answer misses
    // a gate every attempt does, while plain draws may rarely pass a sparse,
    // noisy crop. Whichever is configured goes first, the other is the fallback;
    // both use the same gates.
    let other = LocateParams {
        refit_iterations: if cfg.locate.refit_iterations > 0 {
            0
        } else {
            1
        },
        ..cfg.locate.clone()
    };
    let variants = [cfg.locate.clone(), other];
    let mut last_err = None;
    for (up, params) in ups
        .iter()
        .flat_map(|u| variants.iter().map(move |v| (*u, v)))
    {
        match locate::locate(&points, Some(up), params) {
            Ok(l) => {
                let axis =
                    Vector3::from(l.plates[0].normal).cross(&Vector3::from(l.plates[1].normal));
                let axis = if axis.z < 0.0 { -axis } else { axis };
                detail.axis = Some(axis.normalize().into());
                detail.up = Some(up.into());
                detail.accepted = l.accepted;
                detail.attempts = l.attempts;
                detail.spread = Some(l.std);
                detail.plate_angle_deg = Some(l.plate_angle_deg);
                detail.failed_stage = None;
                let diag = TargetDiagnostics {
                    plate_normals: Some([l.plates[0].normal, l.plates[1].normal]),
                    corner: Some(l.corner),
                    samples: l.samples,
                    labels: l.labels,
                };
                return Located {
                    status: EstimateStatus::Found(l.corner),
                    detail,
                    tight: points,
                    diag,
                };
            }
            Err(e) => last_err = Some(e),
        }
    }
    let reason = last_err
        .map(|e| format!("localisation failed: {e}"))
        .unwrap_or_default();
    detail.failed_stage = Some("locate".into());
    Located {
        status: EstimateStatus::NotFound { reason },
        detail,
        tight: points,
        diag: TargetDiagnostics::default(),
    }
}

/// The map's vertical from the targets themselves: each target's plates meet
/// along a plumb line, so the mean of those axes is the map's "up" (a tilted
/// map tilts them all alike, while ground slopes differ from place to place).
/// Needs three located targets.
fn consensus_up(found: &[Located]) -> Option<Vector3<f64>> {
    let axes: Vec<Vector3<f64>> = found
        .iter()
        .filter_map(|l| l.detail.axis.map(Vector3::from))
        .collect();
    if axes.len() < 3 {
        return None;
    }
    let sum = axes.iter().fold(Vector3::zeros(), |s, a| s + a);
    Some(sum.normalize())
}

/// Finds `DIR/<id>.<ext>` for any readable cloud extension and reads it.
fn manual_crop(dir: &Path, id: &str) -> Result<Vec<Point>> {
    for ext in ["ply", "pcd", "las", "laz", "xyz", "txt", "csv", "e57"] {
        let p = dir.join(format!("{id}.{ext}"));
        if p.is_file() {
            return cloud::read_all(&p);
        }
    }
    Err(Error::Input(format!(
        "no tight crop {}/{id}.ply|pcd|las|laz|xyz|e57",
        dir.display()
    )))
}
