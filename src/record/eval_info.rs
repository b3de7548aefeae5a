//! The `eval` section of result.json: provenance and what the pipeline
//! learned about each target, for reports and debugging.

use crate::pipeline::{Evaluation, FrameFound, FrameHow, TargetRun};
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// What the pipeline learned about one target, for reports and debugging.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct TargetDetail {
    /// Target id.
    pub id: String,
    /// Where the target was looked for (map frame).
    pub expected: [f64; 3],
    /// The pass it comes from: 1, or 2 = searched again around the
    /// alignment's prediction (found there, or, when not found, the reason
    /// is from there).
    pub pass: u8,
    /// How far from `expected` it was searched (m, horizontal): the
    /// configured search radius, or less where the other targets placed it
    /// (a dense crop searched after them, a search again near the fit); 0
    /// for a hand-made crop.
    #[serde(default)]
    pub search_radius_m: f64,
    /// Searched after the other targets, only where they place it (its crop
    /// was far denser than theirs), and found there.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub waited: bool,
    /// Found in the coarse levels of a COPC octree (`crop.by_level`) and
    /// located in every level within this radius (m) of where it was found.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub detail_radius_m: Option<f64>,
    /// Points in the loose crop.
    pub loose_points: usize,
    /// Points the map had inside the loose crop, when more than `crop.max_points`
    /// and the crop was thinned to `loose_points` (of a COPC map read with
    /// `crop.by_level`, the points of the octree levels read there).
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
    /// Stage at which it failed (`loose`, `tight`, `locate`, `check`), when it did.
    pub failed_stage: Option<String>,
    /// The located corner in the map's own frame (for a levelled map, the
    /// corner turned back: positions elsewhere are in the levelled frame);
    /// absent for a target not located.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub corner_in_map: Option<[f64; 3]>,
    /// When the tight crop found no target: the object it saw and refused,
    /// and where (the report draws it on the loose crop).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub seen: Option<crate::crop::Seen>,
    /// What the target is (absent: an L).
    #[serde(default, skip_serializing_if = "is_l")]
    pub model: crate::model::ModelKind,
    /// The sphere fitted, for a sphere target located.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sphere: Option<SphereDetail>,
    /// The board fitted, for a checkerboard target located.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub board: Option<BoardDetail>,
}

fn is_l(m: &crate::model::ModelKind) -> bool {
    *m == crate::model::ModelKind::L
}

/// A located checkerboard board as `result.json` keeps it (see
/// [`crate::model::BoardFit`]).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct BoardDetail {
    /// Where the four squares meet (evaluation frame).
    pub centre: [f64; 3],
    /// The face's unit normal.
    pub normal: [f64; 3],
    /// The two boundary lines' directions.
    pub lines: [[f64; 3]; 2],
    /// Points on the board.
    pub points: usize,
    /// The face's extent seen (horizontal first), m; a board on a surface
    /// (lying, on a wall) is read on a square of its side: that side twice.
    pub extent_m: [f64; 2],
    /// Fitted intensity of the dark and the bright squares.
    pub levels: [f64; 2],
    /// Their difference over the intensity noise.
    pub contrast: f64,
    /// The edges' fitted blur, m.
    pub blur_m: f64,
    /// Share of the intensity's variance the pattern explains.
    pub explained: f64,
    /// Share of the points away from the edges with the pattern's colours.
    pub agreement: f64,
    /// RMS distance of the points from the face, m.
    pub plane_rms: f64,
    /// Boards seen in the search.
    pub candidates: usize,
}

/// A located sphere as `result.json` keeps it (see [`crate::model::SphereFit`]).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct SphereDetail {
    /// Centre (evaluation frame).
    pub centre: [f64; 3],
    /// Radius fitted with (half the surveyed diameter), m.
    pub radius: f64,
    /// Radius of the fit with the radius free, m, and its 1-σ.
    pub free_radius: f64,
    /// 1-σ of `free_radius`, m.
    pub free_radius_sigma: f64,
    /// Points on the surface.
    pub inliers: usize,
    /// Their RMS distance from the fitted surface, m.
    pub rms: f64,
    /// Half-angle of the cap seen, the narrower way (degrees).
    pub cap_deg: f64,
    /// The side the surface was seen from (unit, evaluation frame): the
    /// mean direction from the centre to its points.
    #[serde(default)]
    pub seen_from: [f64; 3],
    /// How far the centre was moved back from the fitted one, away from
    /// the side seen, for the range noise's second-order pull (m).
    #[serde(default)]
    pub shift_m: f64,
    /// Spheres of the surveyed size seen in the search.
    pub candidates: usize,
}

/// How the map's frame was found (the `frame` key of the `eval` section).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct FrameInfo {
    /// `survey` (the map is in the survey frame), `init`, `hints` or `detect`.
    pub how: String,
    /// Map → survey `[tx, ty, yaw_deg]` used to place the crops (survey =
    /// R(yaw)·map + t): in the map's own frame for `survey` and `init`, in the
    /// ground-levelled frame for `hints` and `detect`; a rough guess either
    /// way (the alignment is the measured transform).
    pub init: [f64; 3],
    /// Survey z minus map z used to place the crops (m).
    pub dz: f64,
    /// Levelling: p_levelled = origin + R·(p_map − origin); every position in
    /// this file is levelled (identity when the map is level).
    pub levelling: Levelling,
    /// Detection and matching, when the frame was found that way.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub detection: Option<DetectionInfo>,
}

/// The levelling applied to the map.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Levelling {
    /// Total tilt corrected (degrees; 0 = none).
    pub tilt_deg: f64,
    /// Centre of rotation (map frame).
    pub origin: [f64; 3],
    /// Rotation matrix, row-major.
    pub rotation: [[f64; 3]; 3],
    /// The ground's lean from +z of the map (degrees), when enough ground was seen.
    pub ground_tilt_deg: Option<f64>,
    /// Direction the ground rises towards (degrees from +x).
    pub ground_azimuth_deg: Option<f64>,
    /// Share of 2 m ground blocks within 1° of the ground's vertical.
    pub ground_support: Option<f64>,
    /// The targets' mean plumb line: its tilt from the ground-levelled +z
    /// and standard error (degrees), and whether the frame was turned to it.
    pub plumb_tilt_deg: Option<f64>,
    /// Standard error of `plumb_tilt_deg`.
    pub plumb_se_deg: Option<f64>,
    /// Whether the plumb lines were applied.
    pub plumb_applied: bool,
    /// The lean beyond which the plumb lines turn the frame (degrees): 3σ
    /// and 0.5° on their own, 3σ and 0.1° with the surveyed heights, 5σ
    /// and 1° where the map's header declares a coordinate reference
    /// system, any lean where the ground turned the frame already.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub plumb_bar_deg: Option<f64>,
    /// The surveyed heights' lean (degrees): the located corners' heights
    /// less the survey's, as a plane over the site (five or more targets
    /// with surveyed heights).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub heights_tilt_deg: Option<f64>,
    /// Standard error of `heights_tilt_deg` (of the angle, both directions
    /// together: √ of its covariance's trace).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub heights_se_deg: Option<f64>,
    /// Targets that plane was fitted to.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub heights_targets: Option<usize>,
    /// Whether the heights entered the vertical: they agreed with the plumb
    /// lines, and the ground turned the map or its plumb lines lean beyond
    /// 2 standard errors (heights alone never turn a map).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub heights_used: Option<bool>,
    /// Standard error of the vertical the frame was turned to (degrees; of
    /// the angle, both directions together), whenever it was turned: the
    /// ground's 2° alone, or every estimate the plumb step combined.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub vertical_se_deg: Option<f64>,
}

/// What map-wide detection found and matched.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct DetectionInfo {
    /// Target-shaped objects detected.
    pub detections: usize,
    /// Survey ids matched to a detection.
    pub matched: Vec<String>,
    /// RMS horizontal residual of the matches (m).
    pub rms: f64,
    /// Matches of the best different transform (0: none).
    pub runner_up: usize,
    /// Detections matched to no surveyed target (map frame corners, or
    /// centres for spheres).
    pub unmatched: Vec<[f64; 3]>,
    /// Each unmatched detection's model (`l`, `sphere`), in the same order:
    /// an unmatched sphere is a sphere the survey has no row for.
    #[serde(default)]
    pub unmatched_models: Vec<String>,
}

/// Provenance and per-target details of an `eval` run (the `eval` key of result.json).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct EvalInfo {
    /// Map file as given.
    pub map: String,
    /// Map size in bytes.
    pub map_bytes: u64,
    /// Finite points in the map when a pass read all of it; else the most
    /// any pass read (`reads` says what each pass read).
    pub map_points: u64,
    /// Points skipped as NaN / infinite.
    pub skipped_nonfinite: u64,
    /// Survey file as given.
    pub survey: String,
    /// Per target.
    pub targets: Vec<TargetDetail>,
    /// How the map's frame was found.
    #[serde(default)]
    pub frame: FrameInfo,
    /// What each pass over the map read (points, bytes), in order: the
    /// ground pass, detection's when it ran, the crops, a second pass.
    #[serde(default)]
    pub reads: Vec<crate::cloud::PassRead>,
    /// How close two copies of a target may be and still be reported
    /// `ambiguous` in this map (its plates' thickness sets it); closer
    /// copies blend into one corner unflagged. Absent with fewer than three
    /// targets located.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub doubling: Option<crate::locate::DoublingLimit>,
    /// Every parameter of the run, keyed as `eval --print-config` prints
    /// them (a setting left unset is `null`), so a result without its
    /// report still says what produced it. Absent in files of older
    /// versions.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub config: Option<serde_json::Value>,
}

impl EvalInfo {
    /// The `eval` section of an evaluation: what was read and what happened to
    /// each target. `survey` names the survey as the user gave it.
    pub fn from_evaluation(ev: &Evaluation, survey: &str) -> EvalInfo {
        EvalInfo {
            map: ev.map.name.clone(),
            map_bytes: ev.map.bytes,
            map_points: ev.map.points,
            skipped_nonfinite: ev.map.skipped_nonfinite,
            survey: survey.to_string(),
            targets: ev
                .targets
                .iter()
                .map(|t| {
                    let mut d = detail(t);
                    // Always there, so a user never has to know whether
                    // the map was levelled to find a target in it.
                    let l = &ev.frame.levelling;
                    d.corner_in_map = t.corner().map(|c| {
                        let p = if l.is_identity() { c } else { l.invert(&c) };
                        [p.x, p.y, p.z]
                    });
                    d
                })
                .collect(),
            frame: frame_info(&ev.frame),
            reads: ev.reads.clone(),
            doubling: ev.doubling,
            config: serde_json::to_value(&ev.config).ok(),
        }
    }
}

fn frame_info(f: &FrameFound) -> FrameInfo {
    let r = f.levelling.rotation.matrix();
    let detection = match &f.how {
        FrameHow::Detected {
            detections,
            matched,
            rms,
            runner_up,
        } => Some(DetectionInfo {
            detections: *detections,
            matched: matched.iter().map(|m| m.0.clone()).collect(),
            rms: *rms,
            runner_up: *runner_up,
            unmatched: f
                .unmatched
                .iter()
                .map(|d| [d.corner_map.x, d.corner_map.y, d.corner_map.z])
                .collect(),
            unmatched_models: f.unmatched.iter().map(|d| d.model.name().into()).collect(),
        }),
        _ => None,
    };
    let heights = f.plumb.as_ref().and_then(|p| p.heights.as_ref());
    FrameInfo {
        how: f.how.name().into(),
        init: f.init.into(),
        dz: f.dz,
        levelling: Levelling {
            tilt_deg: f.levelling.tilt_deg(),
            origin: [
                f.levelling.origin.x,
                f.levelling.origin.y,
                f.levelling.origin.z,
            ],
            rotation: [
                [r[(0, 0)], r[(0, 1)], r[(0, 2)]],
                [r[(1, 0)], r[(1, 1)], r[(1, 2)]],
                [r[(2, 0)], r[(2, 1)], r[(2, 2)]],
            ],
            ground_tilt_deg: f.ground.as_ref().map(|g| g.tilt_deg),
            ground_azimuth_deg: f.ground.as_ref().map(|g| g.azimuth_deg),
            ground_support: f.ground.as_ref().map(|g| g.support),
            plumb_tilt_deg: f.plumb.as_ref().map(|p| p.tilt_deg),
            plumb_se_deg: f.plumb.as_ref().map(|p| p.se_deg),
            plumb_applied: f.plumb.as_ref().is_some_and(|p| p.applied),
            plumb_bar_deg: f.plumb.as_ref().map(|p| p.bar_deg),
            heights_tilt_deg: heights.map(|h| h.tilt_deg),
            heights_se_deg: heights.map(|h| h.se_deg),
            heights_targets: heights.map(|h| h.targets),
            heights_used: heights.map(|h| h.used),
            vertical_se_deg: (!f.levelling.is_identity())
                .then(|| crate::pipeline::vertical_se_deg(f.plumb.as_ref())),
        },
        detection,
    }
}

fn arr(v: &Vector3<f64>) -> [f64; 3] {
    [v.x, v.y, v.z]
}

fn detail(t: &TargetRun) -> TargetDetail {
    let mut d = TargetDetail {
        id: t.id.clone(),
        expected: [t.expected.x, t.expected.y, t.expected.z],
        pass: t.pass as u8,
        search_radius_m: t.search_radius,
        waited: t.waited,
        detail_radius_m: (t.detail_radius > 0.0).then_some(t.detail_radius),
        loose_points: t.loose.len(),
        loose_thinned_from: t.loose_thinned_from,
        tight_points: t.tight.len(),
        ground_normal: t.ground_normal.as_ref().map(arr),
        model: t.model,
        ..Default::default()
    };
    match &t.outcome {
        Ok(f) => {
            d.up = Some(arr(&f.up));
            d.axis = Some(arr(&f.axis));
            d.accepted = f.located.accepted;
            d.attempts = f.located.attempts;
            d.spread = Some(f.located.std);
            if f.is_l() {
                d.plate_angle_deg = Some(f.located.plate_angle_deg);
            }
            d.sphere = f.sphere.as_ref().map(|s| SphereDetail {
                centre: [s.centre.x, s.centre.y, s.centre.z],
                radius: s.radius,
                free_radius: s.free_radius,
                free_radius_sigma: s.free_radius_sigma,
                inliers: s.inliers,
                rms: s.rms,
                cap_deg: s.cap_deg,
                seen_from: s.seen_from,
                shift_m: s.shift_m,
                candidates: s.candidates,
            });
            d.board = f.board.as_ref().map(|b| BoardDetail {
                centre: [b.centre.x, b.centre.y, b.centre.z],
                normal: b.normal,
                lines: b.lines,
                points: b.points,
                extent_m: b.extent_m,
                levels: b.levels,
                contrast: b.contrast,
                blur_m: b.blur_m,
                explained: b.explained,
                agreement: b.agreement,
                plane_rms: b.plane_rms,
                candidates: b.candidates,
            });
        }
        Err(e) => {
            d.failed_stage = Some(e.stage().into());
            if let crate::pipeline::Failure::Tight(crate::crop::TightError::NoTargetShape {
                seen: Some(s),
                ..
            }) = e
            {
                d.seen = Some(s.clone());
            }
        }
    }
    d
}
