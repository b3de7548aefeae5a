//! Synthetic scenes with known truth: the data that proves the pipeline works.
//!
//! A world (sloped, undulating ground; L-targets built like the paper's; poles,
//! a façade, bushes, cars) is scanned by a simulated 32-beam spinning LiDAR
//! driven along a road, and the accumulated scans are distorted the way a SLAM
//! map is (offset, yaw, tilt, smooth drift). [`generate`] streams the map through
//! a sink batch by batch, so maps of hundreds of millions of points never sit in
//! memory, and returns the [`Truth`]: where every target really is, in the
//! survey (world) frame and in the map frame.
//!
//! Output is deterministic: every ray draws its noise from a hash of
//! (seed, scan, ray), and scans are emitted in order whatever the thread count.

mod decoys;
pub mod distort;
mod drive;
pub mod geometry;
pub mod lidar;
mod obstacles;
mod params;
mod parts;
mod scene;
mod truth;

use crate::{Error, Point, Result};
pub use decoys::DecoyTruth;
use distort::{DistortParams, Distortion};
use drive::{Drive, Driven};
use geometry::{Ground, World};
use lidar::{LidarParams, Pose, Road};
use nalgebra::Vector3;
pub use obstacles::ObstacleParams;
use parts::stream;
use rand::Rng;
use scene::{Scene, build_scene};

pub use params::{BoardShape, SecondPass, SphereShape, TargetShape};
pub use params::{ClutterParams, Layout, SynthParams};
pub use truth::SurveyPoint;
pub use truth::Truth;
pub use truth::{ClutterInfo, TargetTruth};

/// Scans cast per parallel batch (at most); any value gives the same output.
const BATCH: u64 = 16;
/// Points held in memory per batch (at most, roughly): 4 M points = 96 MB.
const BATCH_POINTS: u64 = 4_000_000;

/// What a synthetic point is a return from ([`generate_labelled`]): the
/// oracle a test compares the locator with (planes fitted to a target's
/// plate points alone). The returns of a second pass (`second_pass`, a
/// target mapped twice) carry the labels of what they struck, like the
/// first pass's: the truth's `ghost` says where that copy stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum PointLabel {
    /// The terrain.
    Ground,
    /// A plate of a target.
    Plate {
        /// The target, 0-based as in [`Truth::targets`].
        target: u32,
        /// 0: the plate along the target's heading; 1: the one at 90° to it.
        plate: u8,
    },
    /// Another part of a target (its post, its antenna).
    TargetOther {
        /// The target, 0-based as in [`Truth::targets`].
        target: u32,
    },
    /// Anything else: clutter, decoys, obstacles.
    Other,
}

impl PointLabel {
    /// Most targets a label code can name.
    pub const MAX_TARGETS: usize = (u16::MAX as usize - 16) / 4;

    /// The label as `synth --labels` writes it (`labels.u16`): 0 the ground,
    /// 1 anything else, `16 + 4 k + j` for target k (0-based) with j = 0 and
    /// 1 its plates, 2 its post or antenna. Targets beyond
    /// [`PointLabel::MAX_TARGETS`] share the last code.
    pub fn code(&self) -> u16 {
        let of =
            |k: u32, j: u32| (16 + 4 * (k as usize).min(Self::MAX_TARGETS - 1) + j as usize) as u16;
        match *self {
            PointLabel::Ground => 0,
            PointLabel::Other => 1,
            PointLabel::Plate { target, plate } => of(target, u32::from(plate)),
            PointLabel::TargetOther { target } => of(target, 2),
        }
    }
}

/// Generates the scene described by `params`, handing the map (distorted,
/// accumulated scans, in scan order) to `sink` in blocks, and returns the truth.
///
/// Memory is bounded by one batch of scans whatever `params.points` is.
pub fn generate(
    params: &SynthParams,
    sink: &mut dyn FnMut(&[Point]) -> Result<()>,
) -> Result<Truth> {
    run(params, &mut |p, _| sink(p), false)
}

/// What [`generate_labelled`] hands each block of points to: the points and
/// what each is a return from.
pub(crate) type LabelledSink<'a> = dyn FnMut(&[Point], &[PointLabel]) -> Result<()> + 'a;

/// [`generate`], handing `sink` with each block of points what each point is
/// a return from (the same points, in the same order, as [`generate`]).
pub fn generate_labelled(params: &SynthParams, sink: &mut LabelledSink) -> Result<Truth> {
    run(params, sink, true)
}

fn run(params: &SynthParams, sink: &mut LabelledSink, labelled: bool) -> Result<Truth> {
    params.validate()?;
    let scene = build_scene(params);
    let Scene {
        world,
        road,
        mut targets,
        mut clutter,
        mut decoys,
    } = scene;
    let distortion = distortion_of(params, &world, &road);
    // Scanned points are in the local frame L (see `Truth`).
    let warp = distortion.local_applier();
    // Returns are counted for every object (targets first, then decoys).
    let drive = Drive::plan(params, &world, &road, targets.len(), labelled, &warp);
    let mut driven = drive.driven();
    let seen_first = drive.pass((0, 0), Vector3::zeros(), sink, &mut driven)?;
    // The second pass: the last `share` of the stations driven again (scan
    // indices after the first pass's, so its noise is its own), its points
    // displaced by the drift the loop closure left.
    let sp = &params.second_pass;
    let n_scans = drive.n_scans;
    let seen_again = if sp.is_off() {
        vec![0u64; world.objects.len()]
    } else {
        let again = ((n_scans as f64 * sp.share).round() as u64).min(n_scans);
        let shift = Vector3::from(sp.offset_m);
        drive.pass((n_scans - again, n_scans), shift, sink, &mut driven)?
    };
    let counts: Vec<u64> = seen_first
        .iter()
        .zip(&seen_again)
        .map(|(a, b)| a + b)
        .collect();
    settle_targets(params, &warp, &mut targets, &counts, &seen_again);
    for d in decoys.iter_mut() {
        d.points = counts[d.object];
        let m = warp(&Point::from(d.world));
        d.map = [m.x, m.y, m.z];
    }
    let Driven { total, mut path } = driven;
    // The route as the SLAM software would have written it: in the map.
    let path_in_map: Vec<[f64; 3]> = path
        .iter()
        .map(|q| {
            let m = warp(&Point::new(q.x, q.y, q.z));
            [m.x, m.y, m.z]
        })
        .collect();
    drop(warp);
    let f = params.survey_false_origin_m;
    if f != [0.0; 3] {
        // Added once, at the end, so the map and every draw are as without it.
        add_false_origin(f, &mut targets, &mut decoys, &mut clutter, &mut path);
    }
    Ok(Truth {
        schema: "mapgauge.synth_truth/1".into(),
        params: params.clone(),
        points: total,
        scans: path.len() as u64,
        targets,
        distortion,
        ground: world.ground.clone(),
        road,
        path,
        path_in_map,
        clutter,
        decoys,
    })
}

/// The SLAM distortion of `params` about the middle of the spread, its
/// drift along the road.
pub(super) fn distortion_of(params: &SynthParams, world: &World, road: &Road) -> Distortion {
    Distortion {
        params: params.distortion.clone(),
        centre: [
            params.spread_m / 2.0,
            0.0,
            world.ground.height(params.spread_m / 2.0, 0.0),
        ],
        drift_x0: road.x0,
        drift_length: road.length(),
        survey_origin: params.survey_false_origin_m,
    }
}

/// Fills in what the scan tells of each target (its returns, where the map
/// has it, its second-pass ghost) and the survey's noise, drawn in target
/// order from its own stream.
fn settle_targets(
    params: &SynthParams,
    warp: &impl Fn(&Point) -> Point,
    targets: &mut [TargetTruth],
    counts: &[u64],
    seen_again: &[u64],
) {
    let mut noise = stream(params.seed, 4);
    for ((t, n), again) in targets.iter_mut().zip(counts).zip(seen_again) {
        t.points = *n;
        let m = warp(&Point::from(t.world));
        t.map = [m.x, m.y, m.z];
        if *again > 0 {
            let o = params.second_pass.offset_m;
            t.ghost = Some([m.x + o[0], m.y + o[1], m.z + o[2]]);
            t.ghost_points = *again;
        }
        if params.survey_noise_m > 0.0 {
            let s = params.survey_noise_m;
            let mut e = || s * noise.sample::<f64, _>(rand_distr::StandardNormal);
            t.survey.x += e();
            t.survey.y += e();
            t.survey.z += e();
        }
    }
}

/// The truth's world positions (targets, decoys, clutter) and the route moved
/// by the survey's false origin `f`, as a survey in projected coordinates
/// would give them.
fn add_false_origin(
    f: [f64; 3],
    targets: &mut [TargetTruth],
    decoys: &mut [DecoyTruth],
    clutter: &mut [ClutterInfo],
    path: &mut [Pose],
) {
    let xyz = |v: &mut [f64; 3]| {
        for (a, b) in v.iter_mut().zip(f) {
            *a += b;
        }
    };
    for t in targets.iter_mut() {
        xyz(&mut t.world);
        t.survey.x += f[0];
        t.survey.y += f[1];
        t.survey.z += f[2];
        t.ground_z += f[2];
        t.plate_bottom_z += f[2];
        t.plate_top_z += f[2];
        t.antenna_top_z += f[2];
    }
    for d in decoys.iter_mut() {
        xyz(&mut d.world);
        d.ground_z += f[2];
        d.bottom_z += f[2];
        d.top_z += f[2];
    }
    for c in clutter.iter_mut() {
        c.x += f[0];
        c.y += f[1];
    }
    for q in path.iter_mut() {
        q.x += f[0];
        q.y += f[1];
        q.z += f[2];
    }
}

#[cfg(test)]
mod tests;

mod files;
pub(crate) mod print;
pub use files::SceneFiles;
pub use files::{write_scene, write_scene_labelled};
