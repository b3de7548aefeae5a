//! Scene-wide decoys (issue 15): objects shaped partly like a target, placed
//! along the road where targets stand, so a map-wide detector has to reject
//! them by size. Off by default (`ClutterParams::decoys`); they draw from
//! their own random stream and are added after every other object, so the
//! targets and the rest of the clutter stay where they were.

use super::geometry::{Ground, Object};
use super::lidar::Road;
use super::parts::{box_on_ground, l_plate, stream, yaw_box};
use super::{ClutterInfo, SynthParams, TargetTruth};
use nalgebra::Vector3;
use rand::Rng;
use rand_pcg::Pcg64;
use std::f64::consts::{FRAC_PI_2, TAU};

/// Ground truth of one scene-wide decoy (see `Truth` for which fields carry
/// the survey's false origin).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct DecoyTruth {
    /// "building_corner" (two solid walls 3–8 m long, 3–6 m tall, 0.3 m
    /// thick), "l_board" (two plates with 0.9–1.2 m arms on the target's
    /// height band and a corner post), "cabinet" (0.6 × 0.4 × 1.2 m box),
    /// "small_l" (as l_board, 0.35–0.45 m arms), "pallet" (1.2 × 0.8 × 1.0 m box).
    pub kind: String,
    /// Reference point, world (survey) frame. L shapes: (x, y) on the corner
    /// line where the arms' outer faces meet (boards: where the plate planes
    /// meet, as for a target); z the plates' centre height (boards) or half
    /// the height above the ground (building corner). Boxes: the footprint's
    /// centre, z half the height above the ground.
    pub world: [f64; 3],
    /// The reference point in the map frame.
    pub map: [f64; 3],
    /// L shapes: direction of arm 1 from the corner, arm 2 at +90° (a
    /// target's `heading_deg` convention); boxes: direction of the long side.
    /// Degrees from +x, in [0, 360).
    pub heading_deg: f64,
    /// L shapes: [arm 1, arm 2, height]; boxes: [long side, short side,
    /// height], metres.
    pub size_m: [f64; 3],
    /// Boards: plates meshed like a target's grill (true) or solid; absent
    /// for the other kinds.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub grill: Option<bool>,
    /// Ground height at the reference point.
    pub ground_z: f64,
    /// Bottom of the shape: the plates' bottom edge (boards), else `ground_z`.
    pub bottom_z: f64,
    /// Top of the shape.
    pub top_z: f64,
    /// Horizontal distance of the reference point from the road centre line.
    pub road_distance_m: f64,
    /// Map points that are returns from it.
    pub points: u64,
    /// Index of its object in the world (returns are counted per object).
    #[serde(skip)]
    pub(super) object: usize,
}

/// Nearest distance (metres) any part of a decoy keeps from a target's corner.
const TARGET_CLEAR_M: f64 = 4.0;
/// Nearest distance from the road centre line.
const ROAD_CLEAR_M: f64 = 3.0;
/// Nearest distance between two decoys.
const DECOY_CLEAR_M: f64 = 2.0;
/// Attempts at placing one decoy before it is left out.
const ATTEMPTS: usize = 300;

/// What is drawn for a decoy before it is placed.
struct Draw {
    kind: usize,
    heading: f64,
    /// L shapes: arm lengths and height; boxes: long side, short side, height.
    size: [f64; 3],
    grill: bool,
}

impl Draw {
    fn new(kind: usize, p: &SynthParams, rng: &mut Pcg64) -> Draw {
        let heading = rng.random_range(0.0..TAU);
        let h = p.target.plate_height_m;
        let (size, grill) = match kind {
            0 => (
                [
                    rng.random_range(3.0..8.0),
                    rng.random_range(3.0..8.0),
                    rng.random_range(3.0..6.0),
                ],
                false,
            ),
            1 => (
                [rng.random_range(0.9..1.2), rng.random_range(0.9..1.2), h],
                rng.random_bool(0.5),
            ),
            2 => ([0.6, 0.4, 1.2], false),
            3 => (
                [
                    rng.random_range(0.35..0.45),
                    rng.random_range(0.35..0.45),
                    h,
                ],
                rng.random_bool(0.5),
            ),
            _ => ([1.2, 0.8, 1.0], false),
        };
        Draw {
            kind,
            heading,
            size,
            grill,
        }
    }

    fn is_l(&self) -> bool {
        matches!(self.kind, 0 | 1 | 3)
    }

    fn name(&self) -> &'static str {
        ["building_corner", "l_board", "cabinet", "small_l", "pallet"][self.kind]
    }

    /// Points every 0.25 m along the outline of the footprint at (x, y).
    fn outline(&self, x: f64, y: f64) -> Vec<(f64, f64)> {
        let mut out = Vec::new();
        for (a, b) in self.segments(x, y) {
            let len = (b.0 - a.0).hypot(b.1 - a.1);
            let n = (len / 0.25).ceil().max(1.0) as usize;
            for i in 0..=n {
                let f = i as f64 / n as f64;
                out.push((a.0 + f * (b.0 - a.0), a.1 + f * (b.1 - a.1)));
            }
        }
        out
    }

    /// The footprint's outline at (x, y) as segments: an L's two arms (outer
    /// faces), a box's four sides.
    fn segments(&self, x: f64, y: f64) -> Vec<((f64, f64), (f64, f64))> {
        let (c, s) = (self.heading.cos(), self.heading.sin());
        let u1 = (c, s);
        let u2 = (-s, c);
        let mut segs = Vec::new();
        if self.is_l() {
            segs.push(((x, y), (x + self.size[0] * u1.0, y + self.size[0] * u1.1)));
            segs.push(((x, y), (x + self.size[1] * u2.0, y + self.size[1] * u2.1)));
        } else {
            let (a, b) = (self.size[0] / 2.0, self.size[1] / 2.0);
            let at = |i: f64, j: f64| {
                (
                    x + i * a * u1.0 + j * b * u2.0,
                    y + i * a * u1.1 + j * b * u2.1,
                )
            };
            let k = [at(1.0, 1.0), at(-1.0, 1.0), at(-1.0, -1.0), at(1.0, -1.0)];
            for i in 0..4 {
                segs.push((k[i], k[(i + 1) % 4]));
            }
        }
        segs
    }

    /// The object at (x, y) and its truth (object index filled in by the caller).
    fn build(
        &self,
        p: &SynthParams,
        g: &Ground,
        road: &Road,
        x: f64,
        y: f64,
    ) -> (Object, DecoyTruth) {
        let gz = g.height(x, y);
        let shape = &p.target;
        let hd = self.heading;
        let [a1, a2, h] = self.size;
        let (prims, zref, bottom, top) = match self.kind {
            0 => {
                let th = 0.3;
                let low = self
                    .outline(x, y)
                    .iter()
                    .map(|&(u, v)| g.height(u, v))
                    .fold(gz, f64::min)
                    - 0.5;
                let top = gz + h;
                let zc = (low + top) / 2.0;
                let (u1, u2) = (
                    Vector3::new(hd.cos(), hd.sin(), 0.0),
                    Vector3::new(-hd.sin(), hd.cos(), 0.0),
                );
                let c = Vector3::new(x, y, zc);
                let prims = vec![
                    yaw_box(
                        c + u1 * (a1 / 2.0) + u2 * (th / 2.0),
                        [a1, th, top - low],
                        hd,
                    ),
                    yaw_box(
                        c + u2 * (a2 / 2.0) + u1 * (th / 2.0),
                        [a2, th, top - low],
                        hd + FRAC_PI_2,
                    ),
                ];
                (prims, gz + h / 2.0, gz, top)
            }
            1 | 3 => {
                let z0 = gz + shape.plate_bottom_m;
                let top = z0 + h;
                let plate = |a: f64, w: f64| l_plate(shape, (x, y, z0), a, (w, h), self.grill);
                let post_bottom = gz - 0.05;
                let prims = vec![
                    plate(hd, a1),
                    plate(hd + FRAC_PI_2, a2),
                    yaw_box(
                        Vector3::new(x, y, (post_bottom + top) / 2.0),
                        [shape.post_m, shape.post_m, top - post_bottom],
                        hd,
                    ),
                ];
                (prims, z0 + h / 2.0, z0, top)
            }
            _ => {
                let (prim, _, top) = box_on_ground(g, x, y, self.size, hd);
                (vec![prim], gz + h / 2.0, gz, top)
            }
        };
        let truth = DecoyTruth {
            kind: self.name().into(),
            world: [x, y, zref],
            map: [0.0; 3],
            heading_deg: hd.to_degrees().rem_euclid(360.0),
            size_m: self.size,
            grill: matches!(self.kind, 1 | 3).then_some(self.grill),
            ground_z: gz,
            bottom_z: bottom,
            top_z: top,
            road_distance_m: (y - road.y(x)).abs(),
            points: 0,
            object: 0,
        };
        (Object::new(prims), truth)
    }
}

/// Distance from q to the segment [a, b].
fn segment_distance(q: (f64, f64), a: (f64, f64), b: (f64, f64)) -> f64 {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let len2 = dx * dx + dy * dy;
    let f = if len2 > 0.0 {
        (((q.0 - a.0) * dx + (q.1 - a.1) * dy) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (q.0 - a.0 - f * dx).hypot(q.1 - a.1 - f * dy)
}

/// How close a decoy may come to a clutter object's noted centre, metres
/// (the façade is checked as a segment, see `clear_of_clutter`).
fn clutter_clearance(kind: &str) -> f64 {
    match kind {
        "pole" => 1.5,
        "car" => 3.5,
        "wall" | "barrier" => 4.0,
        _ => 2.5,
    }
}

/// Whether the outline point q keeps clear of the clutter.
fn clear_of_clutter(q: (f64, f64), clutter: &[ClutterInfo], road: &Road) -> bool {
    clutter.iter().all(|c| {
        if c.kind == "wall" && c.role == "random" {
            // The 40 m façade along the road: distance to its centre line.
            let h = road.heading(c.x);
            let (dx, dy) = (q.0 - c.x, q.1 - c.y);
            let along = (dx * h.cos() + dy * h.sin()).clamp(-20.0, 20.0);
            let (px, py) = (c.x + along * h.cos(), c.y + along * h.sin());
            (q.0 - px).hypot(q.1 - py) >= 1.5
        } else {
            (q.0 - c.x).hypot(q.1 - c.y) >= clutter_clearance(&c.kind)
        }
    })
}

/// Whether q would stand between target t and the road: on its side, nearer
/// the road, within the 45° cone (plus 1 m) from the target towards the road.
fn hides(q: (f64, f64), t: &TargetTruth, road: &Road) -> bool {
    let lt = t.world[1] - road.y(t.world[0]);
    let lq = q.1 - road.y(q.0);
    lt * lq > 0.0 && lq.abs() < lt.abs() && (q.0 - t.world[0]).abs() < lt.abs() - lq.abs() + 1.0
}

/// Places `p.clutter.decoys` decoys, appending their objects; returns their
/// truth in placement order (a decoy with no room after `ATTEMPTS` is left out).
pub(super) fn add(
    p: &SynthParams,
    g: &Ground,
    road: &Road,
    objects: &mut Vec<Object>,
    targets: &[TargetTruth],
    clutter: &[ClutterInfo],
) -> Vec<DecoyTruth> {
    let mut out = Vec::new();
    if p.clutter.decoys == 0 {
        return out;
    }
    let mut rng = stream(p.seed, 6);
    let [dmin, dmax] = p.target_distance_m;
    let mut placed: Vec<(f64, f64)> = Vec::new();
    for i in 0..p.clutter.decoys {
        let d = Draw::new(i % 5, p, &mut rng);
        for _ in 0..ATTEMPTS {
            let sx = rng.random_range(road.x0 + 10.0..road.x1 - 10.0);
            let side = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
            let dist = if dmax > dmin {
                rng.random_range(dmin..dmax)
            } else {
                dmin
            };
            let h = road.heading(sx);
            let (x, y) = (
                sx - side * dist * h.sin(),
                road.y(sx) + side * dist * h.cos(),
            );
            let clear_of_targets = d.segments(x, y).iter().all(|&(a, b)| {
                targets
                    .iter()
                    .all(|t| segment_distance((t.world[0], t.world[1]), a, b) >= TARGET_CLEAR_M)
            });
            if !clear_of_targets {
                continue;
            }
            let outline = d.outline(x, y);
            let ok = outline.iter().all(|&q| {
                (q.1 - road.y(q.0)).abs() >= ROAD_CLEAR_M
                    && targets.iter().all(|t| !hides(q, t, road))
                    && placed
                        .iter()
                        .all(|r| (q.0 - r.0).hypot(q.1 - r.1) >= DECOY_CLEAR_M)
                    && clear_of_clutter(q, clutter, road)
            });
            if !ok {
                continue;
            }
            let (obj, mut truth) = d.build(p, g, road, x, y);
            truth.object = objects.len();
            objects.push(obj);
            out.push(truth);
            placed.extend(outline);
            break;
        }
    }
    out
}
