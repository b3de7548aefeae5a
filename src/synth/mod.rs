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

pub mod distort;
pub mod geometry;
pub mod lidar;

use crate::{Error, Point, Result};
use distort::{DistortParams, Distortion};
use geometry::{Ground, Object, Plate, Prim, Wave, World};
use lidar::{LidarParams, Pose, Road};
use nalgebra::Vector3;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use rayon::prelude::*;

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
    /// The sensor.
    pub lidar: LidarParams,
    /// World → map distortion.
    pub distortion: DistortParams,
    /// 1σ noise added to the surveyed positions (x, y, z), metres.
    pub survey_noise_m: f64,
    /// Geodetic origin (lat°, lon°, ellipsoidal height m) of the local ENU world
    /// frame, for writing the survey in WGS84.
    pub origin_llh: [f64; 3],
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
            lidar: LidarParams::default(),
            distortion: DistortParams::default(),
            survey_noise_m: 0.0,
            origin_llh: [36.3725, 127.3631, 70.0],
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
        if let Some(d) = c.near_target_m
            && !(0.0..=20.0).contains(&d)
        {
            return bad("clutter.near_target_m must be in [0, 20]");
        }
        self.lidar.validate()?;
        self.distortion.validate()
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
    /// Clutter objects.
    pub clutter: Vec<ClutterInfo>,
}

/// A scene before scanning.
struct Scene {
    world: World,
    road: Road,
    targets: Vec<TargetTruth>,
    clutter: Vec<ClutterInfo>,
}

/// Independent random streams, so enabling one feature does not move the rest.
fn stream(seed: u64, what: u64) -> Pcg64 {
    Pcg64::seed_from_u64(geometry::splitmix(seed ^ geometry::splitmix(what)))
}

fn build_ground(p: &SynthParams) -> Ground {
    let mut rng = stream(p.seed, 1);
    let s = p.slope_deg.to_radians().tan();
    let dir = p.slope_dir_deg.to_radians();
    let n = 4;
    let weights: Vec<f64> = (0..n).map(|_| rng.random_range(0.5..1.0)).collect();
    let wsum: f64 = weights.iter().sum();
    let waves = weights
        .iter()
        .map(|w| {
            let lambda = rng.random_range(6.0..25.0);
            let a = rng.random_range(0.0..std::f64::consts::TAU);
            let k = std::f64::consts::TAU / lambda;
            Wave {
                kx: k * a.cos(),
                ky: k * a.sin(),
                amp: p.undulation_m * w / wsum,
                phase: rng.random_range(0.0..std::f64::consts::TAU),
            }
        })
        .filter(|w| w.amp > 0.0)
        .collect();
    Ground {
        z0: 0.0,
        cx: p.spread_m / 2.0,
        cy: 0.0,
        gx: s * dir.cos(),
        gy: s * dir.sin(),
        waves,
    }
}

fn yaw_box(c: Vector3<f64>, size: [f64; 3], yaw: f64) -> Prim {
    Prim::Box {
        c,
        half: Vector3::from(size) / 2.0,
        cs: (yaw.cos(), yaw.sin()),
    }
}

/// The primitives of one L-target with its corner line at (x, y).
fn build_target(
    g: &Ground,
    shape: &TargetShape,
    x: f64,
    y: f64,
    heading: f64,
) -> (Object, [f64; 4]) {
    let gz = g.height(x, y);
    let z0 = gz + shape.plate_bottom_m;
    let z1 = z0 + shape.plate_height_m;
    let post_top = z1 + shape.post_above_m;
    let ant_top = post_top + shape.antenna_height_m;
    let plate = |a: f64| {
        Prim::Plate(Plate {
            x,
            y,
            u: (a.cos(), a.sin()),
            z0,
            w: shape.plate_width_m,
            h: shape.plate_height_m,
            frame: shape.frame_m,
            pitch: shape.mesh_pitch_m,
            hole: shape.mesh_hole_m,
        })
    };
    let mut prims = vec![plate(heading), plate(heading + std::f64::consts::FRAC_PI_2)];
    // The corner post, centred on the corner line, from the ground to above the plates.
    let bottom = gz - 0.05;
    prims.push(yaw_box(
        Vector3::new(x, y, (bottom + post_top) / 2.0),
        [shape.post_m, shape.post_m, post_top - bottom],
        heading,
    ));
    // The stand's three feet on the ground.
    for k in 0..3 {
        let a = heading + std::f64::consts::FRAC_PI_4 + k as f64 * std::f64::consts::TAU / 3.0;
        let (fx, fy) = (x + 0.25 * a.cos(), y + 0.25 * a.sin());
        let fz = g.height(fx, fy);
        prims.push(yaw_box(
            Vector3::new(fx, fy, fz + 0.01),
            [0.5, 0.04, 0.08],
            a,
        ));
    }
    // The GNSS antenna on top of the post.
    prims.push(Prim::VCyl {
        x,
        y,
        r: shape.antenna_radius_m,
        z0: post_top,
        z1: ant_top,
    });
    (Object::new(prims), [gz, z0, z1, ant_top])
}

fn build_scene(p: &SynthParams) -> Scene {
    let ground = build_ground(p);
    let k = p.targets;
    let lead = 30.0;
    let road = Road {
        x0: -lead,
        x1: p.spread_m + lead,
        amp: p.road_curve_m,
        wavelength: (p.spread_m + 2.0 * lead).max(40.0),
    };
    let mut objects = Vec::new();
    let mut targets = Vec::new();
    let mut rng = stream(p.seed, 2);
    let [dmin, dmax] = p.target_distance_m;
    for i in 0..k {
        let tx = if k > 1 {
            p.spread_m * i as f64 / (k - 1) as f64 + rng.random_range(-2.0..2.0)
        } else {
            p.spread_m / 2.0
        };
        let side = if i % 2 == 0 { -1.0 } else { 1.0 };
        let dist = if dmax > dmin {
            rng.random_range(dmin..dmax)
        } else {
            dmin
        };
        // Perpendicular to the road's local heading.
        let h = road.heading(tx);
        let (cx, cy) = (
            tx - side * dist * h.sin(),
            road.y(tx) + side * dist * h.cos(),
        );
        let heading = rng.random_range(0.0..std::f64::consts::TAU);
        let (obj, [gz, z0, z1, ant]) = build_target(&ground, &p.target, cx, cy, heading);
        objects.push(obj);
        let zc = (z0 + z1) / 2.0;
        targets.push(TargetTruth {
            id: (i + 1).to_string(),
            world: [cx, cy, zc],
            survey: SurveyPoint {
                x: cx,
                y: cy,
                z: ant,
                antenna_height: ant - zc,
            },
            map: [0.0; 3],
            heading_deg: heading.to_degrees().rem_euclid(360.0),
            ground_z: gz,
            plate_bottom_z: z0,
            plate_top_z: z1,
            antenna_top_z: ant,
            road_distance_m: dist,
            points: 0,
        });
    }

    let mut clutter = Vec::new();
    let corners: Vec<(f64, f64)> = targets.iter().map(|t| (t.world[0], t.world[1])).collect();
    let free = |x: f64, y: f64, clear: f64| {
        (y - road.y(x)).abs() >= 3.0 && corners.iter().all(|&(a, b)| (x - a).hypot(y - b) >= clear)
    };
    let mut rng = stream(p.seed, 3);
    let place = |rng: &mut Pcg64, clear: f64, lat: (f64, f64)| -> Option<(f64, f64)> {
        for _ in 0..100 {
            let x = rng.random_range(road.x0 + 5.0..road.x1 - 5.0);
            let side = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
            let y = road.y(x) + side * rng.random_range(lat.0..lat.1);
            if free(x, y, clear) {
                return Some((x, y));
            }
        }
        None
    };
    let g = &ground;
    for _ in 0..p.clutter.poles {
        let r = rng.random_range(0.08..0.2);
        let hgt = rng.random_range(4.0..9.0);
        if let Some((x, y)) = place(&mut rng, 4.0 + r, (4.0, 28.0)) {
            let gz = g.height(x, y);
            objects.push(Object::new(vec![Prim::VCyl {
                x,
                y,
                r,
                z0: gz - 0.2,
                z1: gz + hgt,
            }]));
            clutter.push(ClutterInfo {
                kind: "pole".into(),
                x,
                y,
                role: "random".into(),
            });
        }
    }
    for _ in 0..p.clutter.bushes {
        let n = rng.random_range(3..8);
        let params: Vec<(f64, f64, f64, f64)> = (0..n)
            .map(|_| {
                (
                    rng.random_range(-0.8..0.8),
                    rng.random_range(-0.8..0.8),
                    rng.random_range(0.3..0.8),
                    rng.random_range(0.3..0.8),
                )
            })
            .collect();
        if let Some((x, y)) = place(&mut rng, 5.5, (4.0, 28.0)) {
            objects.push(bush(g, x, y, &params));
            clutter.push(ClutterInfo {
                kind: "bush".into(),
                x,
                y,
                role: "random".into(),
            });
        }
    }
    for _ in 0..p.clutter.cars {
        let x = rng.random_range(road.x0 + 10.0..road.x1 - 10.0);
        let side = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
        let h = road.heading(x);
        let (cx, cy) = (x - side * 3.6 * h.sin(), road.y(x) + side * 3.6 * h.cos());
        if corners.iter().all(|&(a, b)| (cx - a).hypot(cy - b) >= 5.0) {
            objects.push(car(g, cx, cy, h));
            clutter.push(ClutterInfo {
                kind: "car".into(),
                x: cx,
                y: cy,
                role: "random".into(),
            });
        }
    }
    if p.clutter.wall {
        let x = road.x0 + 0.35 * road.length();
        let h = road.heading(x);
        let (cx, cy) = (x - 36.0 * h.sin(), road.y(x) + 36.0 * h.cos());
        let len = 40.0;
        let zmin = (-20..=20)
            .map(|i| {
                let s = i as f64 / 40.0 * len;
                g.height(cx + s * h.cos(), cy + s * h.sin())
            })
            .fold(f64::INFINITY, f64::min);
        let top = g.height(cx, cy) + 6.0;
        objects.push(Object::new(vec![yaw_box(
            Vector3::new(cx, cy, (zmin - 0.5 + top) / 2.0),
            [len, 0.3, top - zmin + 0.5],
            h,
        )]));
        clutter.push(ClutterInfo {
            kind: "wall".into(),
            x: cx,
            y: cy,
            role: "random".into(),
        });
    }
    // Hard cases.
    if let Some(d) = p.clutter.near_target_m {
        let t = &targets[0];
        let a = t.heading_deg.to_radians();
        let (x, y) = (t.world[0], t.world[1]);
        // A pole off the L's outer corner ...
        let r = 0.1;
        let ap = a + 1.25 * std::f64::consts::PI;
        let (px, py) = (x + (d + r) * ap.cos(), y + (d + r) * ap.sin());
        let gz = g.height(px, py);
        objects.push(Object::new(vec![Prim::VCyl {
            x: px,
            y: py,
            r,
            z0: gz - 0.2,
            z1: gz + 3.5,
        }]));
        clutter.push(ClutterInfo {
            kind: "pole".into(),
            x: px,
            y: py,
            role: format!("near target 1 ({d} m)"),
        });
        // ... and a flat-faced utility cabinet inside it.
        let ai = a + std::f64::consts::FRAC_PI_4;
        let (bx, by) = (x + (d + 0.25) * ai.cos(), y + (d + 0.25) * ai.sin());
        let gz = g.height(bx, by);
        objects.push(Object::new(vec![yaw_box(
            Vector3::new(bx, by, gz + 0.55),
            [0.5, 0.8, 1.3],
            ai,
        )]));
        clutter.push(ClutterInfo {
            kind: "cabinet".into(),
            x: bx,
            y: by,
            role: format!("near target 1 ({d} m)"),
        });
    }
    if p.clutter.bush_touching {
        let t = &targets[k.min(2) - 1];
        let a = t.heading_deg.to_radians();
        let (u1, u2) = (
            Vector3::new(a.cos(), a.sin(), 0.0),
            Vector3::new(-a.sin(), a.cos(), 0.0),
        );
        let c = Vector3::new(t.world[0], t.world[1], 0.0);
        let r1 = 0.55;
        let s1 = c + u1 * 0.3 - u2 * r1;
        let s2 = c + u1 * 0.75 - u2 * 0.45;
        let gz = t.ground_z;
        let prims = vec![
            Prim::Sphere {
                c: Vector3::new(s1.x, s1.y, t.plate_bottom_z + 0.05),
                r: r1,
                porosity: 0.25,
            },
            Prim::Sphere {
                c: Vector3::new(s2.x, s2.y, gz + 0.4),
                r: 0.45,
                porosity: 0.25,
            },
        ];
        objects.push(Object::new(prims));
        clutter.push(ClutterInfo {
            kind: "bush".into(),
            x: s1.x,
            y: s1.y,
            role: format!("touching target {}", t.id),
        });
    }
    Scene {
        world: World { ground, objects },
        road,
        targets,
        clutter,
    }
}

fn bush(g: &Ground, x: f64, y: f64, spheres: &[(f64, f64, f64, f64)]) -> Object {
    let prims = spheres
        .iter()
        .map(|&(dx, dy, r, f)| {
            let (sx, sy) = (x + dx, y + dy);
            Prim::Sphere {
                c: Vector3::new(sx, sy, g.height(sx, sy) + r * f),
                r,
                porosity: 0.3,
            }
        })
        .collect();
    Object::new(prims)
}

fn car(g: &Ground, x: f64, y: f64, yaw: f64) -> Object {
    let gz = g.height(x, y);
    let (c, s) = (yaw.cos(), yaw.sin());
    let mut prims = vec![
        yaw_box(Vector3::new(x, y, gz + 0.75), [4.5, 1.8, 0.9], yaw),
        yaw_box(
            Vector3::new(x - 0.3 * c, y - 0.3 * s, gz + 1.45),
            [2.4, 1.6, 0.5],
            yaw,
        ),
    ];
    for (a, b) in [(1.4, 0.8), (1.4, -0.8), (-1.4, 0.8), (-1.4, -0.8)] {
        let (wx, wy) = (x + a * c - b * s, y + a * s + b * c);
        prims.push(yaw_box(
            Vector3::new(wx, wy, g.height(wx, wy) + 0.3),
            [0.6, 0.22, 0.6],
            yaw,
        ));
    }
    Object::new(prims)
}

/// Scans cast per parallel batch (at most); any value gives the same output.
const BATCH: u64 = 16;
/// Points held in memory per batch (at most, roughly): 4 M points = 96 MB.
const BATCH_POINTS: u64 = 4_000_000;

/// Generates the scene described by `params`, handing the map (distorted,
/// accumulated scans, in scan order) to `sink` in blocks, and returns the truth.
///
/// Memory is bounded by one batch of scans whatever `params.points` is.
pub fn generate(
    params: &SynthParams,
    sink: &mut dyn FnMut(&[Point]) -> Result<()>,
) -> Result<Truth> {
    params.validate()?;
    let scene = build_scene(params);
    let Scene {
        world,
        road,
        mut targets,
        clutter,
    } = scene;
    let lidar = &params.lidar;
    let k = targets.len();
    let distortion = Distortion {
        params: params.distortion.clone(),
        centre: [
            params.spread_m / 2.0,
            0.0,
            world.ground.height(params.spread_m / 2.0, 0.0),
        ],
        drift_x0: road.x0,
        drift_length: road.length(),
    };
    let warp = distortion.applier();
    let dx_rev = lidar.speed_mps / lidar.rate_hz;
    let usable = (road.length() - dx_rev).max(0.0);

    // Returns per scan, estimated from three probe scans along the road.
    let probe: u64 = [0.25, 0.5, 0.75]
        .par_iter()
        .map(|f| {
            let mut out = Vec::new();
            let mut cnt = vec![0; k];
            lidar::scan(
                &world,
                &road,
                lidar,
                params.seed,
                u64::MAX,
                road.x0 + f * usable,
                &mut out,
                &mut cnt,
            );
            out.len() as u64
        })
        .sum();
    let per_scan = (probe / 3).max(1);
    let n_scans = params.points.div_ceil(per_scan).max(1);
    let spacing = usable / n_scans as f64;
    let station = |i: u64| road.x0 + (i as f64 + 0.5) * spacing;

    let mut total = 0u64;
    let mut counts = vec![0u64; k];
    let mut path = Vec::with_capacity(n_scans.min(1 << 24) as usize);
    let batch_scans = (BATCH_POINTS / per_scan).clamp(1, BATCH);
    let mut first = 0u64;
    while first < n_scans {
        let last = (first + batch_scans).min(n_scans);
        let batch: Vec<(Vec<Point>, Vec<u64>)> = (first..last)
            .into_par_iter()
            .map(|i| {
                let mut out = Vec::with_capacity(per_scan as usize + per_scan as usize / 4);
                let mut cnt = vec![0u64; k];
                lidar::scan(
                    &world,
                    &road,
                    lidar,
                    params.seed,
                    i,
                    station(i),
                    &mut out,
                    &mut cnt,
                );
                for p in out.iter_mut() {
                    *p = warp(p);
                }
                (out, cnt)
            })
            .collect();
        for (i, (pts, cnt)) in (first..last).zip(batch) {
            sink(&pts)?;
            total += pts.len() as u64;
            for (a, b) in counts.iter_mut().zip(cnt) {
                *a += b;
            }
            path.push(lidar::pose_at(&world, &road, lidar, station(i)));
        }
        first = last;
    }

    let mut noise = stream(params.seed, 4);
    for (t, n) in targets.iter_mut().zip(counts) {
        t.points = n;
        let m = warp(&Point::from(t.world));
        t.map = [m.x, m.y, m.z];
        if params.survey_noise_m > 0.0 {
            let s = params.survey_noise_m;
            let mut e = || s * noise.sample::<f64, _>(rand_distr::StandardNormal);
            t.survey.x += e();
            t.survey.y += e();
            t.survey.z += e();
        }
    }
    drop(warp);
    Ok(Truth {
        schema: "mapgauge.synth_truth/1".into(),
        params: params.clone(),
        points: total,
        scans: n_scans,
        targets,
        distortion,
        ground: world.ground.clone(),
        road,
        path,
        clutter,
    })
}

#[cfg(test)]
mod tests;

mod files;
pub use files::{SceneFiles, TruthFile, write_scene};
