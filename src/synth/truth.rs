//! What a synthetic scene really is: every target's corner in the survey
//! and map frames, the clutter placed, the survey file's points.

use super::*;

/// A surveyed target position as a GNSS rover on the antenna records it.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SurveyPoint {
    /// Easting (local), metres.
    pub x: f64,
    /// Northing (local), metres.
    pub y: f64,
    /// Height of the antenna top, metres.
    pub z: f64,
    /// Antenna top above the target's reference height (plate centre), metres.
    pub antenna_height: f64,
}

/// Ground truth of one target.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TargetTruth {
    /// "1".."K".
    pub id: String,
    /// True corner in the world (= survey) frame: (x, y) where the plate planes
    /// meet, z the plates' centre height.
    pub world: [f64; 3],
    /// What the survey file says (world + survey noise; z is the antenna top).
    pub survey: SurveyPoint,
    /// True corner in the map frame: the distortion applied to `world`.
    pub map: [f64; 3],
    /// Direction of plate 1 from the corner, degrees from +x; plate 2 is +90°.
    pub heading_deg: f64,
    /// Ground height at the corner.
    pub ground_z: f64,
    /// Plates' bottom edge height.
    pub plate_bottom_z: f64,
    /// Plates' top edge height.
    pub plate_top_z: f64,
    /// Antenna top height.
    pub antenna_top_z: f64,
    /// Horizontal distance from the road centre line, metres.
    pub road_distance_m: f64,
    /// Map points that are returns from this target (plates, post, stand, antenna).
    pub points: u64,
    /// Where the second pass (`second_pass`) mapped this target again, map
    /// frame, when it saw it: the copy `map` + `offset_m`. Absent otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ghost: Option<[f64; 3]>,
    /// Of `points`, the returns of the second pass (the copy's).
    #[serde(default, skip_serializing_if = "is_zero_u64")]
    pub ghost_points: u64,
    /// What the target is; an L when absent. For a sphere, `world` is its
    /// centre, the survey gives the centre, the plate heights are the
    /// sphere's bottom and top and `antenna_top_z` its top.
    #[serde(default, skip_serializing_if = "is_l")]
    pub model: crate::model::ModelKind,
    /// Its size when not an L (a sphere's diameter, m).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub size: Option<f64>,
}

fn is_l(m: &crate::model::ModelKind) -> bool {
    *m == crate::model::ModelKind::L
}

fn is_zero_u64(v: &u64) -> bool {
    *v == 0
}

/// A clutter object, for inspection.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ClutterInfo {
    /// "pole", "wall", "bush", "car", "cabinet".
    pub kind: String,
    /// Centre x, world frame.
    pub x: f64,
    /// Centre y.
    pub y: f64,
    /// Why it is there: "random" or the hard case it implements.
    pub role: String,
}

/// Everything known about a generated scene.
///
/// Frames: the scene is built in a local frame L; the world (= survey) frame
/// is L + `params.survey_false_origin_m` (F, zero by default). Positions carry
/// F: `targets[].world`, `.survey` (x, y, z), `.ground_z`, `.plate_bottom_z`,
/// `.plate_top_z`, `.antenna_top_z`; `decoys[].world`, `.ground_z`,
/// `.bottom_z`, `.top_z`; `clutter[].x`, `.y`; `path[].x`, `.y`, `.z`. The
/// scene's model parameters stay in L: `ground` (evaluate `Ground::height` at
/// world − F), `road`, `distortion.centre` and `distortion.drift_x0`.
/// `distortion.survey_origin` = F, so `distortion.apply(world)` = map holds for
/// every position above. Map-frame positions (`map`) never include F.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Truth {
    /// Schema tag of this JSON.
    pub schema: String,
    /// The parameters used.
    pub params: SynthParams,
    /// Points emitted to the sink.
    pub points: u64,
    /// Scans (revolutions) accumulated.
    pub scans: u64,
    /// The targets, in id order.
    pub targets: Vec<TargetTruth>,
    /// The world → map transform.
    pub distortion: Distortion,
    /// The terrain.
    pub ground: Ground,
    /// The road driven.
    pub road: Road,
    /// Sensor pose at the start of each scan, world frame, in emission order.
    pub path: Vec<Pose>,
    /// The sensor's positions in the map frame, pose by pose (written as the
    /// scene's `trajectory.txt`, not into truth.json).
    #[serde(skip)]
    pub path_in_map: Vec<[f64; 3]>,
    /// Clutter objects.
    pub clutter: Vec<ClutterInfo>,
    /// Scene-wide decoys (`clutter.decoys`), in placement order; absent from
    /// truth.json when there are none.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub decoys: Vec<DecoyTruth>,
}
