//! The parts scenes are built of: a target's primitives and its truth,
//! plates and boxes standing on the ground, and the independent random
//! streams each feature draws from. Shared by the scene, its obstacles and
//! its decoys.

use super::geometry::{self, Ground, Object, Plate, Prim};
use super::{SurveyPoint, TargetShape, TargetTruth};
use nalgebra::Vector3;
use rand::SeedableRng;
use rand_pcg::Pcg64;

/// Independent random streams, so enabling one feature does not move the rest.
pub(super) fn stream(seed: u64, what: u64) -> Pcg64 {
    Pcg64::seed_from_u64(geometry::splitmix(seed ^ geometry::splitmix(what)))
}

pub(super) fn yaw_box(c: Vector3<f64>, size: [f64; 3], yaw: f64) -> Prim {
    Prim::Box {
        c,
        half: Vector3::from(size) / 2.0,
        cs: (yaw.cos(), yaw.sin()),
    }
}

/// One vertical plate of an L (a target's or a decoy's) starting at the
/// corner line `at` (x, y, bottom z), along heading `a`, `size` = (width,
/// height): meshed like `shape`'s grill, or solid when `grill` is false.
pub(super) fn l_plate(
    shape: &TargetShape,
    at: (f64, f64, f64),
    a: f64,
    size: (f64, f64),
    grill: bool,
) -> Prim {
    Prim::Plate(Plate {
        x: at.0,
        y: at.1,
        u: (a.cos(), a.sin()),
        z0: at.2,
        w: size.0,
        h: size.1,
        frame: shape.frame_m,
        pitch: shape.mesh_pitch_m,
        hole: if grill { shape.mesh_hole_m } else { 0.0 },
        keep: 1.0,
    })
}

/// A box of `size` (along `yaw`, across, tall) standing on the ground at
/// (x, y): its bottom 5 cm below the lowest ground under its corners, its top
/// `size[2]` above the ground at (x, y). Returns the box, the ground height at
/// (x, y) and the top.
pub(super) fn box_on_ground(
    g: &Ground,
    x: f64,
    y: f64,
    size: [f64; 3],
    yaw: f64,
) -> (Prim, f64, f64) {
    let (c, s) = (yaw.cos(), yaw.sin());
    let gz = g.height(x, y);
    let mut low = gz;
    for (a, b) in [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)] {
        let (u, v) = (a * size[0] / 2.0, b * size[1] / 2.0);
        low = low.min(g.height(x + u * c - v * s, y + u * s + v * c));
    }
    let bottom = low - 0.05;
    let top = gz + size[2];
    let prim = yaw_box(
        Vector3::new(x, y, (bottom + top) / 2.0),
        [size[0], size[1], top - bottom],
        yaw,
    );
    (prim, gz, top)
}

/// The primitives of one L-target with its corner line at (x, y).
pub(super) fn build_target(
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
        l_plate(
            shape,
            (x, y, z0),
            a,
            (shape.plate_width_m, shape.plate_height_m),
            true,
        )
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

/// The truth of a target just built from its corner line (x, y), heading and
/// [`build_target`]'s heights: the scan fills in its map position and counts.
pub(super) fn target_truth(
    id: String,
    (x, y): (f64, f64),
    heading: f64,
    [gz, z0, z1, ant]: [f64; 4],
    road_distance_m: f64,
) -> TargetTruth {
    let zc = (z0 + z1) / 2.0;
    TargetTruth {
        id,
        world: [x, y, zc],
        survey: SurveyPoint {
            x,
            y,
            z: ant,
            antenna_height: ant - zc,
        },
        map: [0.0; 3],
        heading_deg: heading.to_degrees().rem_euclid(360.0),
        ground_z: gz,
        plate_bottom_z: z0,
        plate_top_z: z1,
        antenna_top_z: ant,
        road_distance_m,
        points: 0,
        ghost: None,
        ghost_points: 0,
        model: crate::model::ModelKind::L,
        size: None,
    }
}

/// A sphere target at (x, y): the sphere on a thin pole from the ground.
/// Returns the object and its truth (the survey gives the centre).
pub(super) fn sphere_target(
    g: &Ground,
    shape: &super::SphereShape,
    id: String,
    (x, y): (f64, f64),
    road_distance_m: f64,
    away: f64,
) -> (Object, TargetTruth) {
    let gz = g.height(x, y);
    let r = shape.diameter_m / 2.0;
    let zc = gz + shape.centre_height_m;
    let mut prims = vec![
        Prim::Sphere {
            c: Vector3::new(x, y, zc),
            r,
            porosity: 0.0,
        },
        // The pole ends inside the sphere, as a threaded stud does.
        Prim::VCyl {
            x,
            y,
            r: shape.pole_radius_m,
            z0: gz - 0.05,
            z1: zc - 0.5 * r,
        },
    ];
    if let Some(gap) = shape.wall_gap_m {
        // The panel behind the sphere, away from the road (`away`: ±1 in y),
        // its front face `gap` from the sphere's surface, on its own post.
        let y_panel = y + away * (r + gap + 0.01);
        prims.push(Prim::Box {
            c: Vector3::new(x, y_panel, zc),
            half: Vector3::new(0.3, 0.01, 0.3),
            cs: (1.0, 0.0),
        });
        prims.push(Prim::VCyl {
            x,
            y: y_panel + away * 0.04,
            r: 0.03,
            z0: gz - 0.05,
            z1: zc,
        });
    }
    let truth = point_truth(
        id,
        [x, y, zc],
        (gz, r),
        0.0,
        road_distance_m,
        (crate::model::ModelKind::Sphere, shape.diameter_m),
    );
    (Object::new(prims), truth)
}

/// A checkerboard board at (x, y) on two legs, its face towards the road
/// (`towards`: the face's unit normal, horizontal). Returns the object and
/// its truth (the survey gives the crossing, on the face).
pub(super) fn board_target(
    g: &Ground,
    shape: &super::BoardShape,
    id: String,
    (x, y): (f64, f64),
    road_distance_m: f64,
    towards: (f64, f64),
) -> (Object, TargetTruth) {
    let gz = g.height(x, y);
    let half = shape.side_m / 2.0;
    let t = 0.01;
    if shape.flat {
        return flat_board(g, shape, id, (x, y), road_distance_m, towards);
    }
    let zc = gz + shape.centre_height_m;
    // The box's own x along the face, y through it (towards the road is -y).
    let (nx, ny) = towards;
    let cs = (-ny, nx);
    let mid = Vector3::new(x - nx * t, y - ny * t, zc);
    let mut prims = vec![Prim::Box {
        c: mid,
        half: Vector3::new(half, t, half),
        cs,
    }];
    let mut boards = vec![mid];
    if let Some(gap) = shape.sign_gap_m {
        let along = 2.0 * half + gap;
        let sign = mid + Vector3::new(cs.0, cs.1, 0.0) * along;
        prims.push(Prim::Box {
            c: sign,
            half: Vector3::new(half, t, half),
            cs,
        });
        boards.push(sign);
    }
    if let Some(gap) = shape.wall_gap_m {
        // The wall behind, away from the road, 10 cm thick.
        let back = 2.0 * t + gap + 0.05;
        prims.push(Prim::Box {
            c: Vector3::new(x - nx * back, y - ny * back, gz + 1.2),
            half: Vector3::new(1.5, 0.05, 1.25),
            cs,
        });
    }
    for b in boards {
        for s in [-0.7, 0.7] {
            prims.push(Prim::VCyl {
                x: b.x + cs.0 * s * half - nx * 0.03,
                y: b.y + cs.1 * s * half - ny * 0.03,
                r: 0.015,
                z0: gz - 0.05,
                z1: zc - 0.05,
            });
        }
    }
    let truth = point_truth(
        id,
        [x, y, zc],
        (gz, half),
        ny.atan2(nx).to_degrees(),
        road_distance_m,
        (crate::model::ModelKind::Board, shape.side_m),
    );
    (Object::new(prims), truth)
}

/// A board lying face up on the ground at (x, y), the print's first axis
/// along the road (across `towards`): a level 2 cm slab resting on the
/// ground's highest point under it. The survey gives the crossing, on the
/// top face.
fn flat_board(
    g: &Ground,
    shape: &super::BoardShape,
    id: String,
    (x, y): (f64, f64),
    road_distance_m: f64,
    towards: (f64, f64),
) -> (Object, TargetTruth) {
    let half = shape.side_m / 2.0;
    let t = 0.01;
    let (nx, ny) = towards;
    let cs = (-ny, nx);
    let mut centres = vec![(x, y)];
    if let Some(gap) = shape.sign_gap_m {
        let along = 2.0 * half + gap;
        centres.push((x + cs.0 * along, y + cs.1 * along));
    }
    let mut prims = Vec::new();
    let mut top = 0.0;
    for (k, &(bx, by)) in centres.iter().enumerate() {
        let rest = [
            (-1.0, -1.0),
            (-1.0, 1.0),
            (1.0, -1.0),
            (1.0, 1.0),
            (0.0, 0.0),
        ]
        .iter()
        .map(|(a, b)| g.height(bx + a * half, by + b * half))
        .fold(f64::NEG_INFINITY, f64::max);
        let face = rest + 2.0 * t;
        if k == 0 {
            top = face;
        }
        prims.push(Prim::Box {
            c: Vector3::new(bx, by, face - t),
            half: Vector3::new(half, half, t),
            cs,
        });
    }
    let truth = point_truth(
        id,
        [x, y, top],
        (g.height(x, y), 0.0),
        ny.atan2(nx).to_degrees(),
        road_distance_m,
        (crate::model::ModelKind::Board, shape.side_m),
    );
    (Object::new(prims), truth)
}

/// The truth of a target surveyed at one point (a sphere's centre, a
/// board's crossing), `world`: its top and bottom `half` above and below,
/// on ground at `gz`; `heading_deg` its facing; its model and size.
fn point_truth(
    id: String,
    world: [f64; 3],
    (gz, half): (f64, f64),
    heading_deg: f64,
    road_distance_m: f64,
    (model, size): (crate::model::ModelKind, f64),
) -> TargetTruth {
    let [x, y, z] = world;
    TargetTruth {
        id,
        world,
        survey: SurveyPoint {
            x,
            y,
            z,
            antenna_height: 0.0,
        },
        map: [0.0; 3],
        heading_deg,
        ground_z: gz,
        plate_bottom_z: z - half,
        plate_top_z: z + half,
        antenna_top_z: z + half,
        road_distance_m,
        points: 0,
        ghost: None,
        ghost_points: 0,
        model,
        size: Some(size),
    }
}
