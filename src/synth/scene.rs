//! Building the world before it is scanned: the ground, the targets, the
//! clutter and the hard cases (obstacles of issue 16 live in `obstacles.rs`).

use super::geometry::{Ground, Object, Prim, Wave, World};
use super::lidar::Road;
use super::parts::{board_target, build_target, sphere_target, stream, target_truth, yaw_box};
use super::{ClutterInfo, DecoyTruth, Layout, SynthParams, TargetTruth};
use nalgebra::Vector3;
use rand::Rng;
use rand_pcg::Pcg64;

/// A scene before scanning.
pub(super) struct Scene {
    pub(super) world: World,
    pub(super) road: Road,
    pub(super) targets: Vec<TargetTruth>,
    pub(super) clutter: Vec<ClutterInfo>,
    pub(super) decoys: Vec<DecoyTruth>,
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

/// The road the sensor drives: the spread plus a 30 m lead at either end.
pub(super) fn road_of(p: &SynthParams) -> Road {
    let lead = 30.0;
    Road {
        x0: -lead,
        x1: p.spread_m + lead,
        amp: p.road_curve_m,
        wavelength: (p.spread_m + 2.0 * lead).max(40.0),
    }
}

/// The square layout's corners (x, y, heading rad), ids 1..4: the square's
/// sides parallel to x, centred on the road's middle, corner k at direction
/// 45° + 90°·k from the centre, heading that direction + 135° (the L opens to
/// the centre). Errs when a corner is under 4 m from the road centre line.
pub(super) fn square_layout(p: &SynthParams, road: &Road) -> Result<[(f64, f64, f64); 4], String> {
    let half = p.spread_m / 2.0;
    let (cx, cy) = (p.spread_m / 2.0, road.y(p.spread_m / 2.0));
    let signs = [(1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0), (1.0, -1.0)];
    let mut out = [(0.0, 0.0, 0.0); 4];
    for (k, (sx, sy)) in signs.into_iter().enumerate() {
        let (x, y) = (cx + sx * half, cy + sy * half);
        let d = (y - road.y(x)).abs();
        if d < 4.0 {
            return Err(format!(
                "layout = \"square\": corner {} lies {d:.1} m from the road (needs >= 4 m); widen spread_m or reduce road_curve_m",
                k + 1
            ));
        }
        let heading = (45.0 + 90.0 * k as f64 + 135.0).to_radians();
        out[k] = (x, y, heading);
    }
    Ok(out)
}

/// Target `i` of the road layout: along the road, alternating sides, at a
/// random distance in `target_distance_m`, random heading. Returns (x, y,
/// heading rad, distance from the road).
fn road_side(p: &SynthParams, road: &Road, rng: &mut Pcg64, i: usize) -> (f64, f64, f64, f64) {
    let k = p.targets;
    let [dmin, dmax] = p.target_distance_m;
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
    (cx, cy, heading, dist)
}

/// The world of `p` before scanning: the ground, the targets, the clutter,
/// the hard cases, the obstacles and the decoys, in that order (each draws
/// from its own stream).
pub(super) fn build_scene(p: &SynthParams) -> Scene {
    let ground = build_ground(p);
    let road = road_of(p);
    let mut objects = Vec::new();
    let mut targets = place_targets(p, &ground, &road, &mut objects);
    let mut clutter = Vec::new();
    let mut out = Added {
        objects: &mut objects,
        clutter: &mut clutter,
    };
    add_random_clutter(p, &ground, &road, &targets, &mut out);
    // Hard cases.
    if let Some(d) = p.clutter.near_target_m {
        add_near_target(&ground, &targets[0], d, &mut out);
    }
    if p.clutter.bush_touching {
        add_bush_touching(&targets[p.targets.min(2) - 1], &mut out);
    }
    super::obstacles::add(p, &ground, &road, &mut objects, &mut targets, &mut clutter);
    let decoys = super::decoys::add(p, &ground, &road, &mut objects, &targets, &clutter);
    Scene {
        world: World { ground, objects },
        road,
        targets,
        clutter,
        decoys,
    }
}

/// Builds the targets in id order, their objects first in `objects` (object
/// i is target i, so returns are counted per target).
fn place_targets(
    p: &SynthParams,
    ground: &Ground,
    road: &Road,
    objects: &mut Vec<Object>,
) -> Vec<TargetTruth> {
    let mut targets = Vec::new();
    let mut rng = stream(p.seed, 2);
    // Validated before: the square's corners are clear of the road.
    let square = match p.layout {
        Layout::Square => square_layout(p, road).ok(),
        Layout::Road => None,
    };
    for i in 0..p.targets {
        let (cx, cy, heading, dist) = match &square {
            Some(corners) => {
                let (x, y, heading) = corners[i];
                (x, y, heading, (y - road.y(x)).abs())
            }
            None => road_side(p, road, &mut rng, i),
        };
        let model = p
            .models
            .get(i % p.models.len().max(1))
            .copied()
            .unwrap_or_default();
        if model == crate::model::ModelKind::Sphere {
            let (obj, truth) =
                sphere_target(ground, &p.sphere, (i + 1).to_string(), (cx, cy), dist, {
                    // Away from the road: where a wall mount goes.
                    if cy >= road.y(cx) { 1.0 } else { -1.0 }
                });
            objects.push(obj);
            targets.push(truth);
            continue;
        }
        if model == crate::model::ModelKind::Board {
            // Facing the road: the normal from the board to the road's line.
            let ny = if road.y(cx) >= cy { 1.0 } else { -1.0 };
            let (obj, truth) = board_target(
                ground,
                &p.board,
                (i + 1).to_string(),
                (cx, cy),
                dist,
                (0.0, ny),
            );
            objects.push(obj);
            targets.push(truth);
            continue;
        }
        let (obj, levels) = build_target(ground, &p.target, cx, cy, heading);
        objects.push(obj);
        targets.push(target_truth(
            (i + 1).to_string(),
            (cx, cy),
            heading,
            levels,
            dist,
        ));
    }
    targets
}

/// Where clutter goes: an object of the world and its line in the truth's
/// clutter list, added together so the two never disagree.
struct Added<'a> {
    objects: &'a mut Vec<Object>,
    clutter: &'a mut Vec<ClutterInfo>,
}

impl Added<'_> {
    fn push(&mut self, object: Object, kind: &str, (x, y): (f64, f64), role: String) {
        self.objects.push(object);
        self.clutter.push(ClutterInfo {
            kind: kind.into(),
            x,
            y,
            role,
        });
    }
}

/// Free spots for random clutter: off the road and clear of the targets.
struct Spots<'a> {
    road: &'a Road,
    corners: Vec<(f64, f64)>,
}

impl Spots<'_> {
    fn free(&self, x: f64, y: f64, clear: f64) -> bool {
        (y - self.road.y(x)).abs() >= 3.0
            && self
                .corners
                .iter()
                .all(|&(a, b)| (x - a).hypot(y - b) >= clear)
    }

    /// A free spot `clear` from every target at a lateral distance in `lat`
    /// from the road, or `None` after 100 tries (the draws are spent either way).
    fn place(&self, rng: &mut Pcg64, clear: f64, lat: (f64, f64)) -> Option<(f64, f64)> {
        let road = self.road;
        for _ in 0..100 {
            let x = rng.random_range(road.x0 + 5.0..road.x1 - 5.0);
            let side = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
            let y = road.y(x) + side * rng.random_range(lat.0..lat.1);
            if self.free(x, y, clear) {
                return Some((x, y));
            }
        }
        None
    }
}

/// The random clutter of `p.clutter`, drawn from its own stream in a fixed
/// order (poles, bushes, cars), so each kind's count moves only what follows.
fn add_random_clutter(
    p: &SynthParams,
    g: &Ground,
    road: &Road,
    targets: &[TargetTruth],
    out: &mut Added,
) {
    let spots = Spots {
        road,
        corners: targets.iter().map(|t| (t.world[0], t.world[1])).collect(),
    };
    let mut rng = stream(p.seed, 3);
    for _ in 0..p.clutter.poles {
        let r = rng.random_range(0.08..0.2);
        let hgt = rng.random_range(4.0..9.0);
        if let Some((x, y)) = spots.place(&mut rng, 4.0 + r, (4.0, 28.0)) {
            let gz = g.height(x, y);
            let pole = Object::new(vec![Prim::VCyl {
                x,
                y,
                r,
                z0: gz - 0.2,
                z1: gz + hgt,
            }]);
            out.push(pole, "pole", (x, y), "random".into());
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
        if let Some((x, y)) = spots.place(&mut rng, 5.5, (4.0, 28.0)) {
            out.push(bush(g, x, y, &params), "bush", (x, y), "random".into());
        }
    }
    for _ in 0..p.clutter.cars {
        let x = rng.random_range(road.x0 + 10.0..road.x1 - 10.0);
        let side = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
        let h = road.heading(x);
        let (cx, cy) = (x - side * 3.6 * h.sin(), road.y(x) + side * 3.6 * h.cos());
        if spots
            .corners
            .iter()
            .all(|&(a, b)| (cx - a).hypot(cy - b) >= 5.0)
        {
            out.push(car(g, cx, cy, h), "car", (cx, cy), "random".into());
        }
    }
    if p.clutter.wall {
        add_wall(g, road, out);
    }
}

/// A 40 m façade 36 m off the road, a third of the way along: a long flat
/// face the detector must not take for a plate.
fn add_wall(g: &Ground, road: &Road, out: &mut Added) {
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
    let wall = Object::new(vec![yaw_box(
        Vector3::new(cx, cy, (zmin - 0.5 + top) / 2.0),
        [len, 0.3, top - zmin + 0.5],
        h,
    )]);
    out.push(wall, "wall", (cx, cy), "random".into());
}

/// The hard case `near_target_m`: a pole off target `t`'s outer corner and a
/// flat-faced utility cabinet inside its L, each `d` from the corner line.
fn add_near_target(g: &Ground, t: &TargetTruth, d: f64, out: &mut Added) {
    let a = t.heading_deg.to_radians();
    let (x, y) = (t.world[0], t.world[1]);
    // A pole off the L's outer corner ...
    let r = 0.1;
    let ap = a + 1.25 * std::f64::consts::PI;
    let (px, py) = (x + (d + r) * ap.cos(), y + (d + r) * ap.sin());
    let gz = g.height(px, py);
    let pole = Object::new(vec![Prim::VCyl {
        x: px,
        y: py,
        r,
        z0: gz - 0.2,
        z1: gz + 3.5,
    }]);
    out.push(pole, "pole", (px, py), format!("near target 1 ({d} m)"));
    // ... and a flat-faced utility cabinet inside it.
    let ai = a + std::f64::consts::FRAC_PI_4;
    let (bx, by) = (x + (d + 0.25) * ai.cos(), y + (d + 0.25) * ai.sin());
    let gz = g.height(bx, by);
    let cabinet = Object::new(vec![yaw_box(
        Vector3::new(bx, by, gz + 0.55),
        [0.5, 0.8, 1.3],
        ai,
    )]);
    out.push(
        cabinet,
        "cabinet",
        (bx, by),
        format!("near target 1 ({d} m)"),
    );
}

/// The hard case `bush_touching`: two foliage spheres against target `t`'s
/// plate, one reaching up to the plate's bottom edge.
fn add_bush_touching(t: &TargetTruth, out: &mut Added) {
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
    let role = format!("touching target {}", t.id);
    out.push(Object::new(prims), "bush", (s1.x, s1.y), role);
}

pub(super) fn bush(g: &Ground, x: f64, y: f64, spheres: &[(f64, f64, f64, f64)]) -> Object {
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
