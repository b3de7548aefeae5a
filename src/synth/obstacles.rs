//! Obstacles around target 1: the field cases of issue 16 ("targets in real
//! clutter"). Every one is off by default, so scenes without them are
//! unchanged; each draws from its own random stream.

use super::geometry::{Ground, Object, Prim};
use super::lidar::Road;
use super::parts::{build_target, l_plate, stream, target_truth, yaw_box};
use super::{ClutterInfo, SynthParams, TargetShape, TargetTruth};
use crate::{Error, Result};
use nalgebra::Vector3;
use rand::Rng;
use rand_pcg::Pcg64;
use std::f64::consts::{FRAC_PI_2, TAU};

/// Obstacles around target 1 (all off by default).
#[derive(Debug, Clone, PartialEq, Default, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ObstacleParams {
    /// A large flat surface (5 m long, up to 2.6 m above the ground, a
    /// container's side) parallel to one plate, this far behind it as seen
    /// from the road (metres), so rays through the grill hit it.
    pub wall_behind_m: Option<f64>,
    /// A stack (0.5 × 0.5 m, this tall, metres) standing inside the L, its
    /// faces touching both plates' planes.
    pub inside_object_m: Option<f64>,
    /// A barrier between the road and the target hiding about this share of
    /// the plates' height, from below, from the sensor on the road.
    pub hide_lower: Option<f64>,
    /// Share of the rays striking plate 2 that return (0.25: plate 2 has
    /// about a quarter of its points).
    pub plate2_keep: Option<f64>,
    /// Foliage growing through both plates up to this height above their
    /// bottom edge (metres), and down to the ground.
    pub grass_m: Option<f64>,
    /// A second surveyed target (id K + 1) this far from target 1's corner
    /// along the road (metres).
    pub second_target_m: Option<f64>,
    /// Target 1 is not built (it stays in the survey): for the decoy test.
    pub target1_absent: bool,
    /// Target-like objects that are not the target, 0.6–2.5 m from target 1's
    /// corner: a 0.4 × 0.5 m L, a 1.2 m L, a cabinet, an L of 110°, a wall
    /// segment, in turn.
    pub decoys: usize,
}

impl ObstacleParams {
    /// No obstacle at all (the truth file then omits the section).
    pub(crate) fn is_off(&self) -> bool {
        *self == ObstacleParams::default()
    }

    pub(super) fn validate(&self) -> Result<()> {
        let bad = |m: &str| Err(Error::Param(format!("obstacles.{m}")));
        let within = |v: Option<f64>, lo: f64, hi: f64| v.is_none_or(|v| v >= lo && v <= hi);
        if !within(self.wall_behind_m, 0.05, 5.0) {
            return bad("wall_behind_m must be in [0.05, 5]");
        }
        if !within(self.inside_object_m, 0.05, 2.0) {
            return bad("inside_object_m must be in [0.05, 2]");
        }
        if !within(self.hide_lower, 0.0, 0.9) {
            return bad("hide_lower must be in [0, 0.9]");
        }
        if !within(self.plate2_keep, 0.01, 1.0) {
            return bad("plate2_keep must be in [0.01, 1]");
        }
        if !within(self.grass_m, 0.0, 1.0) {
            return bad("grass_m must be in [0, 1]");
        }
        if !within(self.second_target_m, 0.8, 20.0) {
            return bad("second_target_m must be in [0.8, 20]");
        }
        if self.decoys > 20 {
            return bad("decoys must be <= 20");
        }
        Ok(())
    }
}

/// Target 1's frame: corner, plate directions, and the way to the road.
struct Frame {
    c: Vector3<f64>,
    u: [Vector3<f64>; 2],
    /// Unit horizontal vector from the corner towards the nearest road point.
    road: Vector3<f64>,
    /// Horizontal distance to the road, and the sensor's height there.
    road_dist: f64,
    sensor_z: f64,
}

impl Frame {
    fn of(t: &TargetTruth, p: &SynthParams, g: &Ground, road: &Road) -> Frame {
        let a = t.heading_deg.to_radians();
        let c = Vector3::new(t.world[0], t.world[1], 0.0);
        let r = Vector3::new(c.x, road.y(c.x), 0.0);
        let to_road = r - c;
        let road_dist = to_road.norm().max(1e-6);
        Frame {
            c,
            u: [
                Vector3::new(a.cos(), a.sin(), 0.0),
                Vector3::new(-a.sin(), a.cos(), 0.0),
            ],
            road: to_road / road_dist,
            road_dist,
            sensor_z: g.height(r.x, r.y) + p.lidar.height_m,
        }
    }
    fn at(&self, v: Vector3<f64>, z: f64) -> Vector3<f64> {
        Vector3::new(self.c.x + v.x, self.c.y + v.y, z)
    }
}

fn yaw_of(v: &Vector3<f64>) -> f64 {
    v.y.atan2(v.x)
}

/// Adds the obstacles of `p.obstacles` around target 1. The second target is
/// inserted as object K (objects 0..K are the targets, so returns are counted
/// per target).
pub(super) fn add(
    p: &SynthParams,
    g: &Ground,
    road: &Road,
    objects: &mut Vec<Object>,
    targets: &mut Vec<TargetTruth>,
    clutter: &mut Vec<ClutterInfo>,
) {
    let o = &p.obstacles;
    if o.is_off() {
        return;
    }
    let t = targets[0].clone();
    let f = Frame::of(&t, p, g, road);
    let site = Site { p, g, t, f };
    if let Some(d) = o.wall_behind_m {
        site.wall_behind(d, objects, clutter);
    }
    if let Some(hgt) = o.inside_object_m {
        site.inside_object(hgt, objects, clutter);
    }
    if let Some(share) = o.hide_lower {
        site.barrier(share, objects, clutter);
    }
    if let Some(keep) = o.plate2_keep
        && let Some(Prim::Plate(pl)) = objects[0].prims.get_mut(1)
    {
        pl.keep = keep;
    }
    if let Some(gh) = o.grass_m {
        site.grass(gh, objects, clutter);
    }
    let mut rng = stream(p.seed, 5);
    if let Some(d) = o.second_target_m {
        site.second_target(road, d, &mut rng, objects, targets);
    }
    if o.target1_absent {
        objects[0] = Object::new(Vec::new());
    }
    site.decoys(&mut rng, objects, clutter);
}

/// Target 1 as built and its frame, with the scene's parameters and ground:
/// what every obstacle is placed by.
struct Site<'a> {
    p: &'a SynthParams,
    g: &'a Ground,
    t: TargetTruth,
    f: Frame,
}

/// Lists an obstacle in the truth's clutter, where the report shows it.
fn note(clutter: &mut Vec<ClutterInfo>, kind: &str, at: Vector3<f64>, role: String) {
    clutter.push(ClutterInfo {
        kind: kind.into(),
        x: at.x,
        y: at.y,
        role,
    })
}

impl Site<'_> {
    /// `wall_behind_m`: a container side `d` behind a plate, seen through
    /// the grill, so a plate fit must not take the wall's points.
    fn wall_behind(&self, d: f64, objects: &mut Vec<Object>, clutter: &mut Vec<ClutterInfo>) {
        let (f, t) = (&self.f, &self.t);
        let w = self.p.target.plate_width_m;
        // Behind the plate whose outer face looks away from the road; when the
        // road sees both outer faces, behind plate 1 on the inner side, from
        // the corner on (a full-length wall would cut plate 2).
        let (k, normal, from) = if f.road.dot(&f.u[1]) > 0.0 {
            (0, -f.u[1], -2.0)
        } else if f.road.dot(&f.u[0]) > 0.0 {
            (1, -f.u[0], -2.0)
        } else {
            (0, f.u[1], 0.15)
        };
        let to = w + 3.0;
        let mid = f.u[k] * ((from + to) / 2.0) + normal * (d + 0.05);
        let zmin = t.ground_z - 0.5;
        let top = t.ground_z + 2.6;
        let at = f.at(mid, (zmin + top) / 2.0);
        objects.push(Object::new(vec![yaw_box(
            at,
            [to - from, 0.1, top - zmin],
            yaw_of(&f.u[k]),
        )]));
        note(
            clutter,
            "wall",
            at,
            format!("{d} m behind plate {} of target 1", k + 1),
        );
    }

    /// `inside_object_m`: a stack `hgt` tall touching both plates' planes
    /// inside the L, whose faces a plate fit must not take for the plates.
    fn inside_object(&self, hgt: f64, objects: &mut Vec<Object>, clutter: &mut Vec<ClutterInfo>) {
        let (f, t) = (&self.f, &self.t);
        let side = 0.5;
        let gap = self.p.target.post_m / 2.0 + 0.005;
        let mid = (f.u[0] + f.u[1]) * (side / 2.0 + gap);
        let at = f.at(mid, t.ground_z + hgt / 2.0 - 0.05);
        objects.push(Object::new(vec![yaw_box(
            at,
            [side, side, hgt + 0.1],
            yaw_of(&f.u[0]),
        )]));
        note(
            clutter,
            "stack",
            at,
            format!("inside the L of target 1 ({hgt} m tall)"),
        );
    }

    /// `hide_lower`: a barrier between the road and the target, just tall
    /// enough to hide the lower `share` of the plates from the sensor.
    fn barrier(&self, share: f64, objects: &mut Vec<Object>, clutter: &mut Vec<ClutterInfo>) {
        let (f, t) = (&self.f, &self.t);
        // The sight line from the sensor over the barrier's top meets the
        // corner at the hidden height.
        let gap = 0.9;
        let hidden_z = t.plate_bottom_z + share * self.p.target.plate_height_m;
        let top = hidden_z + (f.sensor_z - hidden_z) * gap / f.road_dist;
        let zmin = t.ground_z - 0.5;
        let at = f.at(f.road * gap, (zmin + top) / 2.0);
        objects.push(Object::new(vec![yaw_box(
            at,
            [4.0, 0.1, top - zmin],
            yaw_of(&f.road) + FRAC_PI_2,
        )]));
        note(
            clutter,
            "barrier",
            at,
            format!("hides the lower {share} of target 1 from the road"),
        );
    }

    /// `grass_m`: foliage through both plates' lower parts and down to the
    /// ground, the returns a plate's bottom edge is found among.
    fn grass(&self, gh: f64, objects: &mut Vec<Object>, clutter: &mut Vec<ClutterInfo>) {
        let (f, t) = (&self.f, &self.t);
        let w = self.p.target.plate_width_m;
        let r = 0.3;
        let mut prims = Vec::new();
        for k in 0..2 {
            let n = f.u[1 - k];
            for s in [0.15, 0.45] {
                for side in [-1.0, 1.0] {
                    let v = f.u[k] * (s * w / 0.6) + n * (0.12 * side);
                    for z in [t.plate_bottom_z + gh - r, t.ground_z + r] {
                        prims.push(Prim::Sphere {
                            c: f.at(v, z),
                            r,
                            porosity: 0.5,
                        });
                    }
                }
            }
        }
        objects.push(Object::new(prims));
        note(
            clutter,
            "bush",
            f.c,
            format!("through target 1's lower plates ({gh} m up)"),
        );
    }

    /// `second_target_m`: a surveyed target `d` along the road, inserted as
    /// object K (objects 0..K are the targets, so returns count per target).
    fn second_target(
        &self,
        road: &Road,
        d: f64,
        rng: &mut Pcg64,
        objects: &mut Vec<Object>,
        targets: &mut Vec<TargetTruth>,
    ) {
        let f = &self.f;
        let hd = road.heading(f.c.x);
        let (x, y) = (f.c.x + d * hd.cos(), f.c.y + d * hd.sin());
        let heading = rng.random_range(0.0..TAU);
        let (obj, levels) = build_target(self.g, &self.p.target, x, y, heading);
        objects.insert(targets.len(), obj);
        let id = (targets.len() + 1).to_string();
        targets.push(target_truth(
            id,
            (x, y),
            heading,
            levels,
            (y - road.y(x)).abs(),
        ));
    }

    /// `decoys`: target-like objects 0.6-2.5 m from target 1's corner, clear
    /// of each other (and of the target unless it is absent), kinds in turn.
    fn decoys(&self, rng: &mut Pcg64, objects: &mut Vec<Object>, clutter: &mut Vec<ClutterInfo>) {
        let o = &self.p.obstacles;
        let mut placed: Vec<Vector3<f64>> = Vec::new();
        for i in 0..o.decoys {
            let mut at = None;
            for _ in 0..200 {
                let r = rng.random_range(0.6..2.5);
                let a = rng.random_range(0.0..TAU);
                let v = self.f.c + Vector3::new(r * a.cos(), r * a.sin(), 0.0);
                let clear = |q: &Vector3<f64>| (q - v).norm() >= 1.6;
                if placed.iter().all(clear) && (o.target1_absent || r >= 1.2) {
                    at = Some(v);
                    break;
                }
            }
            let Some(v) = at else { continue };
            placed.push(v);
            let heading = rng.random_range(0.0..TAU);
            let (kind, obj) = decoy(i % 5, self.g, &self.p.target, v, heading);
            objects.push(obj);
            note(clutter, "decoy", v, format!("{kind} near target 1"));
        }
    }
}

/// Decoy `kind` at `v`: something a careless detector could take for the target.
fn decoy(
    kind: usize,
    g: &Ground,
    shape: &TargetShape,
    v: Vector3<f64>,
    heading: f64,
) -> (&'static str, Object) {
    let gz = g.height(v.x, v.y);
    match kind {
        0 => {
            let s = TargetShape {
                plate_width_m: 0.4,
                plate_height_m: 0.5,
                ..shape.clone()
            };
            ("a 0.4 × 0.5 m L", build_target(g, &s, v.x, v.y, heading).0)
        }
        1 => {
            let s = TargetShape {
                plate_width_m: 1.2,
                plate_height_m: 1.2,
                plate_bottom_m: 0.5,
                ..shape.clone()
            };
            ("a 1.2 m L", build_target(g, &s, v.x, v.y, heading).0)
        }
        2 => (
            "a cabinet",
            Object::new(vec![yaw_box(
                Vector3::new(v.x, v.y, gz + 0.6),
                [0.5, 0.8, 1.3],
                heading,
            )]),
        ),
        3 => {
            let z0 = gz + shape.plate_bottom_m;
            let plate = |a: f64| {
                l_plate(
                    shape,
                    (v.x, v.y, z0),
                    a,
                    (shape.plate_width_m, shape.plate_height_m),
                    true,
                )
            };
            (
                "an L of 110°",
                Object::new(vec![plate(heading), plate(heading + 110f64.to_radians())]),
            )
        }
        _ => (
            "a wall segment",
            Object::new(vec![yaw_box(
                Vector3::new(v.x, v.y, gz + 0.9),
                [3.0, 0.1, 2.2],
                heading,
            )]),
        ),
    }
}
