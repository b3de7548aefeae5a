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
pub mod geometry;
pub mod lidar;
mod obstacles;
mod params;
mod scene;
mod truth;

use crate::{Error, Point, Result};
pub use decoys::DecoyTruth;
use distort::{DistortParams, Distortion};
use geometry::Ground;
use lidar::{LidarParams, Pose, Road};
use nalgebra::Vector3;
pub use obstacles::ObstacleParams;
use rand::Rng;
use rayon::prelude::*;
use scene::{Scene, build_scene, stream};

pub use params::{ClutterParams, Layout, SecondPass, SynthParams, TargetShape};
pub use truth::{ClutterInfo, SurveyPoint, TargetTruth, Truth};

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
pub type LabelledSink<'a> = dyn FnMut(&[Point], &[PointLabel]) -> Result<()> + 'a;

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
    let lidar = &params.lidar;
    let distortion = Distortion {
        params: params.distortion.clone(),
        centre: [
            params.spread_m / 2.0,
            0.0,
            world.ground.height(params.spread_m / 2.0, 0.0),
        ],
        drift_x0: road.x0,
        drift_length: road.length(),
        survey_origin: params.survey_false_origin_m,
    };
    // Scanned points are in the local frame L (see `Truth`).
    let warp = distortion.local_applier();
    // Returns are counted for every object (targets first, then decoys).
    let n_obj = world.objects.len();
    let n_targets = targets.len();
    let dx_rev = lidar.speed_mps / lidar.rate_hz;
    let usable = (road.length() - dx_rev).max(0.0);

    // Returns per scan, estimated from three probe scans along the road.
    let probe: u64 = [0.25, 0.5, 0.75]
        .par_iter()
        .map(|f| {
            let mut out = Vec::new();
            let mut cnt = vec![0; n_obj];
            lidar::scan(
                &world,
                &road,
                lidar,
                params.seed,
                u64::MAX,
                road.x0 + f * usable,
                &mut out,
                &mut cnt,
                None,
            );
            out.len() as u64
        })
        .sum();
    let per_scan = (probe / 3).max(1);
    let n_scans = params.points.div_ceil(per_scan).max(1);
    let spacing = usable / n_scans as f64;
    let station = |i: u64| road.x0 + (i as f64 + 0.5) * spacing;

    let mut total = 0u64;
    let mut path = Vec::with_capacity(n_scans.min(1 << 24) as usize);
    let batch_scans = (BATCH_POINTS / per_scan).clamp(1, BATCH);
    // One pass over stations `from..n_scans`: scan `index_base + i` at
    // station i, its points warped and then displaced by `shift`, handed
    // to the sink in scan order; returns per object the returns it saw.
    let mut drive = |from: u64, index_base: u64, shift: Vector3<f64>| -> Result<Vec<u64>> {
        let mut seen = vec![0u64; n_obj];
        let mut first = from;
        while first < n_scans {
            let last = (first + batch_scans).min(n_scans);
            let batch: Vec<(Vec<Point>, Vec<PointLabel>, Vec<u64>)> = (first..last)
                .into_par_iter()
                .map(|i| {
                    let mut out = Vec::with_capacity(per_scan as usize + per_scan as usize / 4);
                    let mut cnt = vec![0u64; n_obj];
                    let mut hits = Vec::new();
                    lidar::scan(
                        &world,
                        &road,
                        lidar,
                        params.seed,
                        index_base + i,
                        station(i),
                        &mut out,
                        &mut cnt,
                        labelled.then_some(&mut hits),
                    );
                    // World objects hold the targets first (index = target).
                    let labels = hits
                        .into_iter()
                        .map(|(object, prim)| match object {
                            None => PointLabel::Ground,
                            Some(o) if (o as usize) < n_targets => match prim {
                                0 | 1 => PointLabel::Plate {
                                    target: o,
                                    plate: prim as u8,
                                },
                                _ => PointLabel::TargetOther { target: o },
                            },
                            Some(_) => PointLabel::Other,
                        })
                        .collect();
                    for p in out.iter_mut() {
                        *p = warp(p);
                    }
                    if shift != Vector3::zeros() {
                        for p in out.iter_mut() {
                            *p += shift;
                        }
                    }
                    (out, labels, cnt)
                })
                .collect();
            for (i, (pts, labels, cnt)) in (first..last).zip(batch) {
                sink(&pts, &labels)?;
                total += pts.len() as u64;
                for (a, b) in seen.iter_mut().zip(cnt) {
                    *a += b;
                }
                path.push(lidar::pose_at(&world, &road, lidar, station(i)));
            }
            first = last;
        }
        Ok(seen)
    };
    let seen_first = drive(0, 0, Vector3::zeros())?;
    // The second pass: the last `share` of the stations driven again (scan
    // indices after the first pass's, so its noise is its own), its points
    // displaced by the drift the loop closure left.
    let sp = &params.second_pass;
    let seen_again = if sp.is_off() {
        vec![0u64; n_obj]
    } else {
        let again = ((n_scans as f64 * sp.share).round() as u64).min(n_scans);
        drive(n_scans - again, n_scans, Vector3::from(sp.offset_m))?
    };
    drop(drive);
    let counts: Vec<u64> = seen_first
        .iter()
        .zip(&seen_again)
        .map(|(a, b)| a + b)
        .collect();

    let mut noise = stream(params.seed, 4);
    for ((t, n), again) in targets.iter_mut().zip(&counts).zip(&seen_again) {
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
    for d in decoys.iter_mut() {
        d.points = counts[d.object];
        let m = warp(&Point::from(d.world));
        d.map = [m.x, m.y, m.z];
    }
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

#[cfg(test)]
mod tests;

mod files;
pub use files::{SceneFiles, TruthFile, write_scene, write_scene_labelled};
