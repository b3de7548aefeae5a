//! The `eval` section of result.json: provenance and what the pipeline
//! learned about each target, for reports and debugging.

use crate::pipeline::{Evaluation, TargetRun};
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

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
            targets: ev.targets.iter().map(detail).collect(),
        }
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
        loose_points: t.loose.len(),
        loose_thinned_from: t.loose_thinned_from,
        tight_points: t.tight.len(),
        ground_normal: t.ground_normal.as_ref().map(arr),
        ..Default::default()
    };
    match &t.outcome {
        Ok(f) => {
            d.up = Some(arr(&f.up));
            d.axis = Some(arr(&f.axis));
            d.accepted = f.located.accepted;
            d.attempts = f.located.attempts;
            d.spread = Some(f.located.std);
            d.plate_angle_deg = Some(f.located.plate_angle_deg);
        }
        Err(e) => d.failed_stage = Some(e.stage().into()),
    }
    d
}
