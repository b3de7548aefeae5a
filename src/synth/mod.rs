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
mod scene;

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

/// The build of one L-target (defaults: the paper's hardware).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TargetShape {
    /// Plate width (horizontal), metres.
    pub plate_width_m: f64,
    /// Plate height, metres.
    pub plate_height_m: f64,
    /// Height of the plates' bottom edge above the ground at the corner, metres.
    pub plate_bottom_m: f64,
    /// Side of the square corner post (aluminium extrusion), metres.
    pub post_m: f64,
    /// Post length above the plates' top edge, below the antenna, metres.
    pub post_above_m: f64,
    /// GNSS antenna radius, metres.
    pub antenna_radius_m: f64,
    /// GNSS antenna height, metres.
    pub antenna_height_m: f64,
    /// Grill mesh hole pitch, metres.
    pub mesh_pitch_m: f64,
    /// Grill mesh hole side (pitch 0.04, hole 0.028 → about half open), metres.
    pub mesh_hole_m: f64,
    /// Solid frame around the mesh, metres.
    pub frame_m: f64,
}

impl Default for TargetShape {
    fn default() -> Self {
        TargetShape {
            plate_width_m: 0.6,
            plate_height_m: 0.6,
            plate_bottom_m: 0.8,
            post_m: 0.03,
            post_above_m: 0.05,
            antenna_radius_m: 0.08,
            antenna_height_m: 0.07,
            mesh_pitch_m: 0.04,
            mesh_hole_m: 0.028,
            frame_m: 0.02,
        }
    }
}

/// Clutter, and the hard cases that defeat a naive locator.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ClutterParams {
    /// Number of poles placed at random (at least 4 m from any target).
    pub poles: usize,
    /// Number of bushes placed at random.
    pub bushes: usize,
    /// Number of parked cars beside the road.
    pub cars: usize,
    /// A building façade (40 m long, 6 m high) 36 m off the road.
    pub wall: bool,
    /// Hard case: a pole and a utility cabinet this far (nearest surface, metres)
    /// from target 1's corner. `None`: off.
    pub near_target_m: Option<f64>,
    /// Hard case: a bush touching a plate of target 2 (target 1 when K = 1).
    pub bush_touching: bool,
    /// Scene-wide decoys (issue 15): objects a map-wide detector could take
    /// for a target, placed along the road at the targets' distances from it
    /// (`target_distance_m`), every part at least 4 m from every target's
    /// corner, off the road, and out of the 45° cone between each target and
    /// the road so none hides a target. In turn: a building corner, an
    /// L-shaped board of 0.9–1.2 m arms, a utility cabinet, a small L of
    /// 0.35–0.45 m arms, a pallet stack (see [`DecoyTruth`]). They draw from
    /// their own random stream, so targets and other clutter do not move;
    /// when the scene has no room for one it is left out (truth.json lists
    /// those placed). 0 (default): none, and truth.json has no `decoys`.
    ///
    /// ```toml
    /// [clutter]
    /// decoys = 10
    /// ```
    #[serde(skip_serializing_if = "is_zero")]
    pub decoys: usize,
}

fn is_zero(n: &usize) -> bool {
    *n == 0
}

fn is_origin(v: &[f64; 3]) -> bool {
    *v == [0.0; 3]
}

/// How the targets are laid out.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Layout {
    /// Spread along the road, alternating sides, at `target_distance_m`.
    #[default]
    Road,
    /// Four targets at the corners of a square of side `spread_m` (16–60 m),
    /// its sides parallel to the road's ends, centred on the road's middle so
    /// the road passes through it; every L opens towards the centre (heading =
    /// direction from the centre + 135°), so the layout maps onto itself under
    /// a 90° rotation about the centre: an ambiguous layout for frame matching.
    /// Corner k (id k + 1) is at direction 45° + 90°·k from the centre. For
    /// equal corner heights too, set `slope_deg = 0` and `undulation_m = 0`.
    /// Corners lie side/2 (± the road's curve) off the road, so a side of up
    /// to ~30 m keeps them at the targets' usual distances; a 60 m square
    /// puts them ~30 m off, with about a quarter of the returns. Ignores
    /// `target_distance_m`.
    Square,
}

impl Layout {
    fn is_road(&self) -> bool {
        *self == Layout::Road
    }
}

impl Default for ClutterParams {
    fn default() -> Self {
        ClutterParams {
            poles: 8,
            bushes: 6,
            cars: 2,
            wall: true,
            near_target_m: None,
            bush_touching: false,
            decoys: 0,
        }
    }
}

/// Everything that defines a synthetic scene. Same parameters → same bytes.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SynthParams {
    /// Seed of every random choice.
    pub seed: u64,
    /// Approximate number of map points (sets the number of scans).
    pub points: u64,
    /// Number of targets K (ids "1".."K").
    pub targets: usize,
    /// Distance along the road over which the targets are spread, metres.
    pub spread_m: f64,
    /// Range of the targets' lateral distance from the road, metres.
    pub target_distance_m: [f64; 2],
    /// The target build.
    pub target: TargetShape,
    /// Ground slope, degrees.
    pub slope_deg: f64,
    /// Direction of steepest ascent, degrees from +x.
    pub slope_dir_deg: f64,
    /// Undulation: bound on the bumps' amplitude, metres (wavelengths 6–25 m).
    pub undulation_m: f64,
    /// Sideways amplitude of the road's curve, metres.
    pub road_curve_m: f64,
    /// Clutter and hard cases.
    pub clutter: ClutterParams,
    /// Obstacles around target 1 (issue 16's field cases); all off by default
    /// and then left out of truth.json, so existing scenes keep their bytes.
    #[serde(skip_serializing_if = "ObstacleParams::is_off")]
    pub obstacles: ObstacleParams,
    /// The sensor.
    pub lidar: LidarParams,
    /// World → map distortion.
    pub distortion: DistortParams,
    /// 1σ noise added to the surveyed positions (x, y, z), metres.
    pub survey_noise_m: f64,
    /// Geodetic origin (lat°, lon°, ellipsoidal height m) of the local ENU world
    /// frame, for writing the survey in WGS84.
    pub origin_llh: [f64; 3],
    /// False origin of the survey frame, metres: the scene is built in a local
    /// frame L and the survey (world) frame is L + this, so [352000, 4026000, 0]
    /// gives a UTM-size survey while the map stays where it was. It is added
    /// to survey.csv and to every position in truth.json except the scene's
    /// model parameters (see [`Truth`]); survey_llh.csv is unchanged (it is
    /// the same physical points). Default [0, 0, 0], then left out of the
    /// printed config and truth.json.
    ///
    /// ```toml
    /// survey_false_origin_m = [352000.0, 4026000.0, 0.0]
    /// ```
    #[serde(skip_serializing_if = "is_origin")]
    pub survey_false_origin_m: [f64; 3],
    /// Target layout: "road" (default) or "square" (see [`Layout`]).
    ///
    /// ```toml
    /// layout = "square"
    /// targets = 4
    /// spread_m = 30.0
    /// slope_deg = 0.0
    /// undulation_m = 0.0
    /// ```
    #[serde(skip_serializing_if = "Layout::is_road")]
    pub layout: Layout,
    /// A second pass over the end of the road that the map did not merge
    /// with the first (a loop closed badly): every object there is mapped
    /// twice. Off by default, and then absent from the printed config and
    /// truth.json.
    ///
    /// ```toml
    /// [second_pass]
    /// share = 0.5             # the last half of the road is driven again
    /// offset_m = [0.05, -0.04, 0.0]
    /// ```
    #[serde(skip_serializing_if = "SecondPass::is_off")]
    pub second_pass: SecondPass,
}

/// The end of the road driven again, its points landing `offset_m` from
/// the first pass's: the seam a badly closed loop leaves (issue 30).
#[derive(Debug, Clone, PartialEq, Default, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SecondPass {
    /// Share of the road, from its end, driven a second time (0: none).
    pub share: f64,
    /// Displacement of the second pass's points from the first's, map
    /// frame, metres: the drift the loop closure left.
    pub offset_m: [f64; 3],
}

impl SecondPass {
    /// No second pass (the truth file then omits the section).
    pub fn is_off(&self) -> bool {
        self.share == 0.0
    }
}

impl Default for SynthParams {
    fn default() -> Self {
        SynthParams {
            seed: 1,
            points: 2_000_000,
            targets: 5,
            spread_m: 100.0,
            target_distance_m: [5.0, 15.0],
            target: TargetShape::default(),
            slope_deg: 1.5,
            slope_dir_deg: 30.0,
            undulation_m: 0.08,
            road_curve_m: 3.0,
            clutter: ClutterParams::default(),
            obstacles: ObstacleParams::default(),
            lidar: LidarParams::default(),
            distortion: DistortParams::default(),
            survey_noise_m: 0.0,
            origin_llh: [36.3725, 127.3631, 70.0],
            survey_false_origin_m: [0.0; 3],
            layout: Layout::Road,
            second_pass: SecondPass::default(),
        }
    }
}

impl SynthParams {
    /// Checks every value, naming the first bad one.
    pub fn validate(&self) -> Result<()> {
        let bad = |m: &str| Err(Error::Param(m.to_string()));
        if self.points == 0 || self.points > 100_000_000_000 {
            return bad("points must be in 1..=1e11");
        }
        if self.targets == 0 || self.targets > 1000 {
            return bad("targets must be in 1..=1000");
        }
        if !(self.spread_m >= 0.0 && self.spread_m <= 10_000.0) {
            return bad("spread_m must be in [0, 10000]");
        }
        let [d0, d1] = self.target_distance_m;
        if !(d0 >= 2.0 && d1 >= d0 && d1 <= 90.0) {
            return bad("target_distance_m = [min, max] with 2 <= min <= max <= 90");
        }
        if !(self.slope_deg.abs() <= 20.0 && self.slope_dir_deg.is_finite()) {
            return bad("|slope_deg| must be <= 20");
        }
        if !(self.undulation_m >= 0.0 && self.undulation_m <= 2.0) {
            return bad("undulation_m must be in [0, 2]");
        }
        if !self.road_curve_m.is_finite() || self.road_curve_m.abs() > 50.0 {
            return bad("|road_curve_m| must be <= 50");
        }
        if !(self.survey_noise_m >= 0.0 && self.survey_noise_m <= 1.0) {
            return bad("survey_noise_m must be in [0, 1]");
        }
        if self.survey_false_origin_m.iter().any(|v| !(v.abs() <= 1e8)) {
            return bad("survey_false_origin_m values must be finite, |v| <= 1e8");
        }
        if self.layout == Layout::Square {
            if self.targets != 4 {
                return bad("layout = \"square\" needs targets = 4");
            }
            if !(10.0..=60.0).contains(&self.spread_m) {
                return bad(
                    "layout = \"square\": spread_m (the square's side) must be in [10, 60]",
                );
            }
        }
        let [lat, lon, hgt] = self.origin_llh;
        if !(lat.abs() <= 89.0 && lon.abs() <= 180.0 && hgt.abs() <= 10_000.0) {
            return bad("origin_llh = [lat, lon, h] with |lat| <= 89, |lon| <= 180, |h| <= 10000");
        }
        let t = &self.target;
        let pos = [
            t.plate_width_m,
            t.plate_height_m,
            t.post_m,
            t.antenna_radius_m,
            t.antenna_height_m,
            t.mesh_pitch_m,
        ];
        if pos.iter().any(|v| !(*v > 0.0 && *v <= 10.0)) {
            return bad("target sizes must be in (0, 10] m");
        }
        if !(t.plate_bottom_m >= 0.0 && t.plate_bottom_m <= 10.0 && t.post_above_m >= 0.0) {
            return bad("target.plate_bottom_m must be in [0, 10], post_above_m >= 0");
        }
        if !(t.mesh_hole_m >= 0.0 && t.mesh_hole_m < t.mesh_pitch_m) {
            return bad("target.mesh_hole_m must be in [0, mesh_pitch_m)");
        }
        if !(t.frame_m >= 0.0 && 2.0 * t.frame_m <= t.plate_width_m.min(t.plate_height_m)) {
            return bad("target.frame_m must be in [0, plate size / 2]");
        }
        let c = &self.clutter;
        if c.poles > 10_000 || c.bushes > 10_000 || c.cars > 10_000 {
            return bad("clutter counts must be <= 10000");
        }
        // Placement checks every decoy against those placed: quadratic.
        if c.decoys > 200 {
            return bad("clutter.decoys must be <= 200");
        }
        if let Some(d) = c.near_target_m
            && !(0.0..=20.0).contains(&d)
        {
            return bad("clutter.near_target_m must be in [0, 20]");
        }
        let sp = &self.second_pass;
        if !(0.0..=1.0).contains(&sp.share) || sp.offset_m.iter().any(|v| !(v.abs() <= 10.0)) {
            return bad("second_pass: share in [0, 1], |offset_m| <= 10 m");
        }
        self.obstacles.validate()?;
        self.lidar.validate()?;
        self.distortion.validate()?;
        if self.layout == Layout::Square {
            scene::square_layout(self, &scene::road_of(self))
                .map(|_| ())
                .map_err(Error::Param)?;
        }
        Ok(())
    }
}

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
